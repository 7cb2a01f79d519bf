"""The model's response at the measured points (force level, frequency), as the test saw it.

Per force level, :func:`nlupdate.core.response.steady_state.steady_state_response` (the canonical
response entry point) over the level's measured points — describing function by default, or
multi-harmonic balance with given :class:`~nlupdate.core.response.harmonic_balance.HarmonicSettings`
(its first harmonic) — read as the **nearest stable solution** to each measured point: where the
response is multi-valued, which solution a test settles on depends on how it reached the
frequency (a sweep up or down, a start from rest). The stepped-sine reading in the stated sweep
direction is kept beside it, so a report can mark the points where the measurement follows
another branch than the stated sweep. Points without a solution are NaN (they count as misfit,
see :mod:`nlupdate.core.discovery.frf_evidence`). Any failure is a :class:`ModelSolveError`
naming the force level.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.discovery.errors import ModelSolveError
from nlupdate.core.model.system import NonlinearSystem
from nlupdate.core.response.continuation import ContinuationError
from nlupdate.core.response.harmonic_balance import HarmonicSettings
from nlupdate.core.response.steady_state import SteadyState, steady_state_response


def simulate_points(
    system: NonlinearSystem,
    input_dof: int,
    force: NDArray[np.float64],
    omega: NDArray[np.float64],
    dofs: Sequence[int],
    sweep: str = "up",
    harmonic_balance: HarmonicSettings | None = None,
) -> NDArray[np.complex128]:
    """Complex amplitudes (m) at ``dofs`` for a harmonic force ``force`` (N) at ``input_dof``
    and frequency ``omega`` (rad/s) per point, as a stepped-sine test sweeping ``sweep``
    ("up" or "down") reads them; shape (n_points, len(dofs)). With ``harmonic_balance`` the
    first harmonic of the multi-harmonic balance, else the describing function's."""
    return simulate_nearest(system, input_dof, force, omega, dofs, None, sweep=sweep,
                            harmonic_balance=harmonic_balance).x


def simulate_nearest(
    system: NonlinearSystem,
    input_dof: int,
    force: NDArray[np.float64],
    omega: NDArray[np.float64],
    dofs: Sequence[int],
    measured: NDArray[np.complex128] | None,
    measured_columns: Sequence[int] = (),
    weight: NDArray[np.float64] | None = None,
    sweep: str = "unknown",
    harmonic_balance: HarmonicSettings | None = None,
) -> SteadyState:
    """The model's solutions at the points (see module docstring): x nearest to ``measured``,
    x_sweep the stepped-sine reading in the stated direction, both (n_points, len(dofs)) (m).

    ``measured`` (n_points, m): measured amplitudes at the coordinates ``dofs[c]`` for c in
    ``measured_columns``, with residual weights ``weight`` (n_points, m; default 1/|measured|);
    None: every point takes the stepped-sine reading. ``sweep``: "up", "down" or "unknown"
    (the stated direction of the test; unknown reads up where a reading is needed).
    """
    dofs = list(dofs)
    n = force.size
    out = np.full((n, len(dofs)), np.nan + 0j)
    out_sweep = np.full((n, len(dofs)), np.nan + 0j) if sweep in ("up", "down") else None
    for level in np.unique(force):
        points = np.flatnonzero(force == level)
        points = points[np.argsort(omega[points], kind="stable")]
        w = omega[points]
        band = f"{w.min() / (2 * np.pi):g}–{w.max() / (2 * np.pi):g} Hz"
        try:
            with np.errstate(all="ignore"):
                found = steady_state_response(
                    system, {input_dof: level}, w, dofs, sweep, harmonic_balance=harmonic_balance,
                    measured=None if measured is None else measured[points], measured_columns=measured_columns,
                    weight=None if weight is None else weight[points])
        except (ContinuationError, np.linalg.LinAlgError, ValueError, ArithmeticError) as error:
            raise ModelSolveError(f"the model cannot be solved at {level:g} N, {band} ({error})") from None
        out[points] = found.x
        if out_sweep is not None:
            out_sweep[points] = found.x_sweep
        if not np.any(np.isfinite(out[points])):
            raise ModelSolveError(f"the model has no finite response at {level:g} N, {band} (singular or unstable)")
    return SteadyState(out, out_sweep)
