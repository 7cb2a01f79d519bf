"""Warnings about updated parameters that should not be trusted as they stand.

:func:`updating_warnings` looks at one updating run (an eigensensitivity run or an
optimisation candidate, :class:`~nlupdate.core.updating.eigensensitivity.UpdatingResult`):

* ``not_converged`` — the run did not converge: it reached its iteration limit, its
  iterates cycled, it came to rest on a bound or found no step that lowers the residual
  (:mod:`nlupdate.core.updating.stopping`). Its values are where it stopped, not a result.
* ``at_bound`` — a parameter that ended within ``BOUND_TOLERANCE`` (1e-3) of the bound
  width of its lower or upper bound. Both methods come to rest there — the
  eigensensitivity iteration because its step is clipped to zero, the optimiser because
  the projected gradient vanishes — and report it as their stop (``"parameter at
  bound"``), not as convergence: the targets are probably not reachable within the
  bounds (a wrong parameter set, wrong bounds, or a target the model cannot meet). 0.1 %
  of the width: both methods land on the bound to round-off or to their step tolerance
  (≤ 1e-6 here), while a free optimum that close to a bound by chance is improbable.
* ``uncertainty_exceeds_value`` — the standard deviation propagated from the targets'
  uncertainty (:mod:`nlupdate.core.updating.target_uncertainty`) exceeds the value's magnitude.

The warning type is :class:`~nlupdate.core.identification.trust.TrustWarning`.
"""
from __future__ import annotations

from typing import Mapping

import numpy as np

from nlupdate.core.identification.trust import TrustWarning, uncertainty_warnings
from nlupdate.core.updating.eigensensitivity import UpdatingResult
from nlupdate.core.updating.stopping import BOUND_TOLERANCE, at_bound
from nlupdate.core.updating.target_uncertainty import ParameterUncertainty


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
    state = f"converged ({result.reason})" if result.converged else f"not converged: {result.reason}"
    out = []
    if not result.converged and result.stop != "parameter at bound":  # that one: the at_bound warning below
        steps = "iterations" if result.method == "eigensensitivity" else "objective calls"
        out.append(TrustWarning(
            "run", "not_converged",
            f"did not converge ({result.reason}, after {result.iterations} {steps}): its values are where it stopped, "
            f"not updated parameters", source))
    for name, value in result.parameters.items():
        if not bounds or name not in bounds:
            continue
        lower, upper = bounds[name]
        side = at_bound(value, lower, upper, tolerance)
        if side is not None:
            bound = lower if side == "lower" else upper
            out.append(TrustWarning(
                name, "at_bound",
                f"{name} = {value:.6g} ended on its {side} bound {bound:.6g} ({state}): the targets may not be "
                f"reachable within the bounds [{lower:.6g}, {upper:.6g}]", source))
    std = uncertainty.std if isinstance(uncertainty, ParameterUncertainty) else uncertainty
    if std:
        flagged = {w.subject for w in out}
        values = {n: v for n, v in result.parameters.items() if n not in flagged}
        finite = {n: s for n, s in std.items() if s is not None and np.isfinite(s)}
        out += uncertainty_warnings(values, finite, "propagated", source)
    return tuple(out)
