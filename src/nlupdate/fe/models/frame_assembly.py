"""Assembly of a frame model's global stiffness and mass, and its constraints.

Node ``n`` owns the full-vector dofs ``6n … 6n+5`` (``ux, uy, uz, rx, ry, rz``). The global
matrices are the sum of the element matrices rotated to global axes
(:func:`~nlupdate.fe.models.frame_elements.element_matrices`), point masses and springs.
Fixed dofs and rigid links (slave node follows master node:
``u_s = u_m + θ_m × (x_s − x_m)``, ``θ_s = θ_m``) are applied by a transformation
``u = T q`` to the independent free dofs q, so ``K_r = Tᵀ K T`` and ``M_r = Tᵀ M T``.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np
import scipy.sparse
from numpy.typing import NDArray

from nlupdate.fe.models.frame_elements import DOF_NAMES, BeamElement, PointMass, Spring, element_matrices, rotation_matrix


def _skew(r: NDArray) -> NDArray:
    """Matrix S with S @ a = r × a."""
    return np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])


def assemble(coordinates: Sequence[tuple[float, float, float]], elements: Sequence[BeamElement],
             point_masses: Sequence[PointMass], springs: Sequence[Spring],
             ) -> tuple[scipy.sparse.csr_matrix, scipy.sparse.csr_matrix]:
    """Unconstrained global stiffness K (N/m) and mass M (kg), sparse, 6·n_nodes square.

    ``coordinates`` are the node positions (m); elements, point masses and springs refer to
    nodes by index.
    """
    n = 6 * len(coordinates)
    if n == 0:
        raise ValueError("FrameModel.assemble: the model has no nodes")
    rows, cols, k_data, m_data = [], [], [], []
    xyz = np.asarray(coordinates)
    for element in elements:
        rot = rotation_matrix(xyz[element.i], xyz[element.j], element.orientation)
        length = float(np.linalg.norm(xyz[element.j] - xyz[element.i]))
        k_local, m_local = element_matrices(
            length, element.material, element.section, element.theory, element.rotary_inertia
        )
        t = np.kron(np.eye(4), rot)
        dofs = np.r_[6 * element.i : 6 * element.i + 6, 6 * element.j : 6 * element.j + 6]
        rows.append(np.repeat(dofs, 12))
        cols.append(np.tile(dofs, 12))
        k_data.append((t.T @ k_local @ t).ravel())
        m_data.append((t.T @ m_local @ t).ravel())
    for pm in point_masses:
        dofs = np.arange(6 * pm.node, 6 * pm.node + 6)
        rows.append(dofs)
        cols.append(dofs)
        k_data.append(np.zeros(6))
        m_data.append(np.array([pm.mass] * 3 + list(pm.inertia)))
    for spring in springs:
        a = 6 * spring.node + spring.dof
        if spring.other is None:
            rows.append(np.array([a]))
            cols.append(np.array([a]))
            k_data.append(np.array([spring.stiffness]))
        else:
            b = 6 * spring.other + spring.dof
            rows.append(np.array([a, a, b, b]))
            cols.append(np.array([a, b, a, b]))
            k_data.append(spring.stiffness * np.array([1.0, -1.0, -1.0, 1.0]))
        m_data.append(np.zeros_like(k_data[-1]))
    if not rows:
        return scipy.sparse.csr_matrix((n, n)), scipy.sparse.csr_matrix((n, n))
    r, c = np.concatenate(rows), np.concatenate(cols)
    K = scipy.sparse.coo_matrix((np.concatenate(k_data), (r, c)), shape=(n, n)).tocsr()
    M = scipy.sparse.coo_matrix((np.concatenate(m_data), (r, c)), shape=(n, n)).tocsr()
    return K, M

def transformation(coordinates: Sequence[tuple[float, float, float]], labels: Sequence[str], fixed: set[int],
                   rigid_links: dict[int, int]) -> tuple[scipy.sparse.csr_matrix, tuple[int, ...]]:
    """Sparse T (6·n_nodes × n_free) with u = T q, and the full-vector index of each q.

    q are the dofs of nodes that are not rigid-link slaves, minus the ``fixed`` full-vector
    dofs; ``rigid_links`` maps a slave node to its master, ``labels`` name the nodes in errors.
    """
    n_nodes = len(coordinates)
    for slave in rigid_links:
        fixed_here = [d for d in range(6) if 6 * slave + d in fixed]
        if fixed_here:
            raise ValueError(
                f"FrameModel: node {labels[slave]!r} is a rigid-link slave and cannot have fixed dofs "
                f"({[DOF_NAMES[d] for d in fixed_here]}); fix its master instead"
            )
    free = tuple(
        6 * node + d
        for node in range(n_nodes)
        if node not in rigid_links
        for d in range(6)
        if 6 * node + d not in fixed
    )
    position = {dof: k for k, dof in enumerate(free)}
    rows, cols, vals = [], [], []
    for dof, k in position.items():
        rows.append(dof)
        cols.append(k)
        vals.append(1.0)
    xyz = np.asarray(coordinates)
    for slave, master in rigid_links.items():
        block = np.eye(6)
        block[0:3, 3:6] = -_skew(xyz[slave] - xyz[master])  # u_s = u_m + θ_m × r = u_m − r × θ_m
        for a in range(6):
            for b in range(6):
                target = 6 * master + b
                if block[a, b] != 0.0 and target in position:
                    rows.append(6 * slave + a)
                    cols.append(position[target])
                    vals.append(block[a, b])
    T = scipy.sparse.coo_matrix((vals, (rows, cols)), shape=(6 * n_nodes, len(free))).tocsr()
    return T, free
