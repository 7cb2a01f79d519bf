"""Frame model of the gun barrel of a battle tank (thesis §5.11; docs/methods.md §8).

What the source gives (thesis Tables 5.28, 5.29): gun tube of carbon steel,
E = 207 GPa, length 6.6 m, inner diameter 120 mm; shielding-armor 650 kg with
29.6 kg·m²; rear components 1845 kg with 667 kg·m²; the tube pivots on a pin joint
at the trunnion axis and the elevation-motor assembly is a linear spring of
stiffness 140e6 N/m (initial) acting along the gun-tube axis, pinned to the turret and
to the gun. Published FE frequencies (vertical plane): initial 6.375 / 17.777 /
43.897 Hz; with the updated motor stiffness 499e6 N/m 7.469 / 21.816 / 45.694 Hz.

What is assumed here (not in the source) and how it was chosen
---------------------------------------------------------------
* Uniform tube of outer diameter 0.275 m (a real tube tapers from a thick chamber to
  a thin muzzle; this is its equivalent uniform section), ν = 0.3, ρ = 7850 kg/m³.
* Trunnion 1.36 m ahead of the breech end; rear components as a point mass at the
  breech end; shielding-armor (mantlet) as a point mass 0.30 m ahead of the trunnion.
* The motor spring acts along the tube axis (global x) at a point 0.80 m below the
  trunnion axis, rigidly linked to the trunnion node, so its pitch stiffness about
  the trunnion is ``motor_stiffness · motor_arm²``.
* Motion in the vertical (x–z) plane only: uy, rx, rz are fixed at every node (the
  traverse drive and horizontal modes are outside the source's model). Point-mass
  inertias are applied about all three axes; only the pitch inertia Iyy acts.

The outer diameter, trunnion position and motor lever arm were chosen (rounded
least-squares fit) so that the six published FE frequencies above are reproduced;
they are plausible for a 120 mm tank gun but are not measured data. Results
(Timoshenko, 48 elements), this model vs source:

=====================  =========================  ==========================
motor stiffness        this model (Hz)            source FE (Hz)
=====================  =========================  ==========================
140e6 N/m (initial)    6.34, 18.28, 44.47         6.375, 17.777, 43.897
499e6 N/m (updated)    7.34, 21.37, 46.20         7.469, 21.816, 45.694
=====================  =========================  ==========================

i.e. within −1.7 … +2.8 %. (To reach the PRD-extracted 7.46875 Hz this model needs a
motor stiffness of about 689e6 N/m rather than the source's 499e6 N/m.) Measurement coordinates follow the thesis test: node 1 at
the muzzle (``"muzzle:uz"``, the drive point) and nodes 2–6 (``"p2:uz"`` … ``"p6:uz"``)
evenly spaced towards the turret, p6 at one sixth of the trunnion–muzzle distance.
"""
from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from nlupdate.fe.models.frame import FrameModel, Material, Section

GUNBARREL_COORDINATES: tuple[str, ...] = ("muzzle:uz", "p2:uz", "p3:uz", "p4:uz", "p5:uz", "p6:uz")


@dataclass(frozen=True)
class GunBarrelParameters:
    """Gun-barrel parameters in SI units (Pa, kg/m³, m, kg, kg·m², N/m).

    Positions: ``trunnion_position`` is measured from the breech end of the tube,
    ``armor_position`` ahead of the trunnion; the rear components sit at the breech end.
    """

    E: float = 207e9
    nu: float = 0.3
    rho: float = 7850.0
    length: float = 6.6
    inner_diameter: float = 0.120
    outer_diameter: float = 0.275
    trunnion_position: float = 1.36
    armor_mass: float = 650.0
    armor_inertia: float = 29.6
    armor_position: float = 0.30
    rear_mass: float = 1845.0
    rear_inertia: float = 667.0
    motor_stiffness: float = 140e6
    motor_arm: float = 0.80

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if not np.isfinite(value):
                raise ValueError(f"GunBarrelParameters.{f.name} must be finite, got {value}")
            if f.name != "nu" and value < 0:
                raise ValueError(f"GunBarrelParameters.{f.name} must be ≥ 0, got {value}")
        for name in ("E", "rho", "length", "outer_diameter", "trunnion_position", "motor_arm"):
            if getattr(self, name) <= 0:
                raise ValueError(f"GunBarrelParameters.{name} must be > 0, got {getattr(self, name)}")
        if not (-1.0 < self.nu < 0.5):
            raise ValueError(f"GunBarrelParameters.nu must be in (-1, 0.5), got {self.nu}")
        if self.inner_diameter >= self.outer_diameter:
            raise ValueError(
                f"GunBarrelParameters: inner_diameter ({self.inner_diameter} m) must be smaller than "
                f"outer_diameter ({self.outer_diameter} m)"
            )
        forward = self.length - self.trunnion_position
        if forward <= 0:
            raise ValueError(
                f"GunBarrelParameters: trunnion_position ({self.trunnion_position} m) must be less than length ({self.length} m)"
            )
        if not (0 < self.armor_position < forward / 6):
            raise ValueError(
                f"GunBarrelParameters: armor_position ({self.armor_position} m) must lie between the trunnion "
                f"and measurement point p6 ({forward / 6:.3f} m ahead of the trunnion)"
            )


def gunbarrel_model(
    params: GunBarrelParameters, elements: int = 48, theory: str = "timoshenko"
) -> FrameModel:
    """Planar (x–z) frame model of the gun barrel; x along the tube, trunnion at x = 0.

    ``elements`` is the target element count of the tube; each segment between the
    stations (breech, trunnion, armor, p6 … p2, muzzle) gets
    ``max(1, round(elements · segment/length))`` elements. Node labels: ``breech``,
    ``trunnion``, ``armor``, ``p6`` … ``p2``, ``muzzle`` and ``motor`` (the spring's
    attachment point, a rigid-link slave of the trunnion). Group ``tube``.
    """
    if int(elements) != elements or elements < 1:
        raise ValueError(f"gunbarrel_model: elements must be a positive integer, got {elements!r}")
    p = params
    material = Material(p.E, p.nu, p.rho)
    section = Section.circular_tube(p.outer_diameter, p.inner_diameter, nu=p.nu)
    forward = p.length - p.trunnion_position
    stations = [("breech", -p.trunnion_position), ("trunnion", 0.0), ("armor", p.armor_position)]
    stations += [(f"p{k}", forward * (1.0 - (k - 1) / 6.0)) for k in range(6, 1, -1)]
    stations.append(("muzzle", forward))
    model = FrameModel()
    nodes = [model.add_node((x, 0.0, 0.0), label) for label, x in stations]
    for (_, xa), (_, xb), a, b in zip(stations[:-1], stations[1:], nodes[:-1], nodes[1:]):
        n = max(1, round(elements * (xb - xa) / p.length))
        model.add_beam(a, b, n, material, section, theory, orientation=(0, 0, 1), group="tube")
    model.add_point_mass("breech", p.rear_mass, (p.rear_inertia,) * 3)
    model.add_point_mass("armor", p.armor_mass, (p.armor_inertia,) * 3)
    motor = model.add_node((0.0, 0.0, -p.motor_arm), "motor")
    model.add_rigid_link("trunnion", motor)
    model.add_spring(motor, "ux", p.motor_stiffness)
    model.fix("trunnion", ("ux", "uz"))
    for node in range(model.n_nodes):
        if node not in model.rigid_links:
            model.fix(node, ("uy", "rx", "rz"))
    return model


__all__ = ["GUNBARREL_COORDINATES", "GunBarrelParameters", "gunbarrel_model"]
