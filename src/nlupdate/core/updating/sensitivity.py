"""Finite-difference sensitivities ``S_ij = ∂r_i/∂p_j`` (docs/methods.md §6).

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
:class:`~nlupdate.fe.adapters.base.Parameter`. Stencil points may lie outside the
parameter bounds by up to 2h; the bounds constrain the updated values, not the probes.

The Jacobian is formed in two steps so that whoever runs the model decides where:
:func:`stencil_points` lists every point the formula needs (the base point ``p`` itself,
offset 0, for the one-sided formulas; a point evaluator returns it from memory), the
caller evaluates them — in order, or all at once — and :func:`assemble_jacobian` combines
the responses. :func:`jacobian` does both in order for a plain response function.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from nlupdate.fe.adapters.base import Parameter


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
#: What the O(·) of a label says, for a reader who meets it in a run's name.
ORDER_MEANING = "error order of the finite-difference sensitivities in their step h"


def order_labels(formulas: Sequence[str]) -> list[str]:
    """The distinct O(·) of the ``formulas``' labels, lowest order first: ``['O(h)', 'O(h²)']``."""
    orders = sorted({stencil(formula).order: FORMULA_LABELS[formula].split()[-1] for formula in formulas}.items())
    return [label for _, label in orders]

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


def stencil_points(
    values: Mapping[str, float], parameters: Sequence[Parameter], formula: str
) -> list[dict[str, float]]:
    """Every point of the finite-difference stencil at ``values``, parameter by parameter
    in the order of the formula's offsets (all other values as in ``values``)."""
    rule = stencil(formula)
    base = {name: float(value) for name, value in values.items()}
    points = []
    for parameter in parameters:
        h = step_size(base[parameter.name], parameter)
        for offset in rule.offsets:
            points.append({**base, parameter.name: base[parameter.name] + offset * h})
    return points


def assemble_jacobian(
    responses: Sequence[NDArray[np.float64]],
    values: Mapping[str, float],
    parameters: Sequence[Parameter],
    formula: str,
) -> NDArray[np.float64]:
    """Sensitivity matrix ``∂r/∂p`` (response units per parameter unit), shape (n_r, n_p),
    from the responses at the :func:`stencil_points` of the same arguments (same order)."""
    rule = stencil(formula)
    n_offsets = len(rule.offsets)
    if len(responses) != n_offsets * len(parameters):
        raise ValueError(
            f"{formula} Jacobian of {len(parameters)} parameter(s) needs {n_offsets * len(parameters)} stencil "
            f"responses, got {len(responses)}"
        )
    columns = []
    for j, parameter in enumerate(parameters):
        block = responses[j * n_offsets : (j + 1) * n_offsets]
        derivative = sum(weight * np.asarray(r, dtype=float) for weight, r in zip(rule.weights, block))
        columns.append(derivative / step_size(float(values[parameter.name]), parameter))
    return np.column_stack(columns)


def jacobian(
    response: Response, values: Mapping[str, float], parameters: Sequence[Parameter], formula: str
) -> NDArray[np.float64]:
    """``∂r/∂p`` of a response function (dict of all parameter values → 1-D array),
    evaluating the stencil points in order."""
    points = stencil_points(values, parameters, formula)
    return assemble_jacobian([response(point) for point in points], values, parameters, formula)
