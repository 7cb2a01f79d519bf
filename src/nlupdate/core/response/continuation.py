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

(Over 400 lines because the continuation, its options, the curve it returns and its two
drivers — one problem, or several force levels in lockstep — are one algorithm.)
"""
from __future__ import annotations

import dataclasses
import warnings
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.model.system import CondensedProblem, LinearTerms, NonlinearSystem, newton_fixed_frequency
from nlupdate.core.response.balance import BalanceProblem, MultiHarmonicProblem
from nlupdate.core.response.arclength import unit_tangents
from nlupdate.core.response.curve_fill import fill_curve
from nlupdate.core.response.folds import insert_folds


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


def _tangent(jac: NDArray, jac_w: NDArray, previous: NDArray) -> NDArray:
    """Unit null vector of [J, J_ω̃] oriented like ``previous``."""
    return unit_tangents(jac[None], jac_w[None], previous[None])[0]


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
    if not (np.isfinite(omega_start) and np.isfinite(omega_end) and 0 <= omega_start < omega_end):
        raise ValueError(f"need 0 ≤ omega_start < omega_end, got {omega_start}, {omega_end} rad/s")


@dataclass(frozen=True, eq=False)
class Curve:
    """Points of a traced solution curve: ω (rad/s), scaled unknowns y, fold flags, the
    determinant of ∂R/∂y and the unit tangent in the continuation's scaled space (y, ω̃),
    oriented along the curve, at each point."""

    omega: NDArray[np.float64]
    y: NDArray[np.float64]
    turning_point: NDArray[np.bool_]
    jacobian_determinant: NDArray[np.float64]
    tangent: NDArray[np.float64]
    stalled_at: float | None = None
    """ω (rad/s) where the step fell below its minimum and the trace stopped, else None."""


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
        coarse = _trace(problem, omega_start, omega_end, _coarse(o))
        return _filled(problem, coarse, omega_start, omega_end, o)
    return _finished(problem, _trace(problem, omega_start, omega_end, o), omega_start, omega_end, o)


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
        return _finished(problem, _trace(problem, omega_start, omega_end, o.updated(fill=1)), omega_start,
                         omega_end, o)
    return insert_folds(problem, filled, omega_start, omega_end, o)


def _finished(problem: BalanceProblem, curve: Curve, omega_start: float, omega_end: float,
              o: ContinuationOptions) -> Curve:
    _warn_if_stalled(curve)
    return insert_folds(problem, curve, omega_start, omega_end, o)


def _warn_if_stalled(curve: Curve) -> None:
    if curve.stalled_at is not None:
        warnings.warn(
            f"continuation stalled at {curve.stalled_at / (2 * np.pi):.6g} Hz (step below minimum); the curve is "
            "returned up to there",
            RuntimeWarning,
            stacklevel=3,
        )


def _trace(problem: BalanceProblem, omega_start: float, omega_end: float, o: ContinuationOptions) -> Curve:
    """Every point of the curve by the continuation (:func:`_continuation`)."""
    band = omega_end - omega_start
    size = problem.size
    steps = _continuation(problem, omega_start, omega_end, o)
    request = next(steps)
    while True:
        r, jac, jac_w = problem.residual_and_jacobians(request[:size], omega_start + band * request[size])
        try:
            request = steps.send((r, jac, jac_w * band))
        except StopIteration as done:
            return done.value


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
        coarse = _lockstep(problems, evaluate_batch, omega_start, omega_end, _coarse(o))
        return [_filled(problem, curve, omega_start, omega_end, o) for problem, curve in zip(problems, coarse)]
    curves = _lockstep(problems, evaluate_batch, omega_start, omega_end, o)
    return [_finished(problem, curve, omega_start, omega_end, o) for problem, curve in zip(problems, curves)]


def _lockstep(problems, evaluate_batch, omega_start: float, omega_end: float, o: ContinuationOptions) -> list[Curve]:
    """Every problem's :func:`_continuation`, their evaluations made together."""
    band = omega_end - omega_start
    steps = [_continuation(problem, omega_start, omega_end, o) for problem in problems]
    requests = {index: next(step) for index, step in enumerate(steps)}
    curves: list[Curve | None] = [None] * len(problems)
    while requests:
        indices = np.array(sorted(requests))
        z = np.array([requests[index] for index in indices])
        r, jac, jac_w = evaluate_batch(indices, z[:, :-1], omega_start + band * z[:, -1])
        for row, index in enumerate(indices):
            try:
                requests[index] = steps[index].send((r[row], jac[row], jac_w[row] * band))
            except StopIteration as done:
                curves[index] = done.value
                del requests[index]
    return curves


def _continuation(problem, omega_start: float, omega_end: float, o: ContinuationOptions):
    """The continuation as a generator: it yields each point z = (y, ω̃) it needs evaluated and
    receives (R, ∂R/∂y, ∂R/∂ω̃); its return value is the :class:`Curve`. Newton at the start and
    at the band edge evaluates ``problem`` directly."""
    step, max_step, min_step, tolerance = o.step, o.max_step, o.min_step, o.tolerance
    band = omega_end - omega_start
    size = problem.size

    for guess in problem.initial_guesses(omega_start):
        y, converged, _ = newton_fixed_frequency(problem, omega_start, guess, tol=tolerance)
        if converged:
            break
    else:
        raise ContinuationError(
            f"no converged starting solution at {omega_start / (2 * np.pi):.6g} Hz; "
            "start the band where the response is closer to linear"
        )
    z = np.append(y, 0.0)
    r, jac, jac_w = yield z
    direction = np.zeros(size + 1)
    direction[size] = 1.0
    t = _tangent(jac, jac_w, direction)

    points = [z]
    dets = [np.linalg.det(jac)]
    tangents = [t]
    ds = step
    stalled_at = None
    cos_max = np.cos(np.radians(o.max_angle_deg))
    cos_half = np.cos(np.radians(0.5 * o.max_angle_deg))
    augmented = np.zeros((size + 1, size + 1))

    curvature = np.zeros(size + 1)  # dt/ds from the last step, for a second-order predictor
    while len(points) < o.max_points:
        z_pred = z + ds * t + (0.5 * ds * ds) * curvature
        z_new = z_pred.copy()
        converged = False
        previous_residual = previous_correction = np.inf
        first_contraction = 0.0
        for iteration in range(1, o.corrector_iterations + 1):
            r, jac, jac_w = yield z_new
            augmented[:size, :size] = jac
            augmented[:size, size] = jac_w
            augmented[size] = t
            rhs = np.append(-r, -t @ (z_new - z_pred))
            try:
                dz = np.linalg.solve(augmented, rhs)
            except np.linalg.LinAlgError:
                break
            z_new = z_new + dz
            residual, correction = np.max(np.abs(r)), np.max(np.abs(dz))
            if iteration == 2:
                first_contraction = correction / previous_correction
            # Converged: a negligible correction with a small residual, or a small residual
            # that Newton no longer reduces (a receptance from a sparse factorisation near
            # resonance is accurate to ~1e-7 only: that is the floor it stagnates at).
            if (correction < o.correction_tolerance and residual < 10 * tolerance) or (
                residual < o.stagnation_residual and residual > 0.5 * previous_residual
            ):
                converged = True
                break
            if correction > o.contraction * previous_correction:
                break
            previous_residual, previous_correction = residual, correction
        if converged:  # the last Jacobian was taken within correction_tolerance of z_new: reuse it
            t_new = _tangent(jac, jac_w, t)
            chord = z_new - z
            chord /= np.linalg.norm(chord)
        # A sharp turn is refined by smaller steps, except at a kink (e.g. stick–slip onset
        # of a Jenkins element, where the DF slope jumps) which no step size smooths; so is a
        # chord that leaves both tangents (the corrector crossed a fold onto the other branch).
        if not converged or (ds > o.kink_step and min(t_new @ t, chord @ t, chord @ t_new) < cos_max):
            ds *= 0.5
            if ds < min_step:
                stalled_at = omega_start + band * z[size]
                break
            continue
        points.append(z_new)
        dets.append(np.linalg.det(jac))
        tangents.append(t_new)
        if t_new @ t > cos_half:  # no kink: the next prediction bends as the last step did
            curvature = (t_new - t) / np.linalg.norm(z_new - z)
        else:
            curvature = np.zeros(size + 1)
        z, t, t_old = z_new, t_new, t
        if iteration >= o.slow_iterations:
            ds *= o.shrink
        else:
            turn = np.degrees(np.arccos(np.clip(t_new @ t_old, -1.0, 1.0)))
            factor = min(o.grow, np.sqrt(o.target_contraction / max(first_contraction, 1e-12)),
                         0.5 * o.max_angle_deg / max(turn, 1e-12))
            ds = min(ds * max(factor, o.shrink), max_step)
        if z[size] >= 1.0 or z[size] <= 0.0:
            break

    points_arr = np.array(points)
    # land exactly on the band edge the curve left through
    if points_arr[-1, size] > 1.0 or points_arr[-1, size] < 0.0:
        edge = 1.0 if points_arr[-1, size] > 1.0 else 0.0
        z_prev, z_last = points_arr[-2], points_arr[-1]
        weight = (edge - z_prev[size]) / (z_last[size] - z_prev[size])
        guess = z_prev[:size] + weight * (z_last[:size] - z_prev[:size])
        y_edge, ok, _ = newton_fixed_frequency(problem, omega_start + band * edge, guess, tol=tolerance)
        if ok:
            points_arr[-1] = np.append(y_edge, edge)
            _, jac, jac_w = yield points_arr[-1]
            dets[-1] = np.linalg.det(jac)
            tangents[-1] = _tangent(jac, jac_w, tangents[-1])
    omega = omega_start + band * points_arr[:, size]
    return Curve(omega, points_arr[:, :size], np.zeros(len(dets), bool), np.array(dets), np.array(tangents),
                 stalled_at)
