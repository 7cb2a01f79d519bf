"""The linear operators of a model integrated in time, and the RK4 step they allow
(:mod:`nlupdate.core.response.time_integration`).

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
"""
from __future__ import annotations

import numpy as np
import scipy.linalg
import scipy.sparse
import scipy.sparse.linalg
from numpy.typing import NDArray

from nlupdate.core.model.elements import NonlinearElement
from nlupdate.core.model.linear import LumpedModel, ModalModel
from nlupdate.core.model.system import NonlinearSystem

#: Above this many coordinates a lumped model is kept sparse (diagonal mass matrix).
DENSE_LIMIT = 2000


class TimeIntegrationError(ValueError):
    """Bad input for the time integration (the message names the argument)."""


# --------------------------------------------------------------------------------------
# linear operators in integration coordinates
# --------------------------------------------------------------------------------------
class Operators:
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
        # rows of y = [q; q̇] holding the nonlinear dofs' displacements, then their velocities (q = x)
        self._motion_idx = np.concatenate([self.a_idx, n + self.a_idx]) if self.identity else None
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
            if n > DENSE_LIMIT:
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

    def nonlinear_motion(self, y: NDArray) -> tuple[NDArray, NDArray]:
        """Displacements and velocities at the nonlinear dofs from states ``y = [q; q̇]``
        (2 n_q, n_cases): :meth:`nonlinear_coordinates` of both halves, in one indexing for a
        lumped model (the time step's hot path)."""
        if self.identity:
            both = y[self._motion_idx]
            return both[:self.a_idx.size], both[self.a_idx.size:]
        return self.p_a @ y[:self.n_q], self.p_a @ y[self.n_q:]

    def linear_response(self, model, omega: NDArray, forced: tuple[int, ...], force: NDArray) -> NDArray:
        """Linear first harmonics in integration coordinates, (n_q, n_cases)."""
        if self.identity:
            h = model.receptance(omega, list(range(model.n_dof)), list(forced))
            return np.einsum("cdf,fc->dc", h, force)
        return (self.input_columns(list(forced)) @ force) / modal_denominator(model, omega)

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


def modal_denominator(model: ModalModel, omega: NDArray) -> NDArray:
    wr, zeta, eta = model.omega_r[:, None], model.damping_ratios[:, None], model.loss_factors[:, None]
    w = omega[None, :]
    return wr**2 - w**2 + 1j * (2 * zeta * wr * w + eta * wr**2)


