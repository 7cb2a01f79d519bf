"""The Prefect API a run reports to: the user's (``PREFECT_API_URL``) or one started for it.

Without ``PREFECT_API_URL`` every process — and every Dask worker — would start its own
temporary server (13–26 s each here). :func:`prefect_api` starts exactly one for the run,
in a subprocess, points this process (Prefect's settings, for the block) and every worker
started afterwards (the environment) at it, and stops it at the end, after Prefect's
background writers have sent the run's history (otherwise most of it is lost). Runs are
kept in Prefect's database (``~/.prefect`` or ``PREFECT_HOME``), so ``prefect server
start`` shows them later.

Once the API answers, flow runs that killed processes of this host left "Running" are
marked Crashed (:func:`nlupdate.orchestration.flows.liveness.mark_dead_runs_crashed`); when that is not
possible the run says so in one line and goes on.
"""
from __future__ import annotations

import contextlib
import importlib.util
import os
import socket
import subprocess
import sys
import time
from pathlib import Path
from typing import Callable, Iterator

import httpx


class ServerError(RuntimeError):
    """The Prefect API cannot be reached or started; the message says what to do."""


_STARTED: list = []  # servers started for a run and not stopped yet
_EARLY: list = []  # of those, the one start_server_early started for the next prefect_api


def stop_started_servers() -> None:
    """Stop the servers :func:`prefect_api` started (for an exit that cannot unwind)."""
    _EARLY.clear()
    while _STARTED:
        _STARTED.pop().stop()


def stop_early_server() -> None:
    """Stop the server :func:`start_server_early` started when no :func:`prefect_api` took
    it (the run ended before it needed one); servers in use are left to their owners."""
    while _EARLY:
        server = _EARLY.pop()
        if server in _STARTED:
            _STARTED.remove(server)
        server.stop()


HELP = ("start one with `prefect server start` (UI at http://127.0.0.1:4200; with "
        "PREFECT_SERVER_ANALYTICS_ENABLED=false in its environment: no telemetry) and set "
        "PREFECT_API_URL=http://127.0.0.1:4200/api, or unset PREFECT_API_URL to let nlupdate start its own")


def _check(url: str, timeout_s: float = 10.0) -> None:
    try:
        response = httpx.get(f"{url.rstrip('/')}/health", timeout=timeout_s)
        response.raise_for_status()
    except httpx.HTTPError as error:
        raise ServerError(f"the Prefect API at PREFECT_API_URL={url} does not answer ({error}); {HELP}") from None


def _crash_dead_runs(url: str, say: Callable[[str], None]) -> None:
    """Mark the runs of killed processes crashed on the API at ``url``; never fails the run."""
    try:
        from nlupdate.orchestration.flows.liveness import mark_dead_runs_crashed

        mark_dead_runs_crashed(say)
    except Exception as error:  # the API may be older, read-only, or busy: not worth failing a run
        say(f"note: could not check for runs left running by killed processes ({type(error).__name__}: {error})")


@contextlib.contextmanager
def _named_in_prefects_settings(url: str) -> Iterator[None]:
    """Within the block, Prefect in this process talks to ``url`` and never starts a server of
    its own. Prefect reads its settings when it is imported: in a process that imported it
    before the run's server existed (a notebook, a test session) they name no API, and
    Prefect would start its own server in the process (6 s here) and record the run there."""
    from prefect.settings import PREFECT_API_URL, PREFECT_SERVER_EPHEMERAL_ENABLED, temporary_settings

    with temporary_settings(updates={PREFECT_API_URL: url, PREFECT_SERVER_EPHEMERAL_ENABLED: False}):
        yield


def flush_run_history(timeout_s: float = 30.0) -> None:
    """Wait until Prefect's background writers (events, logs) have sent what they hold."""
    from prefect.events.worker import EventsWorker
    from prefect.logging.handlers import APILogWorker

    for worker in (APILogWorker, EventsWorker):
        worker.drain_all(timeout=timeout_s)


#: Settings of the run's own server, unless the user's environment sets them. Its event
#: persister is off: it writes every event of the run (three or more per task run) into the
#: database's event table, for Prefect's event feed and automations; the flow run, its task
#: runs with their states, its subflows and its logs are recorded without it (by the task-run
#: recorder and the API), and the UI shows the run as before. Measured on cold demos against
#: a running server (two A/B rounds, load 10–14): the server's CPU 5.6–5.7 s with it,
#: 4.0–4.7 s without (docs/performance.md, "Prefect's share of the demo").
RUN_SERVER_SETTINGS = {"PREFECT_SERVER_SERVICES_EVENT_PERSISTER_ENABLED": "false"}


class RunServer:
    """Prefect's temporary server for one run: uvicorn serving Prefect's API app (Prefect
    3.8's own command line; the app wrapped by :mod:`nlupdate.orchestration.flows.server_app`), started
    through :mod:`nlupdate.orchestration.flows.server_process` so that it ends when this process does,
    even when this process is killed. It runs in a session (process group) of its own, so
    a signal to the run's group does not take the API away while the run reports its end.

    Started without importing Prefect here (the server process imports it itself, at the
    same time as this process imports what the run needs); :meth:`wait` returns once the
    API answers."""

    def __init__(self) -> None:
        self.port = _free_port()
        self.process: subprocess.Popen | None = self._spawn()

    @property
    def api_url(self) -> str:
        return f"http://127.0.0.1:{self.port}/api"

    def _spawn(self) -> subprocess.Popen:
        spec = importlib.util.find_spec("prefect")
        if spec is None or not spec.submodule_search_locations:
            raise RuntimeError("Prefect is not installed")
        app_dir = Path(list(spec.submodule_search_locations)[0]).parent
        settings = {}
        if "prefect.settings" in sys.modules:  # settings this process changed are the server's too
            from prefect.settings import get_current_settings

            settings = get_current_settings().to_environment_variables(exclude_unset=True)
        return subprocess.Popen(
            # -P: the working folder is not put on sys.path, so a source checkout there (whose
            # nlupdate/ lacks the installed nlupdate.orchestration.flows) cannot shadow the installed package
            args=[sys.executable, "-P", "-m", "nlupdate.orchestration.flows.server_process", str(os.getpid()),
                  "--app-dir", str(app_dir), "--factory", "nlupdate.orchestration.flows.server_app:create_app",
                  "--host", "127.0.0.1", "--port", str(self.port), "--log-level", "error", "--lifespan", "on"],
            env={**RUN_SERVER_SETTINGS, **os.environ, "PREFECT_UI_ENABLED": "0", "PREFECT__SERVER_EPHEMERAL": "1",
                 "PREFECT__SERVER_FINAL": "1", **settings},
            # a session of its own: a signal to the run's process group (timeout, kill -- -PGID,
            # a batch scheduler) reaches the run, which then stops its server after reporting to it
            start_new_session=hasattr(os, "setsid"))

    def wait(self, timeout_s: float) -> None:
        """Return once ``/api/health`` answers 200; RuntimeError when the process ends first
        or ``timeout_s`` passes (a port taken meanwhile — uvicorn's exit code 3 — is retried
        on another)."""
        deadline = time.monotonic() + timeout_s
        with httpx.Client(timeout=5.0) as client:
            while time.monotonic() < deadline:
                code = self.process.poll()
                if code == 3:
                    self.port = _free_port()
                    self.process = self._spawn()
                elif code is not None:
                    raise RuntimeError(f"the server process exited with code {code}")
                with contextlib.suppress(httpx.TransportError):
                    if client.get(f"{self.api_url}/health").status_code == 200:
                        return
                time.sleep(0.05)
        raise RuntimeError(f"the server did not answer within {timeout_s:g} s")

    def stop(self) -> None:
        if self.process is not None:
            self.process.terminate()
            try:
                self.process.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
            self.process = None


def _free_port() -> int:
    with contextlib.closing(socket.socket(socket.AF_INET, socket.SOCK_STREAM)) as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def start_server_early() -> None:
    """Start the run's server now, unless ``PREFECT_API_URL`` names one, so that it boots
    while this process imports and prepares the run; :func:`prefect_api` then waits for it
    (and :func:`stop_started_servers` stops it when the run ends before that)."""
    if not os.environ.get("PREFECT_API_URL") and not _EARLY:
        try:
            _EARLY.append(RunServer())
            _STARTED.append(_EARLY[-1])
        except Exception:  # noqa: BLE001 - prefect_api starts one and reports the error in one line
            pass


@contextlib.contextmanager
def prefect_api(say: Callable[[str], None], startup_timeout_s: int = 120) -> Iterator[str]:
    """Yield the API URL the run uses (see the module docstring)."""
    url = os.environ.get("PREFECT_API_URL")
    if url:
        _check(url)
        say(f"Prefect API: {url} (PREFECT_API_URL)")
        with _named_in_prefects_settings(url):
            _crash_dead_runs(url, say)
            try:
                yield url
            finally:
                flush_run_history()
        return
    say("starting a Prefect server for this run …")
    server = _EARLY.pop() if _EARLY else None
    try:
        if server is None:
            server = RunServer()
            _STARTED.append(server)
        server.wait(startup_timeout_s)
    except Exception as error:  # whatever uvicorn or the database raised
        if server in _STARTED:
            _STARTED.remove(server)
            server.stop()
        raise ServerError(f"could not start a Prefect server ({type(error).__name__}: {error}); {HELP}") from None
    os.environ["PREFECT_API_URL"] = server.api_url
    say(f"Prefect server: {server.api_url} (stops with the run)")
    try:
        with _named_in_prefects_settings(server.api_url):
            _crash_dead_runs(server.api_url, say)
            try:
                yield server.api_url
            finally:
                flush_run_history()
    finally:
        os.environ.pop("PREFECT_API_URL", None)
        if server in _STARTED:
            _STARTED.remove(server)
            server.stop()
