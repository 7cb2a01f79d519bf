"""Progress of long loops, for whoever wants to show it (the CLI draws a bar; nothing else does).

A progress callback is called as ``progress(task, done, total)``: ``task`` names the work
("force 10 N: time integration"), ``done`` of ``total`` units of it are finished. The
numerics call it after each unit and never print.
"""
from __future__ import annotations

from typing import Callable

ProgressCallback = Callable[[str, int, int], None]


def no_progress(task: str, done: int, total: int) -> None:
    """The default callback: report nothing."""
