"""A point evaluator (:class:`nlupdate.core.updating.evaluation.PointEvaluator`) that runs each
FE evaluation as a task on the flow's task runner — threads, or Dask workers.

All updating runs of a sweep share one :class:`PointRegistry`: a point any run has
already requested in this flow run is not submitted again, its future is shared, so the
base point that four difference formulas need is evaluated once even when they ask for
it at the same moment. Across runs the FE-point task's persistent cache serves it.
Each evaluator counts, for its own updating run, the points it had computed (``new``) and
those it got from the registry or the cache (``cached``).

The updating-run task finds its evaluator in the context (:func:`evaluating_with`), not
among its arguments: a task's arguments travel with every task it submits (to Dask
workers too), and an evaluator holds a lock and live futures that cannot.
"""
from __future__ import annotations

import contextlib
import contextvars
import threading
from typing import Callable, Iterator, Mapping, Sequence

from prefect import Task
from prefect.futures import PrefectFuture

from nlupdate.fe.adapters.base import FEAdapter, ModalResult
from nlupdate.fe.adapters.registry import AdapterSpec, build_adapter
from nlupdate.orchestration.tasks.keys import point_key
from nlupdate.orchestration.tasks.names import fe_point_name


_ADAPTERS: dict[str, FEAdapter] = {}
_ADAPTERS_LOCK = threading.Lock()


def adapter_for(spec: AdapterSpec) -> FEAdapter:
    """The adapter of ``spec``, built once per process (adapters are stateless solvers)."""
    identity = spec.identity()
    with _ADAPTERS_LOCK:
        if identity not in _ADAPTERS:
            _ADAPTERS[identity] = build_adapter(spec)
        return _ADAPTERS[identity]


class PointRegistry:
    """The FE-point futures of one flow run, by point key (thread-safe). ``evaluate_point``
    gives the FE-point task for a task-run name (:func:`~nlupdate.orchestration.tasks.names.fe_point_name`,
    distinct for distinct points of the run)."""

    def __init__(self, evaluate_point: Callable[[str], Task]) -> None:
        self.evaluate_point = evaluate_point
        self._futures: dict[str, PrefectFuture] = {}
        self._names: set[str] = set()
        self._lock = threading.Lock()

    def future(self, spec: AdapterSpec, point: Mapping[str, float]) -> tuple[PrefectFuture, bool]:
        """The future of ``point`` of model ``spec``, and whether this call submitted it."""
        key = point_key(spec, adapter_for(spec).key(point))
        with self._lock:
            if key in self._futures:
                return self._futures[key], False
            name = fe_point_name(point, self._names)
            self._names.add(name)
            future = self.evaluate_point(name).submit(key, spec, dict(point))
            self._futures[key] = future
            return future, True

    def states(self) -> list[str]:
        """State names (``Completed`` = computed, ``Cached``, ``Failed`` …) of the points so far."""
        with self._lock:
            futures = list(self._futures.values())
        return [future.state.name for future in futures]


class TaskPointEvaluator:
    """Evaluates points of one model through a :class:`PointRegistry`; see the module docstring."""

    def __init__(self, spec: AdapterSpec, registry: PointRegistry) -> None:
        self.spec = spec
        self.registry = registry
        self._new = 0
        self._cached = 0

    def __call__(self, points: Sequence[Mapping[str, float]]) -> list[ModalResult]:
        requests = [self.registry.future(self.spec, point) for point in points]
        results = [future.result() for future, _ in requests]
        for future, submitted in requests:
            if submitted and future.state.name != "Cached":
                self._new += 1
            else:
                self._cached += 1
        return results

    def counts(self) -> dict[str, int]:
        return {"new": self._new, "cached": self._cached}


_EVALUATOR: contextvars.ContextVar[TaskPointEvaluator] = contextvars.ContextVar("nlupdate_point_evaluator")


@contextlib.contextmanager
def evaluating_with(evaluator: TaskPointEvaluator) -> Iterator[None]:
    """Make ``evaluator`` the one :func:`current_evaluator` returns in this context."""
    token = _EVALUATOR.set(evaluator)
    try:
        yield
    finally:
        _EVALUATOR.reset(token)


def current_evaluator() -> TaskPointEvaluator:
    """The evaluator set by :func:`evaluating_with` (LookupError outside one)."""
    return _EVALUATOR.get()
