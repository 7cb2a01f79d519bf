"""The ``nlupdate`` program ends without tearing the interpreter down.

When a command has returned, Python still joins the process's threads and runs every exit
handler (Prefect's writers draining, logging, scratch folders removed), then tears the
interpreter down: every module's objects freed one by one. That last part did nothing
for the user and cost more than anything Prefect does in a run: 0.4 s of CPU after
``import prefect`` alone, about 1 s after an ``nlupdate demo`` (measured with
``benchmarks/prefect_share.py``; docs/performance.md, "Prefect's share of the demo").

:func:`arm` registers a handler before any other module of the run registers its own, so
it runs last of all; once the program has said its exit code (:func:`ending_with`), the
handler flushes the logging handlers and the standard streams and ends the process with
that code (``os._exit``). Exit handlers registered before :func:`arm` are run by it
(logging's shutdown) or are Python's own. A command that raised (``--debug``) or an argparse
exit never sets a code: the interpreter then ends as usual, traceback and all.
"""
from __future__ import annotations

import atexit
import os
import sys

_code: list[int] = []


def arm() -> None:
    """Register the last exit handler (call before the command imports anything)."""
    import logging  # noqa: F401 - its own exit handler (shutdown) registered before ours, so ours does it

    atexit.register(_end)


def ending_with(code: int) -> None:
    """The exit code the process ends with once every other exit handler has run."""
    _code[:] = [int(code)]


def _end() -> None:
    if not _code:
        return
    if "logging" in sys.modules:  # its handlers flushed and closed, as at a normal exit
        logging = sys.modules["logging"]
        # but one a signal cut short inside ``Handler.__init__`` (registered, no lock yet:
        # logging.shutdown raised AttributeError on it and ended the exit with a traceback)
        logging.shutdown([ref for ref in logging._handlerList if hasattr(ref(), "lock")])
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError, AttributeError):  # closed, gone, or a pipe whose reader left
            pass
    os._exit(_code[0])
