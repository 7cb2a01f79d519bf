"""The chain of a study, declared once.

    measured data → identification → targets → updating → comparison → candidate FRFs
    → predictions → validation → amplitude → FE validation → warnings

:data:`CHAIN` lists the steps in order. Each :class:`Step` names the function that
computes it (:mod:`nlupdate.study.steps`), the earlier results it takes, the study
sections its result depends on — its cache key is made of those, the code, the study's
input files and the keys of its inputs (:func:`nlupdate.orchestration.tasks.keys.step_key`) — and when
the study asks for it. A step with ``jobs`` fans out: its jobs (the updating runs, one per
formula × parameter set and optimisation candidate; the predictions, one per model) run
one by one or concurrently, each evaluating FE points of ``model`` through the evaluator
it is given, and ``compute`` gathers their outcomes.

Two short interpreters run the chain: :func:`nlupdate.study.sequential.run_study` in order in one
process, and the Prefect flow :func:`nlupdate.orchestration.flows.study.study_flow` as cached tasks (FE
points and jobs on the task runner). A new step is one function and one entry here.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Mapping, Sequence

import pandas as pd

from nlupdate.core.identification.methods import spelled_out
from nlupdate.core.identification.pipeline import Identification
from nlupdate.core.identification.trust import TrustWarning
from nlupdate.study.spec import Study
from nlupdate.study.steps.measured import identification_step, measured_description, measured_table
from nlupdate.study.steps.prediction import Prediction, PredictionJob, predict_job, prediction_adapter, prediction_jobs
from nlupdate.study.steps.record import models_used
from nlupdate.core.identification.trust import warning_texts
from nlupdate.study.steps.trust import study_warnings
from nlupdate.study.steps.updating import (
    CandidateFRFs, Comparison, RunFailure, TargetSet, UpdatingOutcome, candidate_frfs, compare_runs, run_update,
    run_verdict, study_targets, updating_intro, updating_model, updating_runs,
)
from nlupdate.study.steps.amplitude import amplitude_step
from nlupdate.study.steps.fe_validation import fe_validation_step
from nlupdate.study.steps.validation import validation_step
from nlupdate.core.identification.amplitude_joint import AmplitudeFit
from nlupdate.core.validation.held_out import Validation
from nlupdate.fe.joint_validation import FEValidation
from nlupdate.core.updating.eigensensitivity import UpdatingResult
from nlupdate.core.updating.target_uncertainty import ParameterUncertainty
from nlupdate.core.updating.runs import best_ranked

Results = Mapping[str, Any]


@dataclass(frozen=True)
class Step:
    """One step of the chain.

    name: as progress lines and the Prefect UI show it (and the key of its result);
    compute: ``(study, *inputs) -> result``; for a fan-out step ``(study, outcomes, *inputs)``;
    inputs: names of the earlier results it takes (``None`` when the study has no such step);
    sections: the :class:`~nlupdate.study.spec.Study` attributes its result depends on;
    applies: ``(study, results so far) -> bool``, whether the study asks for it;
    describe: ``(study, result) -> str``, the detail of its progress line;
    jobs: fan-out: ``(study, *inputs) -> jobs``; each: ``(study, job, evaluator, *inputs)``;
    model: fan-out: the FE model (:class:`~nlupdate.fe.adapters.registry.AdapterSpec`) its
        jobs evaluate points of; keep_going: a failing job is recorded as a
        :class:`~nlupdate.study.steps.updating.RunFailure` and the others go on;
    label: fan-out: ``(job, outcome) -> str``, a computed job's progress detail (the line
        already names the job);
    introduce: fan-out: ``(study, jobs) -> str``, the line said before the jobs' lines: what
        their names say ('' for none);
    jobs_describe_themselves: fan-out: a job holds everything its result depends on (an
        updating run: its parameters with their bounds, targets, method and options), so
        its cache key is the job and its model alone — changing one run's bound recomputes
        that run only.
    points: fan-out: ``job -> FE points`` when a job's points are known before it runs
        (a prediction: its model's one point). The flow then submits every job's points
        at once and runs the jobs one after another: their own work is numerics in this
        process, which jobs on threads would only share (two demo predictions on threads
        took 1.3–1.4 s each, one after the other 0.4 and 0.6 s). Without it the jobs run
        at once, each submitting points as it goes (an updating run's points depend on
        its iterations).
    """

    name: str
    compute: Callable[..., Any]
    inputs: tuple[str, ...] = ()
    sections: tuple[str, ...] = ()
    applies: Callable[[Study, Results], bool] = lambda study, results: True
    describe: Callable[[Study, Any], str] = lambda study, result: ""
    jobs: Callable[..., Sequence[Any]] | None = None
    each: Callable[..., Any] | None = None
    model: Callable[[Study], Any] | None = None
    keep_going: bool = False
    label: Callable[[Any, Any], str] = lambda job, outcome: ""
    introduce: Callable[[Study, Sequence[Any]], str] = lambda study, jobs: ""
    jobs_describe_themselves: bool = False
    points: Callable[[Any], Sequence[Mapping[str, float]]] | None = None

    @property
    def fans_out(self) -> bool:
        return self.jobs is not None


def _has_runs(study: Study, results: Results) -> bool:
    outcome = results.get("updating")
    return outcome is not None and bool(outcome.runs)


CHAIN: tuple[Step, ...] = (
    Step("measured data", measured_table, sections=("measured",),
         applies=lambda study, results: study.measured is not None,
         describe=lambda study, table: measured_description(study)),
    Step("identification", identification_step, inputs=("measured data",), sections=("identification",),
         applies=lambda study, results: study.identification is not None,
         describe=lambda study, identified: f"{spelled_out(study.identification.method)}, "
                                            f"{study.identification.samples} Monte-Carlo samples"),
    Step("targets", study_targets, inputs=("identification",), sections=("targets", "comparison"),
         applies=lambda study, results: study.adapter is not None),
    Step("updating", lambda study, outcomes, targets: UpdatingOutcome.of(outcomes), inputs=("targets",),
         sections=("adapter", "parameters", "fixed", "updating", "eigensensitivity", "optimisation", "candidates"),
         applies=lambda study, results: study.adapter is not None,
         jobs=updating_runs, each=run_update, model=updating_model, keep_going=True,
         label=run_verdict, introduce=updating_intro, jobs_describe_themselves=True),
    Step("comparison", compare_runs, inputs=("targets", "updating"), sections=("comparison", "parameters"),
         applies=_has_runs),
    Step("candidate FRFs", candidate_frfs, inputs=("targets", "updating"), sections=("comparison", "targets"),
         applies=lambda study, results: _has_runs(study, results) and results["targets"].reference is not None),
    Step("predictions", lambda study, outcomes, *inputs: tuple(outcomes),
         inputs=("updating", "comparison", "identification", "measured data"), sections=("prediction", "targets"),
         applies=lambda study, results: study.prediction is not None and _has_runs(study, results),
         jobs=prediction_jobs, each=predict_job, model=prediction_adapter, points=lambda job: [job.point]),
    Step("validation", validation_step, inputs=("measured data",), sections=("validation",),
         applies=lambda study, results: study.validation is not None,
         describe=lambda study, validation: f"{len({r.level for r in validation.held_out})} held-out level(s), "
                                            f"{', '.join(study.validation.models)}"),
    Step("amplitude", amplitude_step, inputs=("measured data",), sections=("amplitude", "measured"),
         applies=lambda study, results: study.amplitude is not None,
         describe=lambda study, fit: f"{fit.samples.amplitude.size} samples of {len(fit.points)} source(s), "
                                     f"{fit.model.backbone} backbone, linear limit {fit.model.natural_frequency_hz:.6g} "
                                     f"Hz, {100 * fit.model.damping_ratio:.3g} %" + (
                                         f" — {len(fit.model.warnings)} warning(s) on it, report.md's summary"
                                         if fit.model.warnings else "")),
    Step("FE validation", fe_validation_step, inputs=("targets", "updating", "comparison"),
         sections=("fe_validation", "adapter", "fixed", "parameters", "targets"),
         applies=lambda study, results: study.fe_validation is not None and _has_runs(study, results),
         describe=lambda study, found: f"{len(found.table)} run prediction(s), {found.element} joint per bolt, "
                                       f"fit rms {found.fit['rms_residual']:.3f} after {found.fit['evaluations']} "
                                       "evaluation(s)"),
    Step("warnings", study_warnings, inputs=("identification", "updating", "comparison", "predictions", "targets"),
         sections=("parameters",),
         describe=lambda study, warnings: (f"{len(warning_texts(warnings))} on results not to be trusted as they "
                                           "stand (the summary's Warnings)" if warnings else "none"),
         applies=lambda study, results: results.get("identification") is not None or _has_runs(study, results)),
)
STEPS: dict[str, Step] = {step.name: step for step in CHAIN}


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
    candidate_frfs: CandidateFRFs | None = None
    predictions: tuple[Prediction, ...] = ()
    warnings: tuple[TrustWarning, ...] = ()
    models: Mapping[str, Any] = field(default_factory=dict)
    validation: Validation | None = None
    fe_validation: FEValidation | None = None
    amplitude: AmplitudeFit | None = None

    @property
    def best(self) -> str | None:
        """The best-ranked updating run's name (None without updating runs):
        :func:`~nlupdate.core.updating.runs.best_ranked`."""
        return best_ranked(self.ranking)

    def __repr__(self) -> str:
        """One line: the study, its runs, the best one, predictions and warnings
        (``summary()``: a line per part; the default repr printed the measured table)."""
        failed = f" ({len(self.failures)} failed)" if self.failures else ""
        best = f"; best {self.best!r}" if self.best else ""
        return (f"<StudyResult {self.study.name!r}: {len(self.runs)} updating run(s){failed}{best}; "
                f"{len(self.predictions)} prediction(s); {len(self.warnings)} warning(s)>")

    def summary(self) -> str:
        """A line for the identification, each updating run, each failure, the best run,
        each prediction (FRAC per force level) and each warning."""
        lines = [f"study {self.study.name!r}"]
        if self.identification is not None:
            lines.append(f"identified ({self.identification.settings.method.upper()}): "
                         + ", ".join(f"{k} = {v:.4g}" for k, v in self.identification.parameters().items()))
        lines += [f"run {run.name}: " + ", ".join(f"{k} = {v:.6g}" for k, v in run.parameters.items())
                  + f" ({run.stop} after {run.iterations} iteration(s))" for run in self.runs]
        lines += [f"run {failure.name!r} failed: {failure.error}" for failure in self.failures]
        if self.best:
            lines.append(f"best ranked: {self.best}")
        lines += [f"prediction {p.name}: FRAC per level " + " ".join(f"{v:.3f}" for v in p.correlation["frac"])
                  for p in self.predictions]
        lines += [f"warning: {w.source + ': ' if w.source else ''}{w.message}" for w in self.warnings]
        return "\n".join(lines)


def study_result(study: Study, results: Results) -> StudyResult:
    """The :class:`StudyResult` of the chain's ``results`` (step name → result)."""
    outcome: UpdatingOutcome = results.get("updating") or UpdatingOutcome((), ())
    compared: Comparison | None = results.get("comparison")
    return StudyResult(
        study=study, measured=results.get("measured data"), identification=results.get("identification"),
        targets=results.get("targets"), runs=outcome.runs, failures=outcome.failures,
        comparison=None if compared is None else compared.table, ranking=None if compared is None else compared.ranking,
        uncertainties={} if compared is None else dict(compared.uncertainties),
        candidate_frfs=results.get("candidate FRFs"), predictions=tuple(results.get("predictions") or ()),
        warnings=tuple(results.get("warnings") or ()), models=models_used(study),
        validation=results.get("validation"), fe_validation=results.get("FE validation"),
        amplitude=results.get("amplitude"),
    )


__all__ = ["CHAIN", "STEPS", "PredictionJob", "Step", "StudyResult", "study_result"]
