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

from dataclasses import dataclass
from typing import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

DF = Callable[[NDArray, NDArray], NDArray]


def _g(w: NDArray, nu: DF, force: NDArray, omega: NDArray, a: NDArray) -> NDArray:
    return a * np.abs(w + nu(a, omega)) - force


def _bracketed_root(w, nu, force, omega, low, high, iterations=100):
    """The root of g in each bracket [low, high] (g(low), g(high) of opposite signs) by the
    Illinois variant of regula falsi on log A (the end kept twice in a row has its g halved,
    so the bracket closes from both sides), to |g| ≤ 1e-13·F or a bracket of 1e-12
    relative (where g jumps across zero, e.g. at a gap's contact, the bracket is all that
    closes); every point iterates only until it is done."""
    x_low, x_high = np.log(np.asarray(low, dtype=float)).copy(), np.log(np.asarray(high, dtype=float)).copy()
    g_low, g_high = _g(w, nu, force, omega, np.exp(x_low)), _g(w, nu, force, omega, np.exp(x_high))
    root = np.where(np.abs(g_low) <= np.abs(g_high), x_low, x_high)
    kept = np.zeros(x_low.shape, np.int8)  # +1: the low end was kept last time, −1: the high end
    active = np.flatnonzero(np.minimum(np.abs(g_low), np.abs(g_high)) > 1e-13 * force)
    for _ in range(iterations):
        if active.size == 0:
            break
        lo, hi, f_lo, f_hi = x_low[active], x_high[active], g_low[active], g_high[active]
        x = (lo * f_hi - hi * f_lo) / (f_hi - f_lo)
        x = np.where(np.isfinite(x) & (x > lo) & (x < hi), x, 0.5 * (lo + hi))
        g = _g(w[active], nu, force[active], omega[active], np.exp(x))
        root[active] = x
        low_side = np.sign(g) == np.sign(f_lo)  # the new point replaces the low end
        replace_low, replace_high = active[low_side], active[~low_side]
        g_high[replace_low[kept[replace_low] == -1]] *= 0.5
        g_low[replace_high[kept[replace_high] == 1]] *= 0.5
        x_low[replace_low], g_low[replace_low], kept[replace_low] = x[low_side], g[low_side], -1
        x_high[replace_high], g_high[replace_high], kept[replace_high] = x[~low_side], g[~low_side], 1
        done = (np.abs(g) <= 1e-13 * force[active]) | (x_high[active] - x_low[active] < 1e-12)
        active = active[~done]
    return np.exp(root)


def nearest_amplitude(
    w: ArrayLike,
    nu: DF,
    force: ArrayLike,
    omega: ArrayLike,
    guess: ArrayLike,
    span: float = 10.0,
    grid_points: int = 121,
    newton_iterations: int = 30,
    stall_iterations: int = 4,
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Root of ``g(A)`` nearest (in log A) to ``guess`` for every point.

    Damped Newton from the guess (finite-difference slope), each point until
    |g| ≤ 1e-11·F, at most ``newton_iterations`` times; a point leaves Newton as soon as an
    iterate falls outside ``guess·[1/span, span]`` (its answer must lie inside). Points where
    Newton fails (a kink of ν it circles, a root far off or none: |g| not halved in
    ``stall_iterations`` iterations in a row) are solved by scanning
    ``guess·[1/span, span]`` on a log grid and closing in on the sign change nearest to the
    guess (:func:`_bracketed_root`). Where there is no root in that range, the amplitude of
    smallest ``|g|`` is returned and flagged ``False`` (so a fit sees a large but finite
    residual there).
    """
    w = np.asarray(w, dtype=complex)
    shape = w.shape
    w = w.ravel()
    force = np.broadcast_to(np.asarray(force, dtype=float), shape).ravel()
    omega = np.broadcast_to(np.asarray(omega, dtype=float), shape).ravel()
    guess = np.broadcast_to(np.asarray(guess, dtype=float), shape).ravel()
    a = guess.copy()
    g = _g(w, nu, force, omega, a)
    active = np.flatnonzero(np.abs(g) > 1e-11 * force)
    stalled = np.zeros(a.shape, np.int8)  # iterations in a row that did not halve |g|
    for _ in range(newton_iterations):
        if active.size == 0:
            break
        args = (w[active], nu, force[active], omega[active])
        a_now, g_now = a[active], g[active]
        h = a_now * 1e-7
        slope = (_g(*args, a_now + h) - g_now) / h
        step = np.where(slope != 0, -g_now / np.where(slope != 0, slope, 1.0), 0.0)
        a_new = np.clip(a_now + step, 0.5 * a_now, 2.0 * a_now)
        g_new = _g(*args, a_new)
        worse = np.flatnonzero(np.abs(g_new) > np.abs(g_now))
        if worse.size:
            a_new[worse] = 0.5 * (a_now[worse] + a_new[worse])
            g_new[worse] = _g(w[active[worse]], nu, force[active[worse]], omega[active[worse]], a_new[worse])
        a[active], g[active] = a_new, g_new
        stalled[active] = np.where(np.abs(g_new) > 0.5 * np.abs(g_now), stalled[active] + 1, 0)
        inside = np.abs(np.log(a_new / guess[active])) < np.log(span)
        going = (np.abs(g_new) > 1e-11 * force[active]) & inside & (stalled[active] < stall_iterations)
        active = active[going]
    ok = (np.abs(g) <= 1e-9 * force) & (np.abs(np.log(a / guess)) < np.log(span))
    if np.all(ok):
        return a.reshape(shape), ok.reshape(shape)
    bad = np.flatnonzero(~ok)
    flat_w, flat_f, flat_o, flat_guess = w[bad], force[bad], omega[bad], guess[bad]
    ratios = np.exp(np.linspace(-np.log(span), np.log(span), grid_points))
    grid = flat_guess[:, None] * ratios[None, :]
    values = _g(flat_w[:, None], nu, flat_f[:, None], flat_o[:, None], grid)
    change = np.sign(values[:, :-1]) != np.sign(values[:, 1:])
    distance = np.abs(np.log(ratios[:-1] * np.sqrt(ratios[1] / ratios[0])))
    score = np.where(change, distance[None, :], np.inf)
    k = np.argmin(score, axis=1)
    rows = np.arange(bad.size)
    has_root = np.isfinite(score[rows, k])
    closest = grid[rows, np.argmin(np.abs(values), axis=1)]
    root = closest.copy()
    if has_root.any():
        found = rows[has_root]
        root[found] = _bracketed_root(flat_w[found], nu, flat_f[found], flat_o[found], grid[found, k[found]],
                              grid[found, k[found] + 1])
    a[bad], ok[bad] = root, has_root
    return a.reshape(shape), ok.reshape(shape)


@dataclass(frozen=True, eq=False)
class RootSensitivity:
    """How the roots A of ``g(A) = A|s| − F`` with ``s = W + ν(A, ω)`` move when s changes.

    A change ∂s of s at fixed A (of W or of the DF's parameters) moves the root by
    ``dA = −A Re(s̄ ∂s)/|s| / g_A`` with ``g_A = |s| + A Re(s̄ ν_A)/|s|`` (implicit function
    theorem; ν_A a forward difference of the DF), and s in all by ``∂s + ν_A dA``. Where no
    root was found (``solved`` False), or at a fold (g_A = 0), A is held fixed.
    """

    s: NDArray[np.complex128]
    nu_a: NDArray[np.complex128]
    amplitude: NDArray[np.float64]
    follows: NDArray[np.bool_]
    g_a: NDArray[np.float64]

    @classmethod
    def at(cls, w: NDArray, nu: DF, amplitude: NDArray, omega: NDArray, solved: NDArray) -> "RootSensitivity":
        """At the roots ``amplitude`` (m) of ``g`` for dynamic stiffness ``w`` (N/m)."""
        value = nu(amplitude, omega)
        s = w + value
        step = 1e-7 * amplitude
        nu_a = (nu(amplitude + step, omega) - value) / step
        g_a = np.abs(s) + amplitude * np.real(np.conj(s) * nu_a) / np.abs(s)
        return cls(s, nu_a, amplitude, solved & (np.abs(g_a) > 1e-12 * np.abs(s)), g_a)

    def d_amplitude(self, change: NDArray[np.complex128]) -> NDArray[np.float64]:
        """dA (m) for the change ``change`` of s at fixed A."""
        g_change = self.amplitude * np.real(np.conj(self.s) * change) / np.abs(self.s)
        return np.where(self.follows, -g_change / np.where(self.follows, self.g_a, 1.0), 0.0)

    def d_s(self, change: NDArray[np.complex128]) -> NDArray[np.complex128]:
        """The whole change of s: ``change`` and what the root's move adds through ν."""
        return change + self.nu_a * self.d_amplitude(change)


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
    roots = _bracketed_root(w[point], nu, force[point], omega[point], grid[point, index], grid[point, index + 1])
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
