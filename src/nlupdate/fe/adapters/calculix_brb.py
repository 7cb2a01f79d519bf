"""The Brake–Reuss beam (BRB) in CalculiX, reduced exactly at its bolts.

Geometry (SI, global axes; x along the beam, y the bending direction the test measures
and the bolts' axis — the normal of the lap interface —, z across the width):

* beam A: x ∈ [0, La]; full section y ∈ [−h/2, h/2] for x < La − Llap, its lap
  x ∈ [La − Llap, La] machined to y ∈ [0, h/2];
* beam B: the mirror image, x ∈ [L − La, L] with L = 2·La − Llap, its lap y ∈ [−h/2, 0];
* width z ∈ [−b/2, b/2]; the interface is the plane y = 0 over the lap, the two beams
  meshed separately so each interface point is a pair of coincident nodes;
* three bolts through the lap at x = x_c + (−s, 0, s), z = 0 (x_c the lap's centre): the
  interface nodes of each beam within ``patch_radius`` of a bolt's axis (its clamped
  area) are tied rigidly to the bolt's reference point (an RBE2 spider, done on the
  matrices, :func:`nlupdate.fe.reduction.rigid_patches`), so each bolt is one node pair
  ``bolt<k>_a`` / ``bolt<k>_b`` with six dofs each;
* accelerometers at ``(x, h/2 or −h/2, 0)`` stations, the y displacement of the nearest
  surface node: ``acc1:uy``, ``acc2:uy``, ``acc3:uy`` (acc3 is the shaker's drive point).

Mesh: structured 20-node bricks, full integration (C3D20: ccx integrates the C3D20R mass
matrix at 8 points, which leaves it singular — no use for a reduction). The reduction
(:func:`brb_reduced`) is Craig–Bampton onto the bolts' 36 dofs, the accelerometers' y and
``n_modes`` fixed-interface modes. The joint itself is not in the FE model: the library's
elements act between the bolt pairs (:mod:`examples/brb`).
"""
from __future__ import annotations

import time
from collections import OrderedDict
from dataclasses import asdict, dataclass
from threading import Lock
from typing import Mapping

import numpy as np
import scipy.linalg

from nlupdate.fe.adapters.base import FEAdapter, ModalResult
from nlupdate.fe.adapters.calculix_matrices import CalculixMatrices
from nlupdate.fe.adapters.calculix_tbeam import box_mesh
from nlupdate.fe.reduction import ReducedModel, craig_bampton, rigid_patches
from nlupdate.fingerprints import fingerprint

BRB_DEFAULTS: dict[str, float] = {
    "E": 193e9,  # Pa, 304 stainless steel
    "nu": 0.29,
    "rho": 8000.0,  # kg/m³
    "La": 0.42,  # m, each beam's length
    "Llap": 0.12,  # m, the lap
    "h": 0.0127,  # m, thickness along y (bending direction)
    "b": 0.0254,  # m, width along z
    "bolt_spacing": 0.03,  # m
    "patch_radius": 0.008,  # m, radius of a bolt's clamped area
    "acc1_x": 0.70,  # m
    "acc2_x": 0.56,
    "acc3_x": 0.09,
    "sensor_mass": 0.0,  # kg at each accelerometer station
}
BRB_PARAMETER_NAMES = tuple(BRB_DEFAULTS)
ACCELEROMETERS = ("acc1", "acc2", "acc3")
BOLTS = ("bolt1", "bolt2", "bolt3")
#: The joint's linear stiffness per bolt, between the bolt's two reference points: ``kt`` (N/m)
#: along x and z (in the interface; along x it is the stuck stiffness of the friction element
#: that replaces it in the nonlinear model), ``kn`` (N/m) along y (normal) and ``kr`` (N·m/rad)
#: for the three relative rotations (the clamped area's bending and twist).
JOINT_DEFAULTS: dict[str, float] = {"kt": 3e8, "kn": 1e10, "kr": 1e6}
#: Elastic modes below this are the free–free structure's rigid-body modes (Hz).
RIGID_BODY_HZ = 1.0


@dataclass(frozen=True)
class BRBMesh:
    """Element counts: along the full part of each beam, along the lap, through the full
    thickness (the lap gets half of them), across the width."""

    n_full: int = 15
    n_lap: int = 12
    n_thickness: int = 2
    n_width: int = 2

    def __post_init__(self) -> None:
        for name, value in asdict(self).items():
            if not (isinstance(value, int) and value >= 1):
                raise ValueError(f"BRBMesh.{name} must be a positive integer, got {value!r}")
        if self.n_thickness % 2:
            raise ValueError(f"BRBMesh.n_thickness must be even (the lap is half the section), got {self.n_thickness}")


def brb_parameters(parameters: Mapping[str, float] | None = None) -> dict[str, float]:
    """Defaults overlaid with ``parameters``; checks names and ranges (SI)."""
    values = dict(BRB_DEFAULTS)
    for name, value in (parameters or {}).items():
        if name not in BRB_DEFAULTS:
            raise ValueError(f"BRB deck: unknown parameter {name!r}; expected one of {list(BRB_PARAMETER_NAMES)}")
        values[name] = float(value)
    for name in ("E", "rho", "La", "Llap", "h", "b", "bolt_spacing", "patch_radius"):
        if not values[name] > 0:
            raise ValueError(f"BRB deck: {name} must be positive (SI units), got {values[name]}")
    if not -1.0 < values["nu"] < 0.5:
        raise ValueError(f"BRB deck: nu must be in (-1, 0.5), got {values['nu']}")
    if not values["Llap"] < values["La"]:
        raise ValueError(f"BRB deck: Llap = {values['Llap']} m must be shorter than La = {values['La']} m")
    if not 2 * values["bolt_spacing"] + 2 * values["patch_radius"] < values["Llap"]:
        raise ValueError("BRB deck: the three bolts' patches (2·bolt_spacing + 2·patch_radius) must fit in the lap")
    total = 2 * values["La"] - values["Llap"]
    for name in ("acc1_x", "acc2_x", "acc3_x"):
        if not 0 <= values[name] <= total:
            raise ValueError(f"BRB deck: {name} = {values[name]} m is outside the beam [0, {total}] m")
    if values["sensor_mass"] < 0:
        raise ValueError(f"BRB deck: sensor_mass must be ≥ 0 kg, got {values['sensor_mass']}")
    return values


class BRBModel:
    """Mesh, node sets and reduced model of the BRB for parameter values.

    mesh: element counts; n_modes: fixed-interface modes kept by the reduction.
    """

    def __init__(self, mesh: BRBMesh = BRBMesh(), n_modes: int = 12) -> None:
        self.mesh = mesh
        self.n_modes = int(n_modes)

    def fingerprint(self) -> str:
        return fingerprint({"version": "brb-1", "mesh": self.mesh, "modes": self.n_modes, "defaults": BRB_DEFAULTS},
                           length=16)

    def build(self, parameters: Mapping[str, float] | None = None):
        """``(model_text, nodes (n, 3) m, sets)``: the CalculiX model data (two unconnected
        beams) and the node sets (1-based numbers): ``A_IFACE``, ``B_IFACE``, ``ACC1``…"""
        p = brb_parameters(parameters)
        m = self.mesh
        La, Llap, h, b = p["La"], p["Llap"], p["h"], p["b"]
        total = 2 * La - Llap
        y = np.linspace(-h / 2, h / 2, m.n_thickness + 1)
        z = np.linspace(-b / 2, b / 2, m.n_width + 1)
        half = m.n_thickness // 2
        x_a = np.concatenate([np.linspace(0.0, La - Llap, m.n_full + 1), np.linspace(La - Llap, La, m.n_lap + 1)[1:]])
        beam_a = box_mesh((x_a, y, z), [((0, m.n_full), (0, m.n_thickness), (0, m.n_width)),
                                        ((m.n_full, m.n_full + m.n_lap), (half, m.n_thickness), (0, m.n_width))])
        x_b = total - x_a[::-1]
        beam_b = box_mesh((x_b, y, z), [((0, m.n_lap), (0, half), (0, m.n_width)),
                                        ((m.n_lap, m.n_lap + m.n_full), (0, m.n_thickness), (0, m.n_width))])
        nodes = np.vstack([beam_a.nodes, beam_b.nodes])
        offset = len(beam_a.nodes)
        tol = 1e-9 * total
        lap = (nodes[:, 0] >= La - Llap - tol) & (nodes[:, 0] <= La + tol) & (np.abs(nodes[:, 1]) <= tol)
        numbers = np.arange(1, len(nodes) + 1)
        sets = {"A_IFACE": numbers[:offset][lap[:offset]], "B_IFACE": numbers[offset:][lap[offset:]]}
        for index, name in enumerate(ACCELEROMETERS):
            target = np.array([p[f"{name}_x"], -h / 2 if p[f"{name}_x"] < La - Llap / 2 else h / 2, 0.0])
            distance = np.linalg.norm(nodes - target, axis=1)
            sets[name.upper()] = numbers[[int(np.argmin(distance))]]
        lines = ["** nlupdate Brake-Reuss beam (solid C3D20), units m kg s Pa", "*NODE"]
        lines += [f"{i + 1}, {x:.12e}, {yy:.12e}, {zz:.12e}" for i, (x, yy, zz) in enumerate(nodes)]
        lines.append("*ELEMENT, TYPE=C3D20, ELSET=EALL")
        number = 1
        for connectivity in np.vstack([beam_a.elements + 1, beam_b.elements + 1 + offset]):
            ids = [str(number), *map(str, connectivity)]
            lines += [", ".join(ids[:16]) + ",", ", ".join(ids[16:])]
            number += 1
        if p["sensor_mass"] > 0:
            lines.append("*ELEMENT, TYPE=MASS, ELSET=ESENSORS")
            for name in ACCELEROMETERS:
                lines.append(f"{number}, {int(sets[name.upper()][0])}")
                number += 1
        for name, ids in sets.items():
            lines.append(f"*NSET, NSET={name}")
            lines += [", ".join(map(str, ids[i:i + 16])) for i in range(0, len(ids), 16)]
        lines += ["*MATERIAL, NAME=STEEL", "*ELASTIC", f"{p['E']:.12e}, {p['nu']:.12e}", "*DENSITY", f"{p['rho']:.12e}",
                  "*SOLID SECTION, ELSET=EALL, MATERIAL=STEEL"]
        if p["sensor_mass"] > 0:
            lines += ["*MASS, ELSET=ESENSORS", f"{p['sensor_mass']:.12e}"]
        return "\n".join(lines) + "\n", nodes, sets

    def bolt_patches(self, parameters: Mapping[str, float] | None, nodes: np.ndarray, sets) -> dict:
        """``{bolt<k>_a|b: (reference point, node numbers)}``: each beam's interface nodes within
        ``patch_radius`` of bolt k's axis."""
        p = brb_parameters(parameters)
        centre = p["La"] - p["Llap"] / 2
        patches = {}
        for k, name in enumerate(BOLTS):
            point = np.array([centre + (k - 1) * p["bolt_spacing"], 0.0, 0.0])
            for side in ("a", "b"):
                members = sets[f"{side.upper()}_IFACE"]
                distance = np.hypot(nodes[members - 1, 0] - point[0], nodes[members - 1, 2])
                chosen = members[distance <= p["patch_radius"] * (1 + 1e-9)]
                if chosen.size < 3:
                    raise ValueError(f"BRB mesh: bolt {k + 1}'s patch holds {chosen.size} nodes of beam "
                                     f"{side.upper()}; "
                                     "refine the lap (n_lap, n_width) or widen patch_radius")
                patches[f"{name}_{side}"] = (point, chosen)
        return patches

    def reduced(self, parameters: Mapping[str, float] | None = None,
                matrices: CalculixMatrices | None = None) -> ReducedModel:
        """Craig–Bampton model on the bolts' dofs (``bolt<k>_<a|b>:ux … :rz``), ``acc<i>:uy`` and
        ``n_modes`` fixed-interface modes (one ccx run for the matrices)."""
        model, nodes, sets = self.build(parameters)
        solver = matrices or CalculixMatrices()
        full = solver.assemble(model, fingerprint(self.fingerprint(), brb_parameters(parameters), length=16))
        positions = np.vstack([np.zeros(3), nodes])
        patches = self.bolt_patches(parameters, nodes, sets)
        k, m, kept, patch_names = rigid_patches(full.stiffness, full.mass, full.nodes, full.directions, positions,
                                                patches)
        rows = list(range(kept.size, kept.size + len(patch_names)))
        names = list(patch_names)
        lookup = {(int(n), int(d)): i for i, (n, d) in enumerate(zip(full.nodes[kept], full.directions[kept]))}
        for name in ACCELEROMETERS:
            rows.append(lookup[(int(sets[name.upper()][0]), 2)])
            names.append(f"{name}:uy")
        return craig_bampton(k, m, rows, names, self.n_modes)


def joint_stiffness(reduced: ReducedModel, kt: float, kn: float, kr: float, tangential_x: bool = True) -> np.ndarray:
    """The joint's linear springs on the reduced coordinates (:data:`JOINT_DEFAULTS`); without
    ``tangential_x`` the x springs are left out (the friction elements take their place)."""
    n = len(reduced.dof_names)
    springs = np.zeros((n, n))
    for bolt in BOLTS:
        for axis, value in (("ux", kt if tangential_x else 0.0), ("uy", kn), ("uz", kt),
                            ("rx", kr), ("ry", kr), ("rz", kr)):
            if value:
                i, j = reduced.index(f"{bolt}_a:{axis}"), reduced.index(f"{bolt}_b:{axis}")
                springs[[i, j], [i, j]] += value
                springs[i, j] -= value
                springs[j, i] -= value
    return springs


_REDUCED_CACHE: "OrderedDict[str, ReducedModel]" = OrderedDict()
_CACHE_LOCK = Lock()
_CACHE_SIZE = 8


class BRBAdapter(FEAdapter):
    """The BRB's modes from its Craig–Bampton model with the joint's linear springs.

    Parameters: the deck's (:data:`BRB_DEFAULTS`) and the joint's (:data:`JOINT_DEFAULTS`),
    all SI. Returns the ``n_modes`` lowest elastic modes (the six rigid-body modes of the
    free–free beam left out) at ``acc1:uy``, ``acc2:uy``, ``acc3:uy`` and every bolt's
    ``bolt<k>_<a|b>:ux`` (mass-normalised, 1/√kg). The reduction depends on the deck's
    parameters only: a step in a joint stiffness reuses it (the last 8 reductions are kept
    in the process); each new deck point is one ccx run (``work_root``, ``executable``,
    ``timeout_s``, ``threads`` as :class:`~nlupdate.fe.adapters.calculix.CalculixAdapter`).
    """

    name = "calculix-brb"
    runs_a_program = True

    def __init__(self, mesh: BRBMesh = BRBMesh(), *, n_modes: int = 6, fixed_interface_modes: int = 12,
                 work_root=None, executable: str = "ccx", timeout_s: float | None = 3600.0, threads: int = 1) -> None:
        super().__init__(BRB_PARAMETER_NAMES + tuple(JOINT_DEFAULTS))
        if not (isinstance(n_modes, int) and n_modes >= 1):
            raise ValueError(f"n_modes must be a positive integer, got {n_modes!r}")
        self.model = BRBModel(mesh, fixed_interface_modes)
        self.n_modes = n_modes
        self.matrices = CalculixMatrices(work_root=work_root, executable=executable, timeout_s=timeout_s,
                                         threads=threads)

    def check_available(self) -> None:
        self.matrices.check_available()

    def solver_version(self) -> str:
        return f"CalculiX {self.matrices.runner.version()} (matrices) + Craig–Bampton"

    def model_fingerprint(self) -> str:
        return fingerprint(self.model.fingerprint(), self.n_modes, JOINT_DEFAULTS, length=16)

    def check_values(self, parameters: Mapping[str, float]) -> None:
        deck, joint = self.split(self._check(parameters))
        brb_parameters(deck)
        for name, value in joint.items():
            if not value > 0:
                raise ValueError(f"BRB joint: {name} must be positive, got {value}")

    def split(self, parameters: Mapping[str, float]) -> tuple[dict[str, float], dict[str, float]]:
        """(deck parameters, joint parameters with defaults filled in)."""
        deck = {k: float(v) for k, v in parameters.items() if k in BRB_DEFAULTS}
        joint = {**JOINT_DEFAULTS, **{k: float(v) for k, v in parameters.items() if k in JOINT_DEFAULTS}}
        return deck, joint

    def reduced(self, deck: Mapping[str, float]) -> ReducedModel:
        """The Craig–Bampton model at the deck parameters ``deck`` (kept for the next 8 points)."""
        key = fingerprint(self.model.fingerprint(), brb_parameters(deck), length=20)
        with _CACHE_LOCK:
            if key in _REDUCED_CACHE:
                _REDUCED_CACHE.move_to_end(key)
                return _REDUCED_CACHE[key]
        reduced = self.model.reduced(deck, self.matrices)
        with _CACHE_LOCK:
            _REDUCED_CACHE[key] = reduced
            while len(_REDUCED_CACHE) > _CACHE_SIZE:
                _REDUCED_CACHE.popitem(last=False)
        return reduced

    def _solve(self, parameters: Mapping[str, float]) -> ModalResult:
        started = time.perf_counter()
        self.check_values(parameters)
        deck, joint = self.split(parameters)
        reduced = self.reduced(deck)
        stiffness = reduced.stiffness + joint_stiffness(reduced, joint["kt"], joint["kn"], joint["kr"])
        values, vectors = scipy.linalg.eigh(stiffness, reduced.mass)
        frequencies = np.sqrt(np.maximum(values, 0.0)) / (2 * np.pi)
        elastic = np.flatnonzero(frequencies >= RIGID_BODY_HZ)[: self.n_modes]
        if elastic.size < self.n_modes:
            raise ValueError(f"BRB: {elastic.size} elastic modes in the reduced model, {self.n_modes} asked for")
        coordinates = [f"{name}:uy" for name in ACCELEROMETERS]
        coordinates += [f"{bolt}_{side}:ux" for bolt in BOLTS for side in "ab"]
        rows = [reduced.index(name) for name in coordinates]
        return ModalResult(
            natural_frequencies_hz=frequencies[elastic],
            mode_shapes=vectors[np.ix_(rows, elastic)],
            coordinates=tuple(coordinates),
            metadata={"solver": "calculix+craig-bampton", "mesh_size": None,
                      "wall_time_s": time.perf_counter() - started,
                      "log_path": None, "reduced_dofs": len(reduced.dof_names),
                      "rigid_body_hz": frequencies[:6].tolist()},
        )


def from_options(options: dict) -> BRBAdapter:
    """The adapter of a study's ``[adapter] kind = "calculix", model = "brb"``: options ``mesh``
    (a table of :class:`BRBMesh` counts), ``n_modes``, ``fixed_interface_modes``, ``work_root``,
    ``executable``, ``timeout_s``, ``threads``."""
    mesh = BRBMesh(**options.pop("mesh", {}))
    try:
        return BRBAdapter(mesh, **options)
    except TypeError as error:
        raise ValueError(f"calculix adapter (brb): {error}") from None
