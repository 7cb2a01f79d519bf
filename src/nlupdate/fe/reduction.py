"""A reduced model exact at the joint: Craig–Bampton reduction of assembled FE matrices.

Why Craig–Bampton (and not modes plus residual flexibility). The joint elements act
between interface coordinates whose stiffness changes with amplitude (stuck → slipping).
Craig–Bampton keeps those coordinates (the *boundary* set ``b``) as physical dofs:

    x = [x_b; x_i],   x_i = Ψ x_b + Φ q,   Ψ = −K_ii⁻¹ K_ib,
    (K_ii − ω_j² M_ii) φ_j = 0   (the *fixed-interface* modes, mass-normalised),

    K_r = [[K_bb + K_bi Ψ, 0], [0, diag(ω_j²)]],
    M_r = [[M̂_bb, (M_bi + Ψᵀ M_ii) Φ], [·ᵀ, I]],  M̂_bb = M_bb + Ψᵀ M_ib + M_bi Ψ + Ψᵀ M_ii Ψ.

* **Exact statically**: K_bb + K_bi Ψ is the exact static condensation of the structure
  onto ``b`` (a force at the boundary gives the exact boundary displacement), whatever
  the joint does — the constraint modes Ψ are the static solution.
* **Accurate in the band**: the fixed-interface modes are computed with the boundary
  held, so they do not depend on anything attached at the boundary: the same reduced
  matrices serve every joint state (stuck, slipping, updated stiffness), and the
  truncation error shrinks like (ω/ω_j)² of the first modes left out. A modal sum of the
  free structure's modes plus a residual flexibility would need the structure's modes
  *with* the joint in each state, and on a free–free structure (the BRB hangs on bungee
  cords) its static flexibility is singular (inertia relief needed).
* The coordinates the test measures (and drives) are boundary dofs too, so their FRF is
  read without any mode-shape recovery.

Damping is not reduced here: a :class:`~nlupdate.core.model.linear.LumpedModel` of the
reduced matrices takes a loss factor or a damping matrix on the reduced coordinates.

Units: stiffness N/m (N/rad for rotations), mass kg; frequencies Hz.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np
import scipy.linalg
import scipy.sparse
import scipy.sparse.linalg



@dataclass(frozen=True, eq=False)
class ReducedModel:
    """Craig–Bampton model: the boundary dofs (physical, named) then the fixed-interface modal coordinates.

    mass, stiffness: (n, n) dense, n = boundary + modes (kg, N/m; modal rows in unit modal mass).
    dof_names: boundary names, then ``"cb1"``, ``"cb2"``, …
    fixed_interface_hz: natural frequencies of the kept fixed-interface modes (Hz).
    """

    mass: np.ndarray
    stiffness: np.ndarray
    dof_names: tuple[str, ...]
    n_boundary: int
    fixed_interface_hz: np.ndarray

    def index(self, name: str) -> int:
        try:
            return self.dof_names.index(name)
        except ValueError:
            boundary = list(self.dof_names[: self.n_boundary])
            raise ValueError(f"{name!r} is not a coordinate of the reduced model; it has {boundary}") from None


def _fixed_interface_modes(k_ii, m_ii, solve, n_modes: int) -> tuple[np.ndarray, np.ndarray]:
    """The ``n_modes`` lowest (ω², mass-normalised Φ) of (K_ii, M_ii), shift-invert about 0."""
    n = k_ii.shape[0]
    if n_modes == 0:
        return np.empty(0), np.empty((n, 0))
    if n_modes >= n - 1 or n <= 200:
        values, vectors = scipy.linalg.eigh(k_ii.toarray(), m_ii.toarray(), subset_by_index=[0, min(n_modes, n) - 1])
    else:
        inverse = scipy.sparse.linalg.LinearOperator((n, n), matvec=solve, dtype=float)
        values, vectors = scipy.sparse.linalg.eigsh(k_ii, k=n_modes, M=m_ii, sigma=0.0, which="LM", OPinv=inverse)
        order = np.argsort(values)
        values, vectors = values[order], vectors[:, order]
    modal_mass = np.einsum("ij,ij->j", vectors, m_ii @ vectors)
    return values, vectors / np.sqrt(modal_mass)


def craig_bampton(stiffness, mass, boundary: Sequence[int], names: Sequence[str], n_modes: int) -> ReducedModel:
    """Craig–Bampton reduction of (K, M) onto the rows ``boundary`` plus ``n_modes`` fixed-interface modes.

    stiffness, mass: (N, N) symmetric, dense or scipy.sparse (N/m, kg).
    boundary: distinct row indices kept as physical coordinates, named by ``names``.
    The boundary must hold the structure (K_ii nonsingular): on a free–free solid mesh
    that is three translations of three nodes not on one line — a ValueError says so
    otherwise.
    """
    boundary = np.asarray(boundary, dtype=int)
    if boundary.size == 0 or len(set(boundary.tolist())) != boundary.size:
        raise ValueError(f"boundary rows must be distinct and at least one, got {boundary.tolist()}")
    if len(names) != boundary.size:
        raise ValueError(f"{len(names)} names for {boundary.size} boundary rows")
    if not (isinstance(n_modes, (int, np.integer)) and n_modes >= 0):
        raise ValueError(f"n_modes must be an integer ≥ 0, got {n_modes!r}")
    k = scipy.sparse.csr_matrix(stiffness)
    m = scipy.sparse.csr_matrix(mass)
    n = k.shape[0]
    interior = np.setdiff1d(np.arange(n), boundary)
    if n_modes > interior.size:
        raise ValueError(f"n_modes = {n_modes} exceeds the {interior.size} interior dofs")
    k_ii = k[interior][:, interior].tocsc()
    m_ii = m[interior][:, interior].tocsc()
    k_ib = k[interior][:, boundary].toarray()
    m_ib = m[interior][:, boundary].toarray()
    try:
        factor = scipy.sparse.linalg.splu(k_ii)
    except RuntimeError as error:  # exactly singular
        raise ValueError(f"the boundary does not hold the structure (K_ii is singular: {error}); "
                         "add boundary dofs so that no rigid-body motion is left") from None
    psi = -factor.solve(k_ib)
    residual = np.linalg.norm(k_ii @ psi + k_ib) / max(np.linalg.norm(k_ib), 1e-300)
    if not np.all(np.isfinite(psi)) or residual > 1e-6:
        raise ValueError("the boundary does not hold the structure (K_ii is singular to working precision); "
                         "add boundary dofs so that no rigid-body motion is left")
    omega_sq, phi = _fixed_interface_modes(k_ii, m_ii, factor.solve, int(n_modes))
    k_bb = k[boundary][:, boundary].toarray()
    m_bb = m[boundary][:, boundary].toarray()
    m_ii_psi = m_ii @ psi
    k_guyan = k_bb + k_ib.T @ psi
    m_guyan = m_bb + psi.T @ m_ib + m_ib.T @ psi + psi.T @ m_ii_psi
    coupling = (m_ib.T + m_ii_psi.T) @ phi
    nb, nm = boundary.size, omega_sq.size
    k_r = np.zeros((nb + nm, nb + nm))
    m_r = np.eye(nb + nm)
    k_r[:nb, :nb] = 0.5 * (k_guyan + k_guyan.T)
    k_r[nb:, nb:] = np.diag(omega_sq)
    m_r[:nb, :nb] = 0.5 * (m_guyan + m_guyan.T)
    m_r[:nb, nb:] = coupling
    m_r[nb:, :nb] = coupling.T
    names = tuple(str(name) for name in names) + tuple(f"cb{j + 1}" for j in range(nm))
    return ReducedModel(m_r, k_r, names, nb, np.sqrt(np.maximum(omega_sq, 0.0)) / (2 * np.pi))


def rigid_patches(stiffness, mass, nodes: np.ndarray, directions: np.ndarray, coordinates: np.ndarray,
                  patches: Mapping[str, tuple[Sequence[float], Sequence[int]]]):
    """Tie each patch of nodes rigidly to a reference point (an RBE2 "spider", e.g. a bolt's clamped area).

    nodes, directions: node number and direction (1–3) of each row of (K, M).
    coordinates: (n_nodes_max + 1, 3) node positions (m), indexed by node number.
    patches: ``{name: (reference point (x, y, z) in m, node numbers)}``; patches must not share nodes.

    Returns ``(K', M', rows, names)``: matrices on the kept rows (nodes of no patch, in their
    order) followed by six dofs per patch — translations ``<name>:ux``, ``uy``, ``uz`` (m) and
    rotations ``<name>:rx``, ``ry``, ``rz`` (rad) of its reference point; ``rows`` maps the
    kept rows back to the original ones; ``names`` names the patch dofs.
    """
    n = len(nodes)
    in_patch = np.zeros(n, dtype=bool)
    seen: set[int] = set()
    entries_r, entries_c, values = [], [], []
    names: list[str] = []
    patch_rows = []
    for name, (reference, members) in patches.items():
        members = {int(node) for node in members}
        if not members:
            raise ValueError(f"patch {name!r} holds no nodes")
        if members & seen:
            raise ValueError(f"patch {name!r} shares node(s) {sorted(members & seen)[:5]} with another patch")
        seen |= members
        patch_rows.append((name, np.asarray(reference, dtype=float), np.flatnonzero(np.isin(nodes, list(members)))))
        names += [f"{name}:{axis}" for axis in ("ux", "uy", "uz", "rx", "ry", "rz")]
    for _, _, rows in patch_rows:
        in_patch[rows] = True
    kept = np.flatnonzero(~in_patch)
    n_new = kept.size + 6 * len(patch_rows)
    entries_r += kept.tolist()
    entries_c += list(range(kept.size))
    values += [1.0] * kept.size
    for number, (name, reference, rows) in enumerate(patch_rows):
        first = kept.size + 6 * number
        for row in rows:
            r = coordinates[nodes[row]] - reference
            d = directions[row] - 1
            entries_r.append(row), entries_c.append(first + d), values.append(1.0)
            # u = u_ref + θ × r
            rotation = {0: ((4, r[2]), (5, -r[1])), 1: ((5, r[0]), (3, -r[2])), 2: ((3, r[1]), (4, -r[0]))}[d]
            for column, value in rotation:
                entries_r.append(row), entries_c.append(first + column), values.append(value)
    transform = scipy.sparse.csr_matrix((values, (entries_r, entries_c)), shape=(n, n_new))
    k = (transform.T @ scipy.sparse.csr_matrix(stiffness) @ transform).tocsr()
    m = (transform.T @ scipy.sparse.csr_matrix(mass) @ transform).tocsr()
    return k, m, kept, tuple(names)
