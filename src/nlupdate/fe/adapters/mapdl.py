"""Ansys Mechanical APDL (MAPDL) in batch mode behind the FEAdapter interface.

The user supplies a parametric APDL deck that builds the model in one consistent unit
system and does not solve (its rules and units: :mod:`nlupdate.fe.adapters.mapdl_deck`).
Each evaluation writes the deck with the parameter values substituted, appends a modal
block that solves and writes a plain-text table (:mod:`nlupdate.fe.adapters.mapdl_block`),
runs MAPDL in a fresh folder and reads the table back in SI
(:mod:`nlupdate.fe.adapters.mapdl_files` for the run's files and errors).

Checks on every run
-------------------
* ``*** ERROR ***`` in ``out.out`` or the ``.err`` files (:mod:`~nlupdate.fe.adapters.mapdl_files`).
* exactly ``n`` modes found (Block Lanczos returns fewer when the model has fewer
  degrees of freedom, or fewer above ``min_frequency_hz``); frequencies finite, > 0 and
  ascending (each at least the previous one × (1 − 1e-9), so repeated roots printed in
  either order pass).
* every coordinate's node exists (node number ≥ 1) and, when the node was asked for by a
  point (``(x, y, z)`` in metres or a literal ``NODE(x,y,z)``), lies within
  ``location_tolerance_m`` (default 1e-3 m) of that point. The nearest node of a mesh
  whose nodes sit at the sensor positions passes; a wrong coordinate system, wrong units
  or a point off the model fails, with the coordinate, the point, the chosen node, its
  location and the distance. Raise the tolerance for a mesh coarser than that.

Status: no MAPDL installation was available when this was written; the block, the
parser and the process handling are tested against hand-written files and a fake
``mapdl`` executable that interprets the few commands that matter (selection, ``CSYS``,
``LOCAL``, ``N``, ``*SET``, ``NODE()``, tests/test_mapdl.py), not against a real MAPDL run.
"""
from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from nlupdate.fe.adapters.base import AdapterError, FEAdapter, ModalResult
from nlupdate.fe.adapters.mapdl_block import AXES, TABLE_NAME, check_modes, modal_block, parse_modal_table
from nlupdate.fe.adapters.mapdl_deck import (
    APDL_NAME,
    RESERVED_PREFIX,
    NodeSpec,
    check_reserved_names,
    deck_units,
    requested_point,
    safe_parameter_name,
    single_expression,
    substitute_parameters,
)
from nlupdate.fe.adapters.mapdl_files import INPUT_NAME, JOB_NAME, OUTPUT_NAME, first_error, remove_scratch_files
from nlupdate.fe.adapters.runner import (
    ExecutableNotFoundError,
    ProcessRunner,
    RunResult,
    RunTimeoutError,
    run_failure,
    write_text_atomic,
)
from nlupdate.fingerprints import fingerprint
from nlupdate.input_files import read_input_text

MAPDL_EXEC_ENV = "PYMAPDL_MAPDL_EXEC"
MAPDL_INSTALL_HINT = (
    f"Set `executable` in the MapdlAdapter config to the MAPDL launcher (e.g. /ansys_inc/v241/ansys/bin/ansys241) "
    f"or set the {MAPDL_EXEC_ENV} environment variable."
)
DEFAULT_LOCATION_TOLERANCE_M = 1e-3
_BLOCK_VERSION = "mapdl-block-2"
Coordinates = Mapping[str, tuple[int | str | Sequence[float], str]]


class MapdlAdapter(FEAdapter):
    """Modal analysis with MAPDL batch runs (the contract: this module's docstring and :mod:`~nlupdate.fe.adapters.mapdl_deck`).

    deck_text: the user's parametric APDL deck (model only, in ``units``).
    parameter_names: updating parameters; each needs one ``*SET`` line in the deck; their
        values are written as given, in the deck's units.
    coordinates: ``{name: (node, "ux"|"uy"|"uz")}`` where node is a node number, an APDL
        expression in deck units (``"NODE(430,0,4)"``, ``"TIPNODE"``) or a point
        ``(x, y, z)`` in metres.
    n_modes: modes extracted (LANB) and expanded; exactly this many must be found.
    executable: MAPDL launcher; default: environment variable ``PYMAPDL_MAPDL_EXEC``.
    n_processors: ``-np`` value.
    apdl_names: optional ``{parameter name: the deck's APDL name}`` (default identity).
    units: the deck's unit system, one of :data:`UNIT_SYSTEMS` (``"SI"``, ``"mm-t-s"``,
        ``"mm-kg-s"``); results are converted to SI.
    location_tolerance_m: largest distance (m) between a requested point and the node
        MAPDL picks for it.
    min_frequency_hz: lower end of the Block Lanczos range (Hz), e.g. above rigid-body
        modes; None: MAPDL's default.
    keep_files: keep the large binary files of successful runs (default: delete them).
    """

    name = "mapdl"
    runs_a_program = True

    def __init__(
        self,
        deck_text: str,
        parameter_names: Sequence[str],
        coordinates: Coordinates,
        *,
        n_modes: int = 10,
        executable: str | None = None,
        n_processors: int = 1,
        work_root: str | Path | None = None,
        timeout_s: float | None = 3600.0,
        apdl_names: Mapping[str, str] | None = None,
        units: str = "SI",
        location_tolerance_m: float = DEFAULT_LOCATION_TOLERANCE_M,
        min_frequency_hz: float | None = None,
        keep_files: bool = False,
    ) -> None:
        super().__init__(parameter_names)
        if not (isinstance(n_modes, int) and n_modes >= 1):
            raise ValueError(f"n_modes must be a positive integer, got {n_modes!r}")
        if not (isinstance(n_processors, int) and n_processors >= 1):
            raise ValueError(f"n_processors must be a positive integer, got {n_processors!r}")
        self.units = deck_units(units)
        if isinstance(location_tolerance_m, bool) or not (isinstance(location_tolerance_m, (int, float)) and location_tolerance_m > 0):
            raise ValueError(f"location_tolerance_m must be a positive distance in metres, got {location_tolerance_m!r}")
        if min_frequency_hz is not None and (isinstance(min_frequency_hz, bool) or not (isinstance(min_frequency_hz, (int, float)) and min_frequency_hz > 0)):
            raise ValueError(f"min_frequency_hz must be a positive frequency in Hz or None, got {min_frequency_hz!r}")
        if not isinstance(keep_files, bool):
            raise ValueError(f"keep_files must be true or false, got {keep_files!r}")
        self.location_tolerance_m = float(location_tolerance_m)
        self.min_frequency_hz = None if min_frequency_hz is None else float(min_frequency_hz)
        self.keep_files = keep_files
        self.apdl_names = dict(apdl_names or {})
        unknown = set(self.apdl_names) - set(self.parameter_names)
        if unknown:
            raise ValueError(f"apdl_names: {sorted(unknown)} are not parameters of this adapter ({list(self.parameter_names)})")
        for name in self.parameter_names:
            apdl = self.apdl_names.get(name, name)
            if not APDL_NAME.fullmatch(apdl):
                raise ValueError(f"APDL name {apdl!r} of parameter {name!r}: expected a letter then up to 31 letters, digits or '_'")
            if apdl.upper().startswith(RESERVED_PREFIX):
                raise ValueError(f"APDL name {apdl!r} of parameter {name!r}: names starting with {RESERVED_PREFIX!r} are reserved for the adapter")
        self.safe_names = {name: safe_parameter_name(i) for i, name in enumerate(self.parameter_names, start=1)}
        if not coordinates:
            raise ValueError("coordinates: give at least one {name: (node, 'ux'|'uy'|'uz')}")
        self.coordinates: dict[str, tuple[NodeSpec, str]] = {name: self._check_coordinate(name, spec) for name, spec in coordinates.items()}
        self.deck_text = deck_text
        self.n_modes = n_modes
        self.n_processors = n_processors
        # Validate the deck now (with placeholder values) so a bad deck fails early.
        check_reserved_names(deck_text)
        substitute_parameters(deck_text, {name: 0.0 for name in self.parameter_names}, self.apdl_names, self.safe_names)
        self.runner = ProcessRunner(
            executable=executable or os.environ.get(MAPDL_EXEC_ENV, ""),
            work_root=work_root,
            scratch_prefix="nlupdate-mapdl-",
            timeout_s=timeout_s,
            install_hint=MAPDL_INSTALL_HINT,
            log_name="mapdl.log",
        )

    @staticmethod
    def _check_coordinate(name: str, spec: object) -> tuple[NodeSpec, str]:
        if not (isinstance(spec, (tuple, list)) and len(spec) == 2):
            raise ValueError(f"coordinate {name!r}: expected (node, direction), got {spec!r}")
        node, direction = spec
        if direction not in AXES:
            raise ValueError(f"coordinate {name!r}: direction {direction!r} is not one of {sorted(AXES)}")
        if isinstance(node, (tuple, list)):
            if len(node) != 3 or not all(isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool) and np.isfinite(v) for v in node):
                raise ValueError(f"coordinate {name!r}: a point must be three finite numbers (x, y, z) in metres, got {node!r}")
            return (tuple(float(v) for v in node), direction)  # type: ignore[return-value]
        if isinstance(node, bool) or not (isinstance(node, (int, np.integer)) and node >= 1 or isinstance(node, str) and node.strip()):
            raise ValueError(f"coordinate {name!r}: node must be a positive node number, an APDL expression or a point (x, y, z) in metres, got {node!r}")
        if isinstance(node, str) and not single_expression(node):
            raise ValueError(f"coordinate {name!r}: {node!r} is not a single APDL expression (no '$', '!', line breaks or commas outside parentheses)")
        return (int(node) if isinstance(node, (int, np.integer)) else node.strip(), direction)

    def check_available(self) -> None:
        self.runner.resolve()

    def solver_version(self) -> str:
        executable = self.runner.executable or "(no executable configured)"
        return f"ANSYS MAPDL batch: {executable}"

    def model_fingerprint(self) -> str:
        return fingerprint(_BLOCK_VERSION, self.deck_text, self.n_modes, self.coordinates, self.apdl_names,
                           self.units.name, self.min_frequency_hz, length=16)

    def node_expression(self, node: NodeSpec) -> int | str:
        """What the block assigns to ``NLU_N<c>``: points (m) become ``NODE(…)`` in deck units."""
        if isinstance(node, tuple):
            return "NODE({})".format(",".join(repr(v * self.units.per_metre) for v in node))
        return node

    def input_deck(self, parameters: Mapping[str, float]) -> str:
        """The complete input file for ``parameters``: substituted deck + modal block."""
        deck = substitute_parameters(self.deck_text, parameters, self.apdl_names, self.safe_names)
        coordinates = [(self.node_expression(node), direction) for node, direction in self.coordinates.values()]
        return deck.rstrip("\n") + "\n" + modal_block(self.n_modes, coordinates, self.min_frequency_hz)

    def command(self) -> list[str]:
        """Arguments after the executable."""
        return ["-b", "-i", INPUT_NAME, "-o", OUTPUT_NAME, "-j", JOB_NAME, "-np", str(self.n_processors)]

    def _solve(self, parameters: Mapping[str, float]) -> ModalResult:
        run_dir = self.runner.new_run_dir(self.key(parameters))
        write_text_atomic(run_dir / INPUT_NAME, self.input_deck(parameters))
        output = run_dir / OUTPUT_NAME
        try:
            run = self.runner.run(self.command(), run_dir)
        except (ExecutableNotFoundError, RunTimeoutError):
            raise
        except AdapterError as error:
            reason = str(error).splitlines()[0]
            first = first_error(run_dir)
            detail = f"; {first.describe()}" if first else ""
            raise run_failure(f"MAPDL failed: {reason}{detail} (launcher log: {run_dir / self.runner.log_name})", run_dir, output) from error
        result = self._read_result(run, output)
        if not self.keep_files:
            remove_scratch_files(run_dir)
        return result

    def _read_result(self, run: RunResult, output: Path) -> ModalResult:
        if not output.exists():
            raise run_failure(f"MAPDL exited with code 0 but wrote no {OUTPUT_NAME}", run.run_dir, run.log_path)
        first = first_error(run.run_dir)
        if first is not None:
            raise run_failure(f"MAPDL reported {first.describe(' although it exited with code 0')}", run.run_dir, first.path)
        table_path = run.run_dir / TABLE_NAME
        if not table_path.exists():
            raise run_failure(f"MAPDL finished without writing {TABLE_NAME}", run.run_dir, output)
        try:
            table = parse_modal_table(table_path.read_text(errors="replace"), self.n_modes, len(self.coordinates), str(table_path))
        except ValueError as error:
            raise run_failure(f"could not read the MAPDL modal table: {error}", run.run_dir, output) from error
        try:
            check_modes(table.frequencies_hz, table.modes_found, self.n_modes)
        except ValueError as error:
            raise run_failure(f"implausible MAPDL modes in {table_path}: {error}", run.run_dir, output) from error
        locations_m = table.locations / self.units.per_metre
        distances: dict[str, float | None] = {}
        for (name, (node, _)), chosen, location in zip(self.coordinates.items(), table.nodes, locations_m):
            point = requested_point(node, self.units)
            if point is None:
                distances[name] = None
                continue
            distance = float(np.linalg.norm(location - np.asarray(point)))
            distances[name] = distance
            if not distance <= self.location_tolerance_m:
                raise run_failure(
                    f"coordinate {name!r}: MAPDL chose node {chosen} for {self.node_expression(node)} (requested point "
                    f"{_format_point(point)} m); the node lies at {_format_point(location)} m, {distance:.6g} m away — more than "
                    f"location_tolerance_m = {self.location_tolerance_m:g} m. Check the point, the deck's units "
                    f"(units = {self.units.name!r}: {self.units.description}) and its coordinate systems, or raise "
                    f"location_tolerance_m if the mesh has no node closer",
                    run.run_dir,
                    output,
                )
        metadata = {
            "solver": "mapdl",
            "mesh_size": table.elements,
            "wall_time_s": run.wall_time_s,
            "log_path": str(output),
            "launcher_log_path": str(run.log_path),
            "run_dir": str(run.run_dir),
            "units": self.units.name,
            "normalisation": f"mass (MAPDL MODOPT Nrmkey=OFF), converted from 1/√(deck mass unit) to 1/√kg (× {self.units.shape_factor:.6g})",
            "nodes": dict(zip(self.coordinates, table.nodes)),
            "node_locations_m": {name: tuple(float(v) for v in loc) for name, loc in zip(self.coordinates, locations_m)},
            "node_distances_m": distances,
        }
        return ModalResult(
            natural_frequencies_hz=table.frequencies_hz,
            mode_shapes=table.shapes * self.units.shape_factor,
            coordinates=tuple(self.coordinates),
            metadata=metadata,
        )

def _format_point(point: Sequence[float] | np.ndarray) -> str:
    return "(" + ", ".join(f"{float(v):.6g}" for v in point) + ")"

def from_options(model: str | None, options: dict) -> MapdlAdapter:
    """The adapter of a study's ``[adapter] kind = "mapdl"`` (:mod:`nlupdate.fe.adapters.registry`)."""
    try:
        deck = read_input_text(options.pop("deck"), "MAPDL deck")
        names = options.pop("parameter_names")
        coordinates = {name: tuple(value) for name, value in options.pop("coordinates").items()}
    except KeyError as error:
        raise ValueError(f"mapdl adapter: missing option {error.args[0]!r} (deck, parameter_names, coordinates)") from None
    try:
        return MapdlAdapter(deck, names, coordinates, **options)
    except TypeError as error:
        raise ValueError(f"mapdl adapter: {error}") from None
