"""Progress bars on the terminal (what, i/N, elapsed, estimate), silent when stderr is not one."""
from __future__ import annotations

import contextlib
import sys
from typing import Iterator

from nlupdate.progress import ProgressCallback, no_progress


@contextlib.contextmanager
def terminal_progress() -> Iterator[ProgressCallback]:
    """A progress callback drawing ``rich`` bars on stderr while the block runs.

    When stderr is not a terminal (a log file, a pipe, CI) the callback does nothing, so
    logs hold only the command's own lines.
    """
    if not sys.stderr.isatty():
        yield no_progress
        return
    from rich.console import Console
    from rich.progress import (BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn,
                               TimeRemainingColumn)

    bars = Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TextColumn("elapsed"),
                    TimeElapsedColumn(), TextColumn("left"), TimeRemainingColumn(),
                    console=Console(stderr=True), transient=False)
    tasks: dict[str, int] = {}

    def update(task: str, done: int, total: int) -> None:
        if task not in tasks:
            tasks[task] = bars.add_task(task, total=total)
        bars.update(tasks[task], completed=done, total=total)

    with bars:
        yield update
