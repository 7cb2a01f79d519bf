"""The model's response at the measured points (force level, frequency), as the test saw it.

Per force level the nonlinear frequency response is traced by continuation over the measured
band — describing function by default, or multi-harmonic balance with given
:class:`~nlupdate.core.response.harmonic_balance.HarmonicSettings` (its first harmonic). Where the
response is multi-valued, which solution a test settles on depends on how it reached the
frequency (a sweep up or down, a start from rest), so every measured point is compared with
the **nearest stable solution at its frequency** anywhere on the traced curve: the stable
segments of the curve that contain the frequency are interpolated, polished by Newton at the
exact frequency, and the one closest to the measurement (in the misfit's own weights) is
taken. The stepped-sine reading of the curve in the stated sweep direction
(:mod:`nlupdate.core.response.stepped_sine`) is kept beside it, so a report can mark the points
where the measurement follows another branch than the stated sweep.

A measured point that no stable segment of the traced curve reaches (the continuation
stalled before it, or it lies on a branch the trace never visited) gets a second chance:
Newton at its frequency started from the measured amplitudes, accepted when it converges
to a stable solution (the determinant criterion of :mod:`nlupdate.core.response.continuation`;
describing function only). A model without nonlinear elements is evaluated directly,
``X = H(ω)·F``. Points still without a solution are NaN (they count as misfit, see
:mod:`nlupdate.core.discovery.frf_evidence`). Any failure is a :class:`ModelSolveError` naming the
force level.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.discovery.errors import ModelSolveError
from nlupdate.core.model.system import CondensedProblem, NonlinearSystem, newton_fixed_frequency
from nlupdate.core.response.continuation import ContinuationError, FrequencyResponse, trace_frequency_response
from nlupdate.core.response.harmonic_balance import HarmonicSettings, trace_harmonic_balance
from nlupdate.core.response.stepped_sine import stepped_sine

_BAND_MARGIN = 0.005
_SAME_SOLUTION = 1e-6  # relative distance below which two polished solutions are one


@dataclass(frozen=True, eq=False)
class SimulatedPoints:
    """Model amplitudes (m) at the points, columns = the requested coordinates.

    x: the stable solution nearest to the measurement at each point (without a
    measurement: the stepped-sine reading in the stated direction, up if unknown);
    x_sweep: the stepped-sine reading in the stated direction (None when unknown).
    """

    x: NDArray[np.complex128]
    x_sweep: NDArray[np.complex128] | None


def _stable_segments(curve: FrequencyResponse) -> NDArray[np.bool_]:
    """Segment k (points k, k+1) is stable when its ends that are not folds are stable."""
    stable = curve.stable
    turning = curve.turning_point
    ends_ok = stable | turning
    both_turning = turning[:-1] & turning[1:]
    return ends_ok[:-1] & ends_ok[1:] & ~both_turning


def _solutions_at(curve: FrequencyResponse, stable_segments: NDArray, target: float, polish: bool) -> list[NDArray]:
    """Every distinct stable solution (states of ``curve.problem``) at ``target`` (rad/s)."""
    w = curve.omega
    low, high = np.minimum(w[:-1], w[1:]), np.maximum(w[:-1], w[1:])
    found: list[NDArray] = []
    problem = curve.problem
    for k in np.flatnonzero((low <= target) & (target <= high) & stable_segments):
        span = w[k + 1] - w[k]
        weight = 0.0 if span == 0 else (target - w[k]) / span
        state = curve.x_nonlinear[k] + weight * (curve.x_nonlinear[k + 1] - curve.x_nonlinear[k])
        if polish and problem.size:
            y, ok, _ = newton_fixed_frequency(problem, target, problem.to_real(state))
            if ok:
                state = problem.to_complex(y)
        scale = max(float(np.linalg.norm(state)), 1e-300)
        if all(np.linalg.norm(state - other) > _SAME_SOLUTION * scale for other in found):
            found.append(state)
    return found


def _from_measurement(problem: CondensedProblem, target: float, measured: NDArray, measured_at: dict) -> list[NDArray]:
    """A stable solution at ``target`` (rad/s) by Newton from the measured amplitudes at the
    nonlinear coordinates (the linear response where one is not measured), or none."""
    _, x_linear = problem.linear_terms(target, derivative=False)
    start = np.array([measured[measured_at[d]] if d in measured_at else x_linear[i] for i, d in enumerate(problem.a)])
    y, ok, _ = newton_fixed_frequency(problem, target, problem.to_real(start))
    if not ok:
        return []
    _, jacobian, _ = problem.residual_and_jacobians(y, target)
    return [problem.to_complex(y)] if np.linalg.det(jacobian) > 0 else []


def _trace(system: NonlinearSystem, input_dof: int, level: float, w: NDArray, settings: HarmonicSettings | None):
    band_rad = (w.min() * (1 - _BAND_MARGIN), w.max() * (1 + _BAND_MARGIN))
    if settings is None:
        return trace_frequency_response(system, {input_dof: level}, *band_rad)
    return trace_harmonic_balance(
        system, {input_dof: level}, *band_rad, harmonics=settings.harmonics, samples=settings.samples,
        stability=settings.stability, share_limit=settings.share_limit,
    )


def simulate_points(
    system: NonlinearSystem,
    input_dof: int,
    force: NDArray[np.float64],
    omega: NDArray[np.float64],
    dofs: Sequence[int],
    sweep: str = "up",
    harmonic_balance: HarmonicSettings | None = None,
) -> NDArray[np.complex128]:
    """Complex amplitudes (m) at ``dofs`` for a harmonic force ``force`` (N) at ``input_dof``
    and frequency ``omega`` (rad/s) per point, as a stepped-sine test sweeping ``sweep``
    ("up" or "down") reads them; shape (n_points, len(dofs)). With ``harmonic_balance`` the
    first harmonic of the multi-harmonic balance, else the describing function's."""
    return simulate_nearest(system, input_dof, force, omega, dofs, None, sweep=sweep,
                            harmonic_balance=harmonic_balance).x


def simulate_nearest(
    system: NonlinearSystem,
    input_dof: int,
    force: NDArray[np.float64],
    omega: NDArray[np.float64],
    dofs: Sequence[int],
    measured: NDArray[np.complex128] | None,
    measured_columns: Sequence[int] = (),
    weight: NDArray[np.float64] | None = None,
    sweep: str = "unknown",
    harmonic_balance: HarmonicSettings | None = None,
) -> SimulatedPoints:
    """The model's solutions at the points (see module docstring): nearest to ``measured``.

    ``measured`` (n_points, m): measured amplitudes at the coordinates ``dofs[c]`` for c in
    ``measured_columns``, with residual weights ``weight`` (n_points, m; default 1/|measured|);
    None: every point takes the stepped-sine reading. ``sweep``: "up", "down" or "unknown"
    (the stated direction of the test; unknown reads up where a reading is needed).
    """
    dofs = list(dofs)
    n = force.size
    out = np.full((n, len(dofs)), np.nan + 0j)
    out_sweep = np.full((n, len(dofs)), np.nan + 0j) if sweep in ("up", "down") else None
    if measured is not None and weight is None:
        weight = 1.0 / np.abs(measured)
    columns = list(measured_columns)
    for level in np.unique(force):
        points = np.flatnonzero(force == level)
        points = points[np.argsort(omega[points], kind="stable")]
        w = omega[points]
        band = f"{w.min() / (2 * np.pi):g}–{w.max() / (2 * np.pi):g} Hz"
        try:
            with np.errstate(all="ignore"):
                if not system.elements:
                    x = system.model.receptance(w, dofs, [input_dof])[:, :, 0] * level
                    out[points] = x
                    if out_sweep is not None:
                        out_sweep[points] = x
                    continue
                curve = _trace(system, input_dof, level, w, harmonic_balance)
                reading = stepped_sine(curve, w, "down" if sweep == "down" else "up").response(dofs)
                if out_sweep is not None:
                    out_sweep[points] = reading
                if measured is None:
                    out[points] = reading
                    continue
                segments = _stable_segments(curve)
                measured_at = {dofs[c]: k for k, c in enumerate(columns)}
                for point, target in zip(points, w):
                    states = _solutions_at(curve, segments, target, polish=True)
                    if not states and harmonic_balance is None:
                        states = _from_measurement(curve.problem, target, measured[point], measured_at)
                    if not states:
                        continue
                    if len(states) == 1:
                        out[point] = curve.problem.response_at(target, states[0][None], dofs)[0]
                        continue
                    responses = np.vstack([curve.problem.response_at(target, s[None], dofs) for s in states])
                    distance = np.sum(np.abs((responses[:, columns] - measured[point]) * weight[point]) ** 2, axis=1)
                    out[point] = responses[int(np.nanargmin(np.where(np.isfinite(distance), distance, np.inf)))]
        except (ContinuationError, np.linalg.LinAlgError, ValueError, ArithmeticError) as error:
            raise ModelSolveError(f"the model cannot be solved at {level:g} N, {band} ({error})") from None
        if not np.any(np.isfinite(out[points])):
            raise ModelSolveError(f"the model has no finite response at {level:g} N, {band} (singular or unstable)")
    return SimulatedPoints(out, out_sweep)
