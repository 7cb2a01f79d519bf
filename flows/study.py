"""The study as Prefect flows: identification, updating sweep, prediction, and the study
flow that wires them and writes the run's archive.

Every step is a cached task (:mod:`nlupdate.tasks.steps`) calling the same library step
as the plain sequential run (:func:`nlupdate.study.run.run_study`), so both give the same
numbers. The updating sweep starts one coordinator thread per run (formula × parameter
set, optimisation candidate); each coordinator runs its updating-run task, whose FE
evaluations are FE-point tasks submitted to the flow's task runner (threads or Dask
workers) and shared between runs (:class:`~nlupdate.tasks.evaluation.PointRegistry`).
A failing run fails its own branch only; it is named in the report and the manifest.
"""
from __future__ import annotations

import contextvars
import datetime as dt
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd
from prefect import flow
from prefect.context import FlowRunContext
from pydantic import BaseModel, ConfigDict, PrivateAttr, model_serializer

from nlupdate.flows.liveness import claim_flow_run
from nlupdate.flows.progress import current_progress
from nlupdate.identification.pipeline import Identification
from nlupdate.reporting.archive import inputs_hash, run_folder, write_archive, write_failed_archive
from nlupdate.fingerprints import table_hash
from nlupdate.study import steps
from nlupdate.study.run import StudyResult
from nlupdate.study.spec import Study
from nlupdate.study.steps import Prediction, RunFailure, TargetSet
from nlupdate.tasks import keys
from nlupdate.tasks import steps as tasks
from nlupdate.tasks.evaluation import PointRegistry, TaskPointEvaluator, evaluating_with
from nlupdate.updating.eigensensitivity import UpdatingResult
from nlupdate.updating.uncertainty import ParameterUncertainty


class Handle(BaseModel):
    """A value handed to a flow by reference. The API stores a flow run's parameters as
    JSON (at most 512 KB); a handle's JSON is its one-line ``description``, which is what
    the run's page shows, while the flow gets :attr:`value` itself. The value is a private
    attribute, so Prefect does not walk through it looking for futures (seconds for a
    sweep's results)."""

    model_config = ConfigDict(frozen=True)
    description: str
    _value: Any = PrivateAttr()

    @property
    def value(self) -> Any:
        return self._value

    @model_serializer
    def _as_description(self) -> str:
        return self.description


def handle(value: Any, description: str) -> Handle:
    wrapped = Handle(description=description)
    wrapped._value = value
    return wrapped


@dataclass(frozen=True)
class Cache:
    """Where task results persist, and whether to recompute them anyway."""

    store: str
    refresh: bool = False

    def task(self, step):
        return tasks.configured(step, Path(self.store), self.refresh)


@dataclass(frozen=True, eq=False)
class SweepOutcome:
    runs: tuple[UpdatingResult, ...]
    failures: tuple[RunFailure, ...]
    comparison: pd.DataFrame | None
    ranking: pd.DataFrame | None
    uncertainties: dict[str, ParameterUncertainty]


def _finish(step: str, future, detail: str = "", started: float | None = None):
    """Wait for a submitted task, print and tally its state, return its result."""
    future.wait()
    state = future.state
    seconds = None if started is None else time.perf_counter() - started
    current_progress().finished(step, state.name, detail, seconds)
    return future.result()


def _measured_handle(table: pd.DataFrame) -> Handle:
    return handle(table, f"measured-FRF table, {len(table)} rows, sha256 {table_hash(table)[:12]}")


def _describe_targets(target_set: TargetSet) -> str:
    t = target_set.targets
    return "targets " + ", ".join(f"{label} {f:.5g} Hz" for label, f in zip(t.labels, t.frequencies_hz))


def study_handle(study: Study) -> Handle:
    """The study, as its run pages show it: name, file and hash."""
    return handle(study, f"study {study.name!r} ({study.path}, sha256 {study.sha256[:12]})")


def _subflow(sub):
    """``sub`` running on a copy of the current flow's task runner (same threads count or
    the same Dask cluster)."""
    return sub.with_options(task_runner=FlowRunContext.get().task_runner.duplicate())


@flow(name="identification")
def identification_flow(study_handle: Handle, measured_handle: Handle, cache: Cache) -> Identification:
    """Identify the nonlinearity and extract the linear FRF of the measured curve."""
    claim_flow_run()
    study, measured = study_handle.value, measured_handle.value
    key = keys.identification_key(study, table_hash(measured))
    started = time.perf_counter()
    future = cache.task(tasks.identification).submit(key, study, measured)
    return _finish("identification", future, f"{study.identification.method.upper()}, "
                   f"{study.identification.samples} Monte-Carlo samples", started)


@flow(name="updating sweep")
def updating_sweep_flow(study_handle: Handle, targets_handle: Handle, cache: Cache) -> SweepOutcome:
    """Every updating run of the study, submitted together; comparison and ranking."""
    claim_flow_run()
    study, target_set = study_handle.value, targets_handle.value
    progress = current_progress()
    updating_tasks = steps.updating_tasks(study, target_set)
    registry = PointRegistry(cache.task(tasks.evaluate_point))
    run_task = cache.task(tasks.updating_run)
    n = len(updating_tasks)
    done = iter(range(1, n + 1))

    def one_run(updating_task):
        started = time.perf_counter()
        with evaluating_with(TaskPointEvaluator(updating_task.adapter, registry)):
            state = run_task(keys.run_key(updating_task), updating_task, return_state=True)
        i = next(done)
        if state.is_completed():
            result = state.result()
            counts = f"{result.counts['new']} new / {result.counts['cached']} cached FE runs"
            verdict = "converged" if result.converged else f"not converged ({result.reason})"
            progress.finished(f"updating {i}/{n}", state.name, f"{updating_task.name}: {verdict}, {counts}",
                              time.perf_counter() - started)
            return result
        progress.finished(f"updating {i}/{n}", state.name, f"{updating_task.name}: {state.message}")
        try:
            state.result()
        except Exception as error:  # the branch's error, as raised in its task
            return RunFailure(updating_task.name, f"{type(error).__name__}: {error}")
        return RunFailure(updating_task.name, state.message or state.name)

    with ThreadPoolExecutor(max_workers=max(n, 1), thread_name_prefix="updating-run") as pool:
        # each coordinator runs in a copy of this thread's context: the flow run and the progress
        futures = [pool.submit(contextvars.copy_context().run, one_run, t) for t in updating_tasks]
        outcomes = [future.result() for future in futures]
    for name in registry.states():
        progress.record("FE point", name)
    runs = tuple(o for o in outcomes if isinstance(o, UpdatingResult))
    failures = tuple(o for o in outcomes if isinstance(o, RunFailure))
    if not runs:
        return SweepOutcome(runs, failures, None, None, {})
    key = keys.step_key("comparison", keys.digest(study.comparison, study.targets), target_set,
                        [keys.run_key(t) for t in updating_tasks if t.name in {r.name for r in runs}])
    compared, ranking, uncertainties = _finish("comparison", cache.task(tasks.comparison).submit(key, study, target_set, runs))
    return SweepOutcome(runs, failures, compared, ranking, uncertainties)


@flow(name="prediction")
def prediction_flow(study_handle: Handle, sweep_handle: Handle, identification_handle: Handle, measured_handle: Handle,
                    cache: Cache) -> tuple[Prediction, ...]:
    """The updated nonlinear models (and the initial one) at every force level."""
    claim_flow_run()
    study, sweep = study_handle.value, sweep_handle.value
    identified, measured = identification_handle.value, measured_handle.value
    spec = steps.prediction_adapter(study)
    registry = PointRegistry(cache.task(tasks.evaluate_point))
    evaluator = TaskPointEvaluator(spec, registry)
    points = steps.prediction_points(study, sweep.runs, sweep.ranking)
    futures = []
    measured_hash = table_hash(measured)
    identification_key = keys.identification_key(study, measured_hash)
    for name, point in points:
        modes = evaluator([point])[0]
        key = keys.prediction_key(study, spec, point, identification_key, measured_hash)
        futures.append((name, time.perf_counter(),
                        cache.task(tasks.prediction).submit(key, study, name, point, modes, identified, measured)))
    return tuple(_finish(f"prediction {i}/{len(futures)}", future, name, started)
                 for i, (name, started, future) in enumerate(futures, start=1))


def _study_steps(study_handle: Handle, cache: Cache) -> StudyResult:
    """Every step the study asks for, as cached tasks and subflows."""
    study = study_handle.value
    measured = identified = target_set = None
    sweep = SweepOutcome((), (), None, None, {})
    predictions: tuple[Prediction, ...] = ()
    if study.measured is not None:
        step_started = time.perf_counter()
        future = cache.task(tasks.measured_data).submit(keys.measured_key(study), study)
        measured = _finish("measured data", future, "simulated test" if study.measured.simulate else study.measured.file,
                           step_started)
    if study.identification is not None:
        identified = _subflow(identification_flow)(study_handle, _measured_handle(measured), cache)
    if study.adapter is not None:
        identification_key = keys.identification_key(study, table_hash(measured)) if identified is not None else None
        key = keys.step_key("targets", keys.digest(study.targets, study.comparison["frf"]), identification_key)
        target_set = _finish("targets", cache.task(tasks.targets).submit(key, study, identified))
        sweep = _subflow(updating_sweep_flow)(study_handle, handle(target_set, _describe_targets(target_set)), cache)
    if study.prediction is not None and sweep.runs:
        predictions = _subflow(prediction_flow)(
            study_handle, handle(sweep, f"{len(sweep.runs)} updating runs, best: {sweep.ranking['candidate'].iloc[0]}"),
            handle(identified, f"identification ({identified.model_description})"), _measured_handle(measured), cache)
    return StudyResult(study, measured, identified, target_set, sweep.runs, sweep.failures, sweep.comparison,
                       sweep.ranking, sweep.uncertainties, predictions)


@flow(name="study")
def study_flow(study_handle: Handle, cache: Cache, results_root: str, orchestration: str,
               annotations: dict[str, str] | None = None) -> str:
    """The whole study, then its archive under ``results_root``; returns the archive path.
    ``annotations`` go into the manifest's ``run`` record (e.g. ``rerun_of``). A study
    that fails with an error still leaves an archive (status ``failed``: the error, the
    study and its inputs), then the error is raised."""
    claim_flow_run()
    study = study_handle.value
    started = dt.datetime.now(dt.timezone.utc)
    clock = time.perf_counter()
    progress = current_progress()

    def run_record() -> dict:
        return {
            "started_utc": started.isoformat(), "finished_utc": dt.datetime.now(dt.timezone.utc).isoformat(),
            "wall_time_s": time.perf_counter() - clock, "orchestration": orchestration,
            "flow_run_id": str(FlowRunContext.get().flow_run.id), "cache_store": cache.store,
            "cache_refreshed": cache.refresh, "tasks": progress.summary(), **(annotations or {}),
        }

    try:
        result = _study_steps(study_handle, cache)
    except Exception as error:
        folder = write_failed_archive(study, run_folder(results_root, study.name, started, study.sha256), run_record(),
                                      f"{type(error).__name__}: {error}")
        progress.say(f"[bold red]the study failed[/bold red]: {type(error).__name__}: {error}; archive {folder}")
        raise
    progress.say(f"steps done in {time.perf_counter() - clock:.1f} s; writing the archive …")
    folder = write_archive(result, run_folder(results_root, study.name, started, inputs_hash(result)), run_record())
    return str(folder)
