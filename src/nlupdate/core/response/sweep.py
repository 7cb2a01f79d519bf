"""A stepped-sine test of a system on a frequency grid, by the fastest exact route.

1. Where the elements allow (:mod:`nlupdate.core.response.closed_form`: cubic springs on one
   coordinate) every root of the single-harmonic balance comes in closed form at every grid
   frequency and the sweep is read off them.
2. Otherwise all grid frequencies are solved at once by batched Newton
   (:func:`fold_free_branch`) from the response of the linear system with the elements at
   zero amplitude (e.g. stuck friction). The result is accepted only if it is one
   fold-free branch, as a continuation with the grid as its steps would have accepted it:
   every point converged with ``det ∂R/∂y > 0`` (no fold: the determinant changes sign at
   each), neighbouring tangents and the chord between them within the continuation's
   ``max_angle_deg``, chords no longer than its ``max_step``, and the first point the
   continuation's own start. The branch the continuation would trace from there is then this
   one, and a sweep either way stays on it.
3. Otherwise the curve is traced (:func:`~nlupdate.core.response.continuation.trace_frequency_response`:
   continuation connects the branches and locates the folds) and read as a stepped-sine
   test, all grid points polished together (:func:`~nlupdate.core.response.stepped_sine.stepped_sine`).

All give the same responses (to the Newton tolerance) and the same jumps.
"""
from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nlupdate.core.model.system import CondensedProblem, NonlinearSystem, newton_batch, newton_fixed_frequency
from nlupdate.core.response import closed_form
from nlupdate.core.response.continuation import ContinuationOptions, check_band, default_x_scale, trace_frequency_responses
from nlupdate.core.response.stepped_sine import SweepResult, stepped_sine


def frequency_sweep(
    system: NonlinearSystem,
    forcing: Mapping[int | str, complex],
    omega: ArrayLike,
    direction: str = "up",
    *,
    closed_form_roots: bool = True,
    fold_free: bool = True,
    start: NDArray | None = None,
    options: ContinuationOptions | None = None,
) -> SweepResult:
    """Single-harmonic stepped-sine responses at the grid ``omega`` (rad/s) swept ``direction``.

    ``closed_form_roots=False`` and ``fold_free=False`` skip those routes (the result is the
    same; a caller that expects folds saves the attempt); ``start`` (n_grid, n_a) (m) replaces
    the fold-free route's starting guess (e.g. the solution of a neighbouring model);
    ``options`` are the continuation's.
    """
    return frequency_sweeps(system, [forcing], omega, direction, closed_form_roots=closed_form_roots,
                            fold_free=fold_free, start=start, options=options)[0]


def frequency_sweeps(
    system: NonlinearSystem,
    forcings: Sequence[Mapping[int | str, complex]],
    omega: ArrayLike,
    direction: str = "up",
    *,
    closed_form_roots: bool = True,
    fold_free: bool = True,
    start: NDArray | None = None,
    options: ContinuationOptions | None = None,
) -> list[SweepResult]:
    """:func:`frequency_sweep` at several force vectors that differ by a factor (force levels,
    in rising order for the best speed): the levels the direct routes do not solve are traced
    together (:func:`~nlupdate.core.response.continuation.trace_frequency_responses`). Once a level
    needs the trace, the later ones skip the fold-free attempt (a choice of speed only)."""
    if direction not in ("up", "down"):
        raise ValueError(f"direction must be 'up' or 'down', got {direction!r}")
    grid = np.sort(np.atleast_1d(np.asarray(omega, dtype=float)))
    check_band(float(grid[0]), float(grid[-1]))
    options = options or ContinuationOptions()
    results: list[SweepResult | None] = []
    for forcing in forcings:
        problem = CondensedProblem(system, forcing)
        result = None
        if closed_form_roots and closed_form.applies(problem):
            roots = closed_form.cubic_roots(problem, grid)
            read = closed_form.sweep_roots(roots, direction)
            if read is not None:
                index, jumped = read
                x = roots.response(index)[:, None]
                jumps = grid[jumped] if direction == "up" else grid[jumped][::-1]
                result = SweepResult(problem, grid, x, direction, tuple(float(w / (2 * np.pi)) for w in jumps),
                                     "closed form")
        if result is None and problem.n and fold_free:
            x = fold_free_branch(problem, grid, options, start)
            if x is not None:
                result = SweepResult(problem, grid, x, direction, (), "fold-free")
            else:
                fold_free = False
        results.append(result)
    traced = [i for i, result in enumerate(results) if result is None]
    if traced:
        curves = trace_frequency_responses(system, [forcings[i] for i in traced], float(grid[0]), float(grid[-1]),
                                           options)
        for i, curve in zip(traced, curves):
            results[i] = stepped_sine(curve, grid, direction)
    return results


def fold_free_branch(
    problem: CondensedProblem, grid: NDArray, options: ContinuationOptions, start: NDArray | None = None,
    max_halvings: int = 16,
) -> NDArray | None:
    """The responses (P, n) (m) at every grid frequency (rad/s, ascending) when they form one
    fold-free branch that starts where the continuation starts (see the module docstring), else None.

    A grid cell whose chord or tangents turn too much is halved (the midpoint solved from the
    Hermite interpolation, all such cells together) up to ``max_halvings`` times, as the
    continuation would shorten its step there; as there, a turn over a chord shorter than
    ``kink_step`` is a kink (a stick–slip onset) and accepted. Sets ``problem.x_scale`` as the continuation does.
    """
    band = grid[-1] - grid[0]
    problem.x_scale = default_x_scale(problem, grid[0], grid[-1])
    linear = problem.linear_batch(grid)
    if start is None:  # the linear response with the elements at zero amplitude
        with np.errstate(all="ignore"):  # describing functions there are limits
            stuck = problem.forces_batch(np.zeros((grid.size, problem.n), complex), grid, jacobian=True)[1]
            start = np.linalg.solve(np.eye(problem.n) + linear.h_aa @ stuck, linear.x_lin[..., None])[..., 0]
    if not np.all(np.isfinite(start)):
        return None
    y, slope = _regular_points(problem, linear, problem.to_real(start), options.tolerance, band)
    if y is None:
        return None
    for guess in problem.initial_guesses(grid[0]):  # the continuation's own start
        y0, ok, _ = newton_fixed_frequency(problem, grid[0], guess, tol=options.tolerance)
        if ok:
            break
    if not ok or np.max(np.abs(y0 - y[0])) > 1e-6 * max(1.0, np.max(np.abs(y0))):
        return None
    # cells (a, b) between neighbouring points, in scaled coordinates z = (y, ω̃)
    w_a, w_b, y_a, y_b, s_a, s_b = grid[:-1], grid[1:], y[:-1], y[1:], slope[:-1], slope[1:]
    cos_max = np.cos(np.radians(options.max_angle_deg))
    for _ in range(max_halvings + 1):
        bad = ~_cell_accepted(w_a, w_b, y_a, y_b, s_a, s_b, band, options, cos_max)
        if not bad.any():
            return problem.to_complex(y)
        w_a, w_b, y_a, y_b, s_a, s_b = (v[bad] for v in (w_a, w_b, y_a, y_b, s_a, s_b))
        w_m = 0.5 * (w_a + w_b)
        h = (w_b - w_a)[:, None]  # Hermite midpoint: ½(y_a + y_b) + h/8 (y'_a − y'_b)
        guess = 0.5 * (y_a + y_b) + h / 8 * (s_a - s_b) / band
        y_m, s_m = _regular_points(problem, problem.linear_batch(w_m), guess, options.tolerance, band)
        if y_m is None:
            return None
        w_a, w_b = np.concatenate([w_a, w_m]), np.concatenate([w_m, w_b])
        y_a, y_b = np.concatenate([y_a, y_m]), np.concatenate([y_m, y_b])
        s_a, s_b = np.concatenate([s_a, s_m]), np.concatenate([s_m, s_b])
    return None


def _regular_points(problem, linear, y0, tolerance: float, band: float, quick_iterations: int = 10):
    """Batched Newton from ``y0``; (y, dy/dω̃) when every point converged with det ∂R/∂y > 0,
    else (None, None). It gives up early — on a branch with folds most points fail — when more
    than 1 % of the points need more than ``quick_iterations``; those few start again from
    their converged neighbour (e.g. near a stick–slip onset, where Newton is slow)."""
    y, converged, _ = newton_batch(problem, linear, y0, tol=tolerance, max_iter=quick_iterations)
    slow = np.flatnonzero(~converged)
    if slow.size > max(1, 0.01 * converged.size) or slow.size == converged.size:
        return None, None
    if slow.size:
        done = np.flatnonzero(converged)
        neighbour = done[np.argmin(np.abs(done[None, :] - slow[:, None]), axis=1)]
        y[slow], again, _ = newton_batch(problem, linear.take(slow), y[neighbour], tol=tolerance)
        if not again.all():
            return None, None
    _, jac, jac_w = problem.residual_batch(y, linear)
    if not np.all(np.linalg.det(jac) > 0):
        return None, None
    return y, -np.linalg.solve(jac, jac_w[..., None])[..., 0] * band


def _cell_accepted(w_a, w_b, y_a, y_b, s_a, s_b, band, options: ContinuationOptions, cos_max) -> NDArray:
    """Per cell: chord no longer than ``max_step`` and within the angle of both tangents,
    which are within the angle of each other (all in z = (y, (ω − ω₀)/band)), or a chord
    shorter than ``kink_step``."""
    def unit(v):
        return v / np.linalg.norm(v, axis=1, keepdims=True)

    ones = np.ones((w_a.size, 1))
    t_a, t_b = unit(np.concatenate([s_a, ones], axis=1)), unit(np.concatenate([s_b, ones], axis=1))
    chord = np.concatenate([y_b - y_a, ((w_b - w_a) / band)[:, None]], axis=1)
    length = np.linalg.norm(chord, axis=1)
    chord = chord / length[:, None]
    smooth = ((np.sum(t_a * t_b, axis=1) >= cos_max) & (np.sum(chord * t_a, axis=1) >= cos_max)
              & (np.sum(chord * t_b, axis=1) >= cos_max))
    return (length <= options.max_step) & (smooth | (length <= options.kink_step))
