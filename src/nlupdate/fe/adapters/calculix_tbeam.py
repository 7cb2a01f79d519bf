"""Parametric solid (C3D20R) CalculiX deck of the T-beam test structure (docs/methods.md §8).

Geometry (SI units, global axes; the thesis' Figure 4.1 is not in the text, so the
layout below is this module's reading of it):

* beam 1 (cantilever): x ∈ [0, L1], y ∈ [−w1/2, w1/2], z ∈ [−h1/2, h1/2];
  h1 = 8 mm high (transverse direction z), w1 = 12 mm wide, L1 = 420 mm long (effective length, default); clamped
  (all translations fixed) on its x = 0 face.
* beams 2 (two identical thin beams): x ∈ [L1 − w2, L1], y ∈ [−L2/2, L2/2],
  z ∈ [h1/2, h1/2 + h2] (upper) and [−h1/2 − h2, −h1/2] (lower); w2 = 13 mm wide (x),
  L2 = 380 mm long (y, effective length, default), h2 = 1.5 mm thick (z); clamped on both y = ±L2/2 end faces.
  So L1 is the full length of beam 1 *including* its last w2 = 13 mm, which is
  sandwiched between the thin beams; the thin beams' centre line lies at
  x = L1 − w2/2, centred on beam 1's axis (y = 0).
* bonding: the three beams are one mesh — the thin beams' faces and beam 1's faces in
  the overlap share nodes (perfect bond, no contact/friction: the linear underlying
  structure of docs/methods.md §8).
* sensor masses (optional): ``transducer_mass + accelerometer_mass`` (kg) lumped at
  beam 1's tip, shared equally by the nodes of its x = L1 end face (CalculiX MASS
  elements; translational inertia only, rotary inertia neglected). Source values:
  force transducer 30.2 g, accelerometer 4.8 g (:data:`SENSOR_MASSES`).

Mesh: structured boxes of 20-node bricks (CalculiX/Abaqus node order), sizes set by
:class:`TBeamMesh`. Node sets and measurement coordinates (all ``uz``):

* ``tip:uz`` — set TIP: the beam-1 end-face (x = L1) nodes nearest to its centre
  (y = z = 0), averaged (the drive point);
* ``b1_<pct>:uz`` — set B1_<pct>: beam-1 nodes at the mesh station nearest to
  x = pct % of L1, nearest to the beam axis, averaged (default pct 10, 20, …, 90).

Parameter names (SI, exactly): ``E, nu, rho, h1, w1, L1, h2, w2, L2, transducer_mass,
accelerometer_mass``; missing ones take :data:`TBEAM_DEFAULTS`.

The computed modes include local modes of the thin beams (beam 1 at rest); the global
modes are picked by beam 1's share of the modal mass (:func:`global_modes`) — they are
FE modes 1, 2 and 6, as in the source. See :data:`THESIS_EFFECTIVE_LENGTHS` for the
lengths that reproduce the source's published FE frequencies.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np
import pandas as pd

from nlupdate.fingerprints import fingerprint
from nlupdate.fe.adapters.base import ModalResult
from nlupdate.fe.adapters.calculix import CalculixAdapter

TBEAM_PARAMETER_NAMES = ("E", "nu", "rho", "h1", "w1", "L1", "h2", "w2", "L2", "transducer_mass", "accelerometer_mass")

TBEAM_DEFAULTS: dict[str, float] = {
    "E": 210e9,
    "nu": 0.3,
    "rho": 7850.0,
    "h1": 0.008,
    "w1": 0.012,
    "L1": 0.420,  # effective lengths, as the surrogate (nlupdate.fe.models.tbeam); see below
    "h2": 0.0015,
    "w2": 0.013,
    "L2": 0.380,
    "transducer_mass": 0.0,
    "accelerometer_mass": 0.0,
}

SENSOR_MASSES: dict[str, float] = {"transducer_mass": 0.0302, "accelerometer_mass": 0.0048}

# The source's ANSYS model reproduces with the beams' *effective* (clamp-to-clamp)
# lengths quoted in thesis §4.1.1 ("longer than their effective length of 380 mm and
# 420 mm"): with L1 = 420 mm, L2 = 380 mm this deck gives 46.4 / 197.4 / 281.0 Hz
# (published converged 46.4 / 197–197.5 / 280–282 Hz; initial FE f1 = 46.48 Hz), and
# with SENSOR_MASSES 41.1 / 191.7 / 263.2 Hz (published 41.4 / 193.3 / 266.0 Hz).
# These are the defaults; the nominal bar lengths 430 / 400 mm give 43.0 / 185.1 / 256.9 Hz.
THESIS_EFFECTIVE_LENGTHS: dict[str, float] = {"L1": 0.420, "L2": 0.380}

DEFAULT_STATIONS = (10, 20, 30, 40, 50, 60, 70, 80, 90)

_FORMAT_VERSION = "tbeam-deck-1"

# 20-node brick, CalculiX/Abaqus order: lattice offsets (0..2 along x, y, z) of nodes 1..20.
C3D20_OFFSETS = np.array(
    [
        (0, 0, 0), (2, 0, 0), (2, 2, 0), (0, 2, 0), (0, 0, 2), (2, 0, 2), (2, 2, 2), (0, 2, 2),
        (1, 0, 0), (2, 1, 0), (1, 2, 0), (0, 1, 0), (1, 0, 2), (2, 1, 2), (1, 2, 2), (0, 1, 2),
        (0, 0, 1), (2, 0, 1), (2, 2, 1), (0, 2, 1),
    ]
)


@dataclass(frozen=True)
class HexMesh:
    """Structured mesh of 20-node bricks on a tensor lattice.

    nodes: (n_nodes, 3) coordinates (m), node i has CalculiX number i + 1.
    elements: (n_elements, 20) zero-based node indices in CalculiX order.
    element_box: (n_elements,) index of the box each element belongs to.
    """

    nodes: np.ndarray
    elements: np.ndarray
    element_box: np.ndarray

    def node_indices(self, boxes: Sequence[int] | None = None) -> np.ndarray:
        """Sorted zero-based indices of the nodes used by elements of ``boxes`` (all if None)."""
        chosen = self.elements if boxes is None else self.elements[np.isin(self.element_box, list(boxes))]
        return np.unique(chosen)


def box_mesh(axes: Sequence[np.ndarray], boxes: Sequence[tuple[tuple[int, int], tuple[int, int], tuple[int, int]]]) -> HexMesh:
    """Mesh boxes given as element-index ranges on shared axis grids.

    axes: three increasing arrays of element-corner coordinates (x, y, z).
    boxes: per box ``((i0, i1), (j0, j1), (k0, k1))``: elements i0 ≤ i < i1 along x, etc.
    Boxes that touch share the nodes on their common faces (conforming mesh).
    """
    lattices = []
    for axis in axes:
        axis = np.asarray(axis, dtype=float)
        if axis.ndim != 1 or axis.size < 2 or np.any(np.diff(axis) <= 0):
            raise ValueError(f"mesh axis must be a strictly increasing 1-D array, got {axis}")
        lattice = np.empty(2 * axis.size - 1)
        lattice[0::2] = axis
        lattice[1::2] = 0.5 * (axis[:-1] + axis[1:])
        lattices.append(lattice)
    element_lattice = []
    element_box = []
    for number, ranges in enumerate(boxes):
        for (low, high), axis in zip(ranges, axes):
            if not (0 <= low < high <= len(axis) - 1):
                raise ValueError(f"box {number}: element range ({low}, {high}) outside the axis of {len(axis) - 1} elements")
        (i0, i1), (j0, j1), (k0, k1) = ranges
        i, j, k = np.meshgrid(np.arange(i0, i1), np.arange(j0, j1), np.arange(k0, k1), indexing="ij")
        origins = 2 * np.stack([i.ravel(), j.ravel(), k.ravel()], axis=1)
        element_lattice.append(origins[:, None, :] + C3D20_OFFSETS[None, :, :])
        element_box.append(np.full(origins.shape[0], number))
    points = np.concatenate(element_lattice)  # (n_elements, 20, 3) lattice indices
    shape = tuple(len(lattice) for lattice in lattices)
    flat = np.ravel_multi_index((points[..., 0], points[..., 1], points[..., 2]), shape)
    used, connectivity = np.unique(flat, return_inverse=True)
    ijk = np.unravel_index(used, shape)
    nodes = np.stack([lattices[d][ijk[d]] for d in range(3)], axis=1)
    return HexMesh(nodes=nodes, elements=connectivity.reshape(flat.shape), element_box=np.concatenate(element_box))


@dataclass(frozen=True)
class TBeamMesh:
    """Element counts of the T-beam mesh.

    n_h1: through beam 1's height (z); n_w1: across beam 1's width (y, also the thin
    beams' middle part over beam 1); n_l1: along beam 1's free part x ∈ [0, L1 − w2];
    n_h2: through each thin beam's thickness; n_w2: across the thin beams' width (x,
    also beam 1's sandwiched part); n_l2: along each thin-beam arm y ∈ [w1/2, L2/2].
    """

    n_h1: int = 2
    n_w1: int = 2
    n_l1: int = 40
    n_h2: int = 1
    n_w2: int = 2
    n_l2: int = 20

    def __post_init__(self) -> None:
        for name, value in asdict(self).items():
            if not (isinstance(value, int) and value >= 1):
                raise ValueError(f"TBeamMesh.{name} must be a positive integer, got {value!r}")

    def n_elements(self) -> int:
        beam1 = self.n_h1 * self.n_w1 * (self.n_l1 + self.n_w2)
        thin = 2 * self.n_h2 * self.n_w2 * (2 * self.n_l2 + self.n_w1)
        return beam1 + thin


def tbeam_parameters(parameters: Mapping[str, float] | None = None) -> dict[str, float]:
    """Defaults overlaid with ``parameters``; checks names and physical ranges."""
    values = dict(TBEAM_DEFAULTS)
    for name, value in (parameters or {}).items():
        if name not in TBEAM_DEFAULTS:
            raise ValueError(f"T-beam deck: unknown parameter {name!r}; expected one of {list(TBEAM_PARAMETER_NAMES)}")
        values[name] = float(value)
    for name in ("E", "rho", "h1", "w1", "L1", "h2", "w2", "L2"):
        if not values[name] > 0:
            raise ValueError(f"T-beam deck: {name} must be positive (SI units), got {values[name]}")
    for name in ("transducer_mass", "accelerometer_mass"):
        if values[name] < 0:
            raise ValueError(f"T-beam deck: {name} must be ≥ 0 kg, got {values[name]}")
    if not -1.0 < values["nu"] < 0.5:
        raise ValueError(f"T-beam deck: nu must be in (-1, 0.5), got {values['nu']}")
    if not values["w2"] < values["L1"]:
        raise ValueError(f"T-beam deck: w2 = {values['w2']} m must be smaller than L1 = {values['L1']} m")
    if not values["w1"] < values["L2"]:
        raise ValueError(f"T-beam deck: w1 = {values['w1']} m must be smaller than L2 = {values['L2']} m")
    return values


def _nearest(mesh: HexMesh, candidates: np.ndarray, point: Sequence[float]) -> np.ndarray:
    """Candidates (node indices) at the minimum distance from ``point`` (ties kept)."""
    distance = np.linalg.norm(mesh.nodes[candidates] - np.asarray(point), axis=1)
    return candidates[distance <= distance.min() * (1 + 1e-9) + 1e-12]


def _format_ids(ids: np.ndarray, per_line: int = 16) -> str:
    numbers = [str(int(i) + 1) for i in ids]
    return "\n".join(", ".join(numbers[start : start + per_line]) for start in range(0, len(numbers), per_line))


class TBeamDeck:
    """Deck generator for :class:`~nlupdate.fe.adapters.calculix.CalculixAdapter`.

    ``deck(parameters) -> (model_text, {"tip:uz": ("TIP", "uz"), "b1_10:uz": …})``.
    mesh: element counts; stations: beam-1 measurement stations in % of L1;
    element_type: ``"C3D20R"`` (default) or ``"C3D20"`` (same node order).
    """

    def __init__(self, mesh: TBeamMesh = TBeamMesh(), stations: Sequence[int] = DEFAULT_STATIONS, element_type: str = "C3D20R") -> None:
        if element_type not in {"C3D20R", "C3D20"}:
            raise ValueError(f"element_type must be 'C3D20R' or 'C3D20', got {element_type!r}")
        stations = tuple(int(s) for s in stations)
        if any(not 0 < s < 100 for s in stations) or len(set(stations)) != len(stations):
            raise ValueError(f"stations must be distinct percentages of L1 strictly between 0 and 100, got {stations}")
        self.mesh = mesh
        self.stations = stations
        self.element_type = element_type

    def fingerprint(self) -> str:
        return fingerprint({"version": _FORMAT_VERSION, "mesh": self.mesh, "stations": self.stations,
                            "element": self.element_type, "defaults": TBEAM_DEFAULTS}, length=16)

    def build_mesh(self, p: Mapping[str, float]) -> tuple[HexMesh, dict[str, np.ndarray]]:
        """Mesh and named node sets (zero-based node indices) for parameter values ``p``."""
        m = self.mesh
        L1, w1, h1, L2, w2, h2 = p["L1"], p["w1"], p["h1"], p["L2"], p["w2"], p["h2"]
        x = np.concatenate([np.linspace(0.0, L1 - w2, m.n_l1 + 1), np.linspace(L1 - w2, L1, m.n_w2 + 1)[1:]])
        y = np.concatenate(
            [
                np.linspace(-L2 / 2, -w1 / 2, m.n_l2 + 1),
                np.linspace(-w1 / 2, w1 / 2, m.n_w1 + 1)[1:],
                np.linspace(w1 / 2, L2 / 2, m.n_l2 + 1)[1:],
            ]
        )
        z = np.concatenate(
            [
                np.linspace(-h1 / 2 - h2, -h1 / 2, m.n_h2 + 1),
                np.linspace(-h1 / 2, h1 / 2, m.n_h1 + 1)[1:],
                np.linspace(h1 / 2, h1 / 2 + h2, m.n_h2 + 1)[1:],
            ]
        )
        nx, ny, nz = len(x) - 1, len(y) - 1, len(z) - 1
        beam1_y = (m.n_l2, m.n_l2 + m.n_w1)
        beam1_z = (m.n_h2, m.n_h2 + m.n_h1)
        overlap_x = (m.n_l1, nx)
        boxes = [
            ((0, nx), beam1_y, beam1_z),  # beam 1
            (overlap_x, (0, ny), (0, m.n_h2)),  # lower thin beam
            (overlap_x, (0, ny), (nz - m.n_h2, nz)),  # upper thin beam
        ]
        mesh = box_mesh((x, y, z), boxes)
        tol = 1e-9 * max(L1, L2)
        beam1 = mesh.node_indices([0])
        thin = mesh.node_indices([1, 2])
        coords = mesh.nodes
        sets = {
            "CLAMP1": beam1[np.abs(coords[beam1, 0]) <= tol],
            "CLAMP2": thin[np.abs(np.abs(coords[thin, 1]) - L2 / 2) <= tol],
            "TIPFACE": beam1[np.abs(coords[beam1, 0] - L1) <= tol],
        }
        sets["TIP"] = _nearest(mesh, sets["TIPFACE"], (L1, 0.0, 0.0))
        stations_x = np.unique(coords[beam1, 0])
        for pct in self.stations:
            target = stations_x[np.argmin(np.abs(stations_x - pct / 100 * L1))]
            section = beam1[np.abs(coords[beam1, 0] - target) <= tol]
            sets[f"B1_{pct}"] = _nearest(mesh, section, (target, 0.0, 0.0))
        return mesh, sets

    def coordinates(self) -> dict[str, tuple[str, str]]:
        coords = {"tip:uz": ("TIP", "uz")}
        coords.update({f"b1_{pct}:uz": (f"B1_{pct}", "uz") for pct in self.stations})
        return coords

    def __call__(self, parameters: Mapping[str, float]) -> tuple[str, dict[str, tuple[str, str]]]:
        p = tbeam_parameters(parameters)
        mesh, sets = self.build_mesh(p)
        lines = ["** nlupdate T-beam (solid), units m kg s Pa", "*NODE"]
        lines += [f"{i + 1}, {x:.11e}, {y:.11e}, {z:.11e}" for i, (x, y, z) in enumerate(mesh.nodes)]
        lines.append(f"*ELEMENT, TYPE={self.element_type}, ELSET=EALL")
        for number, connectivity in enumerate(mesh.elements + 1, start=1):
            ids = [str(number), *map(str, connectivity)]
            lines.append(", ".join(ids[:16]) + ",")
            lines.append(", ".join(ids[16:]))
        sensor_mass = p["transducer_mass"] + p["accelerometer_mass"]
        if sensor_mass > 0:
            face = sets["TIPFACE"]
            first = len(mesh.elements) + 1
            lines.append("*ELEMENT, TYPE=MASS, ELSET=ESENSORS")
            lines += [f"{first + n}, {node + 1}" for n, node in enumerate(face)]
        for name, ids in sets.items():
            lines.append(f"*NSET, NSET={name}")
            lines.append(_format_ids(ids))
        lines += [
            "*MATERIAL, NAME=STEEL",
            "*ELASTIC",
            f"{p['E']:.11e}, {p['nu']:.11e}",
            "*DENSITY",
            f"{p['rho']:.11e}",
            "*SOLID SECTION, ELSET=EALL, MATERIAL=STEEL",
        ]
        if sensor_mass > 0:
            lines += ["*MASS, ELSET=ESENSORS", f"{sensor_mass / len(sets['TIPFACE']):.11e}"]
        lines += ["*BOUNDARY", "CLAMP1, 1, 3", "CLAMP2, 1, 3"]
        return "\n".join(lines) + "\n", self.coordinates()


def beam1_modal_mass_fraction(result: ModalResult, parameters: Mapping[str, float] | None = None) -> np.ndarray:
    """Share of each mode's unit modal mass carried by beam 1's transverse (z) motion.

    ∫₀^L1 ρ·w1·h1·φ_z(x)² dx by the trapezoidal rule over the clamp (φ = 0), the
    ``b1_<pct>:uz`` stations and the tip (mass-normalised shapes, so 1 = all the
    mass). Near 0 for local modes of the thin beams, large for global modes.
    """
    p = tbeam_parameters(parameters)
    n_modes = result.mode_shapes.shape[1]
    samples = [(0.0, np.zeros(n_modes)), (p["L1"], result.mode_shapes[result.coordinates.index("tip:uz")])]
    for row, name in enumerate(result.coordinates):
        if name.startswith("b1_") and name.endswith(":uz"):
            samples.append((float(name[3:-3]) / 100 * p["L1"], result.mode_shapes[row]))
    samples.sort(key=lambda sample: sample[0])
    x = np.array([position for position, _ in samples])
    shapes = np.array([shape for _, shape in samples])
    return p["rho"] * p["w1"] * p["h1"] * np.trapezoid(shapes**2, x, axis=0)


def global_modes(result: ModalResult, parameters: Mapping[str, float] | None = None, threshold: float = 0.05) -> np.ndarray:
    """Zero-based indices of the modes whose beam-1 z modal-mass share exceeds ``threshold``."""
    return np.flatnonzero(beam1_modal_mass_fraction(result, parameters) > threshold)


def mesh_study(
    meshes: Sequence[TBeamMesh],
    parameters: Mapping[str, float] | None = None,
    *,
    n_modes: int = 12,
    n_global: int = 3,
    work_root: str | Path | None = None,
    executable: str = "ccx",
    threads: int = 1,
) -> pd.DataFrame:
    """First ``n_global`` global natural frequencies (Hz) vs mesh density, one ccx run each.

    Like the source's mesh study (thesis Table 4.13, Figures 4.38–4.46): one row per
    mesh with its element counts, ``elements``, ``wall_time_s``, ``f1_hz`` …
    (global modes, see :func:`global_modes`), ``global_mode_numbers`` (1-based mode
    numbers among all computed modes) and ``all_frequencies_hz``.
    """
    rows = []
    for mesh in meshes:
        deck = TBeamDeck(mesh)
        adapter = CalculixAdapter(deck, TBEAM_PARAMETER_NAMES, n_modes=n_modes, work_root=work_root, executable=executable, threads=threads)
        result = adapter.evaluate(parameters or {})
        chosen = global_modes(result, parameters)
        if chosen.size < n_global:
            raise ValueError(
                f"mesh {mesh}: only {chosen.size} global modes among the {n_modes} computed ({result.natural_frequencies_hz.round(2).tolist()} Hz); raise n_modes"
            )
        row = {**asdict(mesh), "elements": result.metadata["mesh_size"], "wall_time_s": result.metadata["wall_time_s"]}
        row.update({f"f{i + 1}_hz": float(result.natural_frequencies_hz[chosen[i]]) for i in range(n_global)})
        row["global_mode_numbers"] = (chosen[:n_global] + 1).tolist()
        row["all_frequencies_hz"] = result.natural_frequencies_hz.tolist()
        rows.append(row)
    return pd.DataFrame(rows)


def from_options(model: str | None, options: dict) -> CalculixAdapter:
    """The adapter of a study's ``[adapter] kind = "calculix"`` (:mod:`nlupdate.fe.adapters.registry`):
    the solid T-beam deck in CalculiX."""
    if model != "tbeam":
        raise ValueError(f"calculix adapter: model must be 'tbeam', got {model!r}")
    mesh = TBeamMesh(**options.pop("mesh", {}))
    deck_options = {k: options.pop(k) for k in ("element_type", "stations") if k in options}
    deck = TBeamDeck(mesh, **deck_options)
    try:
        return CalculixAdapter(deck, TBEAM_PARAMETER_NAMES, **options)
    except TypeError as error:
        raise ValueError(f"calculix adapter: {error}") from None
