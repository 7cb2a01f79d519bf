"""The predictor–corrector steps of the pseudo-arclength continuation, one curve or several in lockstep.

The curve is traced in (y, ω̃) with ω̃ = (ω − ω_start)/(ω_end − ω_start). Each step predicts
along the unit tangent (second order: z + ds·t + ½ds²·κ) and corrects with Newton on the
pseudo-arclength system (Keller)::

    R(y, ω) = 0,   tᵀ (z − z_pred) = 0.

The step length adapts to how fast the corrector contracts and to the turning angle of the
tangent (:class:`~nlupdate.core.response.continuation_options.ContinuationOptions` states the
rule). The continuation is a generator that asks for each evaluation it needs, so one curve
(:func:`trace_points`) or several problems in lockstep with their evaluations batched
(:func:`trace_in_lockstep`) run the same steps.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Generator, Sequence

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.model.system import newton_fixed_frequency
from nlupdate.core.response.arclength import unit_tangents
from nlupdate.core.response.balance import BalanceProblem
from nlupdate.core.response.continuation_options import ContinuationError, ContinuationOptions


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


def _tangent(jac: NDArray, jac_w: NDArray, previous: NDArray) -> NDArray:
    """Unit null vector of [J, J_ω̃] oriented like ``previous``."""
    return unit_tangents(jac[None], jac_w[None], previous[None])[0]


def trace_points(problem: BalanceProblem, omega_start: float, omega_end: float, o: ContinuationOptions) -> Curve:
    """Every point of the curve by the continuation (:func:`continuation_steps`), folds not yet located."""
    band = omega_end - omega_start
    size = problem.size
    steps = continuation_steps(problem, omega_start, omega_end, o)
    request = next(steps)
    while True:
        r, jac, jac_w = problem.residual_and_jacobians(request[:size], omega_start + band * request[size])
        try:
            request = steps.send((r, jac, jac_w * band))
        except StopIteration as done:
            return done.value


def trace_in_lockstep(problems: Sequence[BalanceProblem], evaluate_batch: Callable, omega_start: float,
                      omega_end: float, o: ContinuationOptions) -> list[Curve]:
    """Every problem's :func:`continuation_steps`, their evaluations made together by
    ``evaluate_batch(indices, y, omega)`` → (R, ∂R/∂y, ∂R/∂ω) stacked."""
    band = omega_end - omega_start
    steps = [continuation_steps(problem, omega_start, omega_end, o) for problem in problems]
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


def continuation_steps(problem: BalanceProblem, omega_start: float, omega_end: float,
                       o: ContinuationOptions) -> Generator[NDArray, tuple[NDArray, NDArray, NDArray], Curve]:
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
