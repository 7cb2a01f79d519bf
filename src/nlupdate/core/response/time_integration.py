"""Steady-state first harmonic by direct time integration — the independent reference.

The describing-function solvers (:mod:`nlupdate.core.response.continuation`, :mod:`nlupdate.core.response.fixed_point`)
balance the first harmonic only. This module integrates the *same* system in time, with
the elements' time-domain force laws ``element.force(x, v, state, ω)``, until the motion
is periodic, and returns the first harmonic of the last period (docs/methods.md §3, "reference a
user can trust"). Conventions: SI units, ω in rad/s, ``x(t) = Re(X e^{iωt})`` so the first
harmonic over a period is ``X = (2/T)∫ x(t) e^{−iωt} dt``; the force at dof f is
``Re(F_f e^{iωt})`` with t = 0 at the start of every integrated period.

Equations of motion
-------------------
``M ẍ + (C + D/ω) ẋ + K x + g(x, ẋ, s) = Re(F e^{iωt})``.
Structural damping ``iD`` has no causal time-domain form; each case uses the equivalent
viscous damping ``D/ω`` at *its own* excitation frequency. For the steady-state first
harmonic this is exact (``iω(D/ω) = iD``); higher harmonics see ``D/(hω)·hω = D`` too, so
the only difference from a frequency-domain ``iD`` is in transients (modes below ω are
damped less, modes above more). ``g`` are the local element forces.

Models: a :class:`~nlupdate.core.model.linear.LumpedModel` (dense, or sparse with a diagonal mass
matrix) is integrated in physical coordinates; a :class:`~nlupdate.core.model.linear.ModalModel` in
modal coordinates ``q`` with ``x = Φ q``:
``q̈ + (2ζ_r ω_r + η_r ω_r²/ω) q̇ + ω_r² q = Φᵀ f``.

The linear operators and the step bound are in :mod:`nlupdate.core.response.time_operators`;
the stepping loop, its vectorisation, the hysteretic states and the convergence rule in
:mod:`nlupdate.core.response.time_stepping`.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nlupdate.core.model.system import NonlinearSystem
from nlupdate.progress import ProgressCallback, no_progress
from nlupdate.core.response.time_operators import Operators, TimeIntegrationError
from nlupdate.core.response.time_stepping import (
    DEFAULT_INTEGRATION, Batch, IntegrationOptions, check_omega, forcing_matrix, integrate, start_batch,
)

__all__ = ["SteadyStateResult", "TimeIntegrationError", "TimeSweepResult", "steady_state_response", "time_sweep"]


# --------------------------------------------------------------------------------------
# results
# --------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class SteadyStateResult:
    """First harmonics of the steady state reached by time integration, one row per case.

    omega: excitation frequencies (rad/s), shape (n_cases,).
    x: complex first-harmonic amplitudes (m) at every dof of the model, (n_cases, n_dof).
    converged: the first harmonic settled below the tolerance (see module docstring).
    periods: forcing periods integrated for each case.
    change: last relative period-to-period change of the first harmonic.
    harmonic_ratio: RMS of harmonics ≥ 2 over RMS of the first harmonic, (n_cases, n_dof).
    steps_per_period: RK4 steps in the last period of each case.
    history: with ``keep_history=True``, per case an array (2, n_dof, N) with the
        displacements (m) and velocities (m/s) at the N step starts of the last period
        (phase 2πk/N); otherwise None.
    """

    omega: NDArray[np.float64]
    x: NDArray[np.complex128]
    converged: NDArray[np.bool_]
    periods: NDArray[np.int64]
    change: NDArray[np.float64]
    harmonic_ratio: NDArray[np.float64]
    steps_per_period: NDArray[np.int64]
    history: tuple[NDArray[np.float64], ...] | None = None

    @property
    def frequency_hz(self) -> NDArray[np.float64]:
        return self.omega / (2 * np.pi)

    def response(self, dofs: Sequence[int]) -> NDArray[np.complex128]:
        """Complex first-harmonic amplitudes (m) at ``dofs``, shape (n_cases, len(dofs))."""
        return self.x[:, list(dofs)]


@dataclass(frozen=True, eq=False)
class TimeSweepResult:
    """Stepped-sine sweep in the time domain, reported in increasing frequency order.

    omega (rad/s), x (n_grid, n_dof, m), converged, periods and harmonic_ratio as in
    :class:`SteadyStateResult`; ``jumps_hz`` are the grid frequencies (Hz), in sweep order,
    at which the response left its branch (see :func:`time_sweep`).
    """

    omega: NDArray[np.float64]
    x: NDArray[np.complex128]
    converged: NDArray[np.bool_]
    periods: NDArray[np.int64]
    harmonic_ratio: NDArray[np.float64]
    direction: str
    jumps_hz: tuple[float, ...]

    @property
    def frequency_hz(self) -> NDArray[np.float64]:
        return self.omega / (2 * np.pi)

    def response(self, dofs: Sequence[int]) -> NDArray[np.complex128]:
        return self.x[:, list(dofs)]



# --------------------------------------------------------------------------------------
# public API
# --------------------------------------------------------------------------------------
def steady_state_response(
    system: NonlinearSystem,
    forcing: Mapping[int | str, ArrayLike],
    omega: ArrayLike,
    *,
    initial: ArrayLike | None = None,
    tolerance: float = DEFAULT_INTEGRATION.tolerance,
    max_periods: int = DEFAULT_INTEGRATION.max_periods,
    steps_per_period: int = DEFAULT_INTEGRATION.steps_per_period,
    settle_periods: int = DEFAULT_INTEGRATION.settle_periods,
    courant: float = DEFAULT_INTEGRATION.courant,
    keep_history: bool = False,
) -> SteadyStateResult:
    """Steady-state first harmonics of many cases by time integration (all cases at once).

    Parameters
    ----------
    system:
        Linear model (LumpedModel or ModalModel) with its nonlinear elements.
    forcing:
        ``{dof: F}`` complex force amplitudes (N), a scalar or one value per case; the force
        is ``Re(F e^{iωt})``.
    omega:
        Excitation frequency of each case (rad/s), shape (n_cases,).
    initial:
        Complex amplitudes (m) at all dofs, shape (n_cases, n_dof) or (n_dof,), that set the
        initial displacement ``Re X`` and velocity ``Re(iωX)`` — e.g. a describing-function
        solution, to check that it is an attractor. Default: the linear response.
    tolerance:
        Relative period-to-period change of the first harmonic that counts as settled.
    max_periods:
        Periods after which a case is returned as not converged.
    steps_per_period:
        Minimum RK4 steps per period (more are used when stability needs them).
    settle_periods:
        Consecutive periods the change must stay below ``tolerance``.
    courant:
        ``dt·ρ`` limit (ρ = spectral-radius bound, see module docstring).
    keep_history:
        Also return the displacement and velocity samples of the last period.
    """
    options = IntegrationOptions(tolerance, max_periods, steps_per_period, settle_periods, courant)
    omega = check_omega(omega, "omega")
    ops = Operators(system)
    forced, force = forcing_matrix(system, forcing, omega.size)
    batch = start_batch(system, ops, omega, forced, force, initial)
    out, _ = integrate(ops, batch, options, keep_history)
    return SteadyStateResult(omega=omega, **out)


def time_sweep(
    system: NonlinearSystem,
    forcing: Mapping[int | str, ArrayLike],
    omega_grid: ArrayLike,
    direction: str = "up",
    *,
    initial: ArrayLike | None = None,
    jump_threshold: float = 0.25,
    tolerance: float = DEFAULT_INTEGRATION.tolerance,
    max_periods: int = DEFAULT_INTEGRATION.max_periods,
    steps_per_period: int = DEFAULT_INTEGRATION.steps_per_period,
    settle_periods: int = DEFAULT_INTEGRATION.settle_periods,
    courant: float = DEFAULT_INTEGRATION.courant,
    progress: ProgressCallback = no_progress,
) -> TimeSweepResult:
    """Stepped-sine test in the time domain: one frequency after the other, state carried over.

    The grid (rad/s) is visited in increasing (``"up"``) or decreasing (``"down"``) order.
    At each frequency the integration starts from the state reached at the end of the
    previous dwell (the frequency changes at a zero-phase instant of the force, displacement,
    velocity and element states are continuous) and dwells until the first harmonic settles
    (options as in :func:`steady_state_response`). The first frequency starts from
    ``initial`` (complex amplitudes at all dofs, shape (n_dof,)) or from the linear response.

    Jumps: when the settled response at a grid frequency ω_k differs from the one at the
    previous grid frequency ω_{k−1} by more than ``jump_threshold`` (relative Euclidean norm
    of the complex amplitudes over all dofs), the integration dwells once more at ω_{k−1},
    starting from the state settled at ω_k. If that lands on a steady state that differs
    from the one recorded at ω_{k−1} by more than ``jump_threshold``, two stable responses
    coexist at ω_{k−1} and the branch followed so far ended between ω_{k−1} and ω_k: a jump
    is recorded at ω_k (Hz, in sweep order) — the grid point at which
    :func:`nlupdate.core.response.stepped_sine.stepped_sine` reports a jump over a fold. A steep but
    single-valued stretch (a linear resonance on a coarse grid) returns to the same state
    and is not a jump.
    ``forcing`` values may be scalars or one per grid frequency (increasing order).
    Cost: one case at a time, so about the cost of a whole vectorised batch per frequency;
    ``progress("time-domain stepped sine", done, total)`` is called before the first
    frequency (done = 0: the first dwell can take seconds) and after each one.
    """
    if direction not in ("up", "down"):
        raise TimeIntegrationError(f"direction: expected 'up' or 'down', got {direction!r}")
    if not (0 < jump_threshold < 1):
        raise TimeIntegrationError(f"jump_threshold: expected a relative change in (0, 1), got {jump_threshold}")
    options = IntegrationOptions(tolerance, max_periods, steps_per_period, settle_periods, courant)
    grid = np.sort(check_omega(omega_grid, "omega_grid"))
    ops = Operators(system)
    forced, force = forcing_matrix(system, forcing, grid.size)
    b_f = ops.input_columns(list(forced))
    order = np.arange(grid.size) if direction == "up" else np.arange(grid.size)[::-1]
    x = np.full((grid.size, ops.n_dof), np.nan + 0j)
    converged = np.zeros(grid.size, bool)
    periods = np.zeros(grid.size, np.int64)
    ratio = np.full((grid.size, ops.n_dof), np.nan)
    jumps: list[float] = []

    def dwell(index: int, start: dict | None):
        w = grid[index : index + 1]
        f = force[:, index : index + 1]
        if start is None:
            batch = start_batch(system, ops, w, forced, f, None if initial is None else np.atleast_2d(initial))
        else:
            batch = Batch(
                index=np.arange(1),
                omega=w.copy(),
                y=start["y"].copy(),
                states=[None if s is None else s.copy() for s in start["states"]],
                bc=b_f @ f.real,
                bs=b_f @ f.imag,
                amp=start["amp"].copy(),
                vel=start["vel"].copy(),
                previous=None,
                streak=np.zeros(1, np.int64),
            )
        return integrate(ops, batch, options, keep_history=False)

    def differ(a: NDArray, b: NDArray) -> bool:
        scale = max(np.linalg.norm(a), np.linalg.norm(b))
        return bool(scale > 0 and np.linalg.norm(a - b) > jump_threshold * scale)

    final = None
    progress("time-domain stepped sine", 0, grid.size)
    for step, index in enumerate(order):
        out, final = dwell(index, final)
        x[index], converged[index] = out["x"][0], out["converged"][0]
        periods[index], ratio[index] = out["periods"][0], out["harmonic_ratio"][0]
        progress("time-domain stepped sine", step + 1, grid.size)
        if not np.all(np.isfinite(final["y"])):
            break
        if step > 0:
            before = order[step - 1]
            if differ(x[index], x[before]):
                back, _ = dwell(before, final)
                if differ(back["x"][0], x[before]):
                    jumps.append(float(grid[index] / (2 * np.pi)))
    return TimeSweepResult(grid, x, converged, periods, ratio, direction, tuple(jumps))
