"""The canonical entry point for a model's steady-state response as a test reads it.

:func:`steady_state_response` gives the response of a :class:`~nlupdate.core.model.system.NonlinearSystem`
to one harmonic force vector on a frequency grid, by the single-harmonic describing function
or the multi-harmonic balance (its first harmonic; :class:`~nlupdate.core.response.harmonic_balance.HarmonicSettings`),
read in one of two ways:

* **stepped sine** (``sweep="up"`` or ``"down"``): the traced curve read as a sweep in that
  direction (:func:`~nlupdate.core.response.stepped_sine.stepped_sine`: the response stays on its
  branch until the branch ends in a fold, then jumps);
* **nearest stable solution** (``measured`` given): where the response is multi-valued, which
  solution a test settles on depends on how it reached the frequency (a sweep up or down, a
  start from rest), so each point takes the stable solution at its frequency nearest to its
  measured amplitudes (in the misfit's own weights), anywhere on the traced curve — the stable
  segments that contain the frequency interpolated and polished by Newton at the exact
  frequency. A point no stable segment reaches (the continuation stalled before it, or it lies
  on a branch the trace never visited) gets a second chance: Newton from the measured
  amplitudes, accepted when it converges to a stable solution (the determinant criterion of
  :mod:`nlupdate.core.response.continuation`; describing function only). The stepped-sine
  reading in the stated direction is kept beside it.

A model without nonlinear elements is evaluated directly, ``X = H(ω)·F``. The discovery's
misfit (:mod:`nlupdate.core.discovery.simulation`) reads the nearest stable solution.

The same stepped-sine rule on an identified scalar balance over a *sampled* linear receptance
(:func:`nlupdate.core.identification.regenerate.regenerate_frf`, all amplitude roots per sample,
no model to trace) is :func:`sweep_stable_roots`: there a continuation over the interpolated
noisy samples stalls where the noise makes spurious folds, so the roots are found per sample
and the sweep follows them.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.model.system import CondensedProblem, NonlinearSystem, newton_fixed_frequency
from nlupdate.core.response.continuation import FrequencyResponse, trace_frequency_response
from nlupdate.core.response.harmonic_balance import HarmonicSettings, trace_harmonic_balance
from nlupdate.core.response.stepped_sine import stable_segments, stepped_sine

#: Relative margin the traced band extends beyond the grid on each side.
BAND_MARGIN = 0.005
_SAME_SOLUTION = 1e-6  # relative distance below which two polished solutions are one


@dataclass(frozen=True, eq=False)
class SteadyState:
    """Amplitudes (m) at the grid, (n_grid, len(dofs)).

    x: the stable solution nearest to the measurement at each point (without a measurement:
    the stepped-sine reading in the stated direction, up if unknown); x_sweep: the stepped-sine
    reading in the stated direction (None when the direction is unknown).
    """

    x: NDArray[np.complex128]
    x_sweep: NDArray[np.complex128] | None


def steady_state_response(
    system: NonlinearSystem,
    forcing: Mapping[int, complex],
    omega: NDArray[np.float64],
    dofs: Sequence[int],
    sweep: str = "up",
    *,
    harmonic_balance: HarmonicSettings | None = None,
    measured: NDArray[np.complex128] | None = None,
    measured_columns: Sequence[int] = (),
    weight: NDArray[np.float64] | None = None,
) -> SteadyState:
    """The steady-state response at ``dofs`` to ``forcing`` (N at model coordinates) at the
    grid ``omega`` (rad/s, ascending), read as in the module docstring.

    ``sweep``: "up", "down" or "unknown" (the stated direction; unknown reads up where a
    reading is needed). ``measured`` (n_grid, m): measured amplitudes at the coordinates
    ``dofs[c]`` for c in ``measured_columns``, with residual weights ``weight`` (n_grid, m;
    default 1/|measured|); None: every point takes the stepped-sine reading. Raises
    :class:`~nlupdate.core.response.continuation.ContinuationError` (and ``LinAlgError``,
    ``ValueError``, ``ArithmeticError``) when the curve cannot be traced.
    """
    dofs = list(dofs)
    if not system.elements:
        inputs = list(forcing)
        x = np.einsum("kij,j->ki", system.model.receptance(omega, dofs, inputs), np.array(list(forcing.values())))
        return SteadyState(x, x if sweep in ("up", "down") else None)
    curve = _trace(system, forcing, omega, harmonic_balance)
    reading = stepped_sine(curve, omega, "down" if sweep == "down" else "up").response(dofs)
    x_sweep = reading if sweep in ("up", "down") else None
    if measured is None:
        return SteadyState(reading, x_sweep)
    if weight is None:
        weight = 1.0 / np.abs(measured)
    columns = list(measured_columns)
    out = np.full((omega.size, len(dofs)), np.nan + 0j)
    segments = stable_segments(curve.stable, curve.turning_point)
    measured_at = {dofs[c]: k for k, c in enumerate(columns)}
    for point, target in enumerate(omega):
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
    return SteadyState(out, x_sweep)


def sweep_stable_roots(roots: Sequence[Sequence[tuple[float, bool]]], direction: str) -> NDArray[np.float64]:
    """A stepped-sine reading of amplitude roots found per frequency: ``roots[k]`` holds the
    ``(amplitude A (m), stable)`` roots at frequency k (ascending). The sweep (``direction``
    "up" or "down") starts on the smallest stable root and stays on the stable root nearest
    (in log A) to the previous frequency's, which is a jump to the nearest remaining stable
    root where its branch ended at a fold. Returns A per frequency, NaN where none is stable."""
    if direction not in ("up", "down"):
        raise ValueError(f"direction must be 'up' or 'down', got {direction!r}")
    out = np.full(len(roots), np.nan)
    previous = None
    for k in (range(len(roots)) if direction == "up" else range(len(roots) - 1, -1, -1)):
        stable = [a for a, is_stable in roots[k] if is_stable]
        if not stable:
            continue
        a = min(stable) if previous is None else min(stable, key=lambda value: abs(np.log(value / previous)))
        out[k] = previous = a
    return out


def _trace(system: NonlinearSystem, forcing: Mapping[int, complex], w: NDArray,
           settings: HarmonicSettings | None) -> FrequencyResponse:
    band_rad = (w.min() * (1 - BAND_MARGIN), w.max() * (1 + BAND_MARGIN))
    if settings is None:
        return trace_frequency_response(system, forcing, *band_rad)
    return trace_harmonic_balance(
        system, forcing, *band_rad, harmonics=settings.harmonics, samples=settings.samples,
        stability=settings.stability, share_limit=settings.share_limit,
    )


def _solutions_at(curve: FrequencyResponse, segments: NDArray, target: float, polish: bool) -> list[NDArray]:
    """Every distinct stable solution (states of ``curve.problem``) at ``target`` (rad/s)."""
    w = curve.omega
    low, high = np.minimum(w[:-1], w[1:]), np.maximum(w[:-1], w[1:])
    found: list[NDArray] = []
    problem = curve.problem
    for k in np.flatnonzero((low <= target) & (target <= high) & segments):
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
