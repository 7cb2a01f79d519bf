"""Who runs the FE evaluations an updating method asks for.

Updating methods never call an FE code themselves. They hand a list of parameter points
(dicts of parameter values, fixed values merged in) to a *point evaluator* and get one
:class:`~nlupdate.fe.adapters.base.ModalResult` per point back, in order. All points of one
request are independent (the stencil of a finite-difference Jacobian, for instance), so
an evaluator may run them concurrently; that is the flow layer's business
(:mod:`nlupdate.orchestration.flows`). The evaluator also counts how many points it had to compute
(``new``) and how many it already knew (``cached``).

:class:`MemoisedEvaluator` is the plain-Python evaluator: it runs the points one after
another through an adapter and remembers every result of its lifetime under the
adapter's point key, so the base point that forward and backward differences share, or a
point revisited by a later iteration, is solved once.
"""
from __future__ import annotations

from typing import Mapping, Protocol, Sequence

from nlupdate.fe.adapters.base import FEAdapter, ModalResult

Point = Mapping[str, float]


class PointEvaluator(Protocol):
    """``evaluator(points) -> results`` (same order) and ``evaluator.counts()``."""

    def __call__(self, points: Sequence[Point]) -> list[ModalResult]: ...

    def counts(self) -> dict[str, int]:
        """Points computed (``new``) and served from memory or cache (``cached``) so far."""
        ...


class MemoisedEvaluator:
    """Sequential evaluator over one adapter, remembering every result by point key."""

    def __init__(self, adapter: FEAdapter) -> None:
        self.adapter = adapter
        self._memory: dict[str, ModalResult] = {}
        self._new = 0
        self._cached = 0

    def __call__(self, points: Sequence[Point]) -> list[ModalResult]:
        results = []
        for point in points:
            key = self.adapter.key(point)
            if key in self._memory:
                self._cached += 1
            else:
                self._memory[key] = self.adapter.evaluate(point)
                self._new += 1
            results.append(self._memory[key])
        return results

    def counts(self) -> dict[str, int]:
        return {"new": self._new, "cached": self._cached}


def as_evaluator(model: FEAdapter | PointEvaluator) -> PointEvaluator:
    """``model`` itself if it is already a point evaluator, else a
    :class:`MemoisedEvaluator` over the adapter."""
    return MemoisedEvaluator(model) if isinstance(model, FEAdapter) else model
