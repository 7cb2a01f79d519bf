"""A whole study in one process, in order, without any orchestration: :func:`run_study`.

This is the plain-Python path (a notebook, ``nlupdate update``): it walks the chain
(:data:`nlupdate.study.chain.CHAIN`) step by step; the Prefect flows
(:mod:`nlupdate.orchestration.flows`) walk the same chain as cached, concurrent tasks and must give the
same numbers. The jobs of a fan-out step evaluate FE points through one memoised
evaluator per FE model, so a point several runs need is solved once. A failing updating
run does not stop the others: it is recorded in ``failures``.
"""
from __future__ import annotations

from typing import Any, Callable

from nlupdate.fe.adapters.registry import build_adapter
from nlupdate.study.chain import CHAIN, Step, StudyResult, study_result
from nlupdate.study.spec import Study, inputs_read_once
from nlupdate.study.steps.updating import RunFailure
from nlupdate.core.updating.evaluation import MemoisedEvaluator


def _fan_out(step: Step, study: Study, inputs: list, say: Callable[[str], None]) -> Any:
    evaluator = MemoisedEvaluator(build_adapter(step.model(study)))
    jobs = step.jobs(study, *inputs)
    intro = step.introduce(study, jobs)
    if intro:
        say(f"{step.name}: {intro}")
    outcomes = []
    for i, job in enumerate(jobs, start=1):
        try:
            outcome = step.each(study, job, evaluator, *inputs)
        except Exception as error:  # a failing run must not stop the sweep
            if not step.keep_going:
                raise
            outcome = RunFailure(getattr(job, "name", str(job)), f"{type(error).__name__}: {error}")
        label = step.label(job, outcome)
        say(f"{step.name}: {getattr(job, 'name', job)} ({i}/{len(jobs)}){': ' + label if label else ''}")
        outcomes.append(outcome)
    return step.compute(study, outcomes, *inputs)


def run_study(study: Study, say: Callable[[str], None] = lambda message: None) -> StudyResult:
    """Run every step the study asks for, in order; ``say`` receives progress lines. The
    study's input files are read once, as it starts (:func:`inputs_read_once`)."""
    results: dict[str, Any] = {}
    with inputs_read_once(study) as study:
        for step in CHAIN:
            if not step.applies(study, results):
                continue
            inputs = [results.get(name) for name in step.inputs]
            if step.fans_out:
                results[step.name] = _fan_out(step, study, inputs, say)
            else:
                results[step.name] = step.compute(study, *inputs)
                detail = step.describe(study, results[step.name])
                say(f"{step.name}{': ' + detail if detail else ''}")
    return study_result(study, results)
