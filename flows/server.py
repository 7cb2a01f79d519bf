"""The Prefect API a run reports to: the user's (``PREFECT_API_URL``) or one started for it.

Without ``PREFECT_API_URL`` every process — and every Dask worker — would start its own
temporary server (13–26 s each here). :func:`prefect_api` starts exactly one for the run,
in a subprocess, points this process and every worker started afterwards at it (through
the environment), and stops it at the end, after Prefect's background writers have sent
the run's history (otherwise most of it is lost). Runs are kept in Prefect's database
(``~/.prefect`` or ``PREFECT_HOME``), so ``prefect server start`` shows them later.

Once the API answers, flow runs that killed processes of this host left "Running" are
marked Crashed (:func:`nlupdate.flows.liveness.mark_dead_runs_crashed`); when that is not
possible the run says so in one line and goes on.
"""
from __future__ import annotations

import contextlib
import os
import subprocess
import sys
from typing import Callable, Iterator

import httpx


class ServerError(RuntimeError):
    """The Prefect API cannot be reached or started; the message says what to do."""


_STARTED: list = []  # servers prefect_api started and has not stopped yet


def stop_started_servers() -> None:
    """Stop the servers :func:`prefect_api` started (for an exit that cannot unwind)."""
    while _STARTED:
        _STARTED.pop().stop()


HELP = ("start one with `prefect server start` (UI at http://127.0.0.1:4200) and set "
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
        from prefect.settings import PREFECT_API_URL, temporary_settings

        from nlupdate.flows.liveness import mark_dead_runs_crashed

        # Prefect's settings were read when it was imported: name the API explicitly
        with temporary_settings(updates={PREFECT_API_URL: url}):
            mark_dead_runs_crashed(say)
    except Exception as error:  # the API may be older, read-only, or busy: not worth failing a run
        say(f"note: could not check for runs left running by killed processes ({type(error).__name__}: {error})")


def flush_run_history(timeout_s: float = 30.0) -> None:
    """Wait until Prefect's background writers (events, logs) have sent what they hold."""
    from prefect.events.worker import EventsWorker
    from prefect.logging.handlers import APILogWorker

    for worker in (APILogWorker, EventsWorker):
        worker.drain_all(timeout=timeout_s)


def _parent_bound_server():
    """Prefect's temporary server (``SubprocessASGIServer``), its uvicorn process started
    through :mod:`nlupdate.flows.server_process` so that it ends when this process does,
    even when this process is killed. The command line is Prefect 3.8's own."""
    import prefect
    from prefect.server.api.server import SubprocessASGIServer
    from prefect.settings import get_current_settings

    class ParentBoundServer(SubprocessASGIServer):
        _instances: dict = {}

        def _run_uvicorn_command(self) -> subprocess.Popen:
            return subprocess.Popen(
                args=[sys.executable, "-m", "nlupdate.flows.server_process", str(os.getpid()),
                      "--app-dir", str(prefect.__module_path__.parent), "--factory",
                      "prefect.server.api.server:create_app", "--host", "127.0.0.1", "--port", str(self.port),
                      "--log-level", "error", "--lifespan", "on"],
                env={**os.environ, "PREFECT_UI_ENABLED": "0", "PREFECT__SERVER_EPHEMERAL": "1",
                     "PREFECT__SERVER_FINAL": "1", **get_current_settings().to_environment_variables(exclude_unset=True)})

    return ParentBoundServer()


@contextlib.contextmanager
def prefect_api(say: Callable[[str], None], startup_timeout_s: int = 120) -> Iterator[str]:
    """Yield the API URL the run uses (see the module docstring)."""
    url = os.environ.get("PREFECT_API_URL")
    if url:
        _check(url)
        say(f"Prefect API: {url} (PREFECT_API_URL)")
        _crash_dead_runs(url, say)
        try:
            yield url
        finally:
            flush_run_history()
        return
    server = _parent_bound_server()
    say("starting a Prefect server for this run …")
    try:
        server.start(timeout=startup_timeout_s)
    except Exception as error:  # whatever uvicorn or the database raised
        raise ServerError(f"could not start a Prefect server ({type(error).__name__}: {error}); {HELP}") from None
    os.environ["PREFECT_API_URL"] = server.api_url
    _STARTED.append(server)
    say(f"Prefect server: {server.api_url} (stops with the run)")
    try:
        _crash_dead_runs(server.api_url, say)
        yield server.api_url
    finally:
        try:
            flush_run_history()
        finally:
            os.environ.pop("PREFECT_API_URL", None)
            if server in _STARTED:
                _STARTED.remove(server)
                server.stop()
