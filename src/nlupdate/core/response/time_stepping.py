"""The time-stepping loop of :mod:`nlupdate.core.response.time_integration`: many
(frequency, force) cases advanced together by classical RK4, the elements' history states
committed once per step, period by period until each case is periodic.

Vectorisation
-------------
Many (frequency, force) cases are integrated together: the state ``y = [q; q̇]`` has shape
``(2·n_coordinates, n_cases)`` and one numpy time-stepping loop advances all of them.
Every case takes the same number N of steps per period, so its step is ``dt = T/N`` with
its own period T, the forcing phase at step k is exactly ``2πk/N`` (the discrete system is
exactly periodic and a converged orbit repeats to round-off), and all cases reach a
period boundary together. Finished cases are dropped from the arrays at each boundary.

Hysteretic elements (operator splitting)
----------------------------------------
An element's history state (Jenkins slider position; an Iwan joint's slider positions, one
row per case) is *committed* once per step: the four
RK4 stage forces are evaluated with the state committed at the start of the step (the
return mapping inside ``force`` clips the trial force, the new state is discarded), and at
the end of the step ``force`` is called at the new displacement and its returned state is
committed (return mapping). Initial states are put on their steady loop by driving each
element through two cycles of the initial harmonic motion (256 points per cycle).

Convergence
-----------
After every period the first harmonic X_p at all dofs is compared with the previous
period's: ``change = max_dof |X_p − X_{p−1}| / max_dof |X_p|``. A case has converged when
``change < tolerance`` for ``settle_periods`` consecutive periods. A transient at another
frequency rotates from period to period, and the change is about its size; a transient at
(nearly) the excitation frequency — a lightly damped mode near resonance — decaying by a
factor ρ per period leaves an error of about ``change·ρ/(1 − ρ)``, so lightly damped
structures need a smaller tolerance than the accuracy wanted. Cases that
reach ``max_periods`` are returned with ``converged = False``; a case whose state becomes
non-finite is returned as NaN, not converged.

``harmonic_ratio`` is the RMS of the harmonics 2, 3, … over the RMS of the first harmonic
over the last period (DC excluded), from Parseval on the period samples; it measures how far
the motion is from the single-harmonic assumption of the describing functions.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nlupdate.core.model.linear import ModalModel, dof_index
from nlupdate.core.model.system import NonlinearSystem
from nlupdate.core.response.time_operators import Operators, TimeIntegrationError, modal_denominator

MAX_STEPS_PER_PERIOD = 200_000
PRECYCLE_POINTS = 256


# --------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------
def forcing_matrix(system: NonlinearSystem, forcing: Mapping[int | str, ArrayLike], n_cases: int):
    """Forced dofs and complex force amplitudes (N), shape (n_forced, n_cases)."""
    if not forcing:
        raise TimeIntegrationError("forcing is empty: give {dof: force amplitude in N (complex, scalar or per case)}")
    dofs = tuple(dof_index(system.model, dof) for dof in forcing)
    rows = []
    for dof, value in forcing.items():
        arr = np.asarray(value, dtype=complex)
        if arr.ndim > 1 or (arr.ndim == 1 and arr.size not in (1, n_cases)):
            raise TimeIntegrationError(
                f"forcing[{dof!r}]: expected a scalar or {n_cases} values (one per case), got shape {arr.shape}"
            )
        if not np.all(np.isfinite(arr)):
            raise TimeIntegrationError(f"forcing[{dof!r}]: force amplitudes must be finite")
        rows.append(np.broadcast_to(arr.reshape(-1), (n_cases,)))
    return dofs, np.array(rows)


def check_omega(omega: ArrayLike, name: str) -> NDArray[np.float64]:
    w = np.atleast_1d(np.asarray(omega, dtype=float))
    if w.ndim != 1 or w.size == 0 or not np.all(np.isfinite(w)) or np.any(w <= 0):
        raise TimeIntegrationError(f"{name}: expected a 1-D array of positive angular frequencies (rad/s), got {omega!r}")
    return w


def _relative(r: int, j: int, xa: NDArray) -> NDArray:
    return xa[r] - xa[j] if j >= 0 else xa[r]


def _modal_initial(ops: Operators, model: ModalModel, omega, forced, force, x_all) -> NDArray:
    """Modal amplitudes consistent with complex amplitudes ``x_all`` (n_dof, n_cases).

    The modal harmonic balance with the elements' describing functions evaluated at the
    given amplitudes; exact for a describing-function solution.
    """
    xa = x_all[ops.a_idx]
    g = np.zeros_like(xa)
    for element, r, j in ops.elements:
        u = _relative(r, j, xa)
        f = element.describing_function(np.abs(u), omega) * u
        g[r] += f
        if j >= 0:
            g[j] -= f
    rhs = ops.input_columns(list(forced)) @ force - ops.b_a @ g
    return rhs / modal_denominator(model, omega)


def _initial_states(ops: Operators, q_amp: NDArray, omega: NDArray) -> list:
    """Element states after two cycles of the initial harmonic motion, ending at phase 0."""
    n_cases = q_amp.shape[1]
    xa_amp = ops.nonlinear_coordinates(q_amp)
    states = []
    theta = 2 * np.pi * np.arange(1, 2 * PRECYCLE_POINTS + 1) / PRECYCLE_POINTS
    for element, r, j in ops.elements:
        state = element.initial_state((n_cases,))
        if state is not None:
            u_amp = _relative(r, j, xa_amp)
            for angle in theta:
                rotated = u_amp * np.exp(1j * angle)
                _, state = element.force(rotated.real, -omega * rotated.imag, state, omega)
        states.append(state)
    return states


@dataclass
class Batch:
    """Working arrays of the active cases (columns); y = [q; q̇]."""

    index: NDArray[np.int64]
    omega: NDArray
    y: NDArray
    states: list
    bc: NDArray
    bs: NDArray
    amp: NDArray
    vel: NDArray
    previous: NDArray | None
    streak: NDArray

    def take(self, keep: NDArray) -> "Batch":
        return Batch(
            self.index[keep],
            self.omega[keep],
            self.y[:, keep],
            [None if s is None else s[keep] for s in self.states],
            self.bc[:, keep],
            self.bs[:, keep],
            self.amp[:, keep],
            self.vel[:, keep],
            None if self.previous is None else self.previous[:, keep],
            self.streak[keep],
        )


def _derivative(ops: Operators, batch: Batch, y: NDArray, c: float, s: float, inv_w: NDArray, complex_force: bool):
    """``ẏ`` at phase (cos, sin) = (c, s) with the committed element states."""
    n = ops.n_q
    k = ops.linear @ y
    acc = k[n:]
    acc += batch.bc * c
    if complex_force:
        acc -= batch.bs * s
    if ops.a_d is not None:
        acc -= (ops.a_d @ y[n:]) * inv_w
    if ops.elements:
        xa, va = ops.nonlinear_motion(y)
        g = np.zeros(xa.shape)
        for index, (element, r, j) in enumerate(ops.elements):
            f, _ = element.force(_relative(r, j, xa), _relative(r, j, va), batch.states[index], batch.omega)
            g[r] += f
            if j >= 0:
                g[j] -= f
        acc -= ops.b_a @ g
    return k


def _commit_states(ops: Operators, batch: Batch, y: NDArray) -> None:
    """Return mapping at the end of a step: commit the new element states."""
    xa, va = ops.nonlinear_motion(y)
    for index, (element, r, j) in enumerate(ops.elements):
        if batch.states[index] is not None:
            _, batch.states[index] = element.force(
                _relative(r, j, xa), _relative(r, j, va), batch.states[index], batch.omega
            )


def _one_period(ops: Operators, batch: Batch, n_steps: int):
    """Advance the batch by one forcing period in ``n_steps`` RK4 steps.

    Returns the samples ``y`` at the N step starts, shape (N, 2 n_q, n_cases), and updates
    ``batch.amp`` / ``batch.vel`` with the largest element relative displacement/velocity.
    """
    inv_w = 1.0 / batch.omega
    dt = (2 * np.pi * inv_w) / n_steps
    half, sixth = 0.5 * dt, dt / 6.0
    phase = 2 * np.pi * np.arange(2 * n_steps + 1) / (2 * n_steps)
    cos_tab, sin_tab = np.cos(phase), np.sin(phase)
    complex_force = bool(np.any(batch.bs))
    stateful = any(s is not None for s in batch.states)
    y = batch.y
    samples = np.empty((n_steps,) + y.shape)
    for k in range(n_steps):
        samples[k] = y
        c0, s0 = cos_tab[2 * k], sin_tab[2 * k]
        ch, sh = cos_tab[2 * k + 1], sin_tab[2 * k + 1]
        k1 = _derivative(ops, batch, y, c0, s0, inv_w, complex_force)
        k2 = _derivative(ops, batch, y + half * k1, ch, sh, inv_w, complex_force)
        k3 = _derivative(ops, batch, y + half * k2, ch, sh, inv_w, complex_force)
        k4 = _derivative(ops, batch, y + dt * k3, cos_tab[2 * k + 2], sin_tab[2 * k + 2], inv_w, complex_force)
        y = y + sixth * (k1 + 2 * (k2 + k3) + k4)
        if stateful:
            _commit_states(ops, batch, y)
    batch.y = y
    n = ops.n_q
    if ops.elements:
        xa = ops.nonlinear_coordinates(np.moveaxis(samples[:, :n], 0, 1))
        va = ops.nonlinear_coordinates(np.moveaxis(samples[:, n:], 0, 1))
        for index, (_, r, j) in enumerate(ops.elements):
            batch.amp[index] = np.max(np.abs(_relative(r, j, xa)), axis=0)
            batch.vel[index] = np.max(np.abs(_relative(r, j, va)), axis=0)
    return samples


def _period_harmonics(ops: Operators, samples: NDArray):
    """First harmonic, mean and mean square at every physical dof over one period of samples."""
    n_steps = samples.shape[0]
    theta = 2 * np.pi * np.arange(n_steps) / n_steps
    x = ops.to_physical(np.moveaxis(samples[:, : ops.n_q], 0, 1))  # (n_dof, N, n_cases)
    first = (2.0 / n_steps) * np.einsum("k,dkc->dc", np.exp(-1j * theta), x)
    return first, x.mean(axis=1), (x * x).mean(axis=1)


def _harmonic_ratio(first: NDArray, mean: NDArray, square: NDArray) -> NDArray:
    """RMS of harmonics ≥ 2 over RMS of the first harmonic (Parseval on the period samples)."""
    first_power = 0.5 * np.abs(first) ** 2
    rest = np.maximum(square - mean**2 - first_power, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(first_power > 0, np.sqrt(rest / first_power), np.where(rest > 0, np.inf, 0.0))


def integrate(ops: Operators, batch: Batch, options: IntegrationOptions, keep_history: bool):
    """Period-by-period integration of a batch until every case converged or stopped.

    Returns the result fields (without omega) and the final state of every case.
    """
    tolerance, max_periods, settle_periods = options.tolerance, options.max_periods, options.settle_periods
    steps_per_period, courant = options.steps_per_period, options.courant
    n_total, n_dof = batch.index.size, ops.n_dof
    out = {
        "x": np.full((n_total, n_dof), np.nan + 0j),
        "converged": np.zeros(n_total, bool),
        "periods": np.zeros(n_total, np.int64),
        "change": np.full(n_total, np.inf),
        "harmonic_ratio": np.full((n_total, n_dof), np.nan),
        "steps_per_period": np.zeros(n_total, np.int64),
        "history": [None] * n_total if keep_history else None,
    }
    final = {
        "y": np.full((2 * ops.n_q, n_total), np.nan),
        "states": [None if s is None else np.full((n_total,) + s.shape[1:], np.nan) for s in batch.states],
        "amp": np.zeros((len(ops.elements), n_total)),
        "vel": np.zeros((len(ops.elements), n_total)),
    }
    for period in range(1, max_periods + 1):
        rho = ops.spectral_radius(batch.omega, batch.amp, batch.vel)
        need = np.ceil(2 * np.pi * rho / (batch.omega * courant))
        n_steps = int(max(steps_per_period, need.max(initial=0)))
        if n_steps > MAX_STEPS_PER_PERIOD:
            raise TimeIntegrationError(
                f"time step: {n_steps} steps per period would be needed (spectral radius bound "
                f"{rho.max():.4g} rad/s at ω = {batch.omega[np.argmax(need)]:.4g} rad/s); the response "
                "amplitude or the model's highest natural frequency is too large for explicit integration"
            )
        samples = _one_period(ops, batch, n_steps)
        first, mean, square = _period_harmonics(ops, samples)
        finite = np.all(np.isfinite(batch.y), axis=0) & np.all(np.isfinite(first), axis=0)
        if batch.previous is None:
            change = np.full(batch.omega.shape, np.inf)
        else:
            difference = np.max(np.abs(first - batch.previous), axis=0)
            scale = np.max(np.abs(first), axis=0)
            with np.errstate(divide="ignore", invalid="ignore"):
                change = np.where(scale > 0, difference / scale, np.where(difference > 0, np.inf, 0.0))
        batch.streak = np.where(change < tolerance, batch.streak + 1, 0)
        batch.previous = first
        done = (batch.streak >= settle_periods) | ~finite | (period == max_periods)
        if np.any(done):
            idx = batch.index[done]
            ok = finite[done]
            out["x"][idx] = np.where(ok, first[:, done], np.nan).T
            out["converged"][idx] = (batch.streak[done] >= settle_periods) & ok
            out["periods"][idx] = period
            out["change"][idx] = change[done]
            out["harmonic_ratio"][idx] = _harmonic_ratio(first[:, done], mean[:, done], square[:, done]).T
            out["steps_per_period"][idx] = n_steps
            final["y"][:, idx] = batch.y[:, done]
            final["amp"][:, idx] = batch.amp[:, done]
            final["vel"][:, idx] = batch.vel[:, done]
            for k, state in enumerate(batch.states):
                if state is not None:
                    final["states"][k][idx] = state[done]
            if keep_history:
                n = ops.n_q
                x = ops.to_physical(np.moveaxis(samples[:, :n][..., done], 0, 1))
                v = ops.to_physical(np.moveaxis(samples[:, n:][..., done], 0, 1))
                for local, case in enumerate(idx):
                    out["history"][case] = np.stack([x[:, :, local], v[:, :, local]])
            batch = batch.take(~done)
        if batch.index.size == 0:
            break
    if keep_history:
        out["history"] = tuple(out["history"])
    return out, final


@dataclass(frozen=True)
class IntegrationOptions:
    """How a case is integrated and when it counts as settled: the options of
    :func:`~nlupdate.core.response.time_integration.steady_state_response` and
    :func:`~nlupdate.core.response.time_integration.time_sweep` (meanings in the former's
    docstring), with their defaults; checked on construction (:func:`check_options`)."""

    tolerance: float = 1e-6
    max_periods: int = 2000
    steps_per_period: int = 64
    settle_periods: int = 3
    courant: float = 1.0

    def __post_init__(self) -> None:
        check_options(self.tolerance, self.max_periods, self.steps_per_period, self.settle_periods, self.courant)


def check_options(
    tolerance: float, max_periods: int, steps_per_period: int, settle_periods: int, courant: float
) -> None:
    if not (np.isfinite(tolerance) and tolerance > 0):
        raise TimeIntegrationError(f"tolerance: expected a positive relative change, got {tolerance}")
    counts = (("max_periods", max_periods), ("steps_per_period", steps_per_period), ("settle_periods", settle_periods))
    for name, value in counts:
        if int(value) != value or value < 1:
            raise TimeIntegrationError(f"{name}: expected a positive integer, got {value}")
    if steps_per_period < 8:
        raise TimeIntegrationError(
            f"steps_per_period: at least 8 steps are needed for a first harmonic, got {steps_per_period}"
        )
    if not (0 < courant <= 2.5):
        raise TimeIntegrationError(f"courant: expected 0 < courant ≤ 2.5 (RK4 stability limit ≈ 2.8), got {courant}")


#: the integration options' defaults (the keywords of steady_state_response and time_sweep)
DEFAULT_INTEGRATION = IntegrationOptions()


def start_batch(
    system: NonlinearSystem,
    ops: Operators,
    omega: NDArray,
    forced: tuple[int, ...],
    force: NDArray,
    initial: ArrayLike | None,
) -> Batch:
    n_cases = omega.size
    if initial is None:
        q_amp = ops.linear_response(system.model, omega, forced, force)
    else:
        x0 = np.asarray(initial, dtype=complex)
        if x0.ndim == 1 and x0.size == ops.n_dof:
            x0 = np.broadcast_to(x0, (n_cases, ops.n_dof))
        if x0.shape != (n_cases, ops.n_dof):
            raise TimeIntegrationError(
                f"initial: expected complex amplitudes at all {ops.n_dof} dofs for each of the {n_cases} cases, "
                f"shape ({n_cases}, {ops.n_dof}), got {np.shape(initial)}"
            )
        if not np.all(np.isfinite(x0)):
            raise TimeIntegrationError("initial: amplitudes must be finite")
        x_all = np.ascontiguousarray(x0.T)
        q_amp = x_all if ops.identity else _modal_initial(ops, system.model, omega, forced, force, x_all)
    b_f = ops.input_columns(list(forced))
    xa_amp = ops.nonlinear_coordinates(q_amp)
    amp = np.array([np.abs(_relative(r, j, xa_amp)) for _, r, j in ops.elements]).reshape(len(ops.elements), n_cases)
    return Batch(
        index=np.arange(n_cases),
        omega=omega.copy(),
        y=np.concatenate([q_amp.real, -omega * q_amp.imag]),
        states=_initial_states(ops, q_amp, omega),
        bc=b_f @ force.real,
        bs=b_f @ force.imag,
        amp=amp,
        vel=amp * omega,
        previous=None,
        streak=np.zeros(n_cases, np.int64),
    )


