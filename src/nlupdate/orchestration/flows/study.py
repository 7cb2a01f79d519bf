"""The study as a Prefect flow: the chain (:data:`nlupdate.study.chain.CHAIN`) as cached
tasks, then the run's archive.

Each step is a task named after it (:mod:`nlupdate.orchestration.tasks.cached`), keyed by its entry in the
chain (:func:`nlupdate.orchestration.tasks.keys.step_key`). A fan-out step — the updating runs, the
predictions — is a task run per job in the study's flow run, each named after its step and
job (``updating: central O(h^2) {E}``). Its jobs start at once, each on a coordinator
thread that runs its job task; jobs whose FE points are known beforehand (the
predictions: :attr:`~nlupdate.study.chain.Step.points`) submit those at once and then run
in turn. The FE evaluations are not tasks: a job computes its points inside its task, on
the run's threads (as many as the task runner has) or its Dask workers, each kept as a
signed cache record of its own, and shares them with the other jobs of the run
(:class:`~nlupdate.orchestration.tasks.fe_points.PointRegistry`), so the start point four difference
formulas need — and the prediction of the initial model — is solved once. A failing
updating run fails its own branch only; it is named in the report and the manifest.
:func:`nlupdate.study.sequential.run_study` walks the same chain in one process and gives
the same numbers.
"""
from __future__ import annotations

import contextlib
import contextvars
import datetime as dt
import functools
import os
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from typing import Any, Callable, Iterator

from prefect import flow
from prefect.context import FlowRunContext
from prefect.utilities.annotations import opaque
from rich.markup import escape

from nlupdate.orchestration.flows.cache import Cache
from nlupdate.orchestration.flows.handles import Handle, study_handle
from nlupdate.orchestration.flows.liveness import claim_flow_run
from nlupdate.orchestration.flows.status_lines import current_progress
from nlupdate.reporting.archive import inputs_hash, run_folder, write_archive, write_failed_archive
from nlupdate.reporting.report import study_warning_lines
from nlupdate.study.chain import CHAIN, Step, StudyResult, study_result
from nlupdate.study.spec import Study
from nlupdate.study.steps.updating import RunFailure
from nlupdate.orchestration.tasks import cached, keys
from nlupdate.orchestration.tasks.figures import FigureStore
from nlupdate.orchestration.tasks.names import job_run_name, step_run_name
from nlupdate.orchestration.tasks.fe_points import PointRegistry, RegistryPointEvaluator, adapter_for, evaluating_with

__all__ = ["Cache", "study_flow", "study_handle"]


def _named(job: Any) -> str:
    return str(getattr(job, "name", job))


def _step_task(step: Step, study: Study, inputs: list, input_keys: list, cache: Cache) -> tuple[Any, str]:
    """One step as a cached task; its result and key."""
    key = keys.step_key(step, study, input_keys)
    started = time.perf_counter()
    task = cache.task(cached.chain_step, step.name, step_run_name(step.name, study.name))
    future = task.submit(key, step.name, Opaque(study), _opaque(inputs))
    future.wait()
    result = future.result()
    current_progress().finished(step.name, future.state.name, step.describe(study, result),
                                time.perf_counter() - started)
    return result, key


def _fan_out(step: Step, study: Study, values: list, input_keys: list, registry: PointRegistry,
             cache: Cache) -> tuple[Any, str]:
    """Every job of the fan-out step ``step``, started together as task runs of the study's
    flow run, their FE points in the run's ``registry``; their outcomes gathered by the
    step. Returns the result and its key. Each job's task run, progress line and manifest
    entry carry the job's name, which starts with the step's
    (:func:`~nlupdate.orchestration.tasks.names.job_run_name`): the UI lists and draws a
    step's jobs together by it. (A subflow per step grouped them too, at four API writes and
    a task runner of its own per step, about 0.2 s of CPU each; tags would cost a
    concurrency-slot round trip per task run.)"""
    progress = current_progress()
    spec = step.model(study)
    model = keys.model_identity(spec, adapter_for(spec).model_fingerprint())
    jobs = step.jobs(study, *values)
    intro = step.introduce(study, jobs)
    if intro:
        progress.introduce(step.name, intro)
    count, finished, in_order = len(jobs), iter(range(1, len(jobs) + 1)), threading.Lock()
    shared = _opaque(values)

    def report(name: str, state: str, detail: str, seconds: float | None = None) -> None:
        with in_order:  # lines in the order of their i/N
            progress.finished(name, state, detail, seconds, f"{next(finished)}/{count}")

    def one(job: Any) -> tuple[Any, str | None]:
        key = keys.job_key(step, study, job, model, input_keys)
        name = job_run_name(step.name, _named(job))
        task = cache.task(cached.chain_job, step.name, name)
        started = time.perf_counter()
        with evaluating_with(RegistryPointEvaluator(spec, registry)):
            state = task(key, step.name, Opaque(study), Opaque(job), shared, return_state=True)
        if state.is_completed():
            outcome = state.result()
            # a job read from the cache ran no FE points here: its result's own counts are
            # those of the run that computed it, so they are not shown as this run's
            report(name, state.name, "" if state.name == "Cached" else step.label(job, outcome),
                   time.perf_counter() - started)
            return outcome, key
        try:
            state.result()
            error = state.message or state.name
        except Exception as raised:  # the job's error, as raised in its task
            if not step.keep_going:
                raise
            error = f"{type(raised).__name__}: {raised}"
        failure = RunFailure(_named(job), error)
        report(name, state.name, step.label(job, failure))
        return failure, None

    if step.points is not None:  # the FE points of every job to compute at once, then the jobs in turn
        for job in jobs:
            if cache.will_compute(keys.job_key(step, study, job, model, input_keys)):
                for point in step.points(job):
                    registry.future(spec, point)
        outcomes = [one(job) for job in jobs]
    else:
        with ThreadPoolExecutor(max_workers=max(count, 1), thread_name_prefix=f"{step.name}-job") as pool:
            # each coordinator runs in a copy of this thread's context: the flow run and the progress
            futures = [pool.submit(contextvars.copy_context().run, one, job) for job in jobs]
            outcomes = [future.result() for future in futures]
    return (step.compute(study, [outcome for outcome, _ in outcomes], *values),
            keys.gathered_key(step, [key for _, key in outcomes if key is not None]))


class Opaque(opaque):
    """Prefect's ``opaque``: a task argument whose own task run Prefect finds (the edge of the
    run graph) and which it does not walk into. Prefect looks through every argument of a
    task run for futures, twice (recording its inputs, then resolving them): through a
    study's results that was about 0.4 s of the demo's CPU. Pickled as what it wraps (for a
    Dask worker): Prefect's own, a tuple, comes back wrapping a tuple of its value."""

    __slots__ = ()

    def __reduce__(self):
        return type(self), (self.unwrap(),)


def _opaque(values: list) -> tuple:
    """A task's inputs, each :class:`Opaque`."""
    return tuple(Opaque(value) for value in values)


def run_chain(study: Study, cache: Cache) -> tuple[StudyResult, dict[str, str]]:
    """Every step the study asks for, as cached tasks; the result and every
    step's key (step name → key)."""
    results: dict[str, Any] = {}
    result_keys: dict[str, str] = {}
    with _point_executor(FlowRunContext.get().task_runner) as submit:
        registry = PointRegistry(submit, cache.store, cache.refresh)
        _run_steps(study, cache, registry, results, result_keys)
        if any(step.fans_out and step.name in results for step in CHAIN):
            _tally_points(registry.states())
    return study_result(study, results), result_keys


@contextlib.contextmanager
def _point_executor(task_runner: Any) -> Iterator[Callable[..., Any]]:
    """``submit(function, *arguments)`` for the run's FE points: the Dask client of a Dask
    task runner, else a thread pool as wide as the runner's (closed with the context)."""
    client = getattr(task_runner, "client", None)  # prefect-dask's runner; the thread pool has none
    if client is not None:
        yield functools.partial(client.submit, pure=False)
        return
    workers = getattr(task_runner, "_max_workers", None) or os.cpu_count() or 1
    pool = ThreadPoolExecutor(max_workers=min(workers, 64), thread_name_prefix="FE-point")
    try:
        yield pool.submit
    finally:  # a run stopped by an error or Ctrl-C computes no queued point
        pool.shutdown(wait=True, cancel_futures=True)


def _run_steps(study: Study, cache: Cache, registry: PointRegistry, results: dict[str, Any],
               result_keys: dict[str, str]) -> None:
    """Each step the study asks for in chain order, its result and key into ``results`` and
    ``result_keys``."""
    for step in CHAIN:
        if not step.applies(study, results):
            continue
        inputs = [results.get(name) for name in step.inputs]
        input_keys = [result_keys.get(name) for name in step.inputs]
        if step.fans_out:
            results[step.name], result_keys[step.name] = _fan_out(step, study, inputs, input_keys, registry, cache)
        else:
            results[step.name], result_keys[step.name] = _step_task(step, study, inputs, input_keys, cache)


def _tally_points(states: list[str]) -> None:
    """Record the run's FE points and say how many were computed here and how many read
    from the cache (none at all when every job came from the cache)."""
    progress = current_progress()
    for state in states:
        progress.record("FE point", state)
    if not states:
        progress.say("[bold]FE points[/bold]: none needed, every job came from the cache")
        return
    computed, from_cache = states.count("Completed"), states.count("Cached")
    failed = len(states) - computed - from_cache
    progress.say(f"[bold]FE points[/bold]: {computed} computed, {from_cache} from the cache"
                 + (f", {failed} failed" if failed else ""))


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
        result, step_keys = run_chain(study, cache)
    except Exception as error:
        folder = write_failed_archive(study, run_folder(results_root, study.name, started, study.sha256), run_record(),
                                      f"{type(error).__name__}: {error}")
        progress.say(f"[bold red]the study failed[/bold red]: {escape(f'{type(error).__name__}: {error}')}; "
                     f"archive {escape(str(folder))}")
        raise
    progress.say(f"steps done in {time.perf_counter() - clock:.1f} s; writing the archive …")
    for line in study_warning_lines(result):  # what not to trust, where the run's page shows it
        progress.warn_run(line)
    figures = FigureStore(cache.store, keys.figures_key(study, step_keys), refresh=cache.refresh)
    folder = write_archive(result, run_folder(results_root, study.name, started, inputs_hash(result)), run_record(),
                           figures=figures)
    return str(folder)
