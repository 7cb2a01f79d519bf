"""3D frame (beam) elements: materials, sections and the local stiffness and mass matrices.

Conventions
-----------
* SI units (m, kg, N, Pa).
* Six dofs per node, in the order ``ux, uy, uz, rx, ry, rz`` (global axes, rotations in
  rad, right-hand rule).
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

Point masses carry rotary inertia about the global axes; springs act on one global dof,
to ground or between two nodes.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass
from math import pi

import numpy as np
from numpy.typing import ArrayLike, NDArray

DOF_NAMES: tuple[str, ...] = ("ux", "uy", "uz", "rx", "ry", "rz")
THEORIES = ("euler", "timoshenko")
_GAUSS_POINTS, _GAUSS_WEIGHTS = np.polynomial.legendre.leggauss(6)


def check_positive(where: str, name: str, value: float, allow_zero: bool = False) -> float:
    """``value`` as a float; ValueError naming ``where`` and ``name`` unless finite and > 0 (≥ 0 with ``allow_zero``)."""
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
        check_positive("Material", "E", self.E)
        check_positive("Material", "rho", self.rho, allow_zero=True)
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
            check_positive("Section", name, getattr(self, name))

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
        width = check_positive("Section.rectangular", "width", width)
        height = check_positive("Section.rectangular", "height", height)
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
        outer = check_positive("Section.circular_tube", "outer_diameter", outer_diameter)
        inner = check_positive("Section.circular_tube", "inner_diameter", inner_diameter, allow_zero=True)
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
    length = check_positive("element_matrices", "length", length)
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

