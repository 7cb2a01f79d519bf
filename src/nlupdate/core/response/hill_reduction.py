"""Hill's method on the joint coordinates plus the retained modes (issue 38).

Why. Hill's eigenproblem (:mod:`nlupdate.core.response.hill`) has ``2·n_q·(2H+1)``
eigenvalues for a model of ``n_q`` coordinates; on every dof of a dense model of 100 dofs
at H = 3 that is a 1400 × 1400 companion matrix per curve point (seconds), though the
element forces act on a few joint coordinates only. The linear structure between the
joints can be condensed.

What was chosen, and why. Three routes were considered:

* **Exact condensation** onto the nonlinear coordinates: eliminating the linear dofs
  leaves the nonlinear eigenproblem ``det(I + H_aa(λ + ikω) N(λ)) = 0`` of size
  ``n_a·(2H+1)`` (``H_aa`` the receptance at the joints). Its zeros are the exponents,
  but finding them (or counting those in the right half-plane by the argument principle)
  needs many evaluations per point, and the centring rule that tells a Floquet exponent
  from its copies ``λ + imω`` needs eigenvectors — it does not carry over.
* **Craig–Bampton** with the nonlinear dofs as interface (as :mod:`nlupdate.fe.reduction`
  does for FE meshes): exact statically for any joint state, but it keeps *every*
  nonlinear dof — 20 for ten joints between node pairs — where the elements act on only
  ten relative displacements.
* **Modes plus residual flexibility of the joint loads** (chosen): the Ritz basis

      T = [Φ_m, K⁻¹S − Φ_m Ω_m⁻² Φ_mᵀ S],

  the model's own modes with ``ω_r ≤ CUTOFF·(H + 1)·ω_max`` (the highest frequency
  Hill's blocks reach, ``(H + ½)ω`` for the exponents that are centred, with a margin)
  and the static response to the joint loads ``S`` not carried by them (one column per
  independent element direction: ``e_r − e_j`` for an element between two dofs, ``e_r``
  for one to ground). A Galerkin projection onto it is *exact statically for any joint
  state* — stuck, slipping, stiffened — because the static response to any joint force
  lies in the basis, and it reproduces the retained modes exactly; the error is the
  dynamic part of the left-out modes, which shrinks like ``(Hω_max/ω_r)²``. M, C, D and K
  are all projected (no proportional-damping assumption). ``n_q = m + r`` coordinates,
  where ``r`` is the rank of the element directions: ten joints between node pairs cost
  ten, not twenty. A grounded model is needed (``K⁻¹``), which the harmonic balance's
  constant term needs anyway.

The projected model is then solved by the unchanged Hill code (same balance Jacobian for
the element part, same centring): the verdicts agree with the dense computation wherever
the reduced model's exponents are accurate, i.e. everywhere except within the reduced
model's error of a bifurcation (``tests/test_hill_reduction.py`` compares every point of
curves with folds, and the exponents).

Where it is used: :func:`hill_model` — what :func:`~nlupdate.core.response.harmonic_balance.trace_harmonic_balance`
calls for its stability — reduces a dense :class:`~nlupdate.core.model.linear.LumpedModel`
whenever the basis is smaller than ``REDUCE_BELOW`` of its dofs; a modal model, a sparse
model and a small dense one keep :meth:`HillModel.of`.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from nlupdate.core.model.linear import LumpedModel
from nlupdate.core.response.hill import HillModel

CUTOFF = 2.0
"""Modes kept up to ``CUTOFF·(H + 1)·ω_max`` (rad/s)."""
REDUCE_BELOW = 0.5
"""Reduce when the basis has fewer than this fraction of the model's dofs."""


def element_directions(n_a: int, element_index: Sequence[tuple]) -> NDArray[np.float64]:
    """Orthonormal basis (n_a, r) of the directions the elements act along, in the nonlinear
    coordinates: ``e_r − e_j`` between two coordinates, ``e_r`` to ground (``j = −1``)."""
    columns = np.zeros((n_a, max(len(element_index), 1)))
    for column, (_, r, j) in enumerate(element_index):
        columns[r, column] = 1.0
        if j >= 0:
            columns[j, column] = -1.0
    u, s, _ = np.linalg.svd(columns, full_matrices=False)
    rank = int(np.sum(s > 1e-10 * max(s.max(initial=0.0), 1e-300)))
    return u[:, :rank]


def residual_basis(model: LumpedModel, nonlinear_dofs: Sequence[int], directions: NDArray,
                   omega_cut: float) -> NDArray[np.float64]:
    """Ritz basis (n_dof, n_q) of the modes with ``ω_r ≤ omega_cut`` (rad/s) and the residual
    static response to the loads ``S = P_aᵀ directions``, rotated so that ``TᵀMT = I`` and
    ``TᵀKT`` is diagonal (the reduced model's own undamped modes)."""
    m, k, _, _ = model._dense_mkcd
    loads = np.zeros((model.n_dof, directions.shape[1]))
    loads[list(nonlinear_dofs)] = directions
    omega_sq, phi = scipy.linalg.eigh(k, m, subset_by_value=(-np.inf, omega_cut**2), check_finite=False)
    static = scipy.linalg.cho_solve(scipy.linalg.cho_factor(k, check_finite=False), loads, check_finite=False)
    residual = static - phi @ ((phi.T @ loads) / omega_sq[:, None])
    residual -= phi @ (phi.T @ (m @ residual))  # M-orthogonal to the modes (rounding)
    gram_values, gram_vectors = np.linalg.eigh(residual.T @ m @ residual)
    scale = np.einsum("ij,ij->", static, m @ static)  # the whole static response's M-norm²
    keep = gram_values > 1e-12 * max(scale, 1e-300)  # what the modes leave of it, not rounding
    residual = residual @ (gram_vectors[:, keep] / np.sqrt(gram_values[keep]))
    basis = np.hstack([phi, residual])
    _, rotation = scipy.linalg.eigh(basis.T @ k @ basis, basis.T @ m @ basis, check_finite=False)
    return basis @ rotation


def reduced_hill_model(model: LumpedModel, nonlinear_dofs: Sequence[int], basis: NDArray) -> HillModel:
    """:class:`HillModel` of the dense ``model`` projected on ``basis`` (n_dof, n_q): every matrix
    ``TᵀXT``, the map to the nonlinear coordinates ``T[a]``."""
    m, k, c, d = (basis.T @ matrix @ basis for matrix in model._dense_mkcd)
    return HillModel(m, c, d, k, basis[list(nonlinear_dofs)])


def hill_model(model, nonlinear_dofs: Sequence[int], element_index: Sequence[tuple], omega_max: float,
               harmonics: int) -> HillModel:
    """The coordinates Hill's method works in for a curve up to ``omega_max`` (rad/s) with H
    ``harmonics``: the reduced model of this module for a dense lumped model when it has
    fewer than ``REDUCE_BELOW`` of its dofs, else :meth:`HillModel.of`."""
    if isinstance(model, LumpedModel) and not model.is_sparse:
        directions = element_directions(len(nonlinear_dofs), element_index)
        omega_cut = CUTOFF * (harmonics + 1) * float(omega_max)
        try:
            basis = residual_basis(model, nonlinear_dofs, directions, omega_cut)
        except np.linalg.LinAlgError:  # K not positive definite: no static condensation
            basis = None
        if basis is not None and basis.shape[1] < REDUCE_BELOW * model.n_dof:
            return reduced_hill_model(model, nonlinear_dofs, basis)
    return HillModel.of(model, nonlinear_dofs)
