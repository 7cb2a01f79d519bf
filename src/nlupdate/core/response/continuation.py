"""Newton + pseudo-arclength continuation of nonlinear frequency responses.

The condensed single-harmonic balance ``R(y, ω) = 0`` (see :mod:`nlupdate.core.model.system`) is
traced as a curve in (y, ω̃) with ω̃ = (ω − ω_start)/(ω_end − ω_start), so both the
scaled amplitudes and the scaled frequency are O(1). Each step predicts along the unit
tangent and corrects with Newton on the pseudo-arclength system (Keller)::

    R(y, ω) = 0,   tᵀ (z − z_pred) = 0.

The step length adapts to how fast the corrector contracts and to the turning angle of
the tangent, so folds are passed without manual tuning; the folds are located afterwards,
all at once (:mod:`nlupdate.core.response.folds`). With ``ContinuationOptions.fill`` the
continuation takes long steps and the points in between are corrected all at once
(:mod:`nlupdate.core.response.curve_fill`).

Stability criterion (documented simplification): a point is *unstable* when the
determinant of the real Jacobian ``∂R/∂y`` has the opposite sign to that of the
underlying linear system (which is +1 in receptance form). The determinant changes
sign exactly at turning points (saddle-node bifurcations), so this flags the middle
branches between folds — the branches a stepped-sine test jumps over. It does not
detect Neimark–Sacker or symmetry-breaking bifurcations of multi-harmonic motion.

* :mod:`~nlupdate.core.response.continuation_options` — every setting, with its default;
* :mod:`~nlupdate.core.response.continuation_steps` — the predictor–corrector steps, one curve
  or several in lockstep;
* here — the curve a trace returns with its folds located (or filled), and the
  single-harmonic drivers: one force vector, or several force levels traced together.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.model.system import CondensedProblem, LinearTerms, NonlinearSystem
from nlupdate.core.response.balance import BalanceProblem, MultiHarmonicProblem
from nlupdate.core.response.continuation_options import ContinuationError, ContinuationOptions
from nlupdate.core.response.continuation_steps import Curve, trace_in_lockstep, trace_points
from nlupdate.core.response.curve_fill import fill_curve
from nlupdate.core.response.folds import insert_folds


@dataclass(frozen=True)
class Bifurcation:
    """A loss or gain of stability between two curve points that is not a fold.

    kind: "branch point" (a real multiplier through +1), "period doubling" (through −1) or
    "Neimark–Sacker" (a complex pair); omega: where (rad/s, interpolated on the growth
    rate of the critical multiplier); index: the unstable neighbour on the curve;
    multiplier: its critical Floquet multiplier.
    """

    kind: str
    omega: float
    index: int
    multiplier: complex

    @property
    def frequency_hz(self) -> float:
        return self.omega / (2 * np.pi)


@dataclass(frozen=True, eq=False)
class FrequencyResponse:
    """A traced nonlinear frequency response (one force vector).

    omega: angular frequencies (rad/s) of the curve points, in curve order.
    x_nonlinear: the solution at the nonlinear coordinates per point — single harmonic:
        complex amplitudes (m), (n_points, n_a); harmonic balance: harmonics X₀ … X_H
        (m), (n_points, H+1, n_a).
    stable: stability flag of each point (determinant sign, or Floquet multipliers).
    turning_point: True at the refined fold points (dω/ds = 0).
    floquet_multipliers: (n_points, 2·n_q) when computed by Hill's method, else None.
    bifurcations: branch points, period doublings and Neimark–Sacker points found.
    harmonic_share: largest share of the two highest harmonics over the curve (0 for one harmonic).
    """

    problem: BalanceProblem
    omega: NDArray[np.float64]
    x_nonlinear: NDArray[np.complex128]
    stable: NDArray[np.bool_]
    turning_point: NDArray[np.bool_]
    floquet_multipliers: NDArray[np.complex128] | None = None
    bifurcations: tuple[Bifurcation, ...] = ()
    harmonic_share: float = 0.0

    @property
    def frequency_hz(self) -> NDArray[np.float64]:
        return self.omega / (2 * np.pi)

    @property
    def nonlinear_dofs(self) -> tuple[int, ...]:
        return self.problem.a

    def response(self, dofs: Sequence[int]) -> NDArray[np.complex128]:
        """Complex first-harmonic amplitudes (m) at any coordinates for every curve point."""
        return self.problem.response_at(self.omega, self.x_nonlinear, dofs)

    def harmonics(self, dofs: Sequence[int]) -> NDArray[np.complex128]:
        """Harmonics X₀ … X_H (m) at any coordinates, (n_points, H+1, len(dofs)); needs harmonic balance."""
        if not isinstance(self.problem, MultiHarmonicProblem):
            raise ValueError("a single-harmonic (describing-function) curve has no higher harmonics")
        return self.problem.harmonics_at(self.omega, self.x_nonlinear, dofs)


def default_x_scale(problem: BalanceProblem, omega_start: float, omega_end: float) -> float:
    """Amplitude scale: the largest linear response at the nonlinear dofs over the band."""
    grid = np.linspace(omega_start, omega_end, 201)
    linear = problem.linear_response(grid, problem.a)
    scale = float(np.max(np.abs(linear))) if linear.size else 0.0
    return scale if scale > 0 else 1.0


def trace_frequency_response(
    system: NonlinearSystem,
    forcing: Mapping[int | str, complex],
    omega_start: float,
    omega_end: float,
    *,
    x_scale: float | None = None,
    options: ContinuationOptions | None = None,
    **overrides,
) -> FrequencyResponse:
    """Trace the single-harmonic frequency response from ``omega_start`` to ``omega_end`` (rad/s).

    ``options`` (:class:`ContinuationOptions`, with single ``overrides`` by name) steer the
    continuation. Returns every point of the curve in order, including the branches between
    folds, with the determinant stability flag.
    """
    check_band(omega_start, omega_end)
    problem = CondensedProblem(system, forcing)
    if problem.n == 0:
        grid = np.linspace(omega_start, omega_end, 201)
        empty = np.zeros((grid.size, 0), dtype=complex)
        return FrequencyResponse(problem, grid, empty, np.ones(grid.size, bool), np.zeros(grid.size, bool))
    problem.x_scale = x_scale or default_x_scale(problem, omega_start, omega_end)
    curve = trace_curve(problem, omega_start, omega_end, options, **overrides)
    stable = curve.jacobian_determinant > 0
    stable[curve.turning_point] = False
    x = problem.to_complex(curve.y)
    return FrequencyResponse(problem, curve.omega, x, stable, curve.turning_point)


def trace_frequency_responses(
    system: NonlinearSystem,
    forcings: Sequence[Mapping[int | str, complex]],
    omega_start: float,
    omega_end: float,
    options: ContinuationOptions | None = None,
) -> list[FrequencyResponse]:
    """:func:`trace_frequency_response` for several force vectors that differ by a factor only
    (force levels of one excitation), all traced in lockstep (:func:`trace_curves`): every step's
    receptances and element forces of all levels come from one batched evaluation. The curves
    are the ones traced one by one."""
    check_band(omega_start, omega_end)
    problems = [CondensedProblem(system, forcing) for forcing in forcings]
    base = problems[0]
    factors = []
    for problem in problems:
        if problem.forced != base.forced:
            raise ValueError("force levels traced together need the same forced coordinates")
        ratio = problem.force / base.force
        if not np.allclose(ratio, ratio[0], rtol=1e-12, atol=0):
            raise ValueError("force levels traced together need force vectors that differ by a factor")
        factors.append(ratio[0])
    if base.n == 0:
        return [trace_frequency_response(system, forcing, omega_start, omega_end) for forcing in forcings]
    unit_scale = default_x_scale(base, omega_start, omega_end)
    factors = np.array(factors)
    for problem, factor in zip(problems, factors):
        problem.x_scale = unit_scale * abs(factor)  # the linear response, hence its maximum, scales with F

    def evaluate_batch(indices, y, omega):
        linear = base.linear_batch(omega)
        linear = LinearTerms(omega, linear.h_aa, linear.x_lin * factors[indices, None], linear.dh_aa,
                             linear.dx_lin * factors[indices, None])
        return base.residual_batch(y, linear, scale=np.array([problems[i].x_scale for i in indices]))

    curves = trace_curves(problems, evaluate_batch, omega_start, omega_end, options)
    out = []
    for problem, curve in zip(problems, curves):
        stable = curve.jacobian_determinant > 0
        stable[curve.turning_point] = False
        out.append(FrequencyResponse(problem, curve.omega, problem.to_complex(curve.y), stable, curve.turning_point))
    return out


def check_band(omega_start: float, omega_end: float) -> None:
    """ValueError unless 0 ≤ ``omega_start`` < ``omega_end`` (rad/s), both finite."""
    if not (np.isfinite(omega_start) and np.isfinite(omega_end) and 0 <= omega_start < omega_end):
        raise ValueError(f"need 0 ≤ omega_start < omega_end, got {omega_start}, {omega_end} rad/s")


def trace_curve(
    problem: BalanceProblem,
    omega_start: float,
    omega_end: float,
    options: ContinuationOptions | None = None,
    **overrides,
) -> Curve:
    """Pseudo-arclength continuation of ``problem`` over ``[omega_start, omega_end]`` (rad/s).

    ``problem`` is a :class:`~nlupdate.core.response.balance.BalanceProblem` — the single-harmonic
    :class:`~nlupdate.core.model.system.CondensedProblem` or the multi-harmonic
    :class:`~nlupdate.core.response.harmonic_balance.HarmonicBalanceProblem`. ``options``
    (:class:`ContinuationOptions`; single ``overrides`` by name, e.g. ``max_step=0.01``) hold
    every step, tolerance and iteration count.
    """
    o = (options or ContinuationOptions()).updated(**overrides)
    check_band(omega_start, omega_end)
    if o.fill > 1:
        coarse = trace_points(problem, omega_start, omega_end, _coarse(o))
        return _filled(problem, coarse, omega_start, omega_end, o)
    return _finished(problem, trace_points(problem, omega_start, omega_end, o), omega_start, omega_end, o)


def _coarse(o: ContinuationOptions) -> ContinuationOptions:
    """The options of the continuation that only connects the branches when it fills: long
    steps, a loose corrector (every point is corrected again to the full tolerance with the
    new ones), wider turns."""
    return o.updated(
        step=o.step * o.fill, max_step=o.max_step * o.fill, fill=1, max_angle_deg=max(o.max_angle_deg, 30.0),
        tolerance=max(o.tolerance, 1e-4), correction_tolerance=max(o.correction_tolerance, 1e-3),
        contraction=min(o.contraction, 0.7), target_contraction=max(o.target_contraction, 0.3),
    )


def _filled(problem: BalanceProblem, coarse: Curve, omega_start: float, omega_end: float,
            o: ContinuationOptions) -> Curve:
    """``coarse`` filled (:func:`~nlupdate.core.response.curve_fill.fill_curve`) with its folds
    located; a stalled coarse trace, or a point that fails the fill's checks: every point by
    continuation."""
    filled = fill_curve(problem, coarse, omega_start, omega_end, o) if coarse.stalled_at is None else None
    if filled is None:
        return _finished(problem, trace_points(problem, omega_start, omega_end, o.updated(fill=1)), omega_start,
                         omega_end, o)
    return insert_folds(problem, filled, omega_start, omega_end, o)


def _finished(problem: BalanceProblem, curve: Curve, omega_start: float, omega_end: float,
              o: ContinuationOptions) -> Curve:
    """``curve`` with its folds located, after a warning if it stalled."""
    _warn_if_stalled(curve)
    return insert_folds(problem, curve, omega_start, omega_end, o)


def _warn_if_stalled(curve: Curve) -> None:
    """A RuntimeWarning naming where ``curve`` stalled, if it did."""
    if curve.stalled_at is not None:
        warnings.warn(
            f"continuation stalled at {curve.stalled_at / (2 * np.pi):.6g} Hz (step below minimum); the curve is "
            "returned up to there",
            RuntimeWarning,
            stacklevel=3,
        )


def trace_curves(
    problems: Sequence[BalanceProblem],
    evaluate_batch,
    omega_start: float,
    omega_end: float,
    options: ContinuationOptions | None = None,
) -> list[Curve]:
    """:func:`trace_curve` of several problems in lockstep: each follows exactly its own
    continuation, and at every step the evaluations all of them ask for are made together by
    ``evaluate_batch(indices, y, omega)`` → (R, ∂R/∂y, ∂R/∂ω) stacked (indices: which problem
    each row belongs to). The curves are those :func:`trace_curve` would give one by one."""
    o = options or ContinuationOptions()
    check_band(omega_start, omega_end)
    if o.fill > 1:
        coarse = trace_in_lockstep(problems, evaluate_batch, omega_start, omega_end, _coarse(o))
        return [_filled(problem, curve, omega_start, omega_end, o) for problem, curve in zip(problems, coarse)]
    curves = trace_in_lockstep(problems, evaluate_batch, omega_start, omega_end, o)
    return [_finished(problem, curve, omega_start, omega_end, o) for problem, curve in zip(problems, curves)]


__all__ = [
    "Bifurcation", "ContinuationError", "ContinuationOptions", "Curve", "FrequencyResponse", "check_band",
    "default_x_scale", "trace_curve", "trace_curves", "trace_frequency_response", "trace_frequency_responses",
]
