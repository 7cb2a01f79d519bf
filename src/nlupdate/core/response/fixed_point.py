"""The source's relaxed fixed-point iteration (docs/methods.md §3), kept for comparison.

In condensed form the seed iteration ``X_{i+1} = (Z + Δ(X_i))⁻¹ F`` reads, at the
nonlinear coordinates (Woodbury identity),

    X_{i+1} = (I + H_aa Δ_aa(X_i))⁻¹ X_lin,     X* = λ X_{i+1} + (1 − λ) X_i,

started from the linear response and stopped when the largest relative change falls
below ``tolerance``. All frequencies iterate together (vectorised); points that do not
converge are flagged, which happens near folds and on unstable branches the method
cannot follow.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nlupdate.core.model.system import CondensedProblem, NonlinearSystem


@dataclass(frozen=True, eq=False)
class FixedPointResult:
    """Responses at the nonlinear coordinates on a frequency grid.

    omega (rad/s), x_nonlinear (n_omega × n_a, m), converged flags and iteration counts.
    """

    problem: CondensedProblem
    omega: NDArray[np.float64]
    x_nonlinear: NDArray[np.complex128]
    converged: NDArray[np.bool_]
    iterations: NDArray[np.int64]

    def response(self, dofs: Sequence[int]) -> NDArray[np.complex128]:
        return self.problem.response_at(self.omega, self.x_nonlinear, dofs)


def delta_batch(problem: CondensedProblem, x: NDArray, omega: NDArray) -> NDArray[np.complex128]:
    """Nonlinearity matrices Δ_aa for many states at once, shape (n_omega, n, n)."""
    n = problem.n
    delta = np.zeros((omega.size, n, n), dtype=complex)
    for element, r, j in problem.element_index:
        u = x[:, r] - x[:, j] if j >= 0 else x[:, r]
        nu = element.describing_function(np.abs(u), omega)
        delta[:, r, r] += nu
        if j >= 0:
            delta[:, j, j] += nu
            delta[:, r, j] -= nu
            delta[:, j, r] -= nu
    return delta


def fixed_point_response(
    system: NonlinearSystem,
    forcing: Mapping[int | str, complex],
    omega: ArrayLike,
    *,
    relaxation: float = 0.5,
    tolerance: float = 1e-8,
    max_iterations: int = 2000,
) -> FixedPointResult:
    """Seed method on a frequency grid ``omega`` (rad/s); relaxation λ in (0, 1]."""
    if not 0 < relaxation <= 1:
        raise ValueError(f"relaxation must be in (0, 1], got {relaxation}")
    omega = np.atleast_1d(np.asarray(omega, dtype=float))
    problem = CondensedProblem(system, forcing)
    h = problem.model.receptance(omega, problem.a, list(problem.a) + list(problem.forced))
    h_aa, x_lin = h[:, :, : problem.n], h[:, :, problem.n :] @ problem.force
    x = x_lin.copy()
    converged = np.zeros(omega.size, bool)
    iterations = np.zeros(omega.size, np.int64)
    eye = np.eye(problem.n)
    active = np.arange(omega.size)
    for iteration in range(1, max_iterations + 1):
        if active.size == 0 or problem.n == 0:
            break
        delta = delta_batch(problem, x[active], omega[active])
        x_next = np.linalg.solve(eye + h_aa[active] @ delta, x_lin[active][..., None])[..., 0]
        x_relaxed = relaxation * x_next + (1 - relaxation) * x[active]
        change = np.max(np.abs(x_relaxed - x[active]), axis=1) / np.maximum(np.max(np.abs(x_relaxed), axis=1), 1e-300)
        x[active] = x_relaxed
        iterations[active] = iteration
        done = change < tolerance
        converged[active[done]] = True
        active = active[~done]
    if problem.n == 0:
        converged[:] = True
    return FixedPointResult(problem, omega, x, converged, iterations)
