"""Pseudo-arclength corrections and tangents of many curve points at once.

A point z = (y, ω̃) of a solution curve of ``R(y, ω) = 0`` (ω̃ = (ω − ω_start)/band, the
continuation's scaled frequency) is corrected from a prediction p on the hyperplane through p
normal to a direction n (Keller)::

    R(y, ω) = 0,   nᵀ (z − p) = 0,

by Newton, and its unit tangent is the null vector of ``[∂R/∂y, ∂R/∂ω̃]`` oriented like a
given vector. Here P points are corrected together: every Newton iteration evaluates the
residuals and Jacobians of all the points still iterating in one batched call
(:meth:`~nlupdate.core.response.balance.BalanceProblem.residual_batch`) and solves their
(size + 1)² systems in one call, so the cost per point falls with P. The convergence test is
the continuation's (:class:`~nlupdate.core.response.continuation.ContinuationOptions`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.model.system import solve_batch
from nlupdate.core.response.balance import BalanceProblem


@dataclass(frozen=True)
class Corrected:
    """Corrected points z (P, size+1), ∂R/∂y (P, size, size) and ∂R/∂ω̃ (P, size) at the last
    evaluation of each (within the correction tolerance of z), and whether each converged."""

    z: NDArray[np.float64]
    jac: NDArray[np.float64]
    jac_w: NDArray[np.float64]
    converged: NDArray[np.bool_]


def correct(
    problem: BalanceProblem,
    z_pred: NDArray,
    normal: NDArray,
    omega_start: float,
    band: float,
    iterations: int,
    correction_tolerance: float,
    tolerance: float,
    stagnation_residual: float,
) -> Corrected:
    """Newton on each point's pseudo-arclength system (module docstring), at most ``iterations``
    iterations. A point has converged when its correction is below ``correction_tolerance``
    and its residual below 10 × ``tolerance`` (scaled units), or when a residual below
    ``stagnation_residual`` no longer halves; the others stop iterating with it."""
    points, size = z_pred.shape[0], z_pred.shape[1] - 1
    z = np.array(z_pred, dtype=float)
    jac = np.zeros((points, size, size))
    jac_w = np.zeros((points, size))
    converged = np.zeros(points, bool)
    previous = np.full(points, np.inf)
    active = np.arange(points)
    augmented = np.zeros((points, size + 1, size + 1))
    for _ in range(iterations):
        if active.size == 0:
            break
        linear = problem.linear_batch(omega_start + band * z[active, size])
        r, jac[active], jac_w_active = problem.residual_batch(z[active, :size], linear)
        jac_w[active] = jac_w_active * band
        system = augmented[: active.size]
        system[:, :size, :size] = jac[active]
        system[:, :size, size] = jac_w[active]
        system[:, size] = normal[active]
        rhs = np.empty((active.size, size + 1))
        rhs[:, :size] = -r
        rhs[:, size] = -np.sum(normal[active] * (z[active] - z_pred[active]), axis=1)
        dz = solve_batch(system, rhs)
        usable = np.all(np.isfinite(dz), axis=1)
        z[active[usable]] += dz[usable]
        residual = np.max(np.abs(r), axis=1)
        correction = np.max(np.abs(np.where(usable[:, None], dz, np.inf)), axis=1)
        done = usable & (correction < correction_tolerance) & (residual < 10 * tolerance)
        done |= usable & (residual < stagnation_residual) & (residual > 0.5 * previous[active])
        previous[active] = residual
        converged[active[done]] = True
        active = active[~done & usable]
    return Corrected(z, jac, jac_w, converged)


def unit_tangents(jac: NDArray, jac_w: NDArray, previous: NDArray) -> NDArray[np.float64]:
    """Unit null vectors (P, size+1) of ``[∂R/∂y, ∂R/∂ω̃]`` (P, size, size), (P, size), each
    oriented like its row of ``previous`` (P, size+1)."""
    points, size = jac_w.shape
    augmented = np.empty((points, size + 1, size + 1))
    augmented[:, :size, :size] = jac
    augmented[:, :size, size] = jac_w
    augmented[:, size] = previous
    rhs = np.zeros((points, size + 1))
    rhs[:, size] = 1.0
    t = solve_batch(augmented, rhs)
    return t / np.linalg.norm(t, axis=1, keepdims=True)


def hermite(z_a: NDArray, t_a: NDArray, z_b: NDArray, t_b: NDArray, length: NDArray, s: NDArray):
    """Points p(s) (P, size+1) and unit directions p′(s)/‖p′(s)‖ of the cubic Hermite curves
    p(s) = h₀₀(s) z_a + h₁₀(s) L t_a + h₀₁(s) z_b + h₁₁(s) L t_b, s ∈ [0, 1], through the
    neighbours z_a, z_b (P, size+1) with unit tangents t_a, t_b and chord lengths L (P,)."""
    s = s[:, None]
    length = length[:, None]
    h00, h10, h01, h11 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2
    d00, d10, d01, d11 = 6 * s**2 - 6 * s, 3 * s**2 - 4 * s + 1, -6 * s**2 + 6 * s, 3 * s**2 - 2 * s
    point = h00 * z_a + h10 * length * t_a + h01 * z_b + h11 * length * t_b
    direction = d00 * z_a + d10 * length * t_a + d01 * z_b + d11 * length * t_b
    return point, direction / np.linalg.norm(direction, axis=1, keepdims=True)
