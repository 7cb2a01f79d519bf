"""Warnings about updated parameters that should not be trusted as they stand.

:func:`updating_warnings` looks at one updating run (an eigensensitivity run or an
optimisation candidate, :class:`~nlupdate.updating.eigensensitivity.UpdatingResult`):

* ``at_bound`` — a parameter that ended within ``BOUND_TOLERANCE`` (1e-3) of the bound
  width of its lower or upper bound. Both methods stop there happily — the
  eigensensitivity iteration because its step is clipped to zero ("converged: parameter
  change"), the optimiser because the projected gradient vanishes — so "converged" then
  means "converged on the bound": the targets are probably not reachable within the
  bounds (a wrong parameter set, wrong bounds, or a target the model cannot meet). 0.1 %
  of the width: both methods land on the bound to round-off or to their step tolerance
  (≤ 1e-6 here), while a free optimum that close to a bound by chance is improbable.
* ``uncertainty_exceeds_value`` — the standard deviation propagated from the targets'
  uncertainty (:mod:`nlupdate.updating.target_uncertainty`) exceeds the value's magnitude.

The warning type is :class:`~nlupdate.identification.trust.TrustWarning`.
"""
from __future__ import annotations

from typing import Mapping

import numpy as np

from nlupdate.identification.trust import TrustWarning, uncertainty_warnings
from nlupdate.updating.eigensensitivity import UpdatingResult
from nlupdate.updating.target_uncertainty import ParameterUncertainty

BOUND_TOLERANCE = 1e-3


def at_bound(value: float, lower: float, upper: float, tolerance: float = BOUND_TOLERANCE) -> str | None:
    """``"lower"``/``"upper"`` when ``value`` lies within ``tolerance`` × (upper − lower)
    of that bound (or beyond it), else None."""
    width = upper - lower
    if value <= lower + tolerance * width:
        return "lower"
    if value >= upper - tolerance * width:
        return "upper"
    return None


def updating_warnings(
    result: UpdatingResult,
    bounds: Mapping[str, tuple[float, float]] | None = None,
    uncertainty: ParameterUncertainty | Mapping[str, float] | None = None,
    tolerance: float = BOUND_TOLERANCE,
) -> tuple[TrustWarning, ...]:
    """Warnings about one updating run (module docstring); the source is the run's name.

    ``bounds``: (lower, upper) per parameter (default: the run's own ``bounds``);
    ``uncertainty``: the run's propagated standard deviations, if any.
    """
    bounds = result.bounds if bounds is None else bounds
    source = result.name or result.method
    state = f"reported converged ({result.reason})" if result.converged else f"not converged ({result.reason})"
    out = []
    for name, value in result.parameters.items():
        if not bounds or name not in bounds:
            continue
        lower, upper = bounds[name]
        side = at_bound(value, lower, upper, tolerance)
        if side is not None:
            bound = lower if side == "lower" else upper
            out.append(TrustWarning(
                name, "at_bound",
                f"{name} = {value:.6g} ended on its {side} bound {bound:.6g} ({state}): the run converged on the "
                f"bound, so the targets may not be reachable within the bounds [{lower:.6g}, {upper:.6g}]", source))
    std = uncertainty.std if isinstance(uncertainty, ParameterUncertainty) else uncertainty
    if std:
        flagged = {w.subject for w in out}
        values = {n: v for n, v in result.parameters.items() if n not in flagged}
        finite = {n: s for n, s in std.items() if s is not None and np.isfinite(s)}
        out += uncertainty_warnings(values, finite, "propagated", source)
    return tuple(out)
