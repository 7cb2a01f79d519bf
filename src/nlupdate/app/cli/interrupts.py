"""Ctrl-C (SIGINT) and SIGTERM end any command within seconds, with one line.

:func:`install` makes both signals raise :class:`Interrupted` (a ``KeyboardInterrupt``)
in the main thread, whatever the process inherited: a command started in the background
of a non-interactive shell inherits SIGINT *ignored*, and would otherwise never stop on
Ctrl-C; Python's default for SIGTERM is to die without unwinding, which left temporary
Prefect servers and half-written folders behind. The command then unwinds as usual (its
temporary outputs are removed by their own cleanup, a Prefect server it started is
stopped) and :func:`nlupdate.app.cli.main` prints one line and exits with 130 (SIGINT) or 143
(SIGTERM).

Python raises the interrupt only in the main thread; threads still busy (Prefect tasks,
minutes for a prediction) would keep the interpreter waiting. So the first signal also
starts a deadline: after ``grace_s`` seconds the callbacks registered with
:func:`on_deadline` run (say what was kept, stop servers) and the process exits with the
signal's code. Further signals are ignored while it unwinds; Prefect's "Crash detected"
console lines are silenced once the user has interrupted.

Libraries may put their own handler in place of this one for a while — Prefect does, for
SIGTERM, while a flow runs, and reports the crash to its API before it passes the signal
on; with the API gone (a temporary server that died with the process group) it retried
for good. So the deadline does not depend on which handler runs: :func:`install` also
makes Python write every signal it catches to a pipe (``signal.set_wakeup_fd``), and a
thread reading it starts the deadline on the first SIGINT or SIGTERM, whoever handles it.

A signal that lands in code whose exceptions Python only reports — a weakref callback,
a ``__del__``, a garbage-collector callback — raises :class:`Interrupted` where it is
swallowed ("Exception ignored in …"); the unraisable hook :func:`install` sets catches it
there and delivers the signal once more, so the command still unwinds (and prints no
traceback).
"""
from __future__ import annotations

import logging
import os
import signal
import sys
import threading
import time
from typing import Callable

EXIT_CODES = {signal.SIGINT: 130, signal.SIGTERM: 143}
GRACE_S = 3.0

_deadline_callbacks: list[Callable[[], None]] = []
_received: list[int] = []
_armed: list[int] = []  # the signal that started the deadline
_arming = threading.Lock()
_wakeups: list[tuple[int, int]] = []  # (the pipe's write end, the wakeup fd it replaced) while installed


class Interrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM, raised where Ctrl-C would be; :attr:`exit_code` 130 or 143."""

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum

    @property
    def exit_code(self) -> int:
        return EXIT_CODES[self.signum]


def signal_received() -> int | None:
    """The first interrupting signal this process received, if any."""
    return _received[0] if _received else None


def exit_code(error: KeyboardInterrupt) -> int:
    """The exit code for an interrupt (130 for Ctrl-C, 143 for SIGTERM)."""
    return error.exit_code if isinstance(error, Interrupted) else EXIT_CODES[signal.SIGINT]


def on_deadline(callback: Callable[[], None]) -> Callable[[], None]:
    """Run ``callback`` if the process must be ended before it has unwound; returns it
    (for :func:`forget`)."""
    _deadline_callbacks.append(callback)
    return callback


def forget(callback: Callable[[], None]) -> None:
    if callback in _deadline_callbacks:
        _deadline_callbacks.remove(callback)


def _deadline(signum: int, grace_s: float) -> None:
    time.sleep(grace_s)
    try:
        for callback in list(_deadline_callbacks):
            try:
                callback()
            except Exception:  # noqa: BLE001 - the process ends anyway
                pass
    finally:
        os._exit(EXIT_CODES[signum])


def _arm(signum: int) -> None:
    """Start the deadline for ``signum`` unless an earlier signal started it."""
    with _arming:
        if _armed:
            return
        _armed.append(signum)
        if not _received:
            _received.append(signum)
    logging.disable(logging.ERROR)  # the user knows; no "Crash detected!" lines …
    logging.raiseExceptions = False  # … nor Prefect's "--- Error logging to API ---"
    threading.Thread(target=_deadline, args=(signum, GRACE_S), name="nlupdate-interrupt-deadline", daemon=True).start()


def _interrupted(signum: int, frame) -> None:
    _received.append(signum)
    for other in EXIT_CODES:
        signal.signal(other, signal.SIG_IGN)
    _arm(signum)
    raise Interrupted(signum)


def _watch_wakeups(read_end: int) -> None:
    """Start the deadline on the first SIGINT or SIGTERM Python caught, whichever handler
    it ran; ends (closing ``read_end``) when the pipe's write end is closed."""
    try:
        while chunk := os.read(read_end, 512):
            for signum in chunk:
                if signum in EXIT_CODES:
                    _arm(signum)
    except OSError:
        pass
    finally:
        os.close(read_end)


def _watch_signals() -> None:
    read_end, write_end = os.pipe()
    os.set_blocking(write_end, False)
    try:
        previous = signal.set_wakeup_fd(write_end, warn_on_full_buffer=False)
    except ValueError:  # not the main thread of the main interpreter
        os.close(read_end)
        os.close(write_end)
        return
    _wakeups.append((write_end, previous))
    threading.Thread(target=_watch_wakeups, args=(read_end,), name="nlupdate-signal-watch", daemon=True).start()


def _unwatch_signals() -> None:
    if _wakeups:
        write_end, previous = _wakeups.pop()
        signal.set_wakeup_fd(previous)
        os.close(write_end)  # the watching thread sees the end of the pipe and closes its end


def _raise_again(signum: int, frame) -> None:
    signal.signal(signum, signal.SIG_IGN)
    raise Interrupted(signum)


def _unraisable(report) -> None:
    """An :class:`Interrupted` that Python swallowed (raised in a callback or ``__del__``):
    deliver the signal again, to be raised in ordinary code; anything else as before."""
    if isinstance(report.exc_value, Interrupted):
        signum = report.exc_value.signum
        signal.signal(signum, _raise_again)
        threading.Timer(0.01, os.kill, (os.getpid(), signum)).start()
        return
    _previous_unraisable[-1](report)


_previous_unraisable: list = []


def install() -> dict:
    """Make SIGINT and SIGTERM raise :class:`Interrupted` (main thread only), start the
    deadline whichever handler they reach, and catch one Python swallowed; returns the
    handlers they had, for :func:`restore`."""
    if threading.current_thread() is not threading.main_thread():
        return {}
    _received.clear()  # a command run in-process after an interrupted one starts afresh
    _armed.clear()
    _previous_unraisable.append(sys.unraisablehook)
    sys.unraisablehook = _unraisable
    previous = {signum: signal.signal(signum, _interrupted) for signum in EXIT_CODES}
    _watch_signals()
    return previous


def restore(previous: dict) -> None:
    """Give the signals the handlers :func:`install` replaced (a command run in-process
    leaves its host as it found it)."""
    if previous and _previous_unraisable:
        sys.unraisablehook = _previous_unraisable.pop()
    if previous:
        _unwatch_signals()
    for signum, handler in previous.items():
        signal.signal(signum, handler)
