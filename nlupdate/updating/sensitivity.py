"""Finite-difference sensitivities ``S_ij = ∂r_i/∂p_j`` (METHODS §6).

Four formulas, with step ``h`` per parameter:

============  ===================================================  ===================
name          formula                                              new points / param
============  ===================================================  ===================
forward       ``(r(p+h) − r(p)) / h``                              1 (+ base, cached)
backward      ``(r(p) − r(p−h)) / h``                              1 (+ base, cached)
central2      ``(r(p+h) − r(p−h)) / (2h)``           — O(h²)        2
central4      ``(−r(p+2h) + 8r(p+h) − 8r(p−h) + r(p−2h)) / (12h)``  4
============  ===================================================  ===================

The step is relative to the current parameter value: ``h = relative_step·|p|``
(``relative_step·(upper − lower)`` when p = 0), with ``relative_step`` from each
:class:`~nlupdate.adapters.base.Parameter`. Stencil points may lie outside the
parameter bounds by up to 2h; the bounds constrain the updated values, not the probes.

The response function is evaluated at every stencil point including the base point
``p`` (offset 0) of the one-sided formulas; the caller routes it through an
:class:`~nlupdate.adapters.base.FEAdapter`, whose cache returns the base point without
recomputing it.
"""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Callable, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from nlupdate.adapters.base import Parameter


@dataclass(frozen=True)
class Stencil:
    """Offsets (in steps h) and weights such that ``r' ≈ Σ w_k r(p + o_k h) / h``."""

    offsets: tuple[int, ...]
    weights: tuple[float, ...]
    order: int

    @property
    def new_points(self) -> int:
        """Points per parameter other than the base point."""
        return sum(1 for offset in self.offsets if offset != 0)


FORMULAS: dict[str, Stencil] = {
    "forward": Stencil((0, 1), (-1.0, 1.0), 1),
    "backward": Stencil((-1, 0), (-1.0, 1.0), 1),
    "central2": Stencil((-1, 1), (-0.5, 0.5), 2),
    "central4": Stencil((-2, -1, 1, 2), (1 / 12, -8 / 12, 8 / 12, -1 / 12), 4),
}

#: Human-readable labels of the formulas (tables, plots).
FORMULA_LABELS: dict[str, str] = {
    "forward": "forward O(h)",
    "backward": "backward O(h)",
    "central2": "central O(h²)",
    "central4": "central O(h⁴)",
}

Response = Callable[[Mapping[str, float]], NDArray[np.float64]]


def stencil(formula: str) -> Stencil:
    """The stencil of a formula name; ValueError naming the accepted names otherwise."""
    try:
        return FORMULAS[formula]
    except KeyError:
        raise ValueError(f"unknown finite-difference formula {formula!r}; expected one of {list(FORMULAS)}") from None


def step_size(value: float, parameter: Parameter) -> float:
    """Finite-difference step h (parameter units) at ``value``."""
    scale = abs(value) if value != 0 else parameter.upper - parameter.lower
    if not scale > 0:
        raise ValueError(f"parameter {parameter.name!r}: zero value and zero bound width, no step can be formed")
    return parameter.relative_step * scale


def jacobian(
    response: Response,
    values: Mapping[str, float],
    parameters: Sequence[Parameter],
    formula: str,
    max_workers: int | None = None,
) -> NDArray[np.float64]:
    """Sensitivity matrix ``∂r/∂p`` (response units per parameter unit), shape (n_r, n_p).

    ``response`` maps a dict of parameter values (all of ``parameters``) to a 1-D array.
    ``max_workers`` > 1 evaluates the stencil points in a thread pool (the adapters are
    thread-safe); None or 1 evaluates them in order.
    """
    rule = stencil(formula)
    base = {name: float(value) for name, value in values.items()}
    points: list[tuple[int, float, dict[str, float]]] = []
    steps = []
    for j, parameter in enumerate(parameters):
        h = step_size(base[parameter.name], parameter)
        steps.append(h)
        for offset, weight in zip(rule.offsets, rule.weights):
            point = dict(base)
            point[parameter.name] = base[parameter.name] + offset * h
            points.append((j, weight, point))
    if max_workers is not None and max_workers > 1:
        with ThreadPoolExecutor(max_workers=max_workers) as pool:
            responses = list(pool.map(lambda item: response(item[2]), points))
    else:
        responses = [response(point) for _, _, point in points]
    first = np.asarray(responses[0], dtype=float)
    matrix = np.zeros((first.size, len(parameters)))
    for (j, weight, _), r in zip(points, responses):
        matrix[:, j] += weight * np.asarray(r, dtype=float)
    return matrix / np.asarray(steps)[None, :]
