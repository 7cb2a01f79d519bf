"""The settings of the pseudo-arclength continuation, and its error.

Every step length, tolerance and iteration count of :func:`~nlupdate.core.response.continuation.trace_curve`
in one frozen dataclass, checked when made; :meth:`ContinuationOptions.updated` changes some by name.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np


class ContinuationError(RuntimeError):
    """The continuation could not start or stalled; the message says where."""


@dataclass(frozen=True)
class ContinuationOptions:
    """Every setting of :func:`trace_curve`, with its default, in one place.

    Lengths are in the scaled space of the continuation (frequency band = 1, amplitude
    scale = 1); residuals are scaled residuals ‖R‖∞.

    Steps: ``step`` the first arc-length step, later ones at most ``max_step``. After each
    accepted step the next is ds × f with f = min(``grow``, √(``target_contraction`` / θ),
    ½ ``max_angle_deg`` / α), at least ``shrink``: θ is the corrector's first contraction
    (‖Δz₂‖ / ‖Δz₁‖, which grows as ds², so the step that gives the target is predicted) and α
    the tangent's turn (∝ ds); a corrector that needed ``slow_iterations`` or more shrinks the
    step by ``shrink``. A corrector that fails, or a tangent that turns by more than
    ``max_angle_deg`` (except below ``kink_step``, where the turn is accepted as a kink such as a
    stick–slip onset), or a chord between the two points that turns more than that from
    either tangent (the corrector crossed a fold onto the other branch), halves the step;
    below ``min_step`` the trace stops with a warning. At
    most ``max_points`` points. The predictor is of second order, z + ds·t + ½ds²·κ with κ
    the change of the unit tangent over the last step per unit length (first order after a
    turn of more than ½ ``max_angle_deg``, such as a kink).

    Corrector: at most ``corrector_iterations`` Newton iterations on the pseudo-arclength
    system; converged when the correction is below ``correction_tolerance`` and the residual
    below 10 × ``tolerance``, or when a residual below ``stagnation_residual`` no longer halves
    (receptances from a sparse factorisation near resonance are accurate to ~1e-7 only).
    A corrector whose correction does not shrink to at most ``contraction`` × the one before
    is abandoned at once (the step was too long for Newton; it halves) instead of running its
    iterations out. ``tolerance`` is also the start's and the band edge's Newton tolerance.

    Folds: located between two points whose tangents' ω-components differ in sign by at
    most ``fold_iterations`` secant steps on that component, each corrected by at most
    ``fold_corrector_iterations`` Newton iterations (to corrections below
    ``fold_correction_tolerance``), until |t_ω| < ``fold_tolerance``.

    Filling: with ``fill`` = k > 1 the continuation takes steps up to k × ``max_step`` (and a
    first step k × ``step``) — it only connects the branches and locates the folds — and the
    points in between, at most ``max_step`` apart, are corrected all at once by one batched
    Newton (:mod:`nlupdate.core.response.curve_fill`), with the same corrector settings and
    tolerances. A point that fails the branch checks there sends the whole curve back to
    ``fill`` = 1, every point by continuation.
    """

    step: float = 0.02
    max_step: float = 0.05
    min_step: float = 1e-7
    max_points: int = 20000
    grow: float = 1.6
    shrink: float = 0.6
    target_contraction: float = 0.2
    slow_iterations: int = 6
    max_angle_deg: float = 15.0
    kink_step: float = 1e-4
    tolerance: float = 1e-10
    corrector_iterations: int = 8
    correction_tolerance: float = 1e-9
    stagnation_residual: float = 1e-6
    contraction: float = 1.0
    fold_iterations: int = 12
    fold_corrector_iterations: int = 10
    fold_tolerance: float = 1e-10
    fold_correction_tolerance: float = 1e-12
    fill: int = 1

    def __post_init__(self) -> None:
        for name in ("step", "max_step", "min_step", "tolerance", "correction_tolerance", "stagnation_residual",
                     "kink_step", "fold_tolerance", "fold_correction_tolerance", "grow", "shrink", "max_angle_deg",
                     "contraction", "target_contraction"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and np.isfinite(value) and value > 0):
                raise ValueError(f"continuation option {name}: expected a positive number, got {value!r}")
        for name in ("max_points", "slow_iterations", "corrector_iterations",
                     "fold_iterations", "fold_corrector_iterations", "fill"):
            value = getattr(self, name)
            if not (isinstance(value, (int, np.integer)) and value >= 1):
                raise ValueError(f"continuation option {name}: expected an integer ≥ 1, got {value!r}")
        if not self.min_step <= min(self.step, self.max_step):
            raise ValueError(
                f"continuation options: need min_step ≤ step and min_step ≤ max_step, got {self.min_step}, {self.step}, "
                f"{self.max_step}"
            )
        if not (self.grow >= 1 and self.shrink <= 1 and self.max_angle_deg < 90):
            raise ValueError("continuation options: need grow ≥ 1, shrink ≤ 1 and max_angle_deg < 90")

    def updated(self, **overrides) -> "ContinuationOptions":
        """A copy with some options changed; unknown names are an error that lists the known ones."""
        if not overrides:
            return self
        known = {f.name for f in dataclasses.fields(self)}
        unknown = sorted(set(overrides) - known)
        if unknown:
            raise TypeError(f"unknown continuation option(s) {unknown}; known: {sorted(known)}")
        return dataclasses.replace(self, **overrides)
