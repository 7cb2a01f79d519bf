"""Scalar harmonic balance at one coordinate: amplitudes from a dynamic stiffness and a DF.

For a nonlinearity at the driven coordinate, the condensed single-harmonic balance is
scalar: ``(W + ν(A, ω))·X = F`` with ``W = 1/H^L`` (N/m) the linear dynamic stiffness
at that coordinate, ``A = |X|`` and F the real force amplitude (N). Taking moduli,
the amplitude solves

    g(A) = A·|W + ν(A, ω)| − F = 0,

and then ``X = F / (W + ν(A, ω))``. The equation can have several roots (folds of the
frequency response). A root is *stable* (in the sense of the continuation module: the
branches a stepped-sine test can dwell on) when ``dg/dA > 0``; the middle branch between
two folds has ``dg/dA < 0``.

All functions are vectorised over points: ``w``, ``force``, ``omega`` and the guesses are
arrays of one shape, and ``nu(A, omega)`` must broadcast (amplitude arrays get a trailing
grid axis, omega is passed with a matching trailing axis of length 1).
"""
from __future__ import annotations

from typing import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

DF = Callable[[NDArray, NDArray], NDArray]


def _g(w: NDArray, nu: DF, force: NDArray, omega: NDArray, a: NDArray) -> NDArray:
    return a * np.abs(w + nu(a, omega)) - force


def _bisect(w, nu, force, omega, low, high, iterations=80):
    """Bisection on brackets [low, high] with g(low) < 0 < g(high) or the reverse."""
    g_low = _g(w, nu, force, omega, low)
    for _ in range(iterations):
        mid = np.sqrt(low * high)
        g_mid = _g(w, nu, force, omega, mid)
        same = np.sign(g_mid) == np.sign(g_low)
        low = np.where(same, mid, low)
        g_low = np.where(same, g_mid, g_low)
        high = np.where(same, high, mid)
        if np.all(high / low - 1 < 1e-14):
            break
    return np.sqrt(low * high)


def nearest_amplitude(
    w: ArrayLike,
    nu: DF,
    force: ArrayLike,
    omega: ArrayLike,
    guess: ArrayLike,
    span: float = 10.0,
    grid_points: int = 121,
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Root of ``g(A)`` nearest (in log A) to ``guess`` for every point.

    Damped Newton from the guess (finite-difference slope); points where it fails are
    solved by scanning ``guess·[1/span, span]`` on a log grid and bisecting the sign
    change nearest to the guess. Where there is no root in that range, the amplitude of
    smallest ``|g|`` is returned and flagged ``False`` (so a fit sees a large but finite
    residual there).
    """
    w = np.asarray(w, dtype=complex)
    force = np.asarray(force, dtype=float)
    omega = np.broadcast_to(np.asarray(omega, dtype=float), w.shape)
    a = np.asarray(guess, dtype=float).copy()
    g = _g(w, nu, force, omega, a)
    for _ in range(30):
        h = a * 1e-7
        slope = (_g(w, nu, force, omega, a + h) - g) / h
        step = np.where(slope != 0, -g / np.where(slope != 0, slope, 1.0), 0.0)
        a_new = np.clip(a + step, 0.5 * a, 2.0 * a)
        g_new = _g(w, nu, force, omega, a_new)
        worse = np.abs(g_new) > np.abs(g)
        a_new = np.where(worse, 0.5 * (a + a_new), a_new)
        g_new = np.where(worse, _g(w, nu, force, omega, a_new), g_new)
        a, g = a_new, g_new
        if np.all(np.abs(g) <= 1e-11 * force):
            break
    ok = (np.abs(g) <= 1e-9 * force) & (np.abs(np.log(a / np.asarray(guess, dtype=float))) < np.log(span))
    if np.all(ok):
        return a, ok
    bad = np.flatnonzero(~ok.ravel())
    flat_w, flat_f, flat_o = w.ravel()[bad], force.ravel()[bad], omega.ravel()[bad]
    flat_guess = np.asarray(guess, dtype=float).ravel()[bad]
    ratios = np.exp(np.linspace(-np.log(span), np.log(span), grid_points))
    grid = flat_guess[:, None] * ratios[None, :]
    values = _g(flat_w[:, None], nu, flat_f[:, None], flat_o[:, None], grid)
    change = np.sign(values[:, :-1]) != np.sign(values[:, 1:])
    distance = np.abs(np.log(ratios[:-1] * np.sqrt(ratios[1] / ratios[0])))
    score = np.where(change, distance[None, :], np.inf)
    k = np.argmin(score, axis=1)
    has_root = np.isfinite(score[np.arange(bad.size), k])
    rows = np.arange(bad.size)
    root = _bisect(flat_w, nu, flat_f, flat_o, grid[rows, k], grid[rows, k + 1])
    closest = grid[rows, np.argmin(np.abs(values), axis=1)]
    a.ravel()[bad] = np.where(has_root, root, closest)
    ok.ravel()[bad] = has_root
    return a, ok


def all_amplitudes(
    w: ArrayLike,
    nu: DF,
    force: float | ArrayLike,
    omega: ArrayLike,
    a_min: ArrayLike,
    a_max: ArrayLike,
    grid_points: int = 400,
) -> list[list[tuple[float, bool]]]:
    """Every root of ``g(A)`` in ``[a_min, a_max]`` for each point, with its stability.

    Returns, per point, a list of ``(amplitude, stable)`` in increasing amplitude;
    stable means ``dg/dA > 0`` (see module docstring). Roots closer together than the
    log grid spacing can be missed; the grid has ``grid_points`` points per point.
    """
    w = np.atleast_1d(np.asarray(w, dtype=complex))
    omega = np.broadcast_to(np.asarray(omega, dtype=float), w.shape)
    force = np.broadcast_to(np.asarray(force, dtype=float), w.shape)
    a_min = np.broadcast_to(np.asarray(a_min, dtype=float), w.shape)
    a_max = np.broadcast_to(np.asarray(a_max, dtype=float), w.shape)
    t = np.linspace(0.0, 1.0, grid_points)
    grid = a_min[:, None] * (a_max / a_min)[:, None] ** t[None, :]
    values = _g(w[:, None], nu, force[:, None], omega[:, None], grid)
    grid, values = _refine_extrema(w, nu, force, omega, grid, values)
    change = np.sign(values[:, :-1]) != np.sign(values[:, 1:])
    point, index = np.nonzero(change)
    roots = _bisect(w[point], nu, force[point], omega[point], grid[point, index], grid[point, index + 1])
    stable = values[point, index + 1] > values[point, index]
    out: list[list[tuple[float, bool]]] = [[] for _ in range(w.size)]
    for p, r, s in zip(point, roots, stable):
        out[p].append((float(r), bool(s)))
    return out


def _refine_extrema(w, nu, force, omega, grid, values, iterations: int = 60):
    """Insert the extremum of g inside every sampled local minimum above zero (maximum
    below zero), so that two roots sharing one grid cell near a fold are not missed."""
    g0, g1, g2 = values[:, :-2], values[:, 1:-1], values[:, 2:]
    minimum = (g1 < g0) & (g1 < g2) & (g1 > 0)
    maximum = (g1 > g0) & (g1 > g2) & (g1 < 0)
    point, index = np.nonzero(minimum | maximum)
    if point.size == 0:
        return grid, values
    sign = np.where(minimum[point, index], 1.0, -1.0)
    low, high = np.log(grid[point, index]), np.log(grid[point, index + 2])
    ratio = (np.sqrt(5.0) - 1) / 2
    args = (w[point], nu, force[point], omega[point])
    x1, x2 = high - ratio * (high - low), low + ratio * (high - low)
    f1, f2 = sign * _g(*args, np.exp(x1)), sign * _g(*args, np.exp(x2))
    for _ in range(iterations):  # golden-section search on log A, vectorised
        left = f1 < f2
        high = np.where(left, x2, high)
        low = np.where(left, low, x1)
        x1_new = np.where(left, high - ratio * (high - low), x2)
        x2_new = np.where(left, x1, low + ratio * (high - low))
        f1_new = np.where(left, np.nan, f2)
        f2_new = np.where(left, f1, np.nan)
        x1, x2 = x1_new, x2_new
        f1 = np.where(left, sign * _g(*args, np.exp(x1)), f1_new)
        f2 = np.where(left, f2_new, sign * _g(*args, np.exp(x2)))
    best = np.exp(0.5 * (low + high))
    extra_values = _g(*args, best)
    crosses = np.sign(extra_values) != np.sign(values[point, index + 1])
    if not np.any(crosses):
        return grid, values
    rows = [grid[p] for p in range(grid.shape[0])]
    vals = [values[p] for p in range(grid.shape[0])]
    for p, a, g in zip(point[crosses], best[crosses], extra_values[crosses]):
        position = np.searchsorted(rows[p], a)
        rows[p] = np.insert(rows[p], position, a)
        vals[p] = np.insert(vals[p], position, g)
    width = max(r.size for r in rows)
    padded_grid = np.array([np.concatenate([r, np.full(width - r.size, r[-1])]) for r in rows])
    padded_values = np.array([np.concatenate([v, np.full(width - v.size, v[-1])]) for v in vals])
    return padded_grid, padded_values
