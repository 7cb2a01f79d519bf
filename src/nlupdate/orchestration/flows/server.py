"""The Prefect API a run reports to: the user's (``PREFECT_API_URL``) or one kept for the runs.

Without ``PREFECT_API_URL`` every process — and every Dask worker — would start its own
temporary server (13–26 s each here). :func:`prefect_api` uses the one server kept for the
runs on this Prefect database (:mod:`nlupdate.orchestration.flows.server_lease`), starting it
in a subprocess when none is running, points this process (Prefect's settings, for the
block) and every worker started afterwards (the environment) at it, and at the end — after
Prefect's background writers have sent the run's history (otherwise most of it is lost) —
lets go of it: the server stops by itself once no run has used it for
``NLUPDATE_PREFECT_SERVER_KEEP_S`` seconds (300 by default; 0: with the run). Runs are kept
in Prefect's database (``~/.prefect`` or ``PREFECT_HOME``), so ``prefect server start``
shows them later.

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

from nlupdate.orchestration.flows import server_lease


class ServerError(RuntimeError):
    """The Prefect API cannot be reached or started; the message says what to do."""


_STARTED: list = []  # kept servers this process holds a lease on
_EARLY: list = []  # of those, the one start_server_early took for the next prefect_api


def stop_started_servers() -> None:
    """Let go of the kept servers this process uses (for an exit that cannot unwind)."""
    _EARLY.clear()
    while _STARTED:
        _STARTED.pop().release()


def stop_early_server() -> None:
    """Let go of the server :func:`start_server_early` took when no :func:`prefect_api` used
    it (the run ended before it needed one); servers in use are left to their owners."""
    while _EARLY:
        server = _EARLY.pop()
        if server in _STARTED:
            _STARTED.remove(server)
        server.release()


HELP = ("start one with `prefect server start` (UI at http://127.0.0.1:4200; with "
        "PREFECT_SERVER_ANALYTICS_ENABLED=false in its environment: no telemetry) and set "
        "PREFECT_API_URL=http://127.0.0.1:4200/api, or unset PREFECT_API_URL to let nlupdate start its own")


def _check(url: str, timeout_s: float = 30.0) -> None:
    """Fail with the help unless the API at ``url`` answers its health check within
    ``timeout_s`` (30 s: a server busy with another run's writes on a loaded machine answers
    late, not never)."""
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
#: Nor does it run the services no run of ours uses: automations (the triggers and actions
#: services read every event of the run against automations, of which a run server has none)
#: and the stream of events to websocket subscribers (none: the UI is not served here). The
#: task-run recorder, which writes the task runs' states from their events, stays; it writes
#: the events it received in one transaction per second (``BATCH_SIZE`` 100, ``FLUSH_INTERVAL``
#: 1 s) instead of one transaction per event (Prefect's batch of 1): a task run's states reach
#: the database and the UI up to a second after its events, and the run's server spends
#: 0.2 s less CPU per demo (0.49 instead of 0.68 s, three interleaved rounds; docs/performance.md).
#: The perpetual services (scheduler, late runs, foreman, pause expirations, cancellation
#: clean-up, repossessor) do not run in a server Prefect calls ephemeral, as this one is.
RUN_SERVER_SETTINGS = {"PREFECT_SERVER_SERVICES_EVENT_PERSISTER_ENABLED": "false",
                       "PREFECT_SERVER_SERVICES_TRIGGERS_ENABLED": "false",
                       "PREFECT_SERVER_EVENTS_STREAM_OUT_ENABLED": "false",
                       "PREFECT_SERVER_SERVICES_TASK_RUN_RECORDER_BATCH_SIZE": "100",
                       "PREFECT_SERVER_SERVICES_TASK_RUN_RECORDER_FLUSH_INTERVAL": "1"}


class RunServer:
    """Prefect's server kept for the runs on one database: uvicorn serving Prefect's API app
    (Prefect 3.8's own command line; the app wrapped by :mod:`nlupdate.orchestration.flows.server_app`),
    started through :mod:`nlupdate.orchestration.flows.server_process`, which stops it once
    no run has held a lease for ``keep_s`` (even when every run was killed). It runs in a
    session (process group) of its own, so a signal to a run's group does not take the API
    away while the run reports its end; its output goes to ``server.log`` in ``folder``.

    Started without importing Prefect here (the server process imports it itself, at the
    same time as this process imports what the run needs); :meth:`KeptServer.wait` returns
    once the API answers."""

    def __init__(self, folder: Path, keep_s: float) -> None:
        self.folder, self.keep_s = folder, keep_s
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
        with open(self.folder / "server.log", "ab") as log:
            process = subprocess.Popen(
                # -P: the working folder is not put on sys.path, so a source checkout there (whose
                # nlupdate/ lacks the installed nlupdate.orchestration.flows) cannot shadow the installed package
                args=[sys.executable, "-P", "-m", "nlupdate.orchestration.flows.server_process", str(self.folder),
                      f"{self.keep_s:g}", "--app-dir", str(app_dir), "--factory",
                      "nlupdate.orchestration.flows.server_app:create_app", "--host", "127.0.0.1",
                      "--port", str(self.port), "--log-level", "error", "--lifespan", "on"],
                env={**RUN_SERVER_SETTINGS, **os.environ, "PREFECT_UI_ENABLED": "0", "PREFECT__SERVER_EPHEMERAL": "1",
                     "PREFECT__SERVER_FINAL": "1", **settings},
                stdin=subprocess.DEVNULL, stdout=log, stderr=log,
                # a session of its own: a signal to the run's process group (timeout, kill -- -PGID,
                # a batch scheduler) reaches the run, which then reports its end to the server
                start_new_session=hasattr(os, "setsid"))
        server_lease.write_record(self.folder, process.pid, self.port)
        return process

    def stop(self) -> None:
        if self.process is not None:
            self.process.terminate()
            try:
                self.process.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
            server_lease.forget_record(self.folder, self.process.pid)
            self.process = None


class KeptServer:
    """This run's use of the server kept for its Prefect database: the running one, else
    one started now (:class:`RunServer`); held by a lease (:class:`server_lease.Lease`)
    until :meth:`release`."""

    def __init__(self) -> None:
        self.keep_s = server_lease.keep_seconds()
        self.folder = folder = server_lease.state_folder()
        with server_lease.starting(folder):
            self.lease = server_lease.Lease(folder)
            try:
                record = server_lease.read_record(folder)
                self.started = None if record else RunServer(folder, self.keep_s)
            except BaseException:
                self.lease.release()
                raise
        self.pid, self.port = (record["pid"], record["port"]) if record else (self.started.process.pid,
                                                                               self.started.port)

    @property
    def api_url(self) -> str:
        return f"http://127.0.0.1:{self.port}/api"

    def wait(self, timeout_s: float) -> None:
        """Return once the server answers ``/api/health``; RuntimeError when the server this
        run started exits (but for a port taken before it bound: uvicorn's exit code 3) or
        ``timeout_s`` passes. A server that could not bind its port, or a kept one that ended
        before it answered, is replaced by :meth:`_take_over`, under the start lock: two runs
        waiting on it then end on one server (a run that found no live server there started
        its own beside the starter's new one, under load, before)."""
        deadline = time.monotonic() + timeout_s
        with httpx.Client(timeout=5.0) as client:
            while time.monotonic() < deadline:
                code = None if self.started is None else self.started.process.poll()
                if code is not None and code != 3:
                    raise RuntimeError(f"the server process exited with code {code} (its output: "
                                       f"{self.folder / 'server.log'})")
                if code == 3 or (self.started is None and server_lease.read_record(self.folder)
                                 != {"pid": self.pid, "port": self.port}):
                    self._take_over()
                with contextlib.suppress(httpx.TransportError):
                    if client.get(f"{self.api_url}/health").status_code == 200:
                        return
                time.sleep(0.05)
        raise RuntimeError(f"the server did not answer within {timeout_s:g} s")

    def _take_over(self) -> None:
        """Under the start lock: use the server the record names if it runs (another run's,
        or this one's starter moved it to another port), else start one."""
        with server_lease.starting(self.folder):
            record = server_lease.read_record(self.folder)
            self.started = None if record else RunServer(self.folder, self.keep_s)
            self.pid, self.port = (record["pid"], record["port"]) if record else (self.started.process.pid,
                                                                                   self.started.port)

    def describe(self) -> str:
        """How long the server stays, for the run's line."""
        started = "started for this run" if self.started is not None else "already running"
        if self.keep_s == 0:
            return f"{started}; stops with the run"
        return f"{started}; kept {self.keep_s:g} s after the last run using it"

    def release(self) -> None:
        """Let go: the server stops once no run has held it for its keep time."""
        self.lease.release()

    def stop(self) -> None:
        """Let go, and stop a server this run started (one that did not answer)."""
        self.release()
        if self.started is not None:
            self.started.stop()


def _free_port() -> int:
    with contextlib.closing(socket.socket(socket.AF_INET, socket.SOCK_STREAM)) as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def start_server_early() -> None:
    """Take the kept server now, starting it unless one is running or ``PREFECT_API_URL``
    names one, so that it boots while this process imports and prepares the run;
    :func:`prefect_api` then waits for it (and :func:`stop_started_servers` lets go of it
    when the run ends before that)."""
    if not os.environ.get("PREFECT_API_URL") and not _EARLY:
        try:
            _EARLY.append(KeptServer())
            _STARTED.append(_EARLY[-1])
        except Exception:  # noqa: BLE001 - prefect_api starts one and reports the error in one line
            pass


@contextlib.contextmanager
def prefect_api(say: Callable[[str], None], startup_timeout_s: int = 300) -> Iterator[str]:
    """Yield the API URL the run uses (see the module docstring). A server this run starts
    may take ``startup_timeout_s`` to answer (10.6 s on an idle machine with a new home, 69 s
    at load 8; one that exits is reported at once, so the limit only ends a hang)."""
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
    server = _EARLY.pop() if _EARLY else None
    try:
        if server is None:
            server = KeptServer()
            _STARTED.append(server)
        if server.started is not None:
            say("starting a Prefect server for this run …")
        server.wait(startup_timeout_s)
    except Exception as error:  # whatever uvicorn or the database raised
        if server in _STARTED:
            _STARTED.remove(server)
        if server is not None:
            server.stop()
        raise ServerError(f"could not start a Prefect server ({type(error).__name__}: {error}); {HELP}") from None
    os.environ["PREFECT_API_URL"] = server.api_url
    say(f"Prefect server: {server.api_url} ({server.describe()})")
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
            server.release()
