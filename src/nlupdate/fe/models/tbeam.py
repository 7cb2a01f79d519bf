"""Frame model of the T-beam test structure (thesis §3.3 and §4; docs/methods.md §8).

Geometry and axes
-----------------
Beam 1 is a cantilever along global x, clamped at x = 0, with its section height h1
along z (the measured transverse direction) and width w1 along y. Its free end
("tip", x = L1) is clamped between two identical thin beams (h2 × w2 section, height
along z) that span y from −L2/2 to +L2/2 and are clamped at both ends; one lies above
beam 1 (centre line z = +(h1 + h2)/2), one below (z = −(h1 + h2)/2).

Joint model (``joint``)
-----------------------
* ``"patch"`` (default): the sandwich is a rigid body. Each thin beam is rigid over
  the clamped patch |y| ≤ w1/2 (its nodes there are rigid-link slaves of the tip node),
  and the offsets ±(h1 + h2)/2 of the thin beams from beam 1's axis are kept through
  the same rigid links.
* ``"point"``: offsets and patch neglected; both thin beams are attached to the tip
  node at their mid-span (the two coincident thin beams then also have anti-phase
  local modes).

Sensor masses (force transducer 30.2 g, accelerometer 4.8 g, thesis Table 4.14) are
point masses at the tip node without rotary inertia (the source modelled them as
stiff solids; their rotary inertia about the tip is negligible for the z modes).

Choice of lengths (documented, not tuned)
-----------------------------------------
Table 3.3 gives the beam lengths 430 mm (beam 1) and 400 mm (thin beams). §4.1.1 says
the test beams are longer than their *effective* lengths of 380 mm and 420 mm because
part of each beam is clamped in the fixture blocks. A 400 mm thin beam cannot have a
420 mm effective length, so beam 1 has 420 mm and the thin beams 380 mm free length.
With the nominal 430/400 mm this model gives 43.0 / 181.5 / 257.7 Hz for the first
three global modes (no sensor masses), 7–8 % below the source's ANSYS values, whereas
the effective lengths reproduce them (below). The defaults are therefore
L1 = 0.420 m and L2 = 0.380 m; :meth:`TBeamParameters.table_3_3` returns the nominal
lengths. No other quantity was adjusted.

Results (Timoshenko, 24 elements per beam, ``joint="patch"``) against the source's
ANSYS solid model (thesis Tables 4.9, 4.11, 4.15 and the §4.2.4.1 mesh study), first
three global modes:

* no sensor masses: 46.42 / 193.4 / 282.0 Hz vs 46.48 / 198.05 / 280–282 Hz
  (−0.1 %, −2.4 %, +0.4 % against 281 Hz);
* with sensor masses: 41.18 / 188.5 / 264.8 Hz vs 41.4 / 193.3 / 266.0 Hz
  (−0.5 %, −2.5 %, −0.5 %);
* updated candidate 1 (E 189.4 GPa, h2 1.600 mm, h1 7.727 mm, sensor masses):
  40.57 / 174.2 / 266.8 Hz vs 40.76 / 178.69 / 268.07 Hz (−0.5 %, −2.5 %, −0.5 %).

Mode 2 is consistently ~2.4 % below the solid model. As in the source, the first three
*global* modes are modes 1, 2 and 6 of the model; modes 3–5 are local modes of the thin
beams in which beam 1 does not move. With ``joint="point"`` the global frequencies are
45.44 / 190.1 / 271.8 Hz (no sensor masses). Euler–Bernoulli elements raise the
values by 0.03–0.15 %.
"""
from __future__ import annotations

from dataclasses import dataclass, fields, replace
from math import ceil

import numpy as np
from numpy.typing import NDArray

from nlupdate.fe.models.frame import FrameModel, Material, ModalSolution, Section

#: Default measurement coordinates: the drive point first, then beam 1 and thin beams.
TBEAM_COORDINATES: tuple[str, ...] = (
    "tip:uz",
    "b1_x0.25:uz",
    "b1_x0.5:uz",
    "b1_x0.75:uz",
    "b2u_ym:uz",
    "b2u_yp:uz",
)
#: A mode is global when beam 1's vertical bending (uz, ry dofs) carries at least this
#: share of its kinetic energy; local thin-beam modes have < 1e-3 here.
GLOBAL_ENERGY_THRESHOLD = 0.05
JOINTS = ("patch", "point")
FORCE_TRANSDUCER_MASS = 0.0302
ACCELEROMETER_MASS = 0.0048


@dataclass(frozen=True)
class TBeamParameters:
    """T-beam parameters in SI units (Pa, kg/m³, m, kg); see the module docstring."""

    E: float = 210e9
    nu: float = 0.3
    rho: float = 7850.0
    h1: float = 0.008
    w1: float = 0.012
    L1: float = 0.420
    h2: float = 0.0015
    w2: float = 0.013
    L2: float = 0.380
    transducer_mass: float = 0.0
    accelerometer_mass: float = 0.0

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if not np.isfinite(value):
                raise ValueError(f"TBeamParameters.{f.name} must be finite, got {value}")
        for name in ("E", "rho", "h1", "w1", "L1", "h2", "w2", "L2"):
            if getattr(self, name) <= 0:
                raise ValueError(f"TBeamParameters.{name} must be > 0, got {getattr(self, name)}")
        for name in ("transducer_mass", "accelerometer_mass"):
            if getattr(self, name) < 0:
                raise ValueError(f"TBeamParameters.{name} must be ≥ 0 kg, got {getattr(self, name)}")
        if not (-1.0 < self.nu < 0.5):
            raise ValueError(f"TBeamParameters.nu must be in (-1, 0.5), got {self.nu}")
        if self.w1 >= self.L2:
            raise ValueError(f"TBeamParameters: w1 ({self.w1} m) must be smaller than L2 ({self.L2} m)")

    def with_sensor_masses(self) -> "TBeamParameters":
        """Same structure with the force transducer (30.2 g) and accelerometer (4.8 g)."""
        return replace(self, transducer_mass=FORCE_TRANSDUCER_MASS, accelerometer_mass=ACCELEROMETER_MASS)

    @classmethod
    def table_3_3(cls) -> "TBeamParameters":
        """Nominal lengths of thesis Table 3.3 (L1 = 430 mm, L2 = 400 mm)."""
        return cls(L1=0.430, L2=0.400)


def tbeam_model(
    params: TBeamParameters,
    elements_per_beam: int = 24,
    theory: str = "timoshenko",
    joint: str = "patch",
) -> FrameModel:
    """Frame model of the T-beam.

    ``elements_per_beam`` is rounded up to a multiple of 4: beam 1 and each thin beam's
    flexible length get that many elements (plus two rigid patch elements per thin
    beam for ``joint="patch"``). Node labels: ``root``, ``tip``, ``b1_x0.25``,
    ``b1_x0.5``, ``b1_x0.75`` on beam 1; ``b2u_*`` / ``b2l_*`` on the upper / lower
    thin beam with ``_c`` (centre, patch joint only), ``_ym`` / ``_yp`` (middle of the
    free span at negative / positive y) and ``_end-`` / ``_end+`` (clamped ends).
    Groups: ``beam1``, ``thin_upper``, ``thin_lower``.
    """
    if joint not in JOINTS:
        raise ValueError(f"tbeam_model: joint must be one of {JOINTS}, got {joint!r}")
    if int(elements_per_beam) != elements_per_beam or elements_per_beam < 1:
        raise ValueError(f"tbeam_model: elements_per_beam must be a positive integer, got {elements_per_beam!r}")
    q = ceil(int(elements_per_beam) / 4)
    p = params
    material = Material(p.E, p.nu, p.rho)
    beam1 = Section.rectangular(width=p.w1, height=p.h1)
    thin = Section.rectangular(width=p.w2, height=p.h2)
    model = FrameModel()
    root = model.add_node((0.0, 0.0, 0.0), "root")
    stations = [root]
    for fraction in (0.25, 0.5, 0.75):
        stations.append(model.add_node((fraction * p.L1, 0.0, 0.0), f"b1_x{fraction:g}"))
    tip = model.add_node((p.L1, 0.0, 0.0), "tip")
    stations.append(tip)
    for a, b in zip(stations[:-1], stations[1:]):
        model.add_beam(a, b, q, material, beam1, theory, orientation=(0, 0, 1), group="beam1")
    model.fix(root)

    patch = joint == "patch"
    half_patch = p.w1 / 2 if patch else 0.0
    for tag, side, group in (("b2u", 1.0, "thin_upper"), ("b2l", -1.0, "thin_lower")):
        z = side * (p.h1 + p.h2) / 2 if patch else 0.0
        y_mid = half_patch + (p.L2 / 2 - half_patch) / 2
        end_minus = model.add_node((p.L1, -p.L2 / 2, z), f"{tag}_end-")
        mid_minus = model.add_node((p.L1, -y_mid, z), f"{tag}_ym")
        mid_plus = model.add_node((p.L1, y_mid, z), f"{tag}_yp")
        end_plus = model.add_node((p.L1, p.L2 / 2, z), f"{tag}_end+")
        if patch:
            centre = model.add_node((p.L1, 0.0, z), f"{tag}_c")
            edge_minus = model.add_node((p.L1, -half_patch, z))
            edge_plus = model.add_node((p.L1, half_patch, z))
            for slave in (edge_minus, centre, edge_plus):
                model.add_rigid_link(tip, slave)
            chain = [end_minus, mid_minus, edge_minus, centre, edge_plus, mid_plus, end_plus]
            counts = [q, q, 1, 1, q, q]
        else:
            chain = [end_minus, mid_minus, tip, mid_plus, end_plus]
            counts = [q, q, q, q]
        for a, b, n in zip(chain[:-1], chain[1:], counts):
            model.add_beam(a, b, n, material, thin, theory, orientation=(0, 0, 1), group=group)
        model.fix(end_minus)
        model.fix(end_plus)
    sensor_mass = p.transducer_mass + p.accelerometer_mass
    if sensor_mass > 0:
        model.add_point_mass(tip, sensor_mass)
    return model


def global_mode_mask(
    model: FrameModel, shapes: NDArray, threshold: float = GLOBAL_ENERGY_THRESHOLD
) -> NDArray[np.bool_]:
    """True for global modes: beam 1's z-bending (uz, ry) carries ≥ ``threshold`` of the
    mode's kinetic energy. Local thin-beam modes, and torsion or lateral modes of
    beam 1, are not global."""
    share = model.energy_fraction(shapes, model.groups["beam1"], dofs=("uz", "ry"))
    return share >= threshold


def global_modes(
    model: FrameModel, n_modes: int, threshold: float = GLOBAL_ENERGY_THRESHOLD
) -> tuple[ModalSolution, NDArray[np.int_]]:
    """The lowest ``n_modes`` global modes and their (0-based) indices among all modes."""
    if int(n_modes) != n_modes or n_modes < 1:
        raise ValueError(f"global_modes: n_modes must be a positive integer, got {n_modes!r}")
    n_free = len(model.transformation()[1])
    count = min(n_free, 3 * int(n_modes) + 6)
    while True:
        solution = model.modal(count)
        indices = np.flatnonzero(global_mode_mask(model, solution.shapes, threshold))
        if indices.size >= n_modes:
            chosen = indices[:n_modes]
            return ModalSolution(solution.frequencies_hz[chosen], solution.shapes[:, chosen]), chosen
        if count == n_free:
            raise ValueError(
                f"global_modes: the model has only {indices.size} global modes, asked for {n_modes}"
            )
        count = min(n_free, 2 * count)


def global_frequencies(model: FrameModel, n_modes: int) -> NDArray[np.float64]:
    """Natural frequencies (Hz) of the lowest ``n_modes`` global modes."""
    return global_modes(model, n_modes)[0].frequencies_hz


__all__ = [
    "ACCELEROMETER_MASS",
    "FORCE_TRANSDUCER_MASS",
    "GLOBAL_ENERGY_THRESHOLD",
    "TBEAM_COORDINATES",
    "TBeamParameters",
    "global_frequencies",
    "global_mode_mask",
    "global_modes",
    "tbeam_model",
]
