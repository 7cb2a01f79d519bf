"""The Prefect tasks of a study: one per chain step, one per job of a fan-out step (and one
per discovery candidate fit). A job computes its FE evaluations inside its task, each kept
as a signed record of its own (:mod:`nlupdate.orchestration.tasks.fe_points`).

Every task takes its cache ``key`` first (:mod:`nlupdate.orchestration.tasks.keys`) and is cached by it
alone — never by the heavy or live arguments beside it (studies, tables, models), which
Prefect could not hash reliably. A step's task runs the step's function from
:data:`nlupdate.study.chain.STEPS`; a job's task runs the step's ``each`` with the FE
evaluator of its context (:func:`nlupdate.orchestration.tasks.fe_points.evaluating_with`). Both read the
run's inputs as it pinned them, also on a Dask worker. Newton steps and continuation
points are not tasks: a task is a step a person would name.

Results persist as signed data records (:mod:`nlupdate.orchestration.tasks.store`): a record someone
else wrote or edited is named and recomputed, never executed or used. Prefect's
``SERIALIZABLE`` isolation with its ``FileSystemLockManager`` is not used: its locks never
expire when taken through a task's transaction, so a run killed while holding one would
leave the next run waiting forever; two runs computing the same key at once both compute
it and write the same result.
"""
from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping

from prefect import Task, task

from nlupdate.input_files import pinned
from nlupdate.study.chain import STEPS
from nlupdate.study.spec import Study
from nlupdate.orchestration.tasks.fe_points import current_evaluator
from nlupdate.orchestration.tasks.store import DataSerializer, record_store

if TYPE_CHECKING:
    from nlupdate.core.discovery.candidates import CandidateFit


def _by_key(context: Any, parameters: Mapping[str, Any]) -> str:
    return parameters["key"]


@task(name="step", cache_key_fn=_by_key, persist_result=True)
def chain_step(key: str, step: str, study: Study, inputs: tuple) -> Any:
    """The chain step named ``step`` on ``inputs`` (the results of its inputs)."""
    with pinned(study.snapshots):
        return STEPS[step].compute(study, *inputs)


@task(name="job", cache_key_fn=_by_key, persist_result=True)
def chain_job(key: str, step: str, study: Study, job: Any, inputs: tuple) -> Any:
    """One job of the fan-out step ``step``; its FE points go to the evaluator of the
    context (computed on the run's threads or Dask workers, each kept in the cache)."""
    with pinned(study.snapshots):
        return STEPS[step].each(study, job, current_evaluator(), *inputs)


@task(name="candidate fit", cache_key_fn=_by_key, persist_result=True)
def candidate_fit(key: str, job: tuple) -> CandidateFit:
    """One discovery candidate (an effect at a place) fitted to the measurements. (Discovery
    is imported here, by the runs that fit candidates: a study's run does not load it.)"""
    from nlupdate.core.discovery.workflow import fit_candidate

    return fit_candidate(job)


def configured(step: Task, store: Path, refresh: bool = False) -> Task:
    """``step`` persisting its results in the cache folder ``store`` (``refresh``: compute
    even when the store has the result, and overwrite it) as signed data records
    (:mod:`nlupdate.orchestration.tasks.store`)."""
    configured_step = step.with_options(result_storage=Path(store), refresh_cache=refresh,
                                        result_serializer=DataSerializer())
    # Task() accepts a block only once saved on the server (for workers elsewhere to load
    # it); a local folder needs no such record — Prefect itself turns the Path into an
    # unsaved LocalFileSystem — so the block replaces the Path after that check.
    configured_step.result_storage = record_store(Path(store))
    return configured_step
