"""A nonlinear system: linear model + local nonlinear elements + harmonic forcing.

The single-harmonic balance ``(Z(ω) + Δ(X)) X = F`` is condensed to the nonlinear
coordinates ``a`` (METHODS §3, receptance form)::

    R(X_a, ω) = X_a − H_af(ω) F_f + H_aa(ω) g(X_a, ω) = 0,

where ``g = Δ X`` collects the first-harmonic element forces at ``a``. Its size is the
number of nonlinear coordinates, whatever the size of the linear model. Any other
coordinate follows from ``X_b = H_bf F_f − H_ba g(X_a)``.

Newton-type solvers work on real unknowns ``y = [Re X_a, Im X_a] / x_scale`` so that
amplitudes are O(1); :class:`CondensedProblem` returns the residual ``R / x_scale``
and its real Jacobians with respect to ``y`` and ω.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nlupdate.fingerprints import fingerprint
from nlupdate.model.elements import NonlinearElement, nonlinear_dofs
from nlupdate.model.linear import LinearModel, dof_index


@dataclass(frozen=True, eq=False)
class NonlinearSystem:
    """A linear model with local nonlinear elements attached to some of its dofs."""

    model: LinearModel
    elements: tuple[NonlinearElement, ...] = field(default=())

    def __post_init__(self) -> None:
        object.__setattr__(self, "elements", tuple(self.elements))
        for element in self.elements:
            for dof in element.dofs:
                if not 0 <= dof < self.model.n_dof:
                    raise ValueError(
                        f"{type(element).__name__} on dofs {list(element.dofs)}: dof {dof} does not exist "
                        f"(the model has {self.model.n_dof} dofs)"
                    )

    @property
    def nonlinear_dofs(self) -> tuple[int, ...]:
        return nonlinear_dofs(self.elements)

    def fingerprint(self) -> str:
        return fingerprint(self.model.fingerprint(), self.elements, length=16)

    def with_elements(self, elements: Sequence[NonlinearElement]) -> "NonlinearSystem":
        return NonlinearSystem(self.model, tuple(elements))


def forcing_vector(system: NonlinearSystem, forcing: Mapping[int | str, complex]) -> tuple[tuple[int, ...], NDArray]:
    """Forced dof indices and complex force amplitudes (N) from ``{dof: amplitude}``."""
    if not forcing:
        raise ValueError("forcing is empty: give at least one {dof: force amplitude in N}")
    dofs = tuple(dof_index(system.model, dof) for dof in forcing)
    return dofs, np.array([complex(value) for value in forcing.values()])


class CondensedProblem:
    """Residual and Jacobians of the condensed harmonic balance at one force vector."""

    def __init__(self, system: NonlinearSystem, forcing: Mapping[int | str, complex], x_scale: float = 1.0) -> None:
        self.system = system
        self.model = system.model
        self.a = system.nonlinear_dofs
        self.n = len(self.a)
        self.forced, self.force = forcing_vector(system, forcing)
        self.x_scale = float(x_scale)
        position = {dof: i for i, dof in enumerate(self.a)}
        self._element_index = [
            (element, position[element.dofs[0]], position[element.dofs[1]] if len(element.dofs) == 2 else -1)
            for element in system.elements
        ]
        self._cols = list(self.a) + list(self.forced)

    # -- linear part -------------------------------------------------------------------
    def linear_terms(self, omega: float, derivative: bool = True):
        """``H_aa``, ``X_lin = H_af F`` (and their ω-derivatives) at one ω (rad/s)."""
        result = self.model.receptance(omega, self.a, self._cols, derivative=derivative)
        if derivative:
            h, dh = result
            h, dh = h[0], dh[0]
            return h[:, : self.n], h[:, self.n :] @ self.force, dh[:, : self.n], dh[:, self.n :] @ self.force
        h = result[0]
        return h[:, : self.n], h[:, self.n :] @ self.force

    def linear_response(self, omega: ArrayLike, dofs: Sequence[int]) -> NDArray[np.complex128]:
        """Response of the underlying linear system (m) at ``dofs``, shape (n_omega, len(dofs))."""
        h = self.model.receptance(np.atleast_1d(omega), list(dofs), list(self.forced))
        return h @ self.force

    # -- nonlinear forces ---------------------------------------------------------------
    def forces(self, x: NDArray, omega: float, jacobian: bool = False):
        """Element forces ``g`` (N) at the a-coordinates for complex amplitudes ``x`` (m).

        With ``jacobian=True`` also ``∂g/∂Re x``, ``∂g/∂Im x`` (complex n×n) and ``∂g/∂ω``.
        """
        n = self.n
        g = np.zeros(n, dtype=complex)
        if jacobian:
            dg_dre = np.zeros((n, n), dtype=complex)
            dg_dim = np.zeros((n, n), dtype=complex)
            dg_dw = np.zeros(n, dtype=complex)
        for element, r, j in self._element_index:
            u = x[r] - x[j] if j >= 0 else x[r]
            amplitude = abs(u)
            nu = complex(element.describing_function(amplitude, omega))
            f = nu * u
            g[r] += f
            if j >= 0:
                g[j] -= f
            if not jacobian:
                continue
            dnu_da, dnu_dw = element.describing_function_derivatives(amplitude, omega)
            dnu_da, dnu_dw = complex(dnu_da), complex(dnu_dw)
            if amplitude > 0:
                df_dure = nu + u * dnu_da * u.real / amplitude
                df_duim = 1j * nu + u * dnu_da * u.imag / amplitude
            else:
                df_dure, df_duim = nu, 1j * nu
            pairs = ((r, 1.0), (j, -1.0)) if j >= 0 else ((r, 1.0),)
            for row, row_sign in pairs:
                dg_dw[row] += row_sign * dnu_dw * u
                for col, col_sign in pairs:
                    dg_dre[row, col] += row_sign * col_sign * df_dure
                    dg_dim[row, col] += row_sign * col_sign * df_duim
        if jacobian:
            return g, dg_dre, dg_dim, dg_dw
        return g

    # -- residual -----------------------------------------------------------------------
    @property
    def size(self) -> int:
        """Number of real unknowns."""
        return 2 * self.n

    def initial_guesses(self, omega: float) -> tuple[NDArray, NDArray]:
        """Starting guesses for Newton at ω: the linear response, then zero."""
        _, x_lin = self.linear_terms(omega, derivative=False)
        return self.to_real(x_lin), np.zeros(self.size)

    def to_complex(self, y: NDArray) -> NDArray[np.complex128]:
        return (y[: self.n] + 1j * y[self.n :]) * self.x_scale

    def to_real(self, x: NDArray) -> NDArray[np.float64]:
        x = np.asarray(x, dtype=complex) / self.x_scale
        return np.concatenate([x.real, x.imag])

    def residual(self, y: NDArray, omega: float) -> NDArray[np.float64]:
        x = self.to_complex(y)
        h_aa, x_lin = self.linear_terms(omega, derivative=False)
        r = (x - x_lin + h_aa @ self.forces(x, omega)) / self.x_scale
        return np.concatenate([r.real, r.imag])

    def residual_and_jacobians(self, y: NDArray, omega: float):
        """Scaled residual, ``∂R/∂y`` (2n×2n) and ``∂R/∂ω`` (2n, per rad/s)."""
        x = self.to_complex(y)
        h_aa, x_lin, dh_aa, dx_lin = self.linear_terms(omega, derivative=True)
        g, dg_dre, dg_dim, dg_dw = self.forces(x, omega, jacobian=True)
        r = (x - x_lin + h_aa @ g) / self.x_scale
        eye = np.eye(self.n)
        d_re = eye + h_aa @ dg_dre
        d_im = 1j * eye + h_aa @ dg_dim
        d_w = (-dx_lin + dh_aa @ g + h_aa @ dg_dw) / self.x_scale
        n = self.n
        jac = np.empty((2 * n, 2 * n))
        jac[:n, :n], jac[:n, n:], jac[n:, :n], jac[n:, n:] = d_re.real, d_im.real, d_re.imag, d_im.imag
        return np.concatenate([r.real, r.imag]), jac, np.concatenate([d_w.real, d_w.imag])

    def response_at(self, omega: ArrayLike, x_a: NDArray, dofs: Sequence[int]) -> NDArray[np.complex128]:
        """Complex amplitudes (m) at any ``dofs`` from solved ``x_a`` (n_omega × n) at ``omega``."""
        omega = np.atleast_1d(np.asarray(omega, dtype=float))
        x_a = np.atleast_2d(x_a)
        dofs = list(dofs)
        h_bf = self.model.receptance(omega, dofs, list(self.forced))
        out = h_bf @ self.force
        if self.n:
            h_ba = self.model.receptance(omega, dofs, list(self.a))
            g = np.array([self.forces(x, w) for x, w in zip(x_a, omega)])
            out = out - np.einsum("wbk,wk->wb", h_ba, g)
        return out


def newton_fixed_frequency(
    problem: CondensedProblem,
    omega: float,
    y0: NDArray,
    tol: float = 1e-10,
    max_iter: int = 50,
) -> tuple[NDArray, bool, int]:
    """Damped Newton on ``R(y, ω) = 0`` at fixed ω (backtracking on ‖R‖).

    Returns ``(y, converged, iterations)``. Tolerance is on ‖R‖∞ in scaled units.
    """
    y = np.array(y0, dtype=float)
    r, jac, _ = problem.residual_and_jacobians(y, omega)
    norm = np.max(np.abs(r))
    for iteration in range(1, max_iter + 1):
        if norm < tol:
            return y, True, iteration - 1
        try:
            step = np.linalg.solve(jac, -r)
        except np.linalg.LinAlgError:
            return y, False, iteration
        factor = 1.0
        while factor > 1e-4:
            trial = y + factor * step
            r_trial, jac_trial, _ = problem.residual_and_jacobians(trial, omega)
            norm_trial = np.max(np.abs(r_trial))
            if norm_trial < norm or norm_trial < tol:
                break
            factor *= 0.5
        y, r, jac, norm = trial, r_trial, jac_trial, norm_trial
    return y, norm < tol, max_iter
