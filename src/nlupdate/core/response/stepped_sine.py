"""Stepped-sine test emulation on a traced frequency response.

A stepped-sine test dwells at each frequency of a grid, in increasing ("up") or
decreasing ("down") order, and the structure stays on the branch it is on until that
branch ends in a fold; then it jumps to another stable solution. On the continuation
curve (:class:`~nlupdate.core.response.continuation.FrequencyResponse`) this is: walk along the curve
in the sweep direction and, for each grid frequency, take the first *stable* curve
segment at or after the current position that contains the frequency. Passing a turning
point on the way is a jump. The picked point is polished by Newton at the exact grid
frequency.

With Floquet stability (harmonic balance) a branch also ends where it loses stability
without turning (period doubling, Neimark–Sacker): grid points no stable periodic branch
covers are NaN, as a test there would not settle on a periodic response.

With more than two coexisting stable solutions the real jump target depends on basins
of attraction; this emulation lands on the next stable branch along the curve.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nlupdate.core.response.continuation import FrequencyResponse
from nlupdate.core.model.system import newton_batch
from nlupdate.core.response.balance import BalanceProblem


@dataclass(frozen=True, eq=False)
class SweepResult:
    """Stepped-sine responses on a frequency grid (in increasing frequency order).

    jumps_hz: grid frequencies (Hz) at which the response jumped to another branch,
    in sweep order. Points no stable branch covers are NaN. route: how it was solved —
    "traced" (continuation + this reading), "closed form" or "fold-free"
    (:mod:`nlupdate.core.response.sweep`).
    """

    problem: BalanceProblem
    omega: NDArray[np.float64]
    x_nonlinear: NDArray[np.complex128]
    direction: str
    jumps_hz: tuple[float, ...]
    route: str = "traced"

    @property
    def frequency_hz(self) -> NDArray[np.float64]:
        return self.omega / (2 * np.pi)

    def response(self, dofs: Sequence[int]) -> NDArray[np.complex128]:
        """First-harmonic amplitudes (m) at ``dofs``, (n_grid, len(dofs))."""
        return self.problem.response_at(self.omega, self.x_nonlinear, dofs)

    def harmonics(self, dofs: Sequence[int]) -> NDArray[np.complex128]:
        """Harmonics X₀ … X_H (m) at ``dofs`` of a harmonic-balance sweep, (n_grid, H+1, len(dofs))."""
        return self.problem.harmonics_at(self.omega, self.x_nonlinear, dofs)


def stepped_sine(
    curve: FrequencyResponse, omega: ArrayLike, direction: str = "up", polish: bool = True
) -> SweepResult:
    """Emulate a stepped-sine sweep over ``omega`` (rad/s) on a traced curve.

    Every grid point is read off the curve at once (:func:`_walk`), then all are polished
    together by :func:`~nlupdate.core.model.system.newton_batch` at their exact frequencies from
    the interpolated guesses. Branch control: a polished point must keep the sign of
    ``det ∂R/∂y`` of its stable segment (> 0); within a few thousandths of a rad/s of a fold
    Newton can land on the unstable root instead, and then it is polished again from the
    segment's end point nearest to it, or left at the interpolation (to the curve's accuracy).
    """
    if direction not in ("up", "down"):
        raise ValueError(f"direction must be 'up' or 'down', got {direction!r}")
    grid = np.sort(np.atleast_1d(np.asarray(omega, dtype=float)))
    problem = curve.problem
    order = np.arange(curve.omega.size) if direction == "up" else np.arange(curve.omega.size)[::-1]
    w, x = curve.omega[order], curve.x_nonlinear[order]
    turning, stable = curve.turning_point[order], curve.stable[order]
    targets = grid if direction == "up" else grid[::-1]
    found, jumped = _walk(w, turning, stable, targets)
    result = np.full((grid.size,) + x.shape[1:], np.nan + 0j)
    hit = np.flatnonzero(found >= 0)
    k = found[hit]
    span = w[k + 1] - w[k]
    weight = np.divide(targets[hit] - w[k], span, out=np.zeros(hit.size), where=span != 0)
    weight = weight.reshape((-1,) + (1,) * (x.ndim - 1))
    guess = x[k] + weight * (x[k + 1] - x[k])
    if polish and problem.size and hit.size:
        nearest = np.where(np.abs(targets[hit] - w[k]) <= np.abs(targets[hit] - w[k + 1]), k, k + 1)
        nearest = np.where(turning[nearest], k + (nearest == k), nearest)  # a stable end point, not a fold
        guess = _polish(problem, targets[hit], guess, x[nearest])
    result[hit] = guess
    jumps = tuple(float(t / (2 * np.pi)) for t in targets[jumped])
    if direction == "down":
        result = result[::-1]
    return SweepResult(problem, grid, result, direction, jumps)


def stable_segments(stable: NDArray[np.bool_], turning: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """Per segment k of a curve (its points k and k + 1): stable when its ends that are not
    folds are stable (a segment's fold end does not count against it) and it is not fold to fold."""
    ends_ok = stable | turning
    return ends_ok[:-1] & ends_ok[1:] & ~(turning[:-1] & turning[1:])


def _walk(w: NDArray, turning: NDArray, stable: NDArray, targets: NDArray) -> tuple[NDArray, NDArray]:
    """The curve segment each target frequency is read from, walking the curve (points ``w``
    in sweep order) with the targets: for each target the first stable segment at or after
    the previous target's that contains it (−1: none), and whether a fold lies between."""
    segment_stable = stable_segments(stable, turning)
    low, high = np.minimum(w[:-1], w[1:]), np.maximum(w[:-1], w[1:])
    cover = (targets[:, None] >= low) & (targets[:, None] <= high) & segment_stable
    found = np.full(targets.size, -1)
    start, position = 0, 0
    while start < targets.size:  # restart only where a later target lies on an earlier segment
        window = cover[start:, position:]
        has = window.any(axis=1)
        first = np.where(has, np.argmax(window, axis=1) + position, -1)
        reached = np.maximum.accumulate(np.where(has, first, position))
        before = np.concatenate([[position], reached[:-1]])
        behind = np.flatnonzero(has & (first < before))
        stop = behind[0] if behind.size else first.size
        found[start : start + stop] = first[:stop]
        if not behind.size:
            break
        start, position = start + stop, int(before[stop])
    passed = np.concatenate([[0], np.cumsum(turning)])  # folds among points 0 … k−1
    previous = np.maximum.accumulate(np.concatenate([[0], np.where(found >= 0, found, 0)[:-1]]))
    jumped = (found >= 0) & (passed[np.maximum(found, 0) + 1] - passed[previous + 1] > 0)
    jumped[0] = False
    return found, jumped


def _polish(problem, omega: NDArray, guess: NDArray, fallback: NDArray) -> NDArray:
    """Newton at the exact frequencies from ``guess``, kept only on the stable side
    (det ∂R/∂y > 0); failures retry from ``fallback`` (curve points), then keep the guess.
    A converged point takes one more Newton step with the Jacobian of the branch check:
    Newton stops once ‖R‖∞ is below its tolerance, and near a resonance the amplitude is
    that residual times the conditioning off (1e-8 on the Duffing reference); the step
    squares the residual."""
    linear = problem.linear_batch(omega, derivative=False)
    out = guess.copy()
    pending = np.arange(omega.size)
    for start in (guess, fallback):
        rows = linear.take(pending)
        y, converged, _ = newton_batch(problem, rows, problem.to_real(start[pending]))
        r, jac, _ = problem.residual_batch(y, rows)
        ok = converged & (np.linalg.det(jac) > 0)
        y[ok] -= np.linalg.solve(jac[ok], r[ok][..., None])[..., 0]
        out[pending[ok]] = problem.to_complex(y[ok])
        pending = pending[~ok]
        if not pending.size:
            break
    return out
