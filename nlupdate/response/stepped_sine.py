"""Stepped-sine test emulation on a traced frequency response.

A stepped-sine test dwells at each frequency of a grid, in increasing ("up") or
decreasing ("down") order, and the structure stays on the branch it is on until that
branch ends in a fold; then it jumps to another stable solution. On the continuation
curve (:class:`~nlupdate.response.continuation.FrequencyResponse`) this is: walk along the curve
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

from nlupdate.response.continuation import FrequencyResponse
from nlupdate.model.system import newton_fixed_frequency


@dataclass(frozen=True, eq=False)
class SweepResult:
    """Stepped-sine responses on a frequency grid (in increasing frequency order).

    jumps_hz: grid frequencies (Hz) at which the response jumped to another branch,
    in sweep order. Points no stable branch covers are NaN.
    """

    problem: object
    omega: NDArray[np.float64]
    x_nonlinear: NDArray[np.complex128]
    direction: str
    jumps_hz: tuple[float, ...]

    @property
    def frequency_hz(self) -> NDArray[np.float64]:
        return self.omega / (2 * np.pi)

    def response(self, dofs: Sequence[int]) -> NDArray[np.complex128]:
        """First-harmonic amplitudes (m) at ``dofs``, (n_grid, len(dofs))."""
        return self.problem.response_at(self.omega, self.x_nonlinear, dofs)

    def harmonics(self, dofs: Sequence[int]) -> NDArray[np.complex128]:
        """Harmonics X₀ … X_H (m) at ``dofs`` of a harmonic-balance sweep, (n_grid, H+1, len(dofs))."""
        return self.problem.harmonics_at(self.omega, self.x_nonlinear, dofs)


def _segment_stable(curve: FrequencyResponse, k: int) -> bool:
    ends = [i for i in (k, k + 1) if not curve.turning_point[i]]
    return bool(ends) and all(curve.stable[i] for i in ends)


def stepped_sine(
    curve: FrequencyResponse, omega: ArrayLike, direction: str = "up", polish: bool = True
) -> SweepResult:
    """Emulate a stepped-sine sweep over ``omega`` (rad/s) on a traced curve."""
    if direction not in ("up", "down"):
        raise ValueError(f"direction must be 'up' or 'down', got {direction!r}")
    grid = np.sort(np.atleast_1d(np.asarray(omega, dtype=float)))
    problem = curve.problem
    order = np.arange(curve.omega.size) if direction == "up" else np.arange(curve.omega.size)[::-1]
    w = curve.omega[order]
    x = curve.x_nonlinear[order]
    turning = curve.turning_point[order]
    reordered = FrequencyResponse(problem, w, x, curve.stable[order], turning)
    targets = grid if direction == "up" else grid[::-1]
    result = np.full((grid.size,) + x.shape[1:], np.nan + 0j)
    jumps: list[float] = []
    position = 0
    for index, target in enumerate(targets):
        found = None
        for k in range(position, w.size - 1):
            low, high = sorted((w[k], w[k + 1]))
            if low <= target <= high and _segment_stable(reordered, k):
                found = k
                break
        if found is None:
            continue
        if np.any(turning[position + 1 : found + 1]) and index > 0:
            jumps.append(float(target / (2 * np.pi)))
        position = found
        span = w[found + 1] - w[found]
        weight = 0.0 if span == 0 else (target - w[found]) / span
        guess = x[found] + weight * (x[found + 1] - x[found])
        if polish and problem.size:
            y, ok, _ = newton_fixed_frequency(problem, target, problem.to_real(guess))
            if ok:
                guess = problem.to_complex(y)
        result[index] = guess
    if direction == "down":
        result = result[::-1]
    return SweepResult(problem, grid, result, direction, tuple(jumps))
