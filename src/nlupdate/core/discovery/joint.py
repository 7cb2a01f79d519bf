"""Every effect at once: the joint refit of all effects found so far.

A candidate is fitted at its place with the rest of the model frozen
(:mod:`nlupdate.core.discovery.frf_fit`); once effects sit at several places, each one's values
were fitted against the others' frozen values, and an error in one (a slip force 6 % too
high) is soaked up by the next. The joint problem fits **every parameter of every effect
together** against the measurement, with each point solved exactly for all of them.

FRFs. At each measured point (force level, frequency) the single-harmonic balance of the
user's linear model with the user's elements and all effects is condensed on the
coordinates ``a`` the elements and effects act on (docs/methods.md §3, receptance form):

    R(X_a) = X_a − H_af F + H_aa g(X_a) = 0,   g = Σ_e s_e ν_e(|s_eᵀX_a|, ω) s_eᵀX_a,

with ``s_e`` the connectivity of an element (+1 at r, −1 at j) and H the receptances of the
user's linear model. Linear effects (stiffness, mass, damping errors) are exact as DFs here
(``ν = Δk``, ``−ω²Δm``, ``iωΔc``). R is solved per point by damped Newton (all points at
once, analytic in X, ``∂ν/∂A`` by central differences) started from the measured amplitudes
(the current model's at unmeasured coordinates), so each point takes the solution nearest
the measurement — the branch the test was on where the response is multi-valued. Then
``X_m = H_mf F − H_ma g(X_a)`` at the measured coordinates, and the residuals are those of
:mod:`nlupdate.core.discovery.frf_evidence` (``Σ r² = χ²``).

Modal tables. The single-mode phase-resonance model of :mod:`nlupdate.core.discovery.backbone_fit`
already solves all elements on the one modal coordinate; the joint problem is that model
with every effect's parameters free.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.discovery.candidates import FoundEffect
from nlupdate.core.discovery.fitting import fit_effects
from nlupdate.core.discovery.backbone_fit import _participation, element_terms, modal_residual, phase_resonance
from nlupdate.core.model.linear import ModalModel
from nlupdate.core.model.system import NonlinearSystem

DF = Callable[[NDArray, NDArray], NDArray]
_NEWTON_ITERATIONS = 40
_TOLERANCE = 1e-10
_DERIVATIVE_STEP = 1e-6


def _terms(fixed: Sequence, effects: Sequence[FoundEffect], values: Sequence[NDArray] | None = None):
    """``(dofs, ν(A, ω))`` of the user's elements and of the effects (at ``values``, or their own)."""
    terms = [(tuple(e.dofs), e.describing_function) for e in fixed]
    for k, found in enumerate(effects):
        v = np.asarray(found.values if values is None else values[k], dtype=float)
        terms.append((tuple(found.dofs), lambda a, w, effect=found.effect, v=v: effect.nu(v, a, w)))
    return terms


class JointFit:
    """Shared part: the joint refit of effects from their current values."""

    penalty: float

    def residual(self, effects: Sequence[FoundEffect], values: Sequence[NDArray] | None = None) -> NDArray[np.float64]:
        raise NotImplementedError

    def chi2(self, effects: Sequence[FoundEffect]) -> float:
        r = self.residual(effects)
        return float(np.sum(np.where(np.isfinite(r), r, 1e6) ** 2))

    def refit(self, effects: Sequence[FoundEffect], max_nfev: int = 30) -> tuple[tuple[FoundEffect, ...], float, bool]:
        """Every parameter of every effect fitted together from their current values;
        returns the refitted effects, χ² and whether the fit converged to finite values."""
        effects = list(effects)
        if not effects:
            return (), self.chi2(()), True
        start = [np.array(f.values, dtype=float) for f in effects]
        solve = getattr(self, "linearise", None)  # FRFJoint solves once for residual and Jacobian
        linearise = None if solve is None else (lambda v: solve(effects, v))
        values, chi2, ok = fit_effects(lambda v: self.residual(effects, v), [f.effect for f in effects], [start],
                                       max_nfev=max_nfev, refine=1, linearise=linearise)
        refitted = tuple(FoundEffect(f.effect, f.dofs, tuple(float(x) for x in v)) for f, v in zip(effects, values))
        return refitted, chi2, ok

    def criterion(self, effects: Sequence[FoundEffect], chi2: float) -> float:
        """χ² plus the criterion cost of the effects' parameters."""
        return chi2 + self.penalty * sum(len(f.effect.parameters) for f in effects)


@dataclass(frozen=True, eq=False)
class FRFJoint(JointFit):
    """The joint problem against stepped-sine FRFs (see module docstring).

    coords: model coordinates of ``h`` (measured, forced, elements'); h: receptances of the
    user's linear model (n, c, c); x_start: start amplitudes (n, c) (measured, else the
    current model's); scale: ``√(2/σ²)/|X̃|`` per measured value (n, m).
    """

    coords: tuple[int, ...]
    h: NDArray[np.complex128]
    input_column: int
    measured_columns: tuple[int, ...]
    omega: NDArray[np.float64]
    force: NDArray[np.float64]
    x_measured: NDArray[np.complex128]
    x_start: NDArray[np.complex128]
    scale: NDArray[np.float64]
    fixed: tuple
    penalty: float

    @classmethod
    def build(
        cls, system: NonlinearSystem, input_dof: int, response_dofs: Sequence[int], omega: NDArray, force: NDArray,
        x_measured: NDArray, x_current: Mapping[int, NDArray], chi2_scale: NDArray, penalty: float,
    ) -> "FRFJoint":
        """For ``system`` (the user's model and elements); effects may act on measured coordinates."""
        coords = tuple(dict.fromkeys(list(response_dofs) + [input_dof] + [d for e in system.elements for d in e.dofs]))
        h = system.model.receptance(omega, list(coords), list(coords))
        start = np.empty((omega.size, len(coords)), complex)
        for c, dof in enumerate(coords):
            if dof in response_dofs:
                start[:, c] = x_measured[:, list(response_dofs).index(dof)]
            elif dof in x_current:
                start[:, c] = x_current[dof]
            else:
                start[:, c] = h[:, c, coords.index(input_dof)] * force
        return cls(
            coords, h, coords.index(input_dof), tuple(coords.index(d) for d in response_dofs), omega, force,
            x_measured, start, np.sqrt(chi2_scale) / np.abs(x_measured), tuple(system.elements), penalty,
        )

    def _converged(self, terms: Sequence[tuple[tuple[int, ...], DF]]) -> tuple[_Condensed, NDArray[np.complex128]]:
        """The condensed problem of these terms and its solution X_a (n, k) by damped Newton."""
        dofs = sorted({d for term_dofs, _ in terms for d in term_dofs})
        a = [self.coords.index(d) for d in dofs]
        s = np.zeros((len(terms), len(a)))
        for t, (term_dofs, _) in enumerate(terms):
            s[t, dofs.index(term_dofs[0])] = 1.0
            if len(term_dofs) == 2:
                s[t, dofs.index(term_dofs[1])] = -1.0
        problem = _Condensed(a, s, self.h[:, a][:, :, a], self.h[:, :, self.input_column][:, a] * self.force[:, None],
                             self.omega)
        functions = [nu for _, nu in terms]
        x = self.x_start[:, a].copy()
        r = problem.residual(x, functions)
        size = np.linalg.norm(x, axis=1) + 1e-300
        with np.errstate(all="ignore"):
            for _ in range(_NEWTON_ITERATIONS):
                norm = np.linalg.norm(r, axis=1)
                active = np.isfinite(norm) & (norm > _TOLERANCE * size)
                if not active.any():
                    break
                _, d_re, d_im = problem.forces(x, functions, True)
                jac = problem.real_jacobian(d_re, d_im)
                rhs = -np.concatenate([r.real, r.imag], axis=1)
                singular = ~np.isfinite(jac).all(axis=(1, 2))
                jac[singular] = np.eye(jac.shape[-1])
                rhs[singular] = 0.0
                step = _solve_each(jac, rhs)
                step = step[:, : len(a)] + 1j * step[:, len(a):]
                factor = np.where(active, 1.0, 0.0)
                for _ in range(8):
                    trial = x + factor[:, None] * step
                    r_trial = problem.residual(trial, functions)
                    better = np.linalg.norm(r_trial, axis=1) < norm
                    if np.all(better | (factor == 0)):
                        break
                    factor = np.where(better | (factor == 0), factor, 0.5 * factor)
                accepted = np.linalg.norm(r_trial, axis=1) < norm
                x = np.where(accepted[:, None], trial, x)
                r = np.where(accepted[:, None], r_trial, r)
                size = np.linalg.norm(x, axis=1) + 1e-300
        with np.errstate(all="ignore"):
            problem.converged = np.linalg.norm(r, axis=1) <= _TOLERANCE * size
        return problem, x

    def _at_measured(self, terms, problem: _Condensed | None, x: NDArray | None) -> NDArray[np.complex128]:
        """``X_m = H_mf F − H_ma g(X_a)`` (n, m); the linear response without terms."""
        m = list(self.measured_columns)
        x_linear = self.h[:, m, self.input_column] * self.force[:, None]
        if problem is None:
            return x_linear
        g, _, _ = problem.forces(x, [nu for _, nu in terms], False)
        return x_linear - np.einsum("nij,nj->ni", self.h[:, m][:, :, problem.a], g)

    def solve(self, terms: Sequence[tuple[tuple[int, ...], DF]]) -> NDArray[np.complex128]:
        """Amplitudes (m) at the measured coordinates (n, m) with these element terms."""
        return self._at_measured(terms, *(self._converged(terms) if terms else (None, None)))

    def linearise(self, effects, values=None) -> "JointSolution":
        """These effects (at ``values``, else their own) solved at every point: gives the
        residual and its Jacobian from one solve."""
        terms = _terms(self.fixed, effects, values)
        problem, x = self._converged(terms) if terms else (None, None)
        return JointSolution(self, tuple(effects), terms, problem, x)

    def residual(self, effects, values=None):
        return self.linearise(effects, values).residual()


@dataclass(frozen=True, eq=False)
class JointSolution:
    """One solve of an :class:`FRFJoint` (problem and X_a None without any element term)."""

    joint: FRFJoint
    effects: tuple[FoundEffect, ...]
    terms: list
    problem: _Condensed | None
    x: NDArray[np.complex128] | None

    def residual(self) -> NDArray[np.float64]:
        r = (self.joint._at_measured(self.terms, self.problem, self.x) - self.joint.x_measured) * self.joint.scale
        return np.concatenate([r.real.ravel(), r.imag.ravel()])

    def jacobian(self, perturbed, steps) -> NDArray[np.float64]:
        """∂r/∂θ_j of :meth:`residual` (see :class:`nlupdate.core.discovery.fitting.Linearised`)
        by the implicit function theorem: at the solution, ``R(X_a, θ) = 0`` gives
        ``dX_a/dθ = −(∂R/∂X_a)⁻¹ H_aa ∂g/∂θ`` (∂R/∂X_a: Newton's own Jacobian), and
        ``dX_m = −H_ma (∂g/∂X_a dX_a + ∂g/∂θ)``; ∂g/∂θ is a forward difference of the DFs
        at the solved amplitudes. Where Newton did not converge, X_a is held fixed."""
        joint, problem, x = self.joint, self.problem, self.x
        functions = [nu for _, nu in self.terms]
        g, d_re, d_im = problem.forces(x, functions, True)
        jac = problem.real_jacobian(d_re, d_im)
        h_ma = joint.h[:, list(joint.measured_columns)][:, :, problem.a]
        k = len(problem.a)
        columns = []
        with np.errstate(all="ignore"):
            for stepped, step in zip(perturbed, steps):
                g_stepped, _, _ = problem.forces(x, [nu for _, nu in _terms(joint.fixed, self.effects, stepped)], False)
                g_theta = (g_stepped - g) / step
                moved = np.einsum("nij,nj->ni", problem.h_aa, g_theta)
                dx = -_solve_each(jac, np.concatenate([moved.real, moved.imag], axis=1))
                dx[~problem.converged] = 0.0  # an unconverged point is no solution to follow
                dg = (np.einsum("nij,nj->ni", d_re, dx[:, :k]) + np.einsum("nij,nj->ni", d_im, dx[:, k:]) + g_theta)
                d_r = -np.einsum("nij,nj->ni", h_ma, dg) * joint.scale
                columns.append(np.concatenate([d_r.real.ravel(), d_r.imag.ravel()]))
        return np.stack(columns, axis=1)


@dataclass
class _Condensed:
    """The FRF problem condensed on the coordinates ``a`` (indices into the joint's coords):
    connectivities s (terms, k), H_aa (n, k, k), the linear response X_a^L (n, k), ω (n,)."""

    a: list[int]
    s: NDArray[np.float64]
    h_aa: NDArray[np.complex128]
    x_linear: NDArray[np.complex128]
    omega: NDArray[np.float64]
    #: per point: Newton met its tolerance (set by :meth:`FRFJoint._converged`)
    converged: NDArray[np.bool_] | None = None

    def forces(self, x: NDArray, functions: Sequence[DF], jacobian: bool):
        """g(X_a) (n, k) and, with ``jacobian``, ∂g/∂Re X_a and ∂g/∂Im X_a (n, k, k)."""
        k = self.s.shape[1]
        g = np.zeros_like(x)
        d_re = np.zeros(x.shape + (k,), complex) if jacobian else None
        d_im = np.zeros(x.shape + (k,), complex) if jacobian else None
        for s_t, nu in zip(self.s, functions):
            u = x @ s_t
            amplitude = np.maximum(np.abs(u), 1e-300)
            value = nu(amplitude, self.omega)
            g += (value * u)[:, None] * s_t[None, :]
            if jacobian:
                step = _DERIVATIVE_STEP * amplitude
                slope = (nu(amplitude + step, self.omega) - nu(amplitude - step, self.omega)) / (2 * step)
                outer = np.outer(s_t, s_t)[None]
                d_re += (value + u * slope * u.real / amplitude)[:, None, None] * outer
                d_im += (1j * value + u * slope * u.imag / amplitude)[:, None, None] * outer
        return g, d_re, d_im

    def residual(self, x: NDArray, functions: Sequence[DF]) -> NDArray[np.complex128]:
        g, _, _ = self.forces(x, functions, False)
        return x - self.x_linear + np.einsum("nij,nj->ni", self.h_aa, g)

    def real_jacobian(self, d_re: NDArray, d_im: NDArray) -> NDArray[np.float64]:
        """∂R/∂(Re X_a, Im X_a) as a real (n, 2k, 2k) matrix acting on (Re, Im) stacked."""
        eye = np.eye(self.s.shape[1])
        j_re = eye[None] + self.h_aa @ d_re
        j_im = 1j * eye[None] + self.h_aa @ d_im
        return np.block([[j_re.real, j_im.real], [j_re.imag, j_im.imag]])


def _solve_each(matrices: NDArray, rhs: NDArray) -> NDArray:
    """``matrices[n]⁻¹ rhs[n]`` for every n (least squares where one is singular)."""
    try:
        return np.linalg.solve(matrices, rhs[..., None])[..., 0]
    except np.linalg.LinAlgError:
        return np.stack([np.linalg.lstsq(j, b, rcond=None)[0] for j, b in zip(matrices, rhs)])


@dataclass(frozen=True, eq=False)
class ModalJoint(JointFit):
    """The joint problem against a modal table: the single-mode phase-resonance model with
    the user's elements and every effect (residuals: :func:`~nlupdate.core.discovery.backbone_fit.modal_residual`)."""

    modal: ModalModel
    mode: NDArray[np.int64]
    input_dof: int
    force: NDArray[np.float64]
    frequency_hz: NDArray[np.float64]
    damping_ratio: NDArray[np.float64]
    fixed: tuple
    frequency_uncertainty: float
    damping_uncertainty: float
    penalty: float

    def residual(self, effects, values=None):
        terms = list(element_terms(self.modal, self.mode, self.fixed))
        for dofs, nu in _terms((), effects, values):
            terms.append((_participation(self.modal, self.mode, dofs), nu))
        w, zeta, _ = phase_resonance(self.modal, self.mode, self.input_dof, self.force, terms)
        return modal_residual(self, w / (2 * np.pi), zeta)
