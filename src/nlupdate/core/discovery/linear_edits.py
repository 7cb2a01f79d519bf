"""Linear corrections of a model at one place: a spring, a mass or a viscous damper.

A place is one coordinate (element to ground) or two coordinates (element between them),
given by model indices. With the connectivity vector ``s`` (``s_r = 1``, ``s_j = −1``) a
spring Δk adds ``Δk·s sᵀ`` to K, a damper Δc adds ``Δc·s sᵀ`` to C and a mass Δm adds Δm
to ``M_rr`` (to ground only). Corrections may be negative (the model was too stiff, too
heavy, too damped). Units: N/m, kg, N·s/m.

* :class:`~nlupdate.core.model.linear.LumpedModel` — the matrices are edited exactly.
* :class:`~nlupdate.core.model.linear.ModalModel` — Rayleigh–Ritz in the model's modal basis:
  with ``ψ = sᵀΦ`` (one entry per mode) the modal matrices become
  ``K_q = diag(ω_r²) + Δk ψᵀψ``, ``M_q = I + Δm ψᵀψ``, ``C_q = diag(2ζ_r ω_r) + Δc ψᵀψ``;
  the generalised eigenproblem ``(K_q, M_q)`` gives the new frequencies and (mass-normalised)
  shapes ``Φ V``. Stiffness and mass corrections are exact within the basis; damping is
  kept modal (the diagonal of ``Vᵀ C_q V`` and of ``Vᵀ diag(η_r ω_r²) V``).
"""
from __future__ import annotations

from typing import Sequence

import numpy as np
import scipy.linalg
import scipy.sparse

from nlupdate.core.discovery.errors import UnphysicalModelError
from nlupdate.core.discovery.places import place_name
from nlupdate.core.model.linear import LinearModel, LumpedModel, ModalModel


def _connectivity(n: int, dofs: Sequence[int]) -> np.ndarray:
    s = np.zeros(n)
    s[dofs[0]] = 1.0
    if len(dofs) == 2:
        s[dofs[1]] = -1.0
    return s


def _add(matrix, correction: np.ndarray, n: int):
    """``matrix + correction`` keeping a sparse matrix sparse; None counts as zero."""
    if matrix is None:
        return correction
    if scipy.sparse.issparse(matrix):
        return scipy.sparse.csr_matrix(matrix + scipy.sparse.csr_matrix(correction))
    return np.asarray(matrix, dtype=float) + correction


def _lumped(model: LumpedModel, dofs: Sequence[int], stiffness: float, mass: float, damping: float) -> LumpedModel:
    n = model.n_dof
    s = _connectivity(n, dofs)
    pattern = np.outer(s, s)
    added_mass = np.zeros((n, n))
    added_mass[dofs[0], dofs[0]] = mass
    return LumpedModel(
        _add(model.mass, added_mass, n) if mass else model.mass,
        _add(model.stiffness, stiffness * pattern, n) if stiffness else model.stiffness,
        _add(model.damping, damping * pattern, n) if damping else model.damping,
        model.structural_damping,
        model.dof_names,
    )


def _modal(model: ModalModel, dofs: Sequence[int], stiffness: float, mass: float, damping: float) -> ModalModel:
    phi = model.mode_shapes
    psi = phi[dofs[0]] - (phi[dofs[1]] if len(dofs) == 2 else 0.0)
    wr = model.omega_r
    k_q = np.diag(wr**2) + stiffness * np.outer(psi, psi)
    m_q = np.eye(wr.size) + mass * np.outer(psi, psi)
    values, vectors = scipy.linalg.eigh(k_q, m_q)
    if np.any(values <= 0):
        raise UnphysicalModelError(
            f"the correction (Δk = {stiffness:g} N/m, Δm = {mass:g} kg on {place_name(dofs, model.dof_names)}) leaves a mode with "
            "zero or negative stiffness"
        )
    omega = np.sqrt(values)
    c_q = np.diag(2 * model.damping_ratios * wr) + damping * np.outer(psi, psi)
    d_q = np.diag(model.loss_factors * wr**2)
    zeta = np.einsum("ir,ij,jr->r", vectors, c_q, vectors) / (2 * omega)
    eta = np.einsum("ir,ij,jr->r", vectors, d_q, vectors) / omega**2
    return ModalModel(omega / (2 * np.pi), phi @ vectors, zeta, eta, model.dof_names)


def add_linear_correction(
    model: LinearModel, dofs: Sequence[int], stiffness: float = 0.0, mass: float = 0.0, damping: float = 0.0
) -> LinearModel:
    """The model with a spring (N/m), mass (kg, ``dofs`` of length 1) and damper (N·s/m) added.

    Raises :class:`~nlupdate.core.discovery.errors.UnphysicalModelError` when a modal model's
    correction leaves a mode with zero or negative stiffness."""
    dofs = tuple(int(d) for d in dofs)
    if mass and len(dofs) != 1:
        raise ValueError(f"a mass correction acts on one coordinate, got {place_name(dofs, model.dof_names)}")
    if isinstance(model, LumpedModel):
        return _lumped(model, dofs, stiffness, mass, damping)
    if isinstance(model, ModalModel):
        return _modal(model, dofs, stiffness, mass, damping)
    raise TypeError(f"linear corrections need a LumpedModel or ModalModel, got {type(model).__name__}")
