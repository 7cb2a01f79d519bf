"""A stepped-sine test of a system on a frequency grid, by the fastest exact route.

Where the elements allow (:mod:`nlupdate.response.closed_form`: cubic springs on one
coordinate) every root of the single-harmonic balance comes in closed form at every grid
frequency and the sweep is read off them; otherwise the curve is traced
(:func:`~nlupdate.response.continuation.trace_frequency_response`, continuation only to
connect the branches and locate the folds) and read as a stepped-sine test, all grid points
polished together (:func:`~nlupdate.response.stepped_sine.stepped_sine`). Both give the same
responses (to the Newton tolerance) and the same jumps.
"""
from __future__ import annotations

from typing import Mapping

import numpy as np
from numpy.typing import ArrayLike

from nlupdate.model.system import CondensedProblem, NonlinearSystem
from nlupdate.response import closed_form
from nlupdate.response.continuation import ContinuationOptions, check_band, trace_frequency_response
from nlupdate.response.stepped_sine import SweepResult, stepped_sine


def frequency_sweep(
    system: NonlinearSystem,
    forcing: Mapping[int | str, complex],
    omega: ArrayLike,
    direction: str = "up",
    *,
    closed_form_roots: bool = True,
    options: ContinuationOptions | None = None,
) -> SweepResult:
    """Single-harmonic stepped-sine responses at the grid ``omega`` (rad/s) swept ``direction``.

    ``closed_form_roots=False`` forces the traced route (for comparison); ``options`` are the
    continuation's when it traces.
    """
    if direction not in ("up", "down"):
        raise ValueError(f"direction must be 'up' or 'down', got {direction!r}")
    grid = np.sort(np.atleast_1d(np.asarray(omega, dtype=float)))
    check_band(float(grid[0]), float(grid[-1]))
    if closed_form_roots:
        problem = CondensedProblem(system, forcing)
        if closed_form.applies(problem):
            roots = closed_form.cubic_roots(problem, grid)
            read = closed_form.sweep_roots(roots, direction)
            if read is not None:
                index, jumped = read
                x = roots.x[np.arange(grid.size), index][:, None]
                jumps = grid[jumped] if direction == "up" else grid[jumped][::-1]
                return SweepResult(problem, grid, x, direction, tuple(float(w / (2 * np.pi)) for w in jumps))
    curve = trace_frequency_response(system, forcing, float(grid[0]), float(grid[-1]), options=options)
    return stepped_sine(curve, grid, direction)
