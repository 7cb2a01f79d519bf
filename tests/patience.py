"""Waits in tests, on a machine that may be 5–10× slower than a developer's and loaded.

A test asserts behaviour, never this machine's speed. A wait that only ends a hang is
:data:`HANG_S` long; a short timeout that a test needs to fire (a program killed at its
timeout) is lengthened when the program had not yet got as far as the test needs
(:func:`timed_out_once_ready`), instead of being a bet on how fast Python starts.
"""
from __future__ import annotations

from pathlib import Path
from typing import Callable, TypeVar

#: The longest a test waits for what only a hang keeps from coming (seconds).
HANG_S = 120.0

T = TypeVar("T")


def timed_out_once_ready(attempt: Callable[[float], T], ready: Callable[[T], bool], first_s: float,
                         tries: int = 4, factor: float = 4.0) -> tuple[float, T]:
    """``attempt(timeout_s)`` (a run killed at ``timeout_s``), first with ``first_s``, again
    ``factor`` times longer while ``ready(outcome)`` says the program had not yet reached
    the point the test is about when it was killed (its start-up took longer than the
    timeout: 0.5 s is enough on an idle machine, not on a loaded one); (timeout, outcome)."""
    timeout_s = first_s
    for _ in range(tries):
        outcome = attempt(timeout_s)
        if ready(outcome):
            return timeout_s, outcome
        timeout_s *= factor
    raise AssertionError(f"the program never got ready before its timeout, the last {timeout_s / factor:g} s")


def written(path: Path) -> bool:
    """Whether ``path`` exists and holds something (a program killed between creating a
    file and writing it leaves it empty)."""
    try:
        return bool(path.read_text().strip())
    except OSError:
        return False
