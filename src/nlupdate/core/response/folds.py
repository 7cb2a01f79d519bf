"""Turning points (folds) of a traced curve, located all at once.

The continuation (:func:`nlupdate.core.response.continuation.trace_curve`) passes a fold between
two neighbours z_a, z_b whose tangents' ω̃-components t_ω differ in sign. Each such fold is
located on the chord between them, z(s) = z_a + s d (d the unit chord, length L): the point
corrected on the hyperplane through z(s) normal to d
(:func:`~nlupdate.core.response.arclength.correct`), and s moved by the Illinois variant of
regula falsi on its tangent's t_ω (the end kept twice in a row has its t_ω halved, so
the bracket closes from both sides) until |t_ω| < ``fold_tolerance``. The first s is where
the cubic Hermite curve through the two neighbours turns (its ω̃-derivative vanishes),
projected on the chord. All folds of the curve are located at once, one batched correction
per step. The fold points are inserted into the curve with ``turning_point`` set.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from nlupdate.core.response.arclength import correct, hermite, unit_tangents


def insert_folds(problem, curve, omega_start: float, omega_end: float, options):
    """``curve`` (a :class:`~nlupdate.core.response.continuation.Curve`) with its folds located and
    inserted (module docstring); ``options`` a
    :class:`~nlupdate.core.response.continuation.ContinuationOptions`."""
    band = omega_end - omega_start
    size = problem.size
    t_w = curve.tangent[:, size]
    found = np.flatnonzero((t_w[:-1] * t_w[1:] < 0) & ~curve.turning_point[:-1] & ~curve.turning_point[1:])
    if found.size == 0:
        return curve
    z = np.column_stack([curve.y, (curve.omega - omega_start) / band])
    z_a, z_b = z[found], z[found + 1]
    length = np.linalg.norm(z_b - z_a, axis=1)
    direction = (z_b - z_a) / length[:, None]
    low, high = np.zeros(found.size), length.copy()
    f_low, f_high = t_w[found].copy(), t_w[found + 1].copy()
    turn, _ = hermite(z_a, curve.tangent[found], z_b, curve.tangent[found + 1], length,
                      _hermite_turn(z_a[:, size], z_b[:, size], length * curve.tangent[found, size],
                                    length * curve.tangent[found + 1, size]))
    s = np.clip(np.sum((turn - z_a) * direction, axis=1), 0.05 * length, 0.95 * length)
    kept = np.zeros(found.size, int)  # +1: the low end was kept last time, −1: the high end
    best_z, best_t = z_b.copy(), curve.tangent[found + 1].copy()
    best_det = curve.jacobian_determinant[found + 1].copy()
    active = np.arange(found.size)
    for iteration in range(options.fold_iterations):
        if active.size == 0:
            break
        if iteration:
            s = (low[active] * f_high[active] - high[active] * f_low[active]) / (f_high[active] - f_low[active])
        pred = z_a[active] + s[:, None] * direction[active]
        done = correct(problem, pred, direction[active], omega_start, band, options.fold_corrector_iterations,
                       options.fold_correction_tolerance, np.inf, 0.0)
        tangent = unit_tangents(done.jac, done.jac_w, curve.tangent[found[active]])
        usable = np.all(np.isfinite(tangent), axis=1)
        keep, s = active[usable], s[usable]
        best_z[keep], best_t[keep] = done.z[usable], tangent[usable]
        best_det[keep] = np.linalg.det(done.jac[usable])
        t_try = tangent[usable, size]
        below = t_try * f_low[keep] > 0  # the new point replaces the low end
        lo, hi = keep[below], keep[~below]
        f_high[lo[kept[lo] == -1]] *= 0.5
        f_low[hi[kept[hi] == 1]] *= 0.5
        low[lo], f_low[lo], kept[lo] = s[below], t_try[below], -1
        high[hi], f_high[hi], kept[hi] = s[~below], t_try[~below], 1
        finished = (np.abs(t_try) < options.fold_tolerance) | (high[keep] - low[keep] < 1e-12)
        active = keep[~finished]
    order = np.argsort(np.concatenate([np.arange(z.shape[0]), found + 0.5]), kind="stable")
    points = np.concatenate([z, best_z])[order]
    return dataclasses.replace(
        curve,
        omega=omega_start + band * points[:, size],
        y=points[:, :size],
        turning_point=np.concatenate([curve.turning_point, np.ones(found.size, bool)])[order],
        jacobian_determinant=np.concatenate([curve.jacobian_determinant, best_det])[order],
        tangent=np.concatenate([curve.tangent, best_t])[order],
    )


def _hermite_turn(w_a, w_b, m_a, m_b):
    """The parameter u ∈ (0, 1) where the cubic Hermite ω̃(u) with end values w_a, w_b and end
    slopes m_a, m_b (arrays) has ω̃′(u) = 0 — a root of a quadratic; ½ where there is none."""
    a = 6 * w_a + 3 * m_a - 6 * w_b + 3 * m_b
    b = -6 * w_a - 4 * m_a + 6 * w_b - 2 * m_b
    u = np.full(w_a.size, 0.5)
    for i in range(w_a.size):
        roots = np.roots([a[i], b[i], m_a[i]]) if a[i] != 0 or b[i] != 0 else np.empty(0)
        inside = [r.real for r in roots if abs(r.imag) < 1e-12 and 0 < r.real < 1]
        if inside:
            u[i] = inside[0]
    return u
