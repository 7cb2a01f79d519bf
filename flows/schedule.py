"""Scheduled studies: Prefect deployments of :func:`scheduled_study`, and serving them.

* :func:`scheduled_study` — the deployments' flow. Its parameters are JSON (the study
  file, the results root and the cache store as absolute paths, the thread count); each
  run loads the study file as it is then and runs it with
  :func:`~nlupdate.flows.run.run_study_flow` as a subflow, so every run writes its own
  archive ``<results root>/<study>/<UTC time>-<hash>/`` and shares the task cache.
* :func:`register`, :func:`registered`, :func:`delete` — the deployments on the Prefect
  API, one per name (default: the study's name), each with one cron or interval schedule.
* :func:`serve` — runs them: a Prefect :class:`~prefect.runner.Runner` with the same
  deployments rebuilt from what the server holds (name, schedules, parameters, paused),
  so serving changes nothing that was registered; stopping it leaves the schedules active.

Schedules fire only when a persistent Prefect server (``prefect server start``, whose
scheduler service creates the runs) and :func:`serve` are both running. A temporary
server (what ``nlupdate run`` starts) keeps the deployments but never creates runs, which
is why :func:`schedule_api` insists on a server that outlives the command.
"""
from __future__ import annotations

import asyncio
import contextlib
import datetime as dt
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterator

import httpx
from prefect import flow

FLOW_NAME = "scheduled study"
DEFAULT_API = "http://127.0.0.1:4200/api"
HOW_TO_START = (f"schedules live in a persistent Prefect server: start one with `prefect server start` and set "
                f"PREFECT_API_URL={DEFAULT_API}")


class ScheduleError(RuntimeError):
    """The Prefect server cannot hold or run the schedules; the message says what to do."""


class UnknownSchedule(LookupError):
    """No scheduled study has that name."""


@dataclass(frozen=True)
class Scheduled:
    """A registered scheduled study, as ``nlupdate schedule list`` shows it."""

    name: str
    schedule: str
    study_file: str
    results_root: str
    workers: int
    cache_dir: str | None
    paused: bool
    next_run_utc: str | None

    def as_dict(self) -> dict:
        return dict(self.__dict__)


def _say(message: str) -> None:
    print(f"{dt.datetime.now(dt.timezone.utc):%Y-%m-%d %H:%M:%S} UTC  {message}", flush=True)


@flow(name=FLOW_NAME)
def scheduled_study(study_file: str, results_root: str, workers: int = 2, cache_dir: str | None = None) -> str:
    """One scheduled run of a study file: the study flow as a subflow on ``workers``
    threads, cached in ``cache_dir``; returns the archive it wrote under ``results_root``."""
    from prefect.runtime import deployment, flow_run

    from nlupdate.flows.liveness import claim_flow_run
    from nlupdate.flows.progress import Progress
    from nlupdate.flows.run import run_study_flow
    from nlupdate.flows.runners import Execution
    from nlupdate.study import load_study

    claim_flow_run()  # killed with serve, it is marked Crashed when the next run starts
    name = deployment.name or Path(study_file).stem
    label = f"{name}: run {flow_run.name!r}"
    _say(f"{label} started")
    started = time.perf_counter()
    scheduled = f"deployment {name!r} of flow {FLOW_NAME!r}, flow run {flow_run.name!r}"
    try:
        archive = run_study_flow(load_study(study_file), results_root, Execution(workers), cache_dir,
                                 progress=Progress(quiet=True), annotations={"scheduled": scheduled})
    except Exception as error:
        _say(f"{label} FAILED after {time.perf_counter() - started:.1f} s: {type(error).__name__}: "
             f"{str(error).strip().splitlines()[0] if str(error).strip() else ''}")
        raise
    _say(f"{label} finished in {time.perf_counter() - started:.1f} s; archive {archive}")
    return str(archive)


# ------------------------------------------------------------------ the Prefect API
def _answers(url: str, timeout_s: float = 5.0) -> bool:
    try:
        return httpx.get(f"{url.rstrip('/')}/health", timeout=timeout_s).status_code == 200
    except httpx.HTTPError:
        return False


@contextlib.contextmanager
def schedule_api(say: Callable[[str], None] = print) -> Iterator[str]:
    """Within the block, Prefect talks to the persistent server the schedules live in:
    ``PREFECT_API_URL`` (environment or Prefect profile), else :data:`DEFAULT_API` when a
    server answers there (said through ``say``); else :class:`ScheduleError`."""
    from prefect.settings import PREFECT_API_URL, get_current_settings, temporary_settings

    url = get_current_settings().api.url
    if url:
        if not _answers(url):
            raise ScheduleError(f"the Prefect API at PREFECT_API_URL={url} does not answer; {HOW_TO_START}")
        yield url
        return
    if not _answers(DEFAULT_API):
        raise ScheduleError(f"PREFECT_API_URL is not set and no Prefect server answers at {DEFAULT_API}; {HOW_TO_START}")
    say(f"Prefect API: {DEFAULT_API} (PREFECT_API_URL is not set; the server of `prefect server start` answers there)")
    previous = os.environ.get("PREFECT_API_URL")
    os.environ["PREFECT_API_URL"] = DEFAULT_API  # for the processes of the runs, too
    try:
        with temporary_settings(updates={PREFECT_API_URL: DEFAULT_API}):
            yield DEFAULT_API
    finally:
        if previous is None:
            os.environ.pop("PREFECT_API_URL", None)
        else:
            os.environ["PREFECT_API_URL"] = previous


def _client():
    from prefect import get_client

    return get_client(sync_client=True)


def describe_schedule(schedule) -> str:
    """``cron "0 2 * * *" (UTC)`` or ``every 5 s``."""
    from prefect.client.schemas.schedules import CronSchedule, IntervalSchedule

    if isinstance(schedule, CronSchedule):
        return f'cron "{schedule.cron}" ({schedule.timezone or "UTC"})'
    if isinstance(schedule, IntervalSchedule):
        seconds = schedule.interval.total_seconds()
        unit, size = next((u, n) for u, n in (("d", 86400), ("h", 3600), ("min", 60), ("s", 1)) if seconds % n == 0
                          or n == 1)
        return f"every {seconds / size:g} {unit}"
    return type(schedule).__name__


def cron_schedule(cron: str, timezone: str | None = None):
    """A Prefect cron schedule; ``ValueError`` naming the expression if it is not valid."""
    from prefect.client.schemas.schedules import CronSchedule

    def reason(error: ValueError) -> str:
        details = [e.get("msg", "") for e in getattr(error, "errors", lambda: [])()]
        return "; ".join(d.removeprefix("Value error, ") for d in details) or str(error).splitlines()[0]

    try:
        CronSchedule(cron=cron)
    except ValueError as error:
        raise ValueError(f"--cron {cron!r}: {reason(error)} (expected five fields: minute hour day-of-month month "
                         f"day-of-week, e.g. \"0 2 * * *\")") from None
    try:
        return CronSchedule(cron=cron, timezone=timezone)
    except ValueError as error:
        raise ValueError(f"--timezone {timezone!r}: {reason(error)}") from None


def interval_schedule(seconds: float):
    """A Prefect interval schedule of ``seconds`` (at least 1), anchored now."""
    from prefect.client.schemas.schedules import IntervalSchedule

    if not seconds >= 1:
        raise ValueError(f"--interval {seconds:g}: expected at least 1 second")
    return IntervalSchedule(interval=dt.timedelta(seconds=seconds))


def _deployment(name: str, parameters: dict, schedules: list, paused: bool | None = None):
    from prefect.client.schemas.actions import DeploymentScheduleCreate
    from prefect.deployments.runner import EntrypointType

    return scheduled_study.to_deployment(
        name=name, parameters=parameters, paused=paused, tags=["nlupdate"],
        schedules=[s if isinstance(s, DeploymentScheduleCreate) else DeploymentScheduleCreate(schedule=s, active=True)
                   for s in schedules],
        description=f"nlupdate study {parameters['study_file']} → {parameters['results_root']}",
        entrypoint_type=EntrypointType.MODULE_PATH)


def parameters_for(study_file: str | os.PathLike, results_root: str | os.PathLike, workers: int,
                   cache_dir: str | os.PathLike | None) -> dict:
    """The deployment parameters: absolute paths, so runs do not depend on where serve starts."""
    from nlupdate.flows.run import cache_directory

    return {"study_file": str(Path(study_file).resolve()), "results_root": str(Path(results_root).resolve()),
            "workers": int(workers), "cache_dir": str(cache_directory(cache_dir))}


def register(name: str, parameters: dict, schedule) -> str:
    """Create or replace the deployment ``name`` of :func:`scheduled_study`; returns its id."""
    return str(_deployment(name, parameters, [schedule]).apply())


def _next_run(client, deployment_id) -> str | None:
    """When the deployment's next scheduled run is due (UTC), if the server has made one."""
    from prefect.client.schemas.filters import (DeploymentFilter, DeploymentFilterId, FlowRunFilter,
                                                FlowRunFilterExpectedStartTime, FlowRunFilterState,
                                                FlowRunFilterStateType)
    from prefect.client.schemas.objects import StateType
    from prefect.client.schemas.sorting import FlowRunSort

    runs = client.read_flow_runs(
        deployment_filter=DeploymentFilter(id=DeploymentFilterId(any_=[deployment_id])),
        flow_run_filter=FlowRunFilter(
            state=FlowRunFilterState(type=FlowRunFilterStateType(any_=[StateType.SCHEDULED])),
            expected_start_time=FlowRunFilterExpectedStartTime(after_=dt.datetime.now(dt.timezone.utc))),
        sort=FlowRunSort.EXPECTED_START_TIME_ASC, limit=1)
    if not runs or runs[0].expected_start_time is None:
        return None
    return runs[0].expected_start_time.astimezone(dt.timezone.utc).strftime("%Y-%m-%d %H:%M:%S")


def _registered_deployments(client) -> list:
    from prefect.client.schemas.filters import FlowFilter, FlowFilterName
    from prefect.client.schemas.sorting import DeploymentSort

    return client.read_deployments(flow_filter=FlowFilter(name=FlowFilterName(any_=[FLOW_NAME])),
                                   sort=DeploymentSort.NAME_ASC)


def registered() -> list[Scheduled]:
    """Every deployment of :func:`scheduled_study`, by name, with its next scheduled run."""
    with _client() as client:
        deployments = _registered_deployments(client)
        next_runs = {d.id: _next_run(client, d.id) for d in deployments}
    listed = []
    for d in deployments:
        p = d.parameters
        listed.append(Scheduled(
            d.name, ", ".join(describe_schedule(s.schedule) for s in d.schedules) or "no schedule",
            p.get("study_file", "?"), p.get("results_root", "?"), int(p.get("workers", 2)), p.get("cache_dir"),
            bool(d.paused), next_runs.get(d.id)))
    return listed


def delete(name: str) -> None:
    """Delete the deployment ``name`` (its scheduled runs go with it)."""
    from prefect.exceptions import ObjectNotFound

    with _client() as client:
        try:
            deployment = client.read_deployment_by_name(f"{FLOW_NAME}/{name}")
        except ObjectNotFound:
            raise UnknownSchedule(name) from None
        client.delete_deployment(deployment.id)


def serve(say: Callable[[str], None] = _say, limit: int | None = None) -> None:
    """Run the scheduled runs of every registered scheduled study until interrupted
    (``KeyboardInterrupt``); each run happens in its own process, as Prefect's runner does."""
    from prefect.client.schemas.actions import DeploymentScheduleCreate
    from prefect.runner import Runner

    with _client() as client:
        deployments = _registered_deployments(client)
    if not deployments:
        raise ScheduleError("no scheduled studies are registered; add one with "
                            "`nlupdate schedule STUDY.toml --cron \"0 2 * * *\"` (or --interval SECONDS)")
    runner = Runner(name=f"nlupdate-serve-{os.getpid()}", pause_on_shutdown=False, limit=limit)
    for d in deployments:
        schedules = [DeploymentScheduleCreate(schedule=s.schedule, active=s.active) for s in d.schedules]
        runner.add_deployment(_deployment(d.name, d.parameters, schedules, paused=d.paused))
    names = ", ".join(f"{d.name} ({', '.join(describe_schedule(s.schedule) for s in d.schedules)}"
                      f"{', paused' if d.paused else ''})" for d in deployments)
    say(f"serving {len(deployments)} scheduled stud{'y' if len(deployments) == 1 else 'ies'}: {names}; Ctrl-C stops")
    sys.stdout.flush()
    asyncio.run(runner.start())
