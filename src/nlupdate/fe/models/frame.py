"""3D frame (beam) finite elements: assembly, constraints and modal solution.

Length: one module because the element matrices, the assembly, the constraints and
the modal solution share the dof numbering and axes stated here; :class:`FrameModel` is
most of it.

Conventions
-----------
* SI units (m, kg, N, Pa); frequencies in Hz at the interface, rad/s inside.
* Six dofs per node, in the order ``ux, uy, uz, rx, ry, rz`` (global axes, rotations in
  rad, right-hand rule). Node ``n`` owns the full-vector dofs ``6n … 6n+5``.
* A coordinate is named ``"<node label>:<dof>"``, e.g. ``"tip:uz"``. Unlabelled nodes
  are called ``"n<index>"``.
* Element local axes: x from node i to node j; local z is the part of the element's
  ``orientation`` vector normal to x (default global z, or global y for elements
  parallel to z); local y = z × x. Rectangular sections have their ``height`` along
  local z and ``width`` along local y.

Element formulation
-------------------
Two-node beam with axial (linear), torsional (linear, Saint-Venant constant J) and
two bending planes. Bending uses the interdependent (Kosmatka) interpolation of the
Timoshenko beam: with the shear parameter ``Φ = 12EI/(κGAL²)`` these shape functions
solve the static Timoshenko equations exactly, so the stiffness is exact and shear
locking cannot occur; ``Φ = 0`` gives the Hermite cubics of Euler–Bernoulli theory.
The consistent mass matrix is the integral of the same shape functions (Gauss
quadrature, exact for these polynomials): translational inertia ``ρA`` plus, when
``rotary_inertia`` is on, the rotary inertia ``ρI`` of the section. Torsional inertia
uses the polar moment ``ρ(Iy + Iz)``.

``theory="euler"`` is the classical Euler–Bernoulli beam (no shear deformation, no
rotary inertia unless asked); ``theory="timoshenko"`` adds shear deformation and rotary
inertia. Shear correction factors κ: 5/6 for rectangles (the usual value; Cowper's
``10(1+ν)/(12+11ν)`` = 0.85 for ν = 0.3 differs by 2 %), Cowper's formula for hollow
circles ``6(1+ν)(1+m²)² / ((7+6ν)(1+m²)² + (20+12ν)m²)``, m = d/D, which gives
0.886 for a solid bar and tends to ``2(1+ν)/(4+3ν)`` ≈ 0.53 for a thin tube.

Other items: point masses with rotary inertia about the global axes, translational or
rotational springs to ground or between two nodes (acting on one global dof),
fixed dofs, and rigid links (slave node follows master node:
``u_s = u_m + θ_m × (x_s − x_m)``, ``θ_s = θ_m``). Constraints and rigid links are
applied by a transformation ``u = T q`` to the independent free dofs q, so
``K_r = Tᵀ K T`` and ``M_r = Tᵀ M T``; mode shapes are returned on the full dof vector.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass
from math import pi
from typing import Iterable, NamedTuple, Sequence

import numpy as np
import scipy.linalg
import scipy.sparse
import scipy.sparse.linalg
from numpy.typing import ArrayLike, NDArray

from nlupdate.core.model.linear import LumpedModel

DOF_NAMES: tuple[str, ...] = ("ux", "uy", "uz", "rx", "ry", "rz")
THEORIES = ("euler", "timoshenko")
#: Dense eigen-solution below this many free dofs, shift-invert Lanczos above.
DENSE_LIMIT = 300
#: Default spectral shift (rad²/s²) of the eigen-solution; negative, so that K − σM is
#: positive definite even when the model has rigid-body modes.
DEFAULT_SHIFT = -1.0

_SINGULAR_MESSAGE = (
    "FrameModel.modal: K − σM is singular or indefinite — some free dof has neither stiffness nor "
    "mass (e.g. a node without elements); fix those dofs"
)
_GAUSS_POINTS, _GAUSS_WEIGHTS = np.polynomial.legendre.leggauss(6)


def _positive(where: str, name: str, value: float, allow_zero: bool = False) -> float:
    value = float(value)
    ok = value >= 0 if allow_zero else value > 0
    if not (np.isfinite(value) and ok):
        expected = "≥ 0" if allow_zero else "> 0"
        raise ValueError(f"{where}: {name} must be finite and {expected}, got {value}")
    return value


@dataclass(frozen=True)
class Material:
    """Linear elastic isotropic material: E (Pa), Poisson's ratio ν, density ρ (kg/m³)."""

    E: float
    nu: float
    rho: float

    def __post_init__(self) -> None:
        _positive("Material", "E", self.E)
        _positive("Material", "rho", self.rho, allow_zero=True)
        if not (-1.0 < float(self.nu) < 0.5):
            raise ValueError(f"Material: nu must be in (-1, 0.5), got {self.nu}")

    @property
    def G(self) -> float:
        """Shear modulus E/(2(1+ν)) (Pa)."""
        return self.E / (2.0 * (1.0 + self.nu))


@dataclass(frozen=True)
class Section:
    """Beam cross-section properties (local axes y, z).

    area (m²); iy, iz: second moments of area about local y and z (m⁴) — ``iy`` governs
    bending in the x–z plane (deflection along local z); torsion_constant J (m⁴);
    shear_coefficient_y/z: κ for shear along local y/z.
    """

    area: float
    iy: float
    iz: float
    torsion_constant: float
    shear_coefficient_y: float = 5.0 / 6.0
    shear_coefficient_z: float = 5.0 / 6.0

    def __post_init__(self) -> None:
        for name in ("area", "iy", "iz", "torsion_constant", "shear_coefficient_y", "shear_coefficient_z"):
            _positive("Section", name, getattr(self, name))

    @property
    def polar_moment(self) -> float:
        """Polar second moment of area Iy + Iz (m⁴), used for torsional inertia."""
        return self.iy + self.iz

    @classmethod
    def rectangular(cls, width: float, height: float, shear_coefficient: float = 5.0 / 6.0) -> "Section":
        """Solid rectangle, ``width`` along local y and ``height`` along local z (m).

        Torsion constant from Roark: ``J = a b³ [1/3 − 0.21 (b/a)(1 − b⁴/(12a⁴))]``,
        a ≥ b the long and short sides (error < 0.5 % for all aspect ratios).
        """
        width = _positive("Section.rectangular", "width", width)
        height = _positive("Section.rectangular", "height", height)
        a, b = max(width, height), min(width, height)
        torsion = a * b**3 * (1.0 / 3.0 - 0.21 * (b / a) * (1.0 - b**4 / (12.0 * a**4)))
        return cls(
            area=width * height,
            iy=width * height**3 / 12.0,
            iz=height * width**3 / 12.0,
            torsion_constant=torsion,
            shear_coefficient_y=shear_coefficient,
            shear_coefficient_z=shear_coefficient,
        )

    @classmethod
    def circular_tube(cls, outer_diameter: float, inner_diameter: float = 0.0, nu: float = 0.3) -> "Section":
        """Hollow (or solid, inner_diameter = 0) circle (m); κ from Cowper (1966)."""
        outer = _positive("Section.circular_tube", "outer_diameter", outer_diameter)
        inner = _positive("Section.circular_tube", "inner_diameter", inner_diameter, allow_zero=True)
        if inner >= outer:
            raise ValueError(
                f"Section.circular_tube: inner_diameter ({inner} m) must be smaller than outer_diameter ({outer} m)"
            )
        m2 = (inner / outer) ** 2
        kappa = 6 * (1 + nu) * (1 + m2) ** 2 / ((7 + 6 * nu) * (1 + m2) ** 2 + (20 + 12 * nu) * m2)
        second_moment = pi * (outer**4 - inner**4) / 64.0
        return cls(
            area=pi * (outer**2 - inner**2) / 4.0,
            iy=second_moment,
            iz=second_moment,
            torsion_constant=2.0 * second_moment,
            shear_coefficient_y=kappa,
            shear_coefficient_z=kappa,
        )


@dataclass(frozen=True)
class BeamElement:
    """Two-node frame element between node indices ``i`` and ``j``."""

    i: int
    j: int
    material: Material
    section: Section
    orientation: tuple[float, float, float]
    theory: str
    rotary_inertia: bool


@dataclass(frozen=True)
class PointMass:
    """Mass (kg) and rotary inertias about global x, y, z (kg·m²) at a node."""

    node: int
    mass: float
    inertia: tuple[float, float, float]


@dataclass(frozen=True)
class Spring:
    """Spring on one global dof: node to ground (``other`` None) or node to node.

    Units N/m for translations, N·m/rad for rotations.
    """

    node: int
    dof: int
    stiffness: float
    other: int | None = None


class ModalSolution(NamedTuple):
    """Natural frequencies (Hz, ascending) and mass-normalised mode shapes.

    ``shapes`` has shape (6·n_nodes, n_modes) on the full dof vector (fixed dofs are 0),
    units 1/√kg; each mode's largest entry is positive.
    """

    frequencies_hz: NDArray[np.float64]
    shapes: NDArray[np.float64]


def _plane_shape_functions(xi: NDArray, length: float, phi: float) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Interdependent Timoshenko shape functions for one bending plane (Kosmatka 1993).

    Plane dofs (w1, θ1, w2, θ2) with θ the section rotation, θ = dw/dx when Φ = 0;
    ξ = x/L. Returns N_w, dN_w/dx, N_θ and dN_θ/dx, each of shape (len(xi), 4).
    """
    c = 1.0 / (1.0 + phi)
    L = length
    n_w = c * np.stack(
        [
            2 * xi**3 - 3 * xi**2 - phi * xi + 1 + phi,
            L * (xi**3 - (2 + phi / 2) * xi**2 + (1 + phi / 2) * xi),
            -(2 * xi**3 - 3 * xi**2 - phi * xi),
            L * (xi**3 - (1 - phi / 2) * xi**2 - (phi / 2) * xi),
        ],
        axis=-1,
    )
    dn_w = c * np.stack(
        [
            (6 * xi**2 - 6 * xi - phi) / L,
            3 * xi**2 - (4 + phi) * xi + 1 + phi / 2,
            -(6 * xi**2 - 6 * xi - phi) / L,
            3 * xi**2 - (2 - phi) * xi - phi / 2,
        ],
        axis=-1,
    )
    n_t = c * np.stack(
        [
            6.0 / L * (xi**2 - xi),
            3 * xi**2 - (4 + phi) * xi + 1 + phi,
            -6.0 / L * (xi**2 - xi),
            3 * xi**2 - (2 - phi) * xi,
        ],
        axis=-1,
    )
    dn_t = c / L * np.stack(
        [
            6.0 / L * (2 * xi - 1),
            6 * xi - (4 + phi),
            -6.0 / L * (2 * xi - 1),
            6 * xi - (2 - phi),
        ],
        axis=-1,
    )
    return n_w, dn_w, n_t, dn_t


def _plane_bending(
    length: float, EI: float, kGA: float, rhoA: float, rhoI: float, shear: bool
) -> tuple[NDArray, NDArray]:
    """Stiffness and consistent mass (4×4) of one bending plane, by Gauss quadrature."""
    phi = 12.0 * EI / (kGA * length**2) if shear else 0.0
    xi = 0.5 * (_GAUSS_POINTS + 1.0)
    weights = 0.5 * length * _GAUSS_WEIGHTS
    n_w, dn_w, n_t, dn_t = _plane_shape_functions(xi, length, phi)
    k = EI * np.einsum("g,ga,gb->ab", weights, dn_t, dn_t)
    if shear:
        # Shear strain γ = dw/dx − θ (constant along the element for these functions).
        gamma = dn_w - n_t
        k = k + kGA * np.einsum("g,ga,gb->ab", weights, gamma, gamma)
    m = rhoA * np.einsum("g,ga,gb->ab", weights, n_w, n_w)
    if rhoI > 0:
        m = m + rhoI * np.einsum("g,ga,gb->ab", weights, n_t, n_t)
    return k, m


@functools.lru_cache(maxsize=4096)
def element_matrices(
    length: float, material: Material, section: Section, theory: str, rotary_inertia: bool
) -> tuple[NDArray, NDArray]:
    """Local 12×12 stiffness and consistent mass of a frame element.

    Local dof order per node: u, v, w, θx, θy, θz. Bending in x–y uses Iz and
    (v, θz) with θz = dv/dx; bending in x–z uses Iy and (w, θy) with θy = −dw/dx.
    """
    if theory not in THEORIES:
        raise ValueError(f"element theory must be one of {THEORIES}, got {theory!r}")
    length = _positive("element_matrices", "length", length)
    E, G, rho = material.E, material.G, material.rho
    A = section.area
    shear = theory == "timoshenko"
    k = np.zeros((12, 12))
    m = np.zeros((12, 12))
    # Axial (u) and torsion (θx): linear interpolation.
    bar_k = np.array([[1.0, -1.0], [-1.0, 1.0]])
    bar_m = np.array([[2.0, 1.0], [1.0, 2.0]]) * length / 6.0
    for dofs, stiff, inertia in (
        ([0, 6], E * A / length, rho * A),
        ([3, 9], G * section.torsion_constant / length, rho * section.polar_moment),
    ):
        k[np.ix_(dofs, dofs)] += stiff * bar_k
        m[np.ix_(dofs, dofs)] += inertia * bar_m
    # Bending x–y: dofs v (1), θz (5); rotation = +dv/dx.
    k_xy, m_xy = _plane_bending(
        length, E * section.iz, section.shear_coefficient_y * G * A, rho * A,
        rho * section.iz if rotary_inertia else 0.0, shear,
    )
    idx = [1, 5, 7, 11]
    k[np.ix_(idx, idx)] += k_xy
    m[np.ix_(idx, idx)] += m_xy
    # Bending x–z: dofs w (2), θy (4); rotation = −dw/dx, hence the sign flip.
    k_xz, m_xz = _plane_bending(
        length, E * section.iy, section.shear_coefficient_z * G * A, rho * A,
        rho * section.iy if rotary_inertia else 0.0, shear,
    )
    sign = np.array([1.0, -1.0, 1.0, -1.0])
    idx = [2, 4, 8, 10]
    k[np.ix_(idx, idx)] += sign[:, None] * k_xz * sign[None, :]
    m[np.ix_(idx, idx)] += sign[:, None] * m_xz * sign[None, :]
    k = 0.5 * (k + k.T)
    m = 0.5 * (m + m.T)
    k.flags.writeable = False
    m.flags.writeable = False
    return k, m


def rotation_matrix(start: ArrayLike, end: ArrayLike, orientation: ArrayLike) -> NDArray:
    """3×3 matrix whose rows are the element's local x, y, z axes in global components."""
    axis = np.asarray(end, dtype=float) - np.asarray(start, dtype=float)
    length = np.linalg.norm(axis)
    if length == 0:
        raise ValueError("rotation_matrix: element has zero length (coincident nodes)")
    ex = axis / length
    v = np.asarray(orientation, dtype=float)
    ez = v - (v @ ex) * ex
    norm = np.linalg.norm(ez)
    if norm < 1e-8 * max(np.linalg.norm(v), 1e-300):
        raise ValueError(
            f"rotation_matrix: orientation {tuple(v)} is parallel to the element axis {tuple(ex)}; "
            "give an orientation vector with a component normal to the element"
        )
    ez = ez / norm
    ey = np.cross(ez, ex)
    return np.vstack([ex, ey, ez])


def _skew(r: NDArray) -> NDArray:
    """Matrix S with S @ a = r × a."""
    return np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])


def _dof(name: str | int, where: str) -> int:
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
        mass = _positive("FrameModel.add_point_mass", "mass", mass, allow_zero=True)
        inertia = tuple(
            _positive("FrameModel.add_point_mass", f"inertia[{k}]", v, allow_zero=True)
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
        stiffness = _positive("FrameModel.add_spring", "stiffness", stiffness, allow_zero=True)
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
        n = 6 * self.n_nodes
        if n == 0:
            raise ValueError("FrameModel.assemble: the model has no nodes")
        rows, cols, k_data, m_data = [], [], [], []
        xyz = np.asarray(self.coordinates)
        for element in self.elements:
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
        for pm in self.point_masses:
            dofs = np.arange(6 * pm.node, 6 * pm.node + 6)
            rows.append(dofs)
            cols.append(dofs)
            k_data.append(np.zeros(6))
            m_data.append(np.array([pm.mass] * 3 + list(pm.inertia)))
        for spring in self.springs:
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

    def transformation(self) -> tuple[scipy.sparse.csr_matrix, tuple[int, ...]]:
        """Sparse T (6·n_nodes × n_free) with u = T q, and the full-vector index of each q.

        q are the dofs of nodes that are not rigid-link slaves, minus the fixed dofs.
        """
        for slave in self.rigid_links:
            fixed_here = [d for d in range(6) if 6 * slave + d in self.fixed]
            if fixed_here:
                raise ValueError(
                    f"FrameModel: node {self.labels[slave]!r} is a rigid-link slave and cannot have fixed dofs "
                    f"({[DOF_NAMES[d] for d in fixed_here]}); fix its master instead"
                )
        free = tuple(
            6 * node + d
            for node in range(self.n_nodes)
            if node not in self.rigid_links
            for d in range(6)
            if 6 * node + d not in self.fixed
        )
        position = {dof: k for k, dof in enumerate(free)}
        rows, cols, vals = [], [], []
        for dof, k in position.items():
            rows.append(dof)
            cols.append(k)
            vals.append(1.0)
        xyz = np.asarray(self.coordinates)
        for slave, master in self.rigid_links.items():
            block = np.eye(6)
            block[0:3, 3:6] = -_skew(xyz[slave] - xyz[master])  # u_s = u_m + θ_m × r = u_m − r × θ_m
            for a in range(6):
                for b in range(6):
                    target = 6 * master + b
                    if block[a, b] != 0.0 and target in position:
                        rows.append(6 * slave + a)
                        cols.append(position[target])
                        vals.append(block[a, b])
        T = scipy.sparse.coo_matrix((vals, (rows, cols)), shape=(6 * self.n_nodes, len(free))).tocsr()
        return T, free

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
        loss_factor = _positive("FrameModel.to_lumped", "loss_factor", loss_factor, allow_zero=True)
        structural = loss_factor * K_r if loss_factor > 0 else None
        return LumpedModel(mass=M_r, stiffness=K_r, structural_damping=structural, dof_names=names)


__all__ = [
    "DOF_NAMES",
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
