"""Ctrl-C during a flow run stops the process within seconds, not when running tasks end.

Python raises ``KeyboardInterrupt`` only in the main thread; Prefect then marks the runs
crashed, but the interpreter still waits for the task threads to finish their current
work (minutes for a prediction). :func:`prompt_interrupt` raises the interrupt as usual
and gives the unwinding ``grace_s`` seconds: archives being written are removed by their
own cleanup, the Prefect server is stopped. If the process is still alive after that,
``on_timeout`` runs (say what was kept, stop the server) and the process exits with 130.
Prefect's "Crash detected" console lines are silenced once the user has interrupted.
"""
from __future__ import annotations

import contextlib
import logging
import os
import signal
import threading
import time
from typing import Callable, Iterator

EXIT_INTERRUPTED = 130


@contextlib.contextmanager
def prompt_interrupt(on_timeout: Callable[[], None], grace_s: float = 3.0) -> Iterator[None]:
    """Within the block, SIGINT raises ``KeyboardInterrupt`` and exits after ``grace_s`` at the latest."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def deadline() -> None:
        time.sleep(grace_s)
        try:
            on_timeout()
        finally:
            os._exit(EXIT_INTERRUPTED)

    def interrupted(signum, frame):
        logging.disable(logging.ERROR)  # the user knows; no "Crash detected!" lines
        threading.Thread(target=deadline, name="nlupdate-interrupt-deadline", daemon=True).start()
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGINT, interrupted)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
