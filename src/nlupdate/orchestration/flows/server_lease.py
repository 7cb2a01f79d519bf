"""One kept Prefect server per Prefect database, shared by the runs that use it.

Starting the run's Prefect server costs about 3.5 s of CPU (imports and its app), a sixth of
a cold ``nlupdate demo``. The server a run starts is therefore kept after the run for
:func:`keep_seconds` (``NLUPDATE_PREFECT_SERVER_KEEP_S``, default 300 s) and the next run —
or a run started at the same time — uses it. It stops by itself once no run has used it
for that long, so no server is left behind, whatever ended the runs (SIGKILL included).
Idle, it uses about 0.011 s of CPU per second (its background loops; measured here), so
300 s of waiting cost about what one start does: keeping it never costs much more than
starting it again, and saves the start for every run within the keep time.

Its files are in ``<PREFECT_HOME>/nlupdate-server/`` beside the database it serves (one
server per database; a test's fresh ``PREFECT_HOME`` gets its own):

* ``server.json`` — the server now serving the database: its pid and port;
* ``lease`` — every run using the server holds a shared ``flock`` on it while it runs;
  the kernel drops it when the run's process ends, however it ends. The server's watchdog
  (:mod:`nlupdate.orchestration.flows.server_process`) stops the server once it has been
  able to take the lock exclusively (no run holds it) for the keep time; it keeps that lock
  until it has exited, so a run arriving meanwhile waits, then starts a new server;
* ``start.lock`` — held while a run finds or starts the server, so two runs started
  together start one;
* ``server.log`` — the server's output (it outlives the terminal of the run that started it).

Imports nothing heavy: the server process and the CLI use it before Prefect is imported.
"""
from __future__ import annotations

import contextlib
import fcntl
import json
import os
import sys
from pathlib import Path
from typing import Iterator

from nlupdate.files import process_running

KEEP_ENV = "NLUPDATE_PREFECT_SERVER_KEEP_S"
DEFAULT_KEEP_S = 300.0


def keep_seconds() -> float:
    """How long (s) a run's server is kept after the last run using it ended: 0 stops it
    with the run. A value that is not a number ≥ 0 is refused in one line."""
    text = os.environ.get(KEEP_ENV, "").strip()
    if not text:
        return DEFAULT_KEEP_S
    try:
        seconds = float(text)
    except ValueError:
        seconds = -1.0
    if not seconds >= 0:
        raise ValueError(f"{KEEP_ENV}={text!r}: expected seconds, a number ≥ 0 (0: stop the server with the run)")
    return seconds


def state_folder() -> Path:
    """``<PREFECT_HOME>/nlupdate-server``: Prefect's home as this process's Prefect settings
    name it (when Prefect is imported) or its environment (``~/.prefect`` by default)."""
    if "prefect.settings" in sys.modules:
        from prefect.settings import get_current_settings

        home = Path(get_current_settings().home)
    else:
        home = Path(os.environ.get("PREFECT_HOME") or "~/.prefect").expanduser()
    folder = home / "nlupdate-server"
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def _open(path: Path) -> int:
    return os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o600)


@contextlib.contextmanager
def starting(folder: Path) -> Iterator[None]:
    """Within the block, no other run finds or starts this database's server."""
    descriptor = _open(folder / "start.lock")
    try:
        fcntl.flock(descriptor, fcntl.LOCK_EX)
        yield
    finally:
        os.close(descriptor)  # releases the lock


class Lease:
    """A run's hold on the kept server (a shared lock on ``lease``): the server is not
    stopped while any is held. Taking one waits while a server stops (seconds at most)."""

    def __init__(self, folder: Path) -> None:
        self.descriptor: int | None = _open(folder / "lease")
        fcntl.flock(self.descriptor, fcntl.LOCK_SH)

    def release(self) -> None:
        if self.descriptor is not None:
            os.close(self.descriptor)
            self.descriptor = None


def unused(folder: Path) -> int | None:
    """An exclusive hold on ``lease`` when no run holds it (the descriptor; closing it lets
    runs in again), else None. For the server's watchdog."""
    descriptor = _open(folder / "lease")
    try:
        fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        os.close(descriptor)
        return None
    return descriptor


def read_record(folder: Path) -> dict | None:
    """The record of the server now serving the database ({"pid", "port"}), or None when
    there is none or its process is gone."""
    try:
        record = json.loads((folder / "server.json").read_text())
        pid, port = int(record["pid"]), int(record["port"])
    except (OSError, ValueError, KeyError, TypeError):
        return None
    if not serving(pid):
        return None
    return {"pid": pid, "port": port}


def write_record(folder: Path, pid: int, port: int) -> None:
    temporary = folder / f"server.json.{os.getpid()}"
    temporary.write_text(json.dumps({"pid": pid, "port": port}))
    os.replace(temporary, folder / "server.json")


def forget_record(folder: Path, pid: int) -> None:
    """Remove the record if it names process ``pid`` (a newer server's is left alone)."""
    path = folder / "server.json"
    with contextlib.suppress(OSError, ValueError, KeyError, TypeError):
        if int(json.loads(path.read_text())["pid"]) == pid:
            path.unlink()


def serving(pid: int) -> bool:
    """Whether process ``pid`` runs and is a server of ours (not a zombie, not another
    process that got its number after it ended)."""
    if not process_running(pid):
        return False
    try:
        return b"nlupdate.orchestration.flows.server_process" in Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:  # no /proc here: the signal check above is all there is
        return True
