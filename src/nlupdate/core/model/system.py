"""A nonlinear system: linear model + local nonlinear elements + harmonic forcing.

The single-harmonic balance ``(Z(ω) + Δ(X)) X = F`` is condensed to the nonlinear
coordinates ``a`` (docs/methods.md §3, receptance form)::

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
from nlupdate.core.model.elements import NonlinearElement, nonlinear_dofs
from nlupdate.core.model.linear import LinearModel, ReceptancePlan, dof_index


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


@dataclass(frozen=True)
class LinearTerms:
    """The linear part of the condensed balance at P frequencies ω (rad/s): ``H_aa`` (P, n, n),
    ``X_lin = H_af F`` (P, n) (m), and with ``derivative`` their ω-derivatives (else None).

    They do not change while Newton iterates at fixed frequencies, so batched solvers
    compute them once per frequency and pass them on (:meth:`take` selects points)."""

    omega: NDArray[np.float64]
    h_aa: NDArray[np.complex128]
    x_lin: NDArray[np.complex128]
    dh_aa: NDArray[np.complex128] | None = None
    dx_lin: NDArray[np.complex128] | None = None

    def take(self, index: NDArray) -> "LinearTerms":
        return LinearTerms(*(None if value is None else value[index] for value in
                             (self.omega, self.h_aa, self.x_lin, self.dh_aa, self.dx_lin)))


class CondensedProblem:
    """Residual and Jacobians of the condensed harmonic balance at one force vector.

    Every evaluation is batched over P points (frequencies and states as arrays); the
    single-point methods are the batch of one. It implements
    :class:`~nlupdate.core.response.balance.BalanceProblem`.
    """

    def __init__(self, system: NonlinearSystem, forcing: Mapping[int | str, complex], x_scale: float = 1.0) -> None:
        self.system = system
        self.model = system.model
        self.a = system.nonlinear_dofs
        self.n = len(self.a)
        self.forced, self.force = forcing_vector(system, forcing)
        self.x_scale = float(x_scale)
        position = {dof: i for i, dof in enumerate(self.a)}
        self.element_index = [
            (element, position[element.dofs[0]], position[element.dofs[1]] if len(element.dofs) == 2 else -1)
            for element in system.elements
        ]
        self._cols = list(self.a) + list(self.forced)
        self._plan = ReceptancePlan(self.model, self.a, self._cols)

    # -- linear part -------------------------------------------------------------------
    def linear_batch(self, omega: ArrayLike, derivative: bool = True) -> LinearTerms:
        """:class:`LinearTerms` at every ω (rad/s) of ``omega``."""
        omega = np.atleast_1d(np.asarray(omega, dtype=float))
        n = self.n
        result = self._plan(omega, derivative)
        h, dh = result if derivative else (result, None)
        terms = [h[:, :, :n], h[:, :, n:] @ self.force]
        if derivative:
            terms += [dh[:, :, :n], dh[:, :, n:] @ self.force]
        return LinearTerms(omega, *terms)

    def linear_terms(self, omega: float, derivative: bool = True):
        """``H_aa``, ``X_lin = H_af F`` (and their ω-derivatives) at one ω (rad/s)."""
        terms = self.linear_batch(omega, derivative).take(0)
        if derivative:
            return terms.h_aa, terms.x_lin, terms.dh_aa, terms.dx_lin
        return terms.h_aa, terms.x_lin

    def linear_response(self, omega: ArrayLike, dofs: Sequence[int]) -> NDArray[np.complex128]:
        """Response of the underlying linear system (m) at ``dofs``, shape (n_omega, len(dofs))."""
        h = self.model.receptance(np.atleast_1d(omega), list(dofs), list(self.forced))
        return h @ self.force

    # -- nonlinear forces ---------------------------------------------------------------
    def forces_batch(self, x: NDArray, omega: NDArray, jacobian: bool = False):
        """Element forces ``g`` (P, n) (N) at the a-coordinates for complex amplitudes ``x``
        (P, n) (m) at ω (P,) (rad/s); with ``jacobian=True`` also ``∂g/∂Re x``, ``∂g/∂Im x``
        (P, n, n) and ``∂g/∂ω`` (P, n)."""
        x = np.asarray(x, dtype=complex)
        omega = np.asarray(omega, dtype=float)
        points, n = x.shape
        g = np.zeros((points, n), dtype=complex)
        if jacobian:
            dg_dre = np.zeros((points, n, n), dtype=complex)
            dg_dim = np.zeros((points, n, n), dtype=complex)
            dg_dw = np.zeros((points, n), dtype=complex)
        for element, r, j in self.element_index:
            u = x[:, r] - x[:, j] if j >= 0 else x[:, r]
            amplitude = np.abs(u)
            nu = np.asarray(element.describing_function(amplitude, omega), dtype=complex)
            f = nu * u
            g[:, r] += f
            if j >= 0:
                g[:, j] -= f
            if not jacobian:
                continue
            dnu_da, dnu_dw = element.describing_function_derivatives(amplitude, omega)
            # ∂(ν(|u|)u)/∂Re u = ν + u ν' Re u/|u| (and Im); at u = 0 only ν
            along = np.divide(u * dnu_da, amplitude, out=np.zeros_like(u), where=amplitude > 0)
            df_dure = nu + along * u.real
            df_duim = 1j * nu + along * u.imag
            df_dw = dnu_dw * u
            pairs = ((r, 1.0), (j, -1.0)) if j >= 0 else ((r, 1.0),)
            for row, row_sign in pairs:
                dg_dw[:, row] += row_sign * df_dw
                for col, col_sign in pairs:
                    dg_dre[:, row, col] += row_sign * col_sign * df_dure
                    dg_dim[:, row, col] += row_sign * col_sign * df_duim
        if jacobian:
            return g, dg_dre, dg_dim, dg_dw
        return g

    def forces(self, x: NDArray, omega: float, jacobian: bool = False):
        """:meth:`forces_batch` at one point: ``g`` (n,) and with ``jacobian`` its derivatives."""
        result = self.forces_batch(np.asarray(x, dtype=complex)[None], np.array([omega], dtype=float), jacobian)
        return tuple(part[0] for part in result) if jacobian else result[0]

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
        """Complex amplitudes (m), (…, n), from scaled unknowns (…, 2n)."""
        y = np.asarray(y)
        return (y[..., : self.n] + 1j * y[..., self.n :]) * self.x_scale

    def to_real(self, x: NDArray) -> NDArray[np.float64]:
        """Scaled unknowns (…, 2n) from complex amplitudes (…, n) (m)."""
        x = np.asarray(x, dtype=complex) / self.x_scale
        return np.concatenate([x.real, x.imag], axis=-1)

    def residual(self, y: NDArray, omega: float) -> NDArray[np.float64]:
        x = self.to_complex(y)
        h_aa, x_lin = self.linear_terms(omega, derivative=False)
        r = (x - x_lin + h_aa @ self.forces(x, omega)) / self.x_scale
        return np.concatenate([r.real, r.imag])

    def residual_batch(self, y: NDArray, linear: LinearTerms, jacobian: bool = True, scale: NDArray | None = None):
        """Scaled residuals (P, 2n) at states ``y`` (P, 2n) and the frequencies of ``linear``;
        with ``jacobian`` also ``∂R/∂y`` (P, 2n, 2n) and, when ``linear`` has derivatives,
        ``∂R/∂ω`` (P, 2n, per rad/s; else None). ``scale`` (P,) replaces ``x_scale`` point by
        point (several force levels evaluated together)."""
        y = np.asarray(y, dtype=float)
        x_scale = self.x_scale if scale is None else np.asarray(scale, dtype=float)[:, None]
        x = (y[:, : self.n] + 1j * y[:, self.n :]) * x_scale
        with_w = jacobian and linear.dh_aa is not None
        if not jacobian:
            g = self.forces_batch(x, linear.omega)
            r = (x - linear.x_lin + (linear.h_aa @ g[..., None])[..., 0]) / x_scale
            return np.concatenate([r.real, r.imag], axis=1)
        g, dg_dre, dg_dim, dg_dw = self.forces_batch(x, linear.omega, jacobian=True)
        h_aa = linear.h_aa
        r = (x - linear.x_lin + (h_aa @ g[..., None])[..., 0]) / x_scale
        eye = np.eye(self.n)
        d_re = eye + h_aa @ dg_dre
        d_im = 1j * eye + h_aa @ dg_dim
        n = self.n
        jac = np.empty((x.shape[0], 2 * n, 2 * n))
        jac[:, :n, :n], jac[:, :n, n:], jac[:, n:, :n], jac[:, n:, n:] = d_re.real, d_im.real, d_re.imag, d_im.imag
        jac_w = None
        if with_w:
            d_w = -linear.dx_lin + (linear.dh_aa @ g[..., None] + h_aa @ dg_dw[..., None])[..., 0]
            d_w = d_w / x_scale
            jac_w = np.concatenate([d_w.real, d_w.imag], axis=1)
        return np.concatenate([r.real, r.imag], axis=1), jac, jac_w

    def residual_and_jacobians(self, y: NDArray, omega: float):
        """Scaled residual, ``∂R/∂y`` (2n×2n) and ``∂R/∂ω`` (2n, per rad/s) at one point."""
        r, jac, jac_w = self.residual_batch(np.asarray(y, dtype=float)[None], self.linear_batch(omega))
        return r[0], jac[0], jac_w[0]

    def response_at(self, omega: ArrayLike, x_a: NDArray, dofs: Sequence[int]) -> NDArray[np.complex128]:
        """Complex amplitudes (m) at any ``dofs`` from solved ``x_a`` (n_omega × n) at ``omega``."""
        omega = np.atleast_1d(np.asarray(omega, dtype=float))
        x_a = np.atleast_2d(x_a)
        dofs = list(dofs)
        h_bf = self.model.receptance(omega, dofs, list(self.forced))
        out = h_bf @ self.force
        if self.n:
            h_ba = self.model.receptance(omega, dofs, list(self.a))
            g = self.forces_batch(x_a, omega)
            out = out - np.einsum("wbk,wk->wb", h_ba, g)
        return out


def newton_batch(
    problem,
    linear,
    y0: NDArray,
    tol: float = 1e-10,
    max_iter: int = 50,
) -> tuple[NDArray, NDArray[np.bool_], NDArray[np.int64]]:
    """Damped Newton on ``R(y, ω) = 0`` at P fixed frequencies at once (backtracking on ‖R‖).

    ``linear`` holds the frequencies' linear terms (``problem.linear_batch(ω)``, computed
    once), ``y0`` the starting states (P, size). Each point: full Newton step, halved until
    ‖R‖∞ falls, at most three times (then the eighth step is taken: a point circling a kink
    of its describing function — a stick–slip onset — would otherwise cost thirteen batched
    evaluations of one or two points per iteration, most of a sweep's time), the tolerance
    on ‖R‖∞ in scaled units. Returns ``(y, converged, iterations)``. The points share the
    numpy calls, so the cost per point falls with P.
    """
    y = np.array(y0, dtype=float, ndmin=2)
    points = y.shape[0]
    r, jac, _ = problem.residual_batch(y, linear)
    norm = np.max(np.abs(r), axis=1)
    iterations = np.zeros(points, np.int64)
    failed = np.zeros(points, bool)
    active = np.flatnonzero(norm >= tol)
    for iteration in range(1, max_iter + 1):
        if active.size == 0:
            break
        iterations[active] = iteration
        step = solve_batch(jac[active], -r[active])
        singular = ~np.all(np.isfinite(step), axis=1)
        failed[active[singular]] = True
        active, step = active[~singular], step[~singular]
        factor = np.ones(active.size)
        pending = np.arange(active.size)
        while pending.size:  # backtracking, per point
            rows = active[pending]
            trial = y[rows] + factor[pending, None] * step[pending]
            r_trial, jac_trial, _ = problem.residual_batch(trial, linear.take(rows))
            norm_trial = np.max(np.abs(r_trial), axis=1)
            accept = (norm_trial < norm[rows]) | (norm_trial < tol) | (factor[pending] <= 0.125)
            done = rows[accept]
            y[done], r[done], jac[done], norm[done] = trial[accept], r_trial[accept], jac_trial[accept], norm_trial[accept]
            factor[pending[~accept]] *= 0.5
            pending = pending[~accept]
        active = active[norm[active] >= tol]
    return y, (norm < tol) & ~failed, iterations


def solve_batch(matrices: NDArray, rhs: NDArray) -> NDArray:
    """Solutions of P small systems; rows whose matrix is singular come back as NaN."""
    try:
        return np.linalg.solve(matrices, rhs[..., None])[..., 0]
    except np.linalg.LinAlgError:
        out = np.full(rhs.shape, np.nan)
        for index, (matrix, b) in enumerate(zip(matrices, rhs)):
            try:
                out[index] = np.linalg.solve(matrix, b)
            except np.linalg.LinAlgError:
                pass
        return out


def newton_fixed_frequency(
    problem,
    omega: float,
    y0: NDArray,
    tol: float = 1e-10,
    max_iter: int = 50,
) -> tuple[NDArray, bool, int]:
    """Damped Newton on ``R(y, ω) = 0`` at one fixed ω (:func:`newton_batch` of one point).

    Returns ``(y, converged, iterations)``. Tolerance is on ‖R‖∞ in scaled units.
    """
    y, converged, iterations = newton_batch(problem, problem.linear_batch(omega), np.asarray(y0)[None], tol, max_iter)
    return y[0], bool(converged[0]), int(iterations[0])
