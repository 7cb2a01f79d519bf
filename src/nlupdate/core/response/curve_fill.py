"""The points between continuation points, corrected all at once.

A continuation (:func:`nlupdate.core.response.continuation.trace_curve`) is sequential: each point
starts from the one before. With ``ContinuationOptions.fill`` = k it takes steps up to k × the
spacing asked for, so it only connects the branches and locates the folds, and this module
puts the other points on the curve in one batched Newton iteration over all of them
(the points share every numpy call, so their cost is a few evaluations of one point).

Between two neighbours z_a, z_b of the coarse curve (z = (y, ω̃), the continuation's scaled
space) with unit tangents t_a, t_b and chord length L, the m = ⌈L / spacing⌉ − 1 new points
start from the cubic Hermite curve through them,

    p(s) = h₀₀(s) z_a + h₁₀(s) L t_a + h₀₁(s) z_b + h₁₁(s) L t_b,   s = j / (m + 1),

and each is corrected on its own hyperplane normal to p′(s) (Keller's pseudo-arclength
system with the interpolant as predictor)::

    R(y, ω) = 0,   n_jᵀ (z − p(s_j)) = 0,   n_j = p′(s_j) / ‖p′(s_j)‖,

with the corrector's convergence test of the continuation; the continuation's own points
are corrected again on the hyperplanes normal to their tangents (the continuation may
stop its corrector early, as it does when it fills), those on a band edge at its frequency. Branch checks: every point must
converge, stay within half a spacing of its prediction (the interpolant is accurate to
O(L⁴), so a point further away went to another branch), and keep the sign of det ∂R/∂y of
its neighbours when they share it (the sign changes only at folds). When any point fails,
:func:`fill_curve` returns None and the caller traces every point by continuation. The
folds are located afterwards, on the filled curve (:mod:`nlupdate.core.response.folds`).
"""
from __future__ import annotations

import dataclasses

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.response.arclength import correct, hermite, unit_tangents
from nlupdate.core.response.balance import BalanceProblem


def fill_curve(problem: BalanceProblem, coarse, omega_start: float, omega_end: float, options):
    """The :class:`~nlupdate.core.response.continuation.Curve` ``coarse`` with points added so that
    neighbours are at most ``options.max_step`` apart (scaled arc length), or None when a new
    point fails the branch checks (module docstring)."""
    band = omega_end - omega_start
    size = problem.size
    z = np.column_stack([coarse.y, (coarse.omega - omega_start) / band])
    chord = np.linalg.norm(np.diff(z, axis=0), axis=1)
    counts = np.maximum(np.ceil(chord / options.max_step - 1e-9).astype(int) - 1, 0)
    total = int(counts.sum())
    interval = np.repeat(np.arange(chord.size), counts)
    s = (np.arange(total) - np.repeat(np.cumsum(counts) - counts, counts) + 1) / np.repeat(counts + 1, counts)
    new_pred, new_normal = hermite(z[interval], coarse.tangent[interval], z[interval + 1],
                                    coarse.tangent[interval + 1], chord[interval], s)
    # the continuation's own points are polished too, on the hyperplanes normal to their
    # tangents, except those on a band edge, which stay at its frequency
    z_pred = np.concatenate([z, new_pred])
    normal = np.concatenate([coarse.tangent, new_normal])
    edge = np.flatnonzero((z[:, size] == 0.0) | (z[:, size] == 1.0))
    normal[edge] = np.eye(size + 1)[size]
    done = correct(problem, z_pred, normal, omega_start, band, options.corrector_iterations,
                   options.correction_tolerance, options.tolerance, options.stagnation_residual)
    z_new, jac = done.z, done.jac
    if not np.all(done.converged):
        return None
    spacing = np.concatenate([np.full(z.shape[0], options.max_step), chord[interval] / (counts[interval] + 1)])
    if np.any(np.max(np.abs(z_new - z_pred), axis=1) > 0.5 * spacing):
        return None
    det = np.linalg.det(jac)
    ends = np.sign(det[: z.shape[0]])
    sign_a, sign_b = ends[interval], ends[interval + 1]
    if np.any((sign_a == sign_b) & (np.sign(det[z.shape[0]:]) != sign_a)):
        return None
    tangent = unit_tangents(jac, done.jac_w, normal)
    order = np.argsort(np.concatenate([np.arange(z.shape[0]), interval + s]), kind="stable")
    points = z_new[order]
    return dataclasses.replace(
        coarse,
        omega=omega_start + band * points[:, size],
        y=points[:, :size],
        turning_point=np.concatenate([coarse.turning_point, np.zeros(total, bool)])[order],
        jacobian_determinant=det[order],
        tangent=tangent[order],
    )
