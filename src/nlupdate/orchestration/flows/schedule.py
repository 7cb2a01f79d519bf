"""Scheduled studies: Prefect deployments of :func:`scheduled_study`, and serving them.

Length: registering, deploying and serving must agree on one check (a run only for a
registered study with its hash), so they live together.

* What a user schedules is kept in their own folder (:mod:`nlupdate.orchestration.flows.registrations`):
  the study's text and hash, results root, cache folder, threads and schedule. The
  deployment on the Prefect API carries only the registration's name and study hash.
* :func:`scheduled_study` — the deployments' flow. A run loads its registration by name,
  checks that the study hash it was given is the registered one and runs the registered
  study text with :func:`~nlupdate.orchestration.flows.run.run_study_flow` as a subflow, so every run
  writes its own archive ``<results root>/<study>/<UTC time>-<hash>/`` and shares the task
  cache. A run that names no registration, another study or any other parameter is
  failed with one line in its log and runs nothing: the API is open to every local
  process, and it must not be a way to make ``nlupdate serve`` run someone else's study
  (or program) as the serving user.
* :func:`register`, :func:`registered`, :func:`delete` — registrations and their
  deployments, one per name, each with one cron or interval schedule.
* :func:`serve` — runs them: a Prefect :class:`~prefect.runner.Runner` with deployments
  rebuilt from the registrations (a deployment changed through the API is restored and
  the change reported).

Schedules fire only when a persistent Prefect server (``prefect server start``, whose
scheduler service creates the runs) and :func:`serve` are both running. A temporary
server (what ``nlupdate run`` starts) keeps the deployments but never creates runs, which
is why :func:`schedule_api` insists on a server that outlives the command.
"""
from __future__ import annotations

import asyncio
import contextlib
import datetime as dt
import json
import os
import signal
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterator

import httpx
from prefect import flow

from nlupdate.orchestration.flows import registrations
from nlupdate.orchestration.flows.registrations import Registration

FLOW_NAME = "scheduled study"
DEFAULT_API = "http://127.0.0.1:4200/api"
HOW_TO_START = (f"schedules live in a persistent Prefect server: start one with `prefect server start` (with "
                f"PREFECT_SERVER_ANALYTICS_ENABLED=false in its environment: no telemetry) and set "
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
    study_sha256: str
    server_drift: str | None

    def as_dict(self) -> dict:
        return dict(self.__dict__)


def _say(message: str) -> None:
    print(f"{dt.datetime.now(dt.timezone.utc):%Y-%m-%d %H:%M:%S} UTC  {message}", flush=True)


def _refused(message: str):
    """Fail the current flow run with ``message`` as its one log line."""
    from prefect import get_run_logger
    from prefect.states import Failed

    get_run_logger().error(message)
    _say(message)
    return Failed(message=message)


def _outcome(archive: Path) -> str:
    """How a run's archive ended, from its manifest: ``complete`` or what failed."""
    try:
        manifest = json.loads((Path(archive) / "manifest.json").read_text())
    except (OSError, ValueError):
        return "archive without a readable manifest"
    failures = manifest.get("failures") or []
    if manifest.get("status", "complete") != "complete":
        return f"status {manifest.get('status')}: {manifest.get('error', '')}".rstrip(": ")
    return f"{len(failures)} updating run(s) failed" if failures else "complete"


def refusal(parameters: dict, run_name: str) -> str | None:
    """Why a flow run with ``parameters`` must not run (one line), or None: it must name a
    registration of this user (``name``) and its study hash (``study_sha256``), nothing else."""
    name = parameters.get("name")
    label = f"{name if isinstance(name, str) else '?'}: run {run_name!r}"
    unexpected = sorted(set(parameters) - {"name", "study_sha256"})
    if unexpected:
        return (f"{label} REFUSED: unexpected parameter(s) {', '.join(map(str, unexpected))} (a scheduled run takes "
                f"only the registration's name and study hash); nothing was run")
    registration = registrations.load(name) if isinstance(name, str) else None
    if registration is None:
        return (f"{label} REFUSED: no study named {name!r} is registered with `nlupdate schedule` by this user; "
                f"nothing was run")
    if parameters.get("study_sha256") != registration.study_sha256:
        return (f"{label} REFUSED: it asks for study sha256 {str(parameters.get('study_sha256'))[:12]}…, the "
                f"registered study has {registration.study_sha256[:12]}… (changed through the API?); nothing was run")
    return None


@flow(name=FLOW_NAME)
def scheduled_study(name: str, study_sha256: str):
    """One scheduled run of the registered study ``name`` (whose study text must have the
    hash ``study_sha256``): the study flow as a subflow; returns the archive it wrote.
    ``serve`` refuses other runs before they start; this flow checks again."""
    from prefect.runtime import flow_run

    from nlupdate.orchestration.flows.liveness import claim_flow_run
    from nlupdate.orchestration.flows.status_lines import Progress
    from nlupdate.orchestration.flows.run import run_study_flow
    from nlupdate.orchestration.flows.runners import Execution
    from nlupdate.study.loading import study_from_text

    claim_flow_run()  # killed with serve, it is marked Crashed when the next run starts
    label = f"{name}: run {flow_run.name!r}"
    refused = refusal({"name": name, "study_sha256": study_sha256}, flow_run.name)
    if refused:
        return _refused(refused)
    registration = registrations.load(name)
    study = study_from_text(registration.study_text, registration.study_file)
    _say(f"{label} started")
    if _file_changed(registration):
        _say(f"{label}: {registration.study_file} changed since it was registered; running the registered study "
             f"(register it again with --replace to run the new one)")
    started = time.perf_counter()
    scheduled = f"deployment {name!r} of flow {FLOW_NAME!r}, flow run {flow_run.name!r}"
    try:
        archive = run_study_flow(study, registration.results_root, Execution(registration.workers),
                                 registration.cache_dir, progress=Progress(quiet=True),
                                 annotations={"scheduled": scheduled})
    except Exception as error:
        _say(f"{label} FAILED after {time.perf_counter() - started:.1f} s: {type(error).__name__}: "
             f"{str(error).strip().splitlines()[0] if str(error).strip() else ''}")
        raise
    outcome = _outcome(archive)
    verb = "finished" if outcome == "complete" else f"finished ({outcome})"
    _say(f"{label} {verb} in {time.perf_counter() - started:.1f} s; archive {archive}")
    return str(archive)


def _file_changed(registration) -> bool:
    try:
        return Path(registration.study_file).read_text() != registration.study_text
    except OSError:
        return True


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


def schedule_of(when: dict):
    """The Prefect schedule of a registration's ``when``."""
    if "cron" in when:
        return cron_schedule(when["cron"], when.get("timezone"))
    return interval_schedule(when["interval_s"])


def when_of(schedule) -> dict:
    """A registration's ``when`` for a Prefect cron or interval schedule."""
    from prefect.client.schemas.schedules import CronSchedule

    if isinstance(schedule, CronSchedule):
        return {"cron": schedule.cron, "timezone": schedule.timezone}
    return {"interval_s": schedule.interval.total_seconds()}


def _deployment(registration: Registration, paused: bool | None = None):
    from prefect.client.schemas.actions import DeploymentScheduleCreate
    from prefect.deployments.runner import EntrypointType

    return scheduled_study.to_deployment(
        name=registration.name, parameters=registration.parameters, paused=paused, tags=["nlupdate"],
        schedules=[DeploymentScheduleCreate(schedule=schedule_of(registration.when), active=True)],
        description=f"nlupdate study {registration.study_file} (sha256 {registration.study_sha256[:12]}) → "
                    f"{registration.results_root}; what it runs is registered in the user's nlupdate folder",
        enforce_parameter_schema=True, entrypoint_type=EntrypointType.MODULE_PATH)


def register(registration: Registration) -> str:
    """Keep ``registration`` and create or replace its deployment; returns the deployment id."""
    registrations.save(registration)
    return str(_deployment(registration).apply())


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


def _registered_deployments(client) -> dict:
    from prefect.client.schemas.filters import FlowFilter, FlowFilterName
    from prefect.client.schemas.sorting import DeploymentSort

    deployments = client.read_deployments(flow_filter=FlowFilter(name=FlowFilterName(any_=[FLOW_NAME])),
                                          sort=DeploymentSort.NAME_ASC)
    return {d.name: d for d in deployments}


def drift(registration: Registration, deployment) -> str | None:
    """How the server's ``deployment`` differs from ``registration`` (None: it does not)."""
    if deployment is None:
        return "its deployment is missing on the server"
    differences = []
    if deployment.parameters != registration.parameters:
        differences.append(f"parameters {deployment.parameters}")
    schedules = [when_of(s.schedule) for s in deployment.schedules]
    if schedules != [when_of(schedule_of(registration.when))]:
        differences.append(f"schedules {', '.join(describe_schedule(s.schedule) for s in deployment.schedules) or 'none'}")
    return "the server's deployment was changed: " + "; ".join(differences) if differences else None


def registered() -> list[Scheduled]:
    """Every registered scheduled study, by name, with its next scheduled run on the server
    and how the server's deployment differs from the registration, if it does."""
    known = registrations.every()
    with _client() as client:
        deployments = _registered_deployments(client)
        next_runs = {name: _next_run(client, d.id) for name, d in deployments.items()}
    listed = []
    for r in known:
        deployment = deployments.get(r.name)
        listed.append(Scheduled(
            r.name, describe_schedule(schedule_of(r.when)), r.study_file, r.results_root, r.workers, r.cache_dir,
            bool(deployment.paused) if deployment is not None else False, next_runs.get(r.name),
            r.study_sha256, drift(r, deployment)))
    return listed


def delete(name: str) -> None:
    """Delete the registration ``name`` and its deployment (its scheduled runs go with it)."""
    from prefect.exceptions import ObjectNotFound

    known = registrations.remove(name)
    with _client() as client:
        try:
            deployment = client.read_deployment_by_name(f"{FLOW_NAME}/{name}")
        except ObjectNotFound:
            if not known:
                raise UnknownSchedule(name) from None
            return
        client.delete_deployment(deployment.id)


def _registered_only_runner(say: Callable[[str], None]):
    """A Prefect :class:`~prefect.runner.Runner` that fails, before they start, the flow
    runs that :func:`refusal` refuses: it checks each run as the runner proposes to move it
    to Pending (Prefect 3.8's ``StateProposer.propose_pending``, the one place every
    scheduled run passes before a process is started for it). SIGTERM is handled as before
    the runner started."""
    from prefect.runner import Runner
    from prefect.states import Failed

    before = signal.getsignal(signal.SIGTERM)

    class RegisteredOnlyRunner(Runner):
        def handle_sigterm(self, signum: int = signal.SIGTERM, frame=None) -> None:
            """SIGTERM as the process handled it before the runner started (the CLI: like
            Ctrl-C), not Prefect's stop-and-exit-0 (which left its stop coroutine unawaited)."""
            if callable(before):
                before(signum, frame)
            else:
                super().handle_sigterm()

        async def __aenter__(self):
            entered = await super().__aenter__()
            proposer = self._state_proposer
            propose_pending = proposer.propose_pending

            async def checked(flow_run) -> bool:
                refused = refusal(dict(flow_run.parameters or {}), flow_run.name)
                if refused is None:
                    return await propose_pending(flow_run)
                self._get_flow_run_logger(flow_run).error(refused)
                await self._client.set_flow_run_state(flow_run.id, Failed(message=refused), force=True)
                say(refused)
                return False

            proposer.propose_pending = checked
            return entered

    return RegisteredOnlyRunner


def serve(say: Callable[[str], None] = _say, limit: int | None = None) -> None:
    """Run the scheduled runs of every registered study until interrupted
    (``KeyboardInterrupt``); each run happens in its own process, as Prefect's runner does.
    Deployments are rebuilt from the registrations: one changed through the API is
    restored, and the change is reported."""
    known = registrations.every()
    if not known:
        raise ScheduleError("no scheduled studies are registered; add one with "
                            "`nlupdate schedule STUDY.toml --cron \"0 2 * * *\"` (or --interval SECONDS)")
    with _client() as client:
        deployments = _registered_deployments(client)
    runner = _registered_only_runner(say)(name=f"nlupdate-serve-{os.getpid()}", pause_on_shutdown=False, limit=limit)
    for r in known:
        deployment = deployments.get(r.name)
        changed = drift(r, deployment)
        if changed:
            say(f"{r.name}: {changed}; serving the registered study and restoring its deployment")
        runner.add_deployment(_deployment(r, paused=deployment.paused if deployment is not None else None))
    names = ", ".join(f"{r.name} ({describe_schedule(schedule_of(r.when))}"
                      f"{', paused' if deployments.get(r.name) is not None and deployments[r.name].paused else ''})"
                      for r in known)
    say(f"serving {len(known)} scheduled stud{'y' if len(known) == 1 else 'ies'}: {names}; Ctrl-C stops")
    sys.stdout.flush()
    asyncio.run(runner.start())
