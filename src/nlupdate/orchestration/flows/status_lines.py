"""What the person running a study sees: which step or job, i/N in sweeps, computed or cached.

:class:`Progress` prints one line per finished step or job (``rich``, which comes with
Prefect) and keeps the tally of task states per step and per job — computed
(``Completed``), ``Cached``, ``Failed`` — for the run's manifest. A job is named as its
task run is in the Prefect UI (``updating: central O(h²) {E, h2}``,
:mod:`nlupdate.orchestration.tasks.names`), so a manifest entry maps to one run; its place in the sweep
(``3/10``, the order of finishing) is shown but is not part of the name. Inside a flow run the same lines go to the run's
log in the Prefect UI (through Prefect's API log handler on a logger of our own, so
Prefect's console logging stays quiet). Flows reach it through :func:`current_progress`
(a context variable, so the coordinator threads of a sweep see it too).
"""
from __future__ import annotations

import contextlib
import contextvars
import logging
import sys
import threading
from collections import Counter, defaultdict
from typing import Iterator

from rich.console import Console
from rich.markup import escape
from rich.text import Text

from nlupdate.orchestration.tasks.names import ascii_name

STATE_WORDS = {"Completed": "computed", "Cached": "cached", "Failed": "FAILED", "Crashed": "CRASHED"}


class Progress:
    """Printer and tally of one run (thread-safe)."""

    def __init__(self, console: Console | None = None, quiet: bool = False) -> None:
        self.console = console or Console(highlight=False, soft_wrap=True)
        self.quiet = quiet
        self.tally: dict[str, Counter] = defaultdict(Counter)
        self._lock = threading.Lock()

    def say(self, message: str) -> None:
        if not self.quiet:
            with self._lock:
                self.console.print(message)
        _log_to_flow_run(Text.from_markup(message).plain)

    def warn_run(self, message: str) -> None:
        """Log ``message`` as a warning of the flow run — the Prefect UI's run page shows it
        beside a run that otherwise reads "Completed" — and not on the terminal, whose
        summary prints it."""
        _log_to_flow_run(message, logging.WARNING)

    def record(self, step: str, state: str, count: int = 1) -> None:
        """Count ``count`` task runs of ``step`` that ended in ``state``."""
        with self._lock:
            self.tally[step][state] += count

    def introduce(self, step: str, text: str) -> None:
        """Print the line before the jobs of fan-out step ``step``: what their names say
        (:attr:`~nlupdate.study.chain.Step.introduce`), spelled as the jobs' lines name them
        (``O(h^2)``, :func:`~nlupdate.orchestration.tasks.names.ascii_name`)."""
        self.say(f"[bold]{escape(step)}[/bold]: {escape(ascii_name(text))}")

    def finished(self, step: str, state: str, detail: str = "", seconds: float | None = None,
                 position: str = "") -> None:
        """Record one task run of ``step`` (a step, or a job's name) and print it;
        ``position``: its place in a sweep (``3/10``), shown, not recorded."""
        self.record(step, state)
        word = STATE_WORDS.get(state, state)
        style = {"computed": "green", "cached": "cyan"}.get(word, "bold red")
        timing = f" in {seconds:.1f} s" if seconds is not None else ""
        place = f" ({position})" if position else ""
        detail = f": {escape(detail)}" if detail else ""  # a "[prediction]" in a message is text, not markup
        self.say(f"[bold]{escape(step)}[/bold]{place}{detail} — [{style}]{word}[/{style}]{timing}")

    def summary(self) -> dict[str, dict[str, int]]:
        """``{step: {"computed": n, "cached": n, "failed": n}}`` for the manifest."""
        with self._lock:
            return {
                step: {"computed": counts.get("Completed", 0), "cached": counts.get("Cached", 0),
                       "failed": sum(v for k, v in counts.items() if k not in ("Completed", "Cached"))}
                for step, counts in self.tally.items()
            }


_CURRENT: contextvars.ContextVar[Progress] = contextvars.ContextVar("nlupdate_progress")


def current_progress() -> Progress:
    """The progress of the run in this context (a silent one when none was set)."""
    try:
        return _CURRENT.get()
    except LookupError:
        progress = Progress(quiet=True)
        _CURRENT.set(progress)
        return progress


@contextlib.contextmanager
def using(progress: Progress) -> Iterator[None]:
    """Context manager: make ``progress`` current."""
    token = _CURRENT.set(progress)
    try:
        yield
    finally:
        _CURRENT.reset(token)


def _run_log() -> logging.Logger:
    """``nlupdate.run``: INFO and above to the Prefect API only (not the console)."""
    logger = logging.getLogger("nlupdate.run")
    if not logger.handlers:
        from prefect.logging.handlers import APILogHandler

        logger.addHandler(APILogHandler())
        logger.setLevel(logging.INFO)
        logger.propagate = False
    return logger


def _log_to_flow_run(message: str, level: int = logging.INFO) -> None:
    """Send ``message`` to the current flow run's log at ``level``, if there is one (none while
    Prefect is not imported: a run answered from the cache, :mod:`nlupdate.orchestration.flows.from_cache`)."""
    if "prefect.context" not in sys.modules:
        return
    from prefect.context import FlowRunContext

    context = FlowRunContext.get()
    if context is None or context.flow_run is None:
        return
    from prefect.logging.loggers import PrefectLogAdapter

    extra = {"flow_run_id": str(context.flow_run.id), "flow_run_name": context.flow_run.name,
             "flow_name": context.flow.name}
    PrefectLogAdapter(_run_log(), extra=extra).log(level, message)
