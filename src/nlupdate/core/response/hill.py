"""Floquet multipliers of a harmonic-balance solution by Hill's method.

A perturbation ``δx = e^{λt} Σ_{m=−H}^{H} p_m e^{imωt}`` of the periodic motion obeys the
linearised equations of motion ``M δẍ + C_eq δẋ + K δx + K_t(t) δx + C_t(t) δẋ = 0`` with
``C_eq = C + D/ω`` (structural damping as the viscous damping equivalent at the fundamental,
the convention of :meth:`~nlupdate.core.model.linear.LumpedModel.harmonic_receptance`) and the
element tangents ``K_t = ∂f/∂x``, ``C_t = ∂f/∂ẋ`` along the orbit
(:func:`nlupdate.core.response.aft.damping_coefficients` for ``C_t``). Balancing the harmonics
−H … H (the orbit's H: then ``L₀`` is the harmonic-balance Jacobian, and a fold of the
traced curve is exactly a multiplier +1) gives the
quadratic eigenvalue problem ``(L₀ + λL₁ + λ²L₂) p = 0`` with blocks

    L₀[k, j] = δ_kj (K + ikω C_eq − k²ω² M) + K̂_{k−j} + ijω Ĉ_{k−j},   (see :func:`floquet`)
    L₁[k, j] = δ_kj (C_eq + 2ikω M) + Ĉ_{k−j},        L₂[k, j] = δ_kj M,

where ``K̂_m, Ĉ_m`` are the Fourier coefficients of the tangents. Of its 2·n_q(2H+1)
eigenvalues, the 2·n_q whose eigenvectors are centred on the harmonic index (the mean of
m weighted by ``‖p_m‖²`` closest to 0; among those within ½ of 0 the least damped first,
see :func:`_centred`) approximate the Floquet exponents; the others are
copies shifted by ``imω``, centred on m. (Centring, not the weight of m = 0: along an orbit
of a symmetric system the perturbations split into even and odd families, and an odd one
has no m = 0 component at all.) The
multipliers are ``μ = e^{λT}``, ``T = 2π/ω``. The orbit is stable when every ``|μ| < 1``.
A real multiplier leaving through +1 is a turning point (or a branch point where the
curve does not turn), through −1 a period doubling, a complex pair a Neimark–Sacker
bifurcation.

Coordinates (:meth:`HillModel.of`): a dense :class:`~nlupdate.core.model.linear.LumpedModel` is
used as it is, a :class:`~nlupdate.core.model.linear.ModalModel` in its modal coordinates; a
sparse lumped model in its lowest ``SPARSE_MODES`` modes (a truncation that affects stability
only). The harmonic balance asks :func:`nlupdate.core.response.hill_reduction.hill_model`, which
reduces a large dense model to its joint coordinates and retained modes first.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.model.linear import LumpedModel, ModalModel
from nlupdate.core.response.aft import Fourier, damping_coefficients_batch

SPARSE_MODES = 20


@dataclass(frozen=True, eq=False)
class HillModel:
    """Linear operators in the Hill coordinates q and the map ``x_a = Φ_a q``."""

    mass: NDArray
    damping: NDArray
    structural: NDArray
    stiffness: NDArray
    phi_a: NDArray

    @classmethod
    def of(cls, model, nonlinear_dofs: Sequence[int]) -> "HillModel":
        a = list(nonlinear_dofs)
        if isinstance(model, LumpedModel) and model.is_sparse:
            model = model.to_modal(min(SPARSE_MODES, model.n_dof - 1))
        if isinstance(model, ModalModel):
            wr = model.omega_r
            return cls(
                np.eye(wr.size),
                np.diag(2 * model.damping_ratios * wr),
                np.diag(model.loss_factors * wr**2),
                np.diag(wr**2),
                model.mode_shapes[a],
            )
        if isinstance(model, LumpedModel):
            m, k, c, d = model._dense_mkcd
            return cls(m, c, d, k, np.eye(model.n_dof)[a])
        raise TypeError(f"Hill's method needs a LumpedModel or ModalModel, got {type(model).__name__}")


@dataclass(frozen=True)
class Floquet:
    """Floquet exponents λ (1/s) and multipliers μ = e^{λT} of one periodic solution."""

    exponents: NDArray[np.complex128]
    multipliers: NDArray[np.complex128]

    @property
    def critical(self) -> complex:
        """The multiplier of largest modulus."""
        return complex(self.multipliers[np.argmax(np.abs(self.multipliers))])


def floquet(
    hill: HillModel,
    element_index: Sequence[tuple],
    x_coefficients: NDArray,
    omega: float,
    fourier: Fourier,
    force_jacobian: NDArray,
) -> Floquet:
    """Floquet exponents of the orbit with coefficients ``x_coefficients`` (2H+1, n_a) (m)
    at the nonlinear coordinates, fundamental ω (rad/s). ``element_index`` lists
    ``(element, r, j)`` with positions in the nonlinear coordinates (j = −1: ground);
    ``force_jacobian`` is ∂G/∂X of the harmonic balance (coefficient-major, as
    :meth:`~nlupdate.core.response.harmonic_balance.HarmonicBalanceProblem.forces` returns it).

    The element part of ``L₀`` is that Jacobian in the exponential basis — for pointwise
    laws the same as ``K̂_{k−j} + ijωĈ_{k−j}``, and for the Jenkins element (whose force
    depends on the last slip, not on the instantaneous motion) the only form in which a
    fold of the curve is a multiplier +1. ``L₁`` takes the tangent damping ``Ĉ``.
    """
    exponents, multipliers = floquet_batch(
        hill, element_index, np.asarray(x_coefficients)[None], np.array([omega], dtype=float), fourier,
        np.asarray(force_jacobian)[None],
    )
    return Floquet(exponents[0], multipliers[0])


def floquet_batch(
    hill: HillModel,
    element_index: Sequence[tuple],
    x_coefficients: NDArray,
    omega: NDArray,
    fourier: Fourier,
    force_jacobians: NDArray,
    max_bytes: int = 2**26,
) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
    """:func:`floquet` for P orbits at once: ``x_coefficients`` (P, 2H+1, n_a), ``omega`` (P,),
    ``force_jacobians`` (P, size, size); returns exponents and multipliers, (P, 2·n_q) each.
    Hill's matrices of all orbits are assembled as arrays and their eigenvalues computed by one
    batched LAPACK call, ``max_bytes`` of companion matrices at a time."""
    omega = np.asarray(omega, dtype=float)
    harmonics = fourier.harmonics
    n_a, n_q = hill.phi_a.shape
    n_h = 2 * harmonics + 1
    size = n_q * n_h
    chunk = max(1, int(max_bytes // (16 * (2 * size) ** 2)))
    exponents = np.empty((omega.size, 2 * n_q), complex)
    for start in range(0, omega.size, chunk):
        part = slice(start, start + chunk)
        exponents[part] = _floquet_exponents(hill, element_index, x_coefficients[part], omega[part], fourier,
                                             force_jacobians[part])
    return exponents, np.exp(exponents * (2 * np.pi / omega)[:, None])


def _floquet_exponents(hill, element_index, x_coefficients, omega, fourier, force_jacobians):
    """Hill's quadratic eigenproblem in the real Fourier basis of the balance (coefficient-major
    ``[X₀, Re X₁, Im X₁, …]``), where every matrix is real: the perturbation's time derivative is
    λ + D with D = kω[[0, −1], [1, 0]] on harmonic k, the element part of ``L₀`` is the balance's
    own Jacobian and that of ``L₁`` the tangent damping's multiplication operator. Its eigenvalues
    are those of the exponential form (a similarity), at the cost of a real eigenproblem; the
    eigenvectors are mapped to the exponential basis for the centring."""
    harmonics = fourier.harmonics
    points = omega.size
    n_a, n_q = hill.phi_a.shape
    n_h = 2 * harmonics + 1
    size = n_q * n_h
    phi = hill.phi_a
    c_hat = np.zeros((points, 4 * harmonics + 1, n_a, n_a), complex)
    for element, r, j in element_index:
        u = x_coefficients[:, :, r] - (x_coefficients[:, :, j] if j >= 0 else 0.0)
        s = np.zeros(n_a)
        s[r] = 1.0
        if j >= 0:
            s[j] = -1.0
        c_hat += damping_coefficients_batch(element, u, omega, fourier)[:, :, None, None] * np.outer(s, s)
    orders = np.arange(-harmonics, harmonics + 1)
    to_exp, from_exp = _exponential_maps(harmonics)
    toeplitz = c_hat[:, orders[:, None] - orders[None, :] + 2 * harmonics]  # (P, n_h, n_h, n_a, n_a), exponential
    c_real = np.einsum("cm,pmnab,nd->pcadb", from_exp, toeplitz, to_exp, optimize=True).real  # real basis
    jac = np.asarray(force_jacobians).reshape(points, n_h, n_a, n_h, n_a)
    l0 = np.einsum("ai,pcadb,bj->pcidj", phi, jac, phi, optimize=True)  # (P, n_h, n_q, n_h, n_q)
    l1 = np.einsum("ai,pcadb,bj->pcidj", phi, c_real, phi, optimize=True)
    w = omega[:, None, None]
    c_eq = hill.damping[None] + hill.structural[None] / w  # (P, n_q, n_q)
    l0[:, 0, :, 0, :] += hill.stiffness
    l1[:, 0, :, 0, :] += c_eq
    for k in range(1, harmonics + 1):  # harmonic k: coefficients 2k − 1 (Re), 2k (Im); D = kω[[0, −1], [1, 0]]
        re, im = 2 * k - 1, 2 * k
        kw = k * w
        l0[:, re, :, re, :] += hill.stiffness - kw**2 * hill.mass
        l0[:, im, :, im, :] += hill.stiffness - kw**2 * hill.mass
        l0[:, re, :, im, :] -= kw * c_eq
        l0[:, im, :, re, :] += kw * c_eq
        l1[:, re, :, re, :] += c_eq
        l1[:, im, :, im, :] += c_eq
        l1[:, re, :, im, :] -= 2 * kw * hill.mass
        l1[:, im, :, re, :] += 2 * kw * hill.mass
    mass_inv = np.linalg.inv(hill.mass)
    companion = np.zeros((points, 2 * size, 2 * size))
    companion[:, :size, size:] = np.eye(size)
    companion[:, size:, :size] = -np.einsum("ij,pcjdk->pcidk", mass_inv, l0).reshape(points, size, size)
    companion[:, size:, size:] = -np.einsum("ij,pcjdk->pcidk", mass_inv, l1).reshape(points, size, size)
    values, vectors = np.linalg.eig(companion)
    exponential = np.einsum("mc,pcqv->pmqv", to_exp, vectors[:, :size].reshape(points, n_h, n_q, -1))
    power = (np.abs(exponential) ** 2).sum(axis=2)  # (P, n_h over m = −H … H, 2·size)
    centroid = np.einsum("m,pmv->pv", orders.astype(float), power) / np.maximum(power.sum(axis=1), 1e-300)
    return np.take_along_axis(values, _centred(values, centroid, 2 * n_q), axis=1)


def _centred(values: NDArray, centroid: NDArray, count: int) -> NDArray:
    """Indices (P, count) of the exponents: those centred within ½ of harmonic index 0, the
    least damped first, then the rest by centring. Every family λ + imω has one such copy;
    when more than ``count`` are (a family resolved poorly by H harmonics — a mode far above
    Hω, or a residual coordinate of :mod:`~nlupdate.core.response.hill_reduction` — spreads
    its copies over the harmonics, several near 0), ordering by centring alone could push
    out the least damped family, the one that decides stability; this order keeps it."""
    outside = np.abs(centroid) > 0.5 + 1e-9
    within = np.where(outside, np.abs(centroid), -values.real)
    return np.lexsort((within, outside), axis=-1)[:, :count]


def _exponential_maps(harmonics: int) -> tuple[NDArray, NDArray]:
    """Maps between real coefficients [U₀, Re U₁, Im U₁, …] and exponential ones p_m,
    m = −H … H, with ``u = Σ p_m e^{imθ}``: ``p_{±k} = (Re U_k ± i Im U_k)/2``."""
    size = 2 * harmonics + 1
    to_exp = np.zeros((size, size), complex)
    from_exp = np.zeros((size, size), complex)
    to_exp[harmonics, 0] = from_exp[0, harmonics] = 1.0
    for k in range(1, harmonics + 1):
        plus, minus = harmonics + k, harmonics - k
        to_exp[plus, 2 * k - 1], to_exp[plus, 2 * k] = 0.5, 0.5j
        to_exp[minus, 2 * k - 1], to_exp[minus, 2 * k] = 0.5, -0.5j
        from_exp[2 * k - 1, plus], from_exp[2 * k - 1, minus] = 1.0, 1.0
        from_exp[2 * k, plus], from_exp[2 * k, minus] = -1j, 1j
    return to_exp, from_exp


def classify(multiplier: complex, tolerance: float = 0.15) -> str:
    """Kind of bifurcation a critical multiplier leaving the unit circle signals."""
    angle = abs(np.angle(multiplier))
    if angle < tolerance:
        return "branch point"
    if angle > np.pi - tolerance:
        return "period doubling"
    return "Neimark–Sacker"
