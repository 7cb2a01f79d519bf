"""A 3D frame (beam) finite-element model, built node by node: the builder and its naming.

* :mod:`~nlupdate.fe.models.frame_elements` — materials, sections, element matrices (the
  element formulation and local axes);
* :mod:`~nlupdate.fe.models.frame_assembly` — global matrices and constraints (fixed dofs,
  rigid links, ``u = T q``);
* :mod:`~nlupdate.fe.models.frame_modal` — the modal solution.

Conventions: SI units (m, kg, N, Pa); frequencies in Hz at the interface, rad/s inside. Six
dofs per node, in the order ``ux, uy, uz, rx, ry, rz`` (global axes, rotations in rad,
right-hand rule). Node ``n`` owns the full-vector dofs ``6n … 6n+5``. A coordinate is named
``"<node label>:<dof>"``, e.g. ``"tip:uz"``. Unlabelled nodes are called ``"n<index>"``.
Mode shapes are returned on the full dof vector.
"""
from __future__ import annotations

from typing import Iterable, Sequence

import numpy as np
import scipy.sparse
from numpy.typing import NDArray

from nlupdate.core.model.linear import LumpedModel
from nlupdate.fe.models.frame_assembly import assemble, transformation
from nlupdate.fe.models.frame_elements import (
    DOF_NAMES, THEORIES, BeamElement, Material, PointMass, Section, Spring, check_positive, element_matrices,
    rotation_matrix,
)
from nlupdate.fe.models.frame_modal import DEFAULT_SHIFT, DENSE_LIMIT, ModalSolution, solve_modes


def _dof(name: str | int, where: str) -> int:
    """The index 0..5 of a dof given by name (``DOF_NAMES``) or number."""
    if isinstance(name, (int, np.integer)) and 0 <= int(name) < 6:
        return int(name)
    if name in DOF_NAMES:
        return DOF_NAMES.index(name)
    raise ValueError(f"{where}: dof must be one of {DOF_NAMES} (or 0..5), got {name!r}")


class FrameModel:
    """A 3D frame model built node by node (mutable builder).

    Typical use::

        model = FrameModel()
        root = model.add_node((0, 0, 0), label="root")
        tip = model.add_node((0.5, 0, 0), label="tip")
        model.add_beam(root, tip, 20, steel, Section.rectangular(0.012, 0.008))
        model.fix(root)
        freqs_hz, shapes = model.modal(4)
        tip_uz = model.shapes_at(shapes, ["tip:uz"])

    ``groups`` maps a name to a list of node indices (filled by :meth:`add_beam` when
    ``group`` is given); :meth:`energy_fraction` uses it to classify modes.
    """

    def __init__(self) -> None:
        self.coordinates: list[tuple[float, float, float]] = []
        self.labels: list[str] = []
        self.elements: list[BeamElement] = []
        self.point_masses: list[PointMass] = []
        self.springs: list[Spring] = []
        self.fixed: set[int] = set()
        self.rigid_links: dict[int, int] = {}
        self.groups: dict[str, list[int]] = {}

    # ------------------------------------------------------------------ building
    @property
    def n_nodes(self) -> int:
        return len(self.coordinates)

    @property
    def n_elements(self) -> int:
        return len(self.elements)

    def _node(self, node: int | str, where: str) -> int:
        if isinstance(node, str):
            if node in self.labels:
                return self.labels.index(node)
            raise ValueError(f"{where}: unknown node label {node!r}")
        if isinstance(node, (int, np.integer)) and 0 <= int(node) < self.n_nodes:
            return int(node)
        raise ValueError(f"{where}: node {node!r} out of range (model has {self.n_nodes} nodes)")

    def add_node(self, xyz: Sequence[float], label: str | None = None) -> int:
        """Add a node at ``xyz`` (m); returns its index. Labels must be unique."""
        point = tuple(float(c) for c in xyz)
        if len(point) != 3 or not all(np.isfinite(point)):
            raise ValueError(f"FrameModel.add_node: xyz must be three finite numbers, got {xyz!r}")
        index = self.n_nodes
        name = f"n{index}" if label is None else str(label)
        if name in self.labels or ":" in name:
            raise ValueError(f"FrameModel.add_node: label {name!r} is already used or contains ':'")
        self.coordinates.append(point)
        self.labels.append(name)
        return index

    def add_element(
        self,
        i: int | str,
        j: int | str,
        material: Material,
        section: Section,
        theory: str = "timoshenko",
        orientation: Sequence[float] | None = None,
        rotary_inertia: bool | None = None,
    ) -> int:
        """Add one element from node i to node j; returns its index.

        ``rotary_inertia`` defaults to True for Timoshenko, False for Euler–Bernoulli.
        """
        i, j = self._node(i, "FrameModel.add_element"), self._node(j, "FrameModel.add_element")
        if i == j:
            raise ValueError(f"FrameModel.add_element: element connects node {i} to itself")
        if theory not in THEORIES:
            raise ValueError(f"FrameModel.add_element: theory must be one of {THEORIES}, got {theory!r}")
        start, end = np.asarray(self.coordinates[i]), np.asarray(self.coordinates[j])
        if orientation is None:
            axis = (end - start) / np.linalg.norm(end - start)
            orientation = (0.0, 1.0, 0.0) if abs(axis[2]) > 0.99 else (0.0, 0.0, 1.0)
        rotation_matrix(start, end, orientation)  # validates length and orientation
        element = BeamElement(
            i, j, material, section, tuple(float(c) for c in orientation), theory,
            theory == "timoshenko" if rotary_inertia is None else bool(rotary_inertia),
        )
        self.elements.append(element)
        return len(self.elements) - 1

    def add_beam(
        self,
        start: int | str,
        end: int | str,
        n_elements: int,
        material: Material,
        section: Section,
        theory: str = "timoshenko",
        orientation: Sequence[float] | None = None,
        rotary_inertia: bool | None = None,
        group: str | None = None,
        label_prefix: str | None = None,
    ) -> list[int]:
        """Mesh a straight beam from node ``start`` to node ``end`` with equal elements.

        Intermediate nodes are created (labelled ``f"{label_prefix}{k}"`` when a prefix
        is given, k = 1 … n_elements−1). Returns the node indices along the beam,
        ends included; with ``group`` they are also stored in ``groups[group]``.
        """
        if int(n_elements) != n_elements or n_elements < 1:
            raise ValueError(f"FrameModel.add_beam: n_elements must be a positive integer, got {n_elements!r}")
        a, b = self._node(start, "FrameModel.add_beam"), self._node(end, "FrameModel.add_beam")
        pa, pb = np.asarray(self.coordinates[a]), np.asarray(self.coordinates[b])
        nodes = [a]
        for k in range(1, int(n_elements)):
            label = None if label_prefix is None else f"{label_prefix}{k}"
            nodes.append(self.add_node(pa + (pb - pa) * k / n_elements, label))
        nodes.append(b)
        for p, q in zip(nodes[:-1], nodes[1:]):
            self.add_element(p, q, material, section, theory, orientation, rotary_inertia)
        if group is not None:
            members = self.groups.setdefault(group, [])
            members.extend(n for n in nodes if n not in members)
        return nodes

    def add_point_mass(
        self, node: int | str, mass: float, inertia: Sequence[float] = (0.0, 0.0, 0.0)
    ) -> None:
        """Lumped mass (kg) and rotary inertias about global x, y, z (kg·m²) at a node."""
        node = self._node(node, "FrameModel.add_point_mass")
        mass = check_positive("FrameModel.add_point_mass", "mass", mass, allow_zero=True)
        inertia = tuple(
            check_positive("FrameModel.add_point_mass", f"inertia[{k}]", v, allow_zero=True)
            for k, v in enumerate(inertia)
        )
        if len(inertia) != 3:
            raise ValueError(f"FrameModel.add_point_mass: inertia must have 3 entries (Ixx, Iyy, Izz), got {inertia}")
        self.point_masses.append(PointMass(node, mass, inertia))  # type: ignore[arg-type]

    def add_spring(
        self, node: int | str, dof: str | int, stiffness: float, other: int | str | None = None
    ) -> None:
        """Spring on global dof ``dof`` between ``node`` and ground (or ``other``)."""
        node = self._node(node, "FrameModel.add_spring")
        other_index = None if other is None else self._node(other, "FrameModel.add_spring")
        if other_index == node:
            raise ValueError(f"FrameModel.add_spring: spring connects node {node} to itself")
        stiffness = check_positive("FrameModel.add_spring", "stiffness", stiffness, allow_zero=True)
        self.springs.append(Spring(node, _dof(dof, "FrameModel.add_spring"), stiffness, other_index))

    def fix(self, node: int | str, dofs: Iterable[str | int] | str = "all") -> None:
        """Fix (zero) the given dofs of a node; ``"all"`` clamps it."""
        node = self._node(node, "FrameModel.fix")
        names = DOF_NAMES if dofs == "all" else ([dofs] if isinstance(dofs, str) else list(dofs))
        for name in names:
            self.fixed.add(6 * node + _dof(name, "FrameModel.fix"))

    def add_rigid_link(self, master: int | str, slave: int | str) -> None:
        """Make ``slave`` follow ``master`` rigidly (no chains: a master cannot be a slave)."""
        m, s = self._node(master, "FrameModel.add_rigid_link"), self._node(slave, "FrameModel.add_rigid_link")
        if m == s:
            raise ValueError(f"FrameModel.add_rigid_link: node {m} cannot be linked to itself")
        if s in self.rigid_links or m in self.rigid_links or s in self.rigid_links.values():
            raise ValueError(
                f"FrameModel.add_rigid_link: node {s} (slave) or {m} (master) is already in a rigid link "
                "as a slave, or the slave is already a master; chains are not supported"
            )
        self.rigid_links[s] = m

    # ------------------------------------------------------------------ naming
    @property
    def dof_names(self) -> tuple[str, ...]:
        """Names of all 6·n_nodes dofs of the full vector."""
        return tuple(f"{label}:{d}" for label in self.labels for d in DOF_NAMES)

    def coordinate_index(self, name: str) -> int:
        """Full-vector index of a coordinate ``"<node label>:<dof>"``."""
        label, sep, dof = str(name).rpartition(":")
        if not sep or label not in self.labels or dof not in DOF_NAMES:
            raise ValueError(
                f"coordinate {name!r}: expected '<node label>:<dof>' with dof in {DOF_NAMES} "
                f"and a known label (e.g. {self.labels[:5]})"
            )
        return 6 * self.labels.index(label) + DOF_NAMES.index(dof)

    def shapes_at(self, shapes: NDArray, coordinates: Sequence[str]) -> NDArray:
        """Rows of full-vector mode shapes at named coordinates: (len(coordinates), n_modes)."""
        return np.asarray(shapes)[[self.coordinate_index(c) for c in coordinates]]

    # ------------------------------------------------------------------ assembly
    def assemble(self) -> tuple[scipy.sparse.csr_matrix, scipy.sparse.csr_matrix]:
        """Unconstrained global stiffness K (N/m) and mass M (kg), sparse, 6·n_nodes square."""
        return assemble(self.coordinates, self.elements, self.point_masses, self.springs)

    def transformation(self) -> tuple[scipy.sparse.csr_matrix, tuple[int, ...]]:
        """Sparse T (6·n_nodes × n_free) with u = T q, and the full-vector index of each q.

        q are the dofs of nodes that are not rigid-link slaves, minus the fixed dofs.
        """
        return transformation(self.coordinates, self.labels, self.fixed, self.rigid_links)

    def reduced(self) -> tuple[scipy.sparse.csr_matrix, scipy.sparse.csr_matrix, scipy.sparse.csr_matrix, tuple[str, ...]]:
        """Constrained system: ``K_r = TᵀKT``, ``M_r = TᵀMT``, T, and names of the free dofs."""
        K, M = self.assemble()
        T, free = self.transformation()
        if not free:
            raise ValueError("FrameModel.reduced: every dof is fixed")
        K_r = (T.T @ K @ T).tocsr()
        M_r = (T.T @ M @ T).tocsr()
        names = self.dof_names
        return K_r, M_r, T, tuple(names[d] for d in free)

    # ------------------------------------------------------------------ solution
    def modal(self, n_modes: int, sigma: float = DEFAULT_SHIFT) -> ModalSolution:
        """Lowest ``n_modes`` natural frequencies (Hz) and mass-normalised mode shapes.

        Dense generalized eigen-solution for small models, otherwise ``eigsh`` in
        shift-invert mode about ``sigma`` (rad²/s², negative so that rigid-body modes
        are allowed). Shapes are returned on the full dof vector.
        """
        K_r, M_r, T, _ = self.reduced()
        return solve_modes(K_r, M_r, T, n_modes, sigma)

    def energy_fraction(
        self, shapes: NDArray, nodes: Iterable[int | str], dofs: Sequence[str] = DOF_NAMES
    ) -> NDArray[np.float64]:
        """Share of each mode's kinetic energy carried by the given dofs of ``nodes``.

        ``Σ_{i∈S} φ_i (Mφ)_i`` over the selected dofs S, for mass-normalised full-vector
        shapes: the shares of a partition of all dofs sum to 1. Point masses at those
        nodes are included.
        """
        _, M = self.assemble()
        directions = [_dof(d, "FrameModel.energy_fraction") for d in dofs]
        selected = np.array(
            [6 * self._node(n, "FrameModel.energy_fraction") + d for n in nodes for d in directions], dtype=int
        )
        shapes = np.asarray(shapes)
        weighted = M @ shapes
        return np.einsum("ir,ir->r", shapes[selected], weighted[selected])

    def to_lumped(self, loss_factor: float = 0.0) -> LumpedModel:
        """The constrained system as a :class:`~nlupdate.core.model.linear.LumpedModel`.

        Coordinates are the independent free dofs (names ``"<label>:<dof>"``; rigid-link
        slaves are not among them). ``loss_factor`` γ gives structural damping D = γK_r.
        """
        K_r, M_r, _, names = self.reduced()
        loss_factor = check_positive("FrameModel.to_lumped", "loss_factor", loss_factor, allow_zero=True)
        structural = loss_factor * K_r if loss_factor > 0 else None
        return LumpedModel(mass=M_r, stiffness=K_r, structural_damping=structural, dof_names=names)


__all__ = [
    "DEFAULT_SHIFT",
    "DENSE_LIMIT",
    "DOF_NAMES",
    "THEORIES",
    "BeamElement",
    "FrameModel",
    "Material",
    "ModalSolution",
    "PointMass",
    "Section",
    "Spring",
    "element_matrices",
    "rotation_matrix",
]
