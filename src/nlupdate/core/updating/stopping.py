"""Why an updating run stopped, in words every report uses.

Each run (:class:`~nlupdate.core.updating.eigensensitivity.UpdatingResult`) records one of
:data:`STOPS` as its ``stop``; only ``"converged"`` is a result:

``converged``
    the targets are met (frequency tolerance), or the iteration came to rest inside the
    bounds (parameter change below its tolerance; the optimiser's own tests).
``iteration limit``
    ``max_iterations`` (``max_evaluations``) was reached first.
``cycle detected``
    the iterates came back to a point visited two to :data:`CYCLE_PERIODS` iterations
    before: undamped Gauss–Newton steps jumping across a region where the linearisation
    is poor (``step_control = "none"``); no further iteration would change that.
``parameter at bound``
    the iteration came to rest with a parameter on a bound (within :data:`BOUND_TOLERANCE`
    of the bound width): the step was clipped to zero there, so the targets are probably
    out of reach within the bounds.
``no decrease``
    the trust region shrank below ``parameter_tolerance`` without finding a step that
    lowers the residual (its sensitivities disagree with the model).
"""
from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np

STOPS = ("converged", "iteration limit", "cycle detected", "parameter at bound", "no decrease")
#: A parameter within this fraction of its bound width from a bound lies on it.
BOUND_TOLERANCE = 1e-3
#: Longest cycle of iterates looked for.
CYCLE_PERIODS = 4


def at_bound(value: float, lower: float, upper: float, tolerance: float = BOUND_TOLERANCE) -> str | None:
    """``"lower"``/``"upper"`` when ``value`` lies within ``tolerance`` × (upper − lower)
    of that bound (or beyond it), else None."""
    width = upper - lower
    if value <= lower + tolerance * width:
        return "lower"
    if value >= upper - tolerance * width:
        return "upper"
    return None


def bound_reason(values: Mapping[str, float], bounds: Mapping[str, tuple[float, float]]) -> str | None:
    """``"parameter at bound (k1 on its upper bound 1.1e+06)"`` when parameters of
    ``values`` lie on a bound of ``bounds`` (name → (lower, upper)), else None."""
    on = []
    for name, value in values.items():
        if name in bounds:
            side = at_bound(value, *bounds[name])
            if side is not None:
                on.append(f"{name} on its {side} bound {bounds[name][0 if side == 'lower' else 1]:.6g}")
    return f"parameter at bound ({', '.join(on)})" if on else None


def cycle_period(points: Sequence[np.ndarray], tolerance: float) -> int | None:
    """The period p (2 … :data:`CYCLE_PERIODS`) when the last of ``points`` (normalised
    parameter vectors, oldest first) lies within ``tolerance`` (largest component) of the
    point p before it, and within a tenth of the step by which it moved from the point
    before it; else None.

    The tenth tells a cycle, which returns to the point it left, from an oscillation
    contracting onto its limit, x_n = x* + a (−c)^n, which returns to within (1 − c)/c of
    its last step: for c > 0.5 that comes within the tolerance before the step does — a
    converging run (c = 0.65 on three noisy targets of a 3-mass chain) was stopped as a
    cycle and ranked as not converged. An oscillation contracting slower than c = 0.91 is
    stopped as a cycle: it would not settle within the iteration limit either.
    """
    if len(points) < 3:
        return None
    last = points[-1]
    step = np.max(np.abs(last - points[-2]))
    if step <= tolerance:
        return None  # at rest, not cycling
    for period in range(2, min(CYCLE_PERIODS, len(points) - 1) + 1):
        back = np.max(np.abs(last - points[-1 - period]))
        if back <= tolerance and back <= 0.1 * step:
            return period
    return None

