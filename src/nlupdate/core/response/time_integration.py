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

Vectorisation
-------------
Many (frequency, force) cases are integrated together: the state ``y = [q; q̇]`` has shape
``(2·n_coordinates, n_cases)`` and one numpy time-stepping loop advances all of them.
Every case takes the same number N of steps per period, so its step is ``dt = T/N`` with
its own period T, the forcing phase at step k is exactly ``2πk/N`` (the discrete system is
exactly periodic and a converged orbit repeats to round-off), and all cases reach a
period boundary together. Finished cases are dropped from the arrays at each boundary.

Time step (fixed-step classical RK4)
------------------------------------
RK4 is stable for ``|λ dt| ≲ 2.8`` on the imaginary and negative real axes. At each period
boundary and for each case we bound the spectral radius of the linearised system by
``ρ = √(λ_K + Σ_e k_e(A_e) w_e) + λ_C + λ_D/ω + Σ_e c_e(V_e) w_e`` where ``λ_K, λ_C, λ_D``
are the largest generalised eigenvalues of (K, M), (C, M), (D, M); ``k_e(A)`` is the
element's ``stiffness_bound`` at 1.5 × the largest relative displacement A_e seen in the
previous period (the initial amplitude for the first), ``c_e`` its ``damping_bound`` at 1.5 ×
its largest relative velocity (``2 cq V`` for a quadratic damper), and ``w_e = sᵀM⁻¹s`` for the
element's connectivity vector s (Weyl + Cauchy–Schwarz make this a true upper bound of the
largest natural frequency, |λ| ≤ max(√(k/m), c/m) for every eigenvalue). The step is
``dt ≤ courant/ρ`` (default ``courant = 1``: a factor 2.8 margin, which also covers a
cubic spring's amplitude growing by ×4 within one period), and at least
``steps_per_period`` steps (default 64: RK4 phase error of a free oscillation at ω about
``(2π)⁵/(120 N⁴)`` ≈ 5e-6 rad per period; near a resonance of quality factor Q the forced
amplitude error is about Q times that relative error).
The velocity terms of a :class:`~nlupdate.core.model.elements.PolynomialDF` are not in the bound (raise
``steps_per_period`` if they dominate the damping). Velocity-discontinuous laws (Coulomb
friction ``Fs·sign(ẋ)``) are integrated as given; use a Jenkins element with a stiff ``kf``
for sticking contacts.

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
from typing import Mapping, Sequence

import numpy as np
import scipy.linalg
import scipy.sparse
import scipy.sparse.linalg
from numpy.typing import ArrayLike, NDArray

from nlupdate.core.model.elements import NonlinearElement
from nlupdate.core.model.linear import LumpedModel, ModalModel, dof_index
from nlupdate.core.model.system import NonlinearSystem
from nlupdate.progress import ProgressCallback, no_progress

_DENSE_LIMIT = 2000
_MAX_STEPS_PER_PERIOD = 200_000
_PRECYCLE_POINTS = 256


class TimeIntegrationError(ValueError):
    """Bad input for the time integration (the message names the argument)."""


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
# linear operators in integration coordinates
# --------------------------------------------------------------------------------------
class _Operators:
    """First-order form ``ẏ = L y + [0; B f − A_D q̇/ω]`` with ``y = [q; q̇]``.

    ``L = [[0, I], [−A_K, −A_C]]`` with ``A_K = M⁻¹K, A_C = M⁻¹C, A_D = M⁻¹D, B = M⁻¹`` for a
    lumped model (q = x) and the diagonal modal matrices with ``B = Φᵀ``, ``x = Φ q`` for a
    modal model. ``lam_k, lam_c, lam_d`` are the largest eigenvalues of A_K, A_C, A_D.
    """

    def __init__(self, system: NonlinearSystem) -> None:
        model = system.model
        if isinstance(model, LumpedModel):
            a_k, a_c, a_d = self._lumped(model)
        elif isinstance(model, ModalModel):
            a_k, a_c, a_d = self._modal(model)
        else:
            raise TimeIntegrationError(
                f"system.model: time integration needs a LumpedModel or ModalModel, got {type(model).__name__}"
            )
        n = a_k.shape[0]
        self.n_q = n
        self.n_dof = model.n_dof
        sparse = scipy.sparse.issparse(a_k)
        stack = scipy.sparse.bmat if sparse else np.block
        zero = scipy.sparse.csr_matrix((n, n)) if sparse else np.zeros((n, n))
        eye = scipy.sparse.identity(n, format="csr") if sparse else np.eye(n)
        damping = a_c if a_c is not None else zero
        self.linear = stack([[zero, eye], [-a_k, -damping]])
        if sparse:
            self.linear = scipy.sparse.csr_matrix(self.linear)
        self.a_d = a_d
        self.a = system.nonlinear_dofs
        self.a_idx = np.array(self.a, dtype=np.int64)
        pos = {d: i for i, d in enumerate(self.a)}
        self.elements = [
            (e, pos[e.dofs[0]], pos[e.dofs[1]] if len(e.dofs) == 2 else -1) for e in system.elements
        ]
        self.p_a = None if self.identity else self.p[self.a_idx]
        self.b_a = self.input_columns(list(self.a))
        self.weights = np.array([self._connectivity_weight(e) for e, _, _ in self.elements])

    def _lumped(self, model: LumpedModel):
        n = model.n_dof
        self.identity = True
        self.p = None
        mats = [model.stiffness, model.damping, model.structural_damping]
        mass = model.mass
        if scipy.sparse.issparse(mass):
            off_diagonal = scipy.sparse.csr_matrix(mass - scipy.sparse.diags(mass.diagonal()))
            if off_diagonal.count_nonzero() == 0:
                diagonal = mass.diagonal()
                if np.any(diagonal <= 0):
                    raise TimeIntegrationError("system.model.mass: the diagonal mass matrix must be positive")
                scale = scipy.sparse.diags(1.0 / diagonal)
                self._inv_mass = lambda cols: scipy.sparse.csc_matrix(scale)[:, cols].toarray()
                self.lam_k, self.lam_c, self.lam_d = (self._largest_sparse(m, mass) for m in mats)
                ops = [None if m is None or m.count_nonzero() == 0 else scipy.sparse.csr_matrix(scale @ m) for m in mats]
                a_k = ops[0] if ops[0] is not None else scipy.sparse.csr_matrix((n, n))
                return a_k, ops[1], ops[2]
            if n > _DENSE_LIMIT:
                raise TimeIntegrationError(
                    f"system.model: a sparse model of {n} dofs with a non-diagonal mass matrix; "
                    "use model.to_modal(n_modes, coordinates) for time integration"
                )
            mass = mass.toarray()
            mats = [None if m is None else m.toarray() for m in mats]
        mass = np.asarray(mass, dtype=float)
        try:
            factor = scipy.linalg.cho_factor(mass)
        except np.linalg.LinAlgError as exc:
            raise TimeIntegrationError("system.model.mass: must be symmetric positive definite") from exc
        eye = np.eye(n)
        self._inv_mass = lambda cols: scipy.linalg.cho_solve(factor, eye[:, cols])
        self.lam_k, self.lam_c, self.lam_d = (
            0.0 if m is None else float(max(scipy.linalg.eigh(m, mass, eigvals_only=True)[-1], 0.0)) for m in mats
        )
        a_k, a_c, a_d = (
            None if m is None or not np.any(m) else scipy.linalg.cho_solve(factor, np.asarray(m, float)) for m in mats
        )
        return (a_k if a_k is not None else np.zeros((n, n))), a_c, a_d

    @staticmethod
    def _largest_sparse(matrix, mass) -> float:
        if matrix is None or matrix.count_nonzero() == 0:
            return 0.0
        if matrix.shape[0] < 3:
            return float(max(scipy.linalg.eigh(matrix.toarray(), mass.toarray(), eigvals_only=True)[-1], 0.0))
        value = scipy.sparse.linalg.eigsh(matrix, k=1, M=mass, which="LA", return_eigenvectors=False,
                                          v0=np.random.default_rng(0).standard_normal(matrix.shape[0]))
        return float(max(value[0], 0.0)) * (1 + 1e-6)  # Lanczos tolerance margin

    def _modal(self, model: ModalModel):
        wr = model.omega_r
        self.identity = False
        self.p = model.mode_shapes
        self._inv_mass = lambda cols: model.mode_shapes[cols].T
        c_r = 2 * model.damping_ratios * wr
        d_r = model.loss_factors * wr**2
        self.lam_k = float(np.max(wr**2, initial=0.0))
        self.lam_c = float(np.max(c_r, initial=0.0))
        self.lam_d = float(np.max(d_r, initial=0.0))
        return np.diag(wr**2), (np.diag(c_r) if np.any(c_r) else None), (np.diag(d_r) if np.any(d_r) else None)

    def input_columns(self, dofs: list[int]) -> NDArray[np.float64]:
        """``B[:, dofs]``: acceleration per unit force at ``dofs`` (M⁻¹ or Φᵀ columns)."""
        if not dofs:
            return np.zeros((self.n_q, 0))
        return np.asarray(self._inv_mass(dofs), dtype=float)

    def _connectivity_weight(self, element: NonlinearElement) -> float:
        """``sᵀM⁻¹s`` (lumped) or ``|Φᵀs|²`` (modal) for the element's connectivity vector s."""
        cols = list(element.dofs)
        b = self.input_columns(cols)
        s = np.array([1.0, -1.0])[: len(cols)]
        if self.identity:
            return float(s @ b[cols] @ s)
        v = b @ s
        return float(v @ v)

    def to_physical(self, q: NDArray) -> NDArray:
        """Physical displacements from integration coordinates (first axis)."""
        if self.identity:
            return q
        return np.tensordot(self.p, q, axes=(1, 0))

    def nonlinear_coordinates(self, q: NDArray) -> NDArray:
        """Displacements at the nonlinear dofs (first axis of q is the coordinate)."""
        return q[self.a_idx] if self.identity else np.tensordot(self.p_a, q, axes=(1, 0))

    def linear_response(self, model, omega: NDArray, forced: tuple[int, ...], force: NDArray) -> NDArray:
        """Linear first harmonics in integration coordinates, (n_q, n_cases)."""
        if self.identity:
            h = model.receptance(omega, list(range(model.n_dof)), list(forced))
            return np.einsum("cdf,fc->dc", h, force)
        return (self.input_columns(list(forced)) @ force) / _modal_denominator(model, omega)

    def spectral_radius(self, omega: NDArray, amp: NDArray, vel: NDArray) -> NDArray:
        """Upper bound of |λ| of the linearised system per case (rad/s); see module docstring."""
        stiff = np.full(omega.shape, self.lam_k)
        damp = self.lam_c + self.lam_d / omega
        for index, (element, _, _) in enumerate(self.elements):
            w = self.weights[index]
            bound = np.asarray(element.stiffness_bound(1.5 * amp[index]), float)
            stiff = stiff + w * np.broadcast_to(bound, omega.shape)
            damp = damp + w * np.asarray(element.damping_bound(1.5 * vel[index]), float)
        return np.sqrt(np.maximum(stiff, 0.0)) + damp


def _modal_denominator(model: ModalModel, omega: NDArray) -> NDArray:
    wr, zeta, eta = model.omega_r[:, None], model.damping_ratios[:, None], model.loss_factors[:, None]
    w = omega[None, :]
    return wr**2 - w**2 + 1j * (2 * zeta * wr * w + eta * wr**2)


# --------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------
def _forcing_matrix(system: NonlinearSystem, forcing: Mapping[int | str, ArrayLike], n_cases: int):
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


def _check_omega(omega: ArrayLike, name: str) -> NDArray[np.float64]:
    w = np.atleast_1d(np.asarray(omega, dtype=float))
    if w.ndim != 1 or w.size == 0 or not np.all(np.isfinite(w)) or np.any(w <= 0):
        raise TimeIntegrationError(f"{name}: expected a 1-D array of positive angular frequencies (rad/s), got {omega!r}")
    return w


def _relative(r: int, j: int, xa: NDArray) -> NDArray:
    return xa[r] - xa[j] if j >= 0 else xa[r]


def _modal_initial(ops: _Operators, model: ModalModel, omega, forced, force, x_all) -> NDArray:
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
    return rhs / _modal_denominator(model, omega)


def _initial_states(ops: _Operators, q_amp: NDArray, omega: NDArray) -> list:
    """Element states after two cycles of the initial harmonic motion, ending at phase 0."""
    n_cases = q_amp.shape[1]
    xa_amp = ops.nonlinear_coordinates(q_amp)
    states = []
    theta = 2 * np.pi * np.arange(1, 2 * _PRECYCLE_POINTS + 1) / _PRECYCLE_POINTS
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
class _Batch:
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

    def take(self, keep: NDArray) -> "_Batch":
        return _Batch(
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


def _derivative(ops: _Operators, batch: _Batch, y: NDArray, c: float, s: float, inv_w: NDArray, complex_force: bool):
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
        xa = ops.nonlinear_coordinates(y[:n])
        va = ops.nonlinear_coordinates(y[n:])
        g = np.zeros_like(xa)
        for index, (element, r, j) in enumerate(ops.elements):
            f, _ = element.force(_relative(r, j, xa), _relative(r, j, va), batch.states[index], batch.omega)
            g[r] += f
            if j >= 0:
                g[j] -= f
        acc -= ops.b_a @ g
    return k


def _commit_states(ops: _Operators, batch: _Batch, y: NDArray) -> None:
    """Return mapping at the end of a step: commit the new element states."""
    n = ops.n_q
    xa = ops.nonlinear_coordinates(y[:n])
    va = ops.nonlinear_coordinates(y[n:])
    for index, (element, r, j) in enumerate(ops.elements):
        if batch.states[index] is not None:
            _, batch.states[index] = element.force(
                _relative(r, j, xa), _relative(r, j, va), batch.states[index], batch.omega
            )


def _one_period(ops: _Operators, batch: _Batch, n_steps: int):
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


def _period_harmonics(ops: _Operators, samples: NDArray):
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


def _integrate(
    ops: _Operators,
    batch: _Batch,
    *,
    tolerance: float,
    max_periods: int,
    steps_per_period: int,
    settle_periods: int,
    courant: float,
    keep_history: bool,
):
    """Period-by-period integration of a batch until every case converged or stopped.

    Returns the result fields (without omega) and the final state of every case.
    """
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
        if n_steps > _MAX_STEPS_PER_PERIOD:
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


def _check_options(
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


def _start_batch(
    system: NonlinearSystem,
    ops: _Operators,
    omega: NDArray,
    forced: tuple[int, ...],
    force: NDArray,
    initial: ArrayLike | None,
) -> _Batch:
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
    return _Batch(
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


# --------------------------------------------------------------------------------------
# public API
# --------------------------------------------------------------------------------------
def steady_state_response(
    system: NonlinearSystem,
    forcing: Mapping[int | str, ArrayLike],
    omega: ArrayLike,
    *,
    initial: ArrayLike | None = None,
    tolerance: float = 1e-6,
    max_periods: int = 2000,
    steps_per_period: int = 64,
    settle_periods: int = 3,
    courant: float = 1.0,
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
    _check_options(tolerance, max_periods, steps_per_period, settle_periods, courant)
    omega = _check_omega(omega, "omega")
    ops = _Operators(system)
    forced, force = _forcing_matrix(system, forcing, omega.size)
    batch = _start_batch(system, ops, omega, forced, force, initial)
    out, _ = _integrate(
        ops,
        batch,
        tolerance=tolerance,
        max_periods=max_periods,
        steps_per_period=steps_per_period,
        settle_periods=settle_periods,
        courant=courant,
        keep_history=keep_history,
    )
    return SteadyStateResult(omega=omega, **out)


def time_sweep(
    system: NonlinearSystem,
    forcing: Mapping[int | str, ArrayLike],
    omega_grid: ArrayLike,
    direction: str = "up",
    *,
    initial: ArrayLike | None = None,
    jump_threshold: float = 0.25,
    tolerance: float = 1e-6,
    max_periods: int = 2000,
    steps_per_period: int = 64,
    settle_periods: int = 3,
    courant: float = 1.0,
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
    _check_options(tolerance, max_periods, steps_per_period, settle_periods, courant)
    grid = np.sort(_check_omega(omega_grid, "omega_grid"))
    ops = _Operators(system)
    forced, force = _forcing_matrix(system, forcing, grid.size)
    b_f = ops.input_columns(list(forced))
    order = np.arange(grid.size) if direction == "up" else np.arange(grid.size)[::-1]
    x = np.full((grid.size, ops.n_dof), np.nan + 0j)
    converged = np.zeros(grid.size, bool)
    periods = np.zeros(grid.size, np.int64)
    ratio = np.full((grid.size, ops.n_dof), np.nan)
    jumps: list[float] = []
    options = dict(
        tolerance=tolerance,
        max_periods=max_periods,
        steps_per_period=steps_per_period,
        settle_periods=settle_periods,
        courant=courant,
        keep_history=False,
    )

    def dwell(index: int, start: dict | None):
        w = grid[index : index + 1]
        f = force[:, index : index + 1]
        if start is None:
            batch = _start_batch(system, ops, w, forced, f, None if initial is None else np.atleast_2d(initial))
        else:
            batch = _Batch(
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
        return _integrate(ops, batch, **options)

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
