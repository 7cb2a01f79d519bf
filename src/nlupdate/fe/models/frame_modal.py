"""The modal solution of a constrained frame model: natural frequencies and mass-normalised shapes.

Frequencies in Hz at the interface, eigenvalues λ = ω² in rad²/s² inside. Dense generalized
eigen-solution below :data:`DENSE_LIMIT` free dofs, shift-invert Lanczos (``eigsh``) about
:data:`DEFAULT_SHIFT` above; shapes are returned on the full dof vector ``u = T q``.
"""
from __future__ import annotations

from math import pi
from typing import NamedTuple

import numpy as np
import scipy.linalg
import scipy.sparse
import scipy.sparse.linalg
from numpy.typing import NDArray

#: Dense eigen-solution below this many free dofs, shift-invert Lanczos above.
DENSE_LIMIT = 300
#: Default spectral shift (rad²/s²) of the eigen-solution; negative, so that K − σM is
#: positive definite even when the model has rigid-body modes.
DEFAULT_SHIFT = -1.0

_SINGULAR_MESSAGE = (
    "FrameModel.modal: K − σM is singular or indefinite — some free dof has neither stiffness nor "
    "mass (e.g. a node without elements); fix those dofs"
)


class ModalSolution(NamedTuple):
    """Natural frequencies (Hz, ascending) and mass-normalised mode shapes.

    ``shapes`` has shape (6·n_nodes, n_modes) on the full dof vector (fixed dofs are 0),
    units 1/√kg; each mode's largest entry is positive.
    """

    frequencies_hz: NDArray[np.float64]
    shapes: NDArray[np.float64]


def solve_modes(K_r: scipy.sparse.csr_matrix, M_r: scipy.sparse.csr_matrix, T: scipy.sparse.csr_matrix, n_modes: int,
                sigma: float = DEFAULT_SHIFT) -> ModalSolution:
    """Lowest ``n_modes`` natural frequencies (Hz) and mass-normalised mode shapes of ``K_r``, ``M_r``.

    Dense generalized eigen-solution for small models, otherwise ``eigsh`` in
    shift-invert mode about ``sigma`` (rad²/s², negative so that rigid-body modes
    are allowed). Shapes are returned on the full dof vector ``T q``.
    """
    n = K_r.shape[0]
    if int(n_modes) != n_modes or not (1 <= n_modes <= n):
        raise ValueError(f"FrameModel.modal: n_modes must be an integer in 1..{n} (free dofs), got {n_modes!r}")
    n_modes = int(n_modes)
    if n <= DENSE_LIMIT or n_modes >= n - 1:
        # (K − σM) is positive definite; μ = 1/(λ − σ) are eigenvalues of M x = μ (K − σM) x.
        try:
            mu, vectors = scipy.linalg.eigh(M_r.toarray(), (K_r - sigma * M_r).toarray())
        except np.linalg.LinAlgError as error:
            raise ValueError(_SINGULAR_MESSAGE) from error
        order = np.argsort(mu)[::-1][:n_modes]
        mu, vectors = mu[order], vectors[:, order]
        if np.any(mu <= 0):
            raise ValueError(
                f"FrameModel.modal: only {int(np.sum(mu > 0))} modes have mass; asked for {n_modes}"
            )
        values = sigma + 1.0 / mu
    else:
        try:
            # a fixed (pseudo-random) start vector: the same model gives bit-identical
            # modes in every run, which the result cache and reruns rely on
            values, vectors = scipy.sparse.linalg.eigsh(
                K_r.tocsc(), k=n_modes, M=M_r.tocsc(), sigma=sigma, which="LM",
                v0=np.random.default_rng(0).standard_normal(n),
            )
        except RuntimeError as error:  # singular factorisation of K − σM
            raise ValueError(_SINGULAR_MESSAGE) from error
        order = np.argsort(values)
        values, vectors = values[order], vectors[:, order]
    scale = np.abs(values).max() if values.size else 1.0
    if np.any(values < -1e-8 * max(scale, 1.0)):
        raise ValueError("FrameModel.modal: negative eigenvalue — the stiffness matrix is not positive semi-definite")
    modal_mass = np.einsum("ir,ir->r", vectors, M_r @ vectors)
    vectors = vectors / np.sqrt(modal_mass)
    shapes = np.asarray(T @ vectors)
    peak = np.argmax(np.abs(shapes), axis=0)
    shapes = shapes * np.sign(shapes[peak, np.arange(shapes.shape[1])])
    freqs = np.sqrt(np.clip(values, 0.0, None)) / (2.0 * pi)
    return ModalSolution(freqs, shapes)
