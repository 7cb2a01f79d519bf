"""Results of pure functions remembered for the length of one run.

A validation asks for the same deterministic results again and again: the other modes'
share of the same kept levels (:func:`~nlupdate.core.identification.level_residual.frf_residual`)
for every candidate model, refit and baseline that keeps them, the resonance of the same
measured curve for every comparison it enters. A function decorated with
:func:`remembered_in_run` computes each distinct input once while a :func:`one_run` block
is open (in the thread that opened it) and returns a copy of that result after; outside one
it is the function itself, so a test that changes a module's settings between calls sees
them. The key is the arguments' fingerprint (:func:`nlupdate.fingerprints.fingerprint`: their
whole content, every bit of every float, arrays by their bytes), each argument bound to its
parameter and the defaults filled in, so ``f(x)`` and ``f(x, default)`` are one input and a
hit is the result of the same computation; a call whose arguments have no fingerprint, or
that raises, is not remembered.
"""
from __future__ import annotations

import copy
import functools
import inspect
from contextlib import contextmanager
from contextvars import ContextVar
from typing import Callable, Iterator, TypeVar

from nlupdate.fingerprints import fingerprint

T = TypeVar("T")

_store: ContextVar[dict | None] = ContextVar("nlupdate_run_cache", default=None)


@contextmanager
def one_run() -> Iterator[None]:
    """Remember the results of :func:`remembered_in_run` functions until the block ends; a
    block inside another shares the outer one's results."""
    if _store.get() is not None:
        yield
        return
    token = _store.set({})
    try:
        yield
    finally:
        _store.reset(token)


def remembered_in_run(function: Callable[..., T]) -> Callable[..., T]:
    """``function`` (pure: its result depends on its arguments alone) remembered within
    :func:`one_run` (module docstring)."""
    signature = inspect.signature(function)

    @functools.wraps(function)
    def wrapper(*args, **kwargs):
        store = _store.get()
        if store is None:
            return function(*args, **kwargs)
        bound = signature.bind(*args, **kwargs)
        bound.apply_defaults()
        try:
            content = fingerprint(dict(bound.arguments))
        except TypeError:  # an argument with no canonical form (a function, say)
            return function(*args, **kwargs)
        key = (function.__module__, function.__qualname__, content)
        if key not in store:
            store[key] = function(*args, **kwargs)
        return copy.deepcopy(store[key])  # a caller that changes its result in place changes no other's

    return wrapper
