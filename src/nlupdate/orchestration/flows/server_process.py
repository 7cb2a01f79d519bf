"""The temporary Prefect server's process: uvicorn, ended when the run that started it ends.

``python -m nlupdate.orchestration.flows.server_process PARENT_PID UVICORN_ARGS…`` runs ``python -m
uvicorn UVICORN_ARGS…`` in this process, with a watchdog thread that ends it (SIGTERM to
itself, then exit after 5 s) as soon as its parent is gone — however the parent ended,
SIGKILL included, when nothing else could stop the server. Without it, each killed run
left a server (~220 MB) listening on loopback for good.
"""
from __future__ import annotations

import os
import runpy
import signal
import sys
import threading
import time

POLL_S = 0.25


def _watch(parent: int) -> None:
    while os.getppid() == parent:
        time.sleep(POLL_S)
    os.kill(os.getpid(), signal.SIGTERM)  # uvicorn shuts down on SIGTERM
    time.sleep(5.0)
    os._exit(0)


def main() -> None:
    parent = int(sys.argv[1])
    if os.getppid() != parent:  # the parent died before we started
        sys.exit(0)
    threading.Thread(target=_watch, args=(parent,), name="parent-watchdog", daemon=True).start()
    sys.argv = ["uvicorn", *sys.argv[2:]]
    runpy.run_module("uvicorn", run_name="__main__", alter_sys=True)


if __name__ == "__main__":
    main()
