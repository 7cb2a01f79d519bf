"""The kept Prefect server's process: uvicorn, stopped once no run has used it for a while.

``python -m nlupdate.orchestration.flows.server_process FOLDER KEEP_S UVICORN_ARGS…`` runs
``python -m uvicorn UVICORN_ARGS…`` in this process, with a watchdog thread that ends it
(SIGTERM to itself, then exit after 5 s) once no run has held a lease on it
(:mod:`nlupdate.orchestration.flows.server_lease`, files in ``FOLDER``) for ``KEEP_S``
seconds. A run's lease ends with its process, however it ended — SIGKILL included — so
no server outlives its last run by more than the keep time (without a watchdog, each
killed run left a server of ~220 MB listening on loopback for good). A server whose
``FOLDER`` is gone (deleted with its Prefect home, as a test session's is) can be found by
no run: it stops at once (the watchdog died on the missing lease file before, and each test
session left its workers' servers running).
"""
from __future__ import annotations

import os
import runpy
import signal
import sys
import threading
import time
from pathlib import Path

from nlupdate.orchestration.flows import server_lease

POLL_S = 0.25


def _stop(folder: Path) -> None:
    server_lease.forget_record(folder, os.getpid())
    os.kill(os.getpid(), signal.SIGTERM)  # uvicorn shuts down on SIGTERM
    time.sleep(5.0)
    os._exit(0)


def _watch(folder: Path, keep_s: float) -> None:
    idle_since: float | None = None
    while True:
        time.sleep(POLL_S)
        if not folder.is_dir():  # no run can find this server any more
            _stop(folder)
        try:
            held = server_lease.unused(folder)
        except OSError:  # the folder went between the two checks
            _stop(folder)
        if held is None:  # a run holds a lease
            idle_since = None
            continue
        now = time.monotonic()
        idle_since = now if idle_since is None else idle_since
        if now - idle_since >= keep_s:  # the exclusive hold stays until exit: a new run waits, then starts one
            _stop(folder)
        os.close(held)


def main() -> None:
    folder, keep_s = Path(sys.argv[1]), float(sys.argv[2])
    threading.Thread(target=_watch, args=(folder, keep_s), name="idle-watchdog", daemon=True).start()
    sys.argv = ["uvicorn", *sys.argv[3:]]
    runpy.run_module("uvicorn", run_name="__main__", alter_sys=True)


if __name__ == "__main__":
    main()
