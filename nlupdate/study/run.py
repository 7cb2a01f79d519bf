"""A whole study in one process, in order, without any orchestration: :func:`run_study`.

This is the plain-Python path (a notebook, ``nlupdate update``); the Prefect flows
(:mod:`nlupdate.flows`) run the same steps (:mod:`nlupdate.study.steps`) as cached,
concurrent tasks and must give the same numbers. FE evaluations go through one
memoised evaluator per FE model, so a point shared by several runs is solved once.
A failing updating run does not stop the others: it is recorded in ``failures``.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import pandas as pd

from nlupdate.identification.pipeline import Identification
from nlupdate.identification.trust import TrustWarning
from nlupdate.study.spec import Study
from nlupdate.study.steps import (
    Prediction, RunFailure, TargetSet, compare_runs, identification_step, measured_table, parameter_uncertainties,
    predict_model, prediction_adapter, prediction_points, study_targets, updating_tasks,
)
from nlupdate.adapters.registry import build_adapter
from nlupdate.updating.candidates import update
from nlupdate.updating.eigensensitivity import UpdatingResult
from nlupdate.updating.evaluation import MemoisedEvaluator
from nlupdate.updating.trust import updating_warnings
from nlupdate.updating.uncertainty import ParameterUncertainty


@dataclass(frozen=True, eq=False)
class StudyResult:
    """Everything a study produced (each part None/empty when the study has no such step)."""

    study: Study
    measured: pd.DataFrame | None = None
    identification: Identification | None = None
    targets: TargetSet | None = None
    runs: tuple[UpdatingResult, ...] = ()
    failures: tuple[RunFailure, ...] = ()
    comparison: pd.DataFrame | None = None
    ranking: pd.DataFrame | None = None
    uncertainties: dict[str, ParameterUncertainty] = field(default_factory=dict)
    predictions: tuple[Prediction, ...] = ()

    @property
    def warnings(self) -> tuple[TrustWarning, ...]:
        """Results that should not be trusted as they stand (:func:`study_warnings`)."""
        return study_warnings(self)


def study_warnings(result: StudyResult) -> tuple[TrustWarning, ...]:
    """The identification's warnings (:mod:`nlupdate.identification.trust`), then each
    updating run's (:mod:`nlupdate.updating.trust`: parameters that ended on a bound of
    the study, propagated uncertainty above the value), in run order."""
    out: list[TrustWarning] = []
    if result.identification is not None:
        out += result.identification.warnings
    bounds = {p.name: (p.lower, p.upper) for p in result.study.parameters}
    for run in result.runs:
        out += updating_warnings(run, {**(run.bounds or {}), **bounds}, result.uncertainties.get(run.name))
    return tuple(out)


def run_study(study: Study, say: Callable[[str], None] = lambda message: None) -> StudyResult:
    """Run every step the study describes, in order; ``say`` receives progress lines."""
    measured = identification = targets = comparison = ranking = None
    runs: list[UpdatingResult] = []
    failures: list[RunFailure] = []
    uncertainties: dict[str, ParameterUncertainty] = {}
    predictions: list[Prediction] = []
    if study.measured is not None:
        say("measured data")
        measured = measured_table(study)
    if study.identification is not None:
        say("identification")
        identification = identification_step(study, measured)
    if study.adapter is not None:
        targets = study_targets(study, identification)
        tasks = updating_tasks(study, targets)
        evaluator = MemoisedEvaluator(build_adapter(study.adapter))
        for i, task in enumerate(tasks, start=1):
            say(f"updating {i}/{len(tasks)}: {task.name}")
            try:
                runs.append(update(task, evaluator))
            except Exception as error:  # one failing branch must not stop the sweep
                failures.append(RunFailure(task.name, f"{type(error).__name__}: {error}"))
        if runs:
            comparison, ranking = compare_runs(study, targets, runs)
            uncertainties = parameter_uncertainties(study, targets, runs)
    if study.prediction is not None and runs:
        evaluator = MemoisedEvaluator(build_adapter(prediction_adapter(study)))
        for name, point in prediction_points(study, runs, ranking):
            say(f"prediction: {name}")
            modes = evaluator([point])[0]
            predictions.append(predict_model(study, name, point, modes, identification, measured))
    return StudyResult(study, measured, identification, targets, tuple(runs), tuple(failures), comparison, ranking,
                       uncertainties, tuple(predictions))
