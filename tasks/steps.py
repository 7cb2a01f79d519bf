"""One thin Prefect task per step of a study (:mod:`nlupdate.study.steps`), and one for a
single FE evaluation.

Each task's first argument is its cache ``key`` (:mod:`nlupdate.tasks.keys`); the cache
policy is the task's inputs *without* the heavy or live arguments (studies, tables,
models, evaluators) plus the task's source, so a key names a result across runs and
processes. Results persist in the store the flow configures (:func:`configured`).
Newton steps and continuation points are not tasks: a task is a step a person would name.

The store is a folder of signed records that hold results as data, written atomically
(:mod:`nlupdate.tasks.store`): a record someone else wrote or edited is named and
recomputed, never executed or used. Prefect's ``SERIALIZABLE`` isolation with its
``FileSystemLockManager`` is not used: its locks never expire when taken through a task's
transaction, so a run killed while holding one would leave the next run waiting forever;
two runs computing the same key at once both compute it and write the same result.
"""
from __future__ import annotations

from pathlib import Path
from typing import Mapping, Sequence

import pandas as pd
from prefect import Task, task
from prefect.cache_policies import INPUTS, TASK_SOURCE

from nlupdate.adapters.base import ModalResult
from nlupdate.discovery.candidates import CandidateFit
from nlupdate.discovery.workflow import fit_candidate
from nlupdate.identification.pipeline import Identification
from nlupdate.input_files import pinned
from nlupdate.study import steps
from nlupdate.study.spec import Study
from nlupdate.study.steps import Prediction, TargetSet
from nlupdate.tasks.evaluation import current_evaluator
from nlupdate.tasks.keys import adapter_for
from nlupdate.tasks.store import DataSerializer, record_store
from nlupdate.adapters.registry import AdapterSpec
from nlupdate.updating.candidates import UpdatingTask, update
from nlupdate.updating.eigensensitivity import UpdatingResult


def _keyed(*live: str):
    """Cache policy: the task's inputs except the ``live`` arguments, plus its source."""
    policy = INPUTS
    for name in live:
        policy = policy - name
    return policy + TASK_SOURCE


@task(name="measured data", cache_policy=_keyed("study"), persist_result=True)
def measured_data(key: str, study: Study) -> pd.DataFrame:
    """The study's measured-FRF table (read or simulated)."""
    with pinned(study.snapshots):  # the run's inputs as read when it started, also on a Dask worker
        return steps.measured_table(study)


@task(name="identification", cache_policy=_keyed("study", "table"), persist_result=True)
def identification(key: str, study: Study, table: pd.DataFrame) -> Identification:
    """PRD/DDF identification, linear-FRF extraction, modes and Monte Carlo."""
    with pinned(study.snapshots):  # the run's inputs as read when it started, also on a Dask worker
        return steps.identification_step(study, table)


@task(name="targets", cache_policy=_keyed("study", "identified"), persist_result=True)
def targets(key: str, study: Study, identified: Identification | None) -> TargetSet:
    """The updating targets (and their uncertainty) of the study."""
    with pinned(study.snapshots):  # the run's inputs as read when it started, also on a Dask worker
        return steps.study_targets(study, identified)


@task(name="FE point", cache_policy=_keyed("spec", "point"), persist_result=True)
def evaluate_point(key: str, spec: AdapterSpec, point: Mapping[str, float]) -> ModalResult:
    """One FE evaluation: modes of the model ``spec`` at parameter values ``point``."""
    return adapter_for(spec).evaluate(point)


@task(name="updating run", cache_policy=_keyed("updating_task"), persist_result=True)
def updating_run(key: str, updating_task: UpdatingTask) -> UpdatingResult:
    """One updating run (formula × parameter set, or optimisation candidate); its FE
    evaluations go to the evaluator of the context (FE-point tasks on the flow's task
    runner, :func:`nlupdate.tasks.evaluation.evaluating_with`)."""
    return update(updating_task, current_evaluator())


@task(name="comparison", cache_policy=_keyed("study", "target_set", "runs"), persist_result=True)
def comparison(key: str, study: Study, target_set: TargetSet, runs: Sequence[UpdatingResult]):
    """Mode-by-mode comparison, ranking and parameter uncertainty of the runs."""
    compared, ranking = steps.compare_runs(study, target_set, runs)
    return compared, ranking, steps.parameter_uncertainties(study, target_set, runs)


@task(name="prediction", cache_policy=_keyed("study", "point", "modes", "identified", "table"), persist_result=True)
def prediction(key: str, study: Study, name: str, point: Mapping[str, float], modes: ModalResult,
               identified: Identification, table: pd.DataFrame) -> Prediction:
    """The updated nonlinear model of one run at every force level, and its correlation."""
    with pinned(study.snapshots):  # the run's inputs as read when it started, also on a Dask worker
        return steps.predict_model(study, name, point, modes, identified, table)


@task(name="candidate fit", cache_policy=_keyed("job"), persist_result=True)
def candidate_fit(key: str, job: tuple) -> CandidateFit:
    """One discovery candidate (an effect at a place) fitted to the measurements."""
    return fit_candidate(job)


def configured(step: Task, store: Path, refresh: bool = False) -> Task:
    """``step`` persisting its results in the cache folder ``store`` (``refresh``: compute
    even when the store has the result, and overwrite it) as signed data records
    (:mod:`nlupdate.tasks.store`)."""
    configured_step = step.with_options(result_storage=Path(store), refresh_cache=refresh,
                                        result_serializer=DataSerializer())
    # Task() accepts a block only once saved on the server (for workers elsewhere to load
    # it); a local folder needs no such record — Prefect itself turns the Path into an
    # unsaved LocalFileSystem — so the block replaces the Path after that check.
    configured_step.result_storage = record_store(Path(store))
    return configured_step
