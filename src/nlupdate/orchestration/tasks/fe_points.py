"""A point evaluator (:class:`nlupdate.core.updating.evaluation.PointEvaluator`) that runs the
FE evaluations of a job inside the job's task, each kept as a signed cache record.

An FE evaluation is not a task of its own: a Prefect task run per point cost the demo more
CPU in the server recording ~100 of them than the points cost to compute (issue 39). The
points still persist one by one — each under its :func:`~nlupdate.orchestration.tasks.keys.point_key`
as a signed data record in the run's cache (:mod:`nlupdate.orchestration.tasks.store`, the
same records the FE-point tasks wrote) — so a rerun with one changed parameter set computes
only the new points, and a record that fails its check is named and computed again.

All jobs of a run share one :class:`PointRegistry`: a point any job has already requested
in this run is not computed again, its future is shared, so the base point that four
difference formulas need is evaluated once even when they ask for it at the same moment.
The registry computes points on an executor of the run — a thread pool as wide as the
run's task runner, or the run's Dask client (:func:`compute_point` then runs on a worker,
which reads and writes the same cache folder). Each evaluator counts, for its own job, the
points it had computed (``new``) and those it got from the registry or the cache (``cached``).

The job's task finds its evaluator in the context (:func:`evaluating_with`), not among its
arguments: an evaluator holds a lock and live futures that cannot travel.
"""
from __future__ import annotations

import contextlib
import contextvars
import threading
from concurrent.futures import Future
from pathlib import Path
from typing import Any, Callable, Iterator, Mapping, Sequence

from prefect.results import ResultRecord, ResultStore

from nlupdate.fe.adapters.base import FEAdapter, ModalResult
from nlupdate.fe.adapters.registry import AdapterSpec, build_adapter
from nlupdate.orchestration.tasks.keys import point_key
from nlupdate.orchestration.tasks.store import DataSerializer, record_store

COMPUTED, CACHED, FAILED = "Completed", "Cached", "Failed"  # the words of task states, for the tally

_ADAPTERS: dict[str, FEAdapter] = {}
_ADAPTERS_LOCK = threading.Lock()


def adapter_for(spec: AdapterSpec) -> FEAdapter:
    """The adapter of ``spec``, built once per process (adapters are stateless solvers)."""
    identity = spec.identity()
    with _ADAPTERS_LOCK:
        if identity not in _ADAPTERS:
            _ADAPTERS[identity] = build_adapter(spec)
        return _ADAPTERS[identity]


def compute_point(key: str, spec: AdapterSpec, point: Mapping[str, float], store: str,
                  refresh: bool) -> tuple[ModalResult, str]:
    """Modes of the model ``spec`` at parameter values ``point``, and ``"Cached"`` when read
    from the signed record ``key`` in the cache folder ``store`` (never when ``refresh``) or
    ``"Completed"`` when computed here (and then kept under ``key``)."""
    records = record_store(Path(store))
    if not refresh:
        payload = records.read_path(key)  # None: absent, or failing its check (named once)
        if payload is not None:
            return ResultRecord.deserialize(payload, backup_serializer=DataSerializer()).result, CACHED
    result = adapter_for(spec).evaluate(point)
    ResultStore(result_storage=records, serializer=DataSerializer(), cache_result_in_memory=False).write(result, key=key)
    return result, COMPUTED


Submit = Callable[..., Any]
"""``submit(function, *arguments)`` → a future with ``result()``: a thread pool's, or a Dask client's."""


class PointRegistry:
    """The FE points of one run, by point key (thread-safe): each computed once on ``submit``
    (:func:`compute_point`, kept in the cache folder ``store``; ``refresh``: never read it)."""

    def __init__(self, submit: Submit, store: str, refresh: bool = False) -> None:
        self.submit, self.store, self.refresh = submit, str(store), refresh
        self._futures: dict[str, Future] = {}
        self._lock = threading.Lock()

    def future(self, spec: AdapterSpec, point: Mapping[str, float]) -> tuple[Any, bool]:
        """The future of ``point`` of model ``spec`` (its result: the modes and the state
        word), and whether this call submitted it."""
        key = point_key(spec, adapter_for(spec).key(point))
        with self._lock:
            if key in self._futures:
                return self._futures[key], False
            future = self.submit(compute_point, key, spec, dict(point), self.store, self.refresh)
            self._futures[key] = future
            return future, True

    def states(self) -> list[str]:
        """State words (``Completed`` = computed, ``Cached``, ``Failed``) of the points so far,
        waiting for those still running."""
        with self._lock:
            futures = list(self._futures.values())
        states = []
        for future in futures:
            try:
                states.append(future.result()[1])
            except Exception:  # the job that asked for it names the error
                states.append(FAILED)
        return states


class RegistryPointEvaluator:
    """Evaluates points of one model through a :class:`PointRegistry`; see the module docstring."""

    def __init__(self, spec: AdapterSpec, registry: PointRegistry) -> None:
        self.spec = spec
        self.registry = registry
        self._new = 0
        self._cached = 0

    def __call__(self, points: Sequence[Mapping[str, float]]) -> list[ModalResult]:
        requests = [self.registry.future(self.spec, point) for point in points]
        outcomes = [future.result() for future, _ in requests]
        for (_, submitted), (_, state) in zip(requests, outcomes):
            if submitted and state != CACHED:
                self._new += 1
            else:
                self._cached += 1
        return [result for result, _ in outcomes]

    def counts(self) -> dict[str, int]:
        return {"new": self._new, "cached": self._cached}


_EVALUATOR: contextvars.ContextVar[RegistryPointEvaluator] = contextvars.ContextVar("nlupdate_point_evaluator")


@contextlib.contextmanager
def evaluating_with(evaluator: RegistryPointEvaluator) -> Iterator[None]:
    """Make ``evaluator`` the one :func:`current_evaluator` returns in this context."""
    token = _EVALUATOR.set(evaluator)
    try:
        yield
    finally:
        _EVALUATOR.reset(token)


def current_evaluator() -> RegistryPointEvaluator:
    """The evaluator set by :func:`evaluating_with` (LookupError outside one)."""
    return _EVALUATOR.get()
