"""Ansys Mechanical APDL (MAPDL) in batch mode behind the FEAdapter interface.

The user supplies a parametric APDL deck that builds the model (geometry, mesh,
materials, supports) in consistent SI units (m, kg, s) and does not solve. Every
updating parameter must be defined by exactly one ``*SET,NAME,value`` line; the
adapter replaces that value (``NAME`` is the parameter's APDL name, by default the
parameter name itself, see ``apdl_names``) and refuses decks where a parameter has no
``*SET`` line, several ones, or is also assigned with ``NAME = value``.

Appended block
--------------
After the user's deck the adapter appends, for ``n`` modes and coordinates
``c = 1..m`` given as ``{name: (node, direction)}`` (node: a node number or an APDL
expression such as ``NODE(0.43,0,0)``; direction ``ux|uy|uz`` → ``U,X|Y|Z``)::

    ! ---- nlupdate modal block (generated) ----
    FINISH
    /SOLU
    ANTYPE,MODAL
    MODOPT,LANB,<n>,,,,OFF
    MXPAND,<n>
    SOLVE
    *DIM,NLU_FRQ,ARRAY,<n>
    *GET,NLU_FRQ(1),MODE,1,FREQ          (one line per mode 1..n)
    FINISH
    /POST1
    ALLSEL,ALL
    *GET,NLU_NEL,ELEM,0,COUNT
    NLU_N1=<node of coordinate 1>        (one line per coordinate 1..m)
    *DIM,NLU_U1,ARRAY,<n>                (one line per coordinate 1..m)
    SET,1,1                              (for each mode i = 1..n: SET,1,i then
    *GET,NLU_U1(1),NODE,NLU_N1,U,Z        one *GET per coordinate)
    *CFOPEN,modal_table,txt
    *VWRITE
    ('NLUPDATE MODAL TABLE')
    *VWRITE,NLU_NEL
    ('ELEMENTS',1X,F12.0)
    *VWRITE
    ('FREQUENCIES')
    *VWRITE,SEQU,NLU_FRQ(1)
    (F8.0,1X,E24.16)
    *VWRITE                              (for each coordinate c = 1..m:
    ('COORDINATE c')                      a title line and its n values)
    *VWRITE,SEQU,NLU_Uc(1)
    (F8.0,1X,E24.16)
    *CFCLOS
    FINISH

``MODOPT`` with Nrmkey = OFF keeps MAPDL's default normalisation of the mode shapes to
the mass matrix (ΦᵀMΦ = I), so the shapes are mass-normalised (1/√kg for SI decks) and
``*GET …MODE,i,FREQ`` is in Hz.

Table layout (``modal_table.txt``)
----------------------------------
Line 1 ``NLUPDATE MODAL TABLE``; line 2 ``ELEMENTS <number of elements>.``; then a
``FREQUENCIES`` title and ``n`` rows ``<mode>. <frequency Hz>``; then for each
coordinate, in the adapter's coordinate order, a ``COORDINATE <c>`` title and ``n``
rows ``<mode>. <displacement>``. Numbers are Fortran ``E24.16``; Fortran drops the
``E`` of 3-digit exponents (``0.12-100``), which the parser accepts.

The run: ``<exe> -b -i in.inp -o out.out -j job -np <N>`` in a fresh directory (see
:mod:`nlupdate.adapters.runner`); a non-zero exit or ``*** ERROR ***`` in ``out.out``
is a failure (:class:`AdapterError` naming the run directory and ``out.out``).

Status: no MAPDL installation was available when this was written; the block, the
parser and the process handling are tested against hand-written files and a fake
``mapdl`` executable (tests/test_mapdl.py), not against a real MAPDL run.
"""
from __future__ import annotations

import hashlib
import os
import re
import tempfile
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from nlupdate.adapters.base import AdapterError, FEAdapter, ModalResult
from nlupdate.adapters.calculix import fortran_float
from nlupdate.adapters.runner import (
    ExecutableNotFoundError,
    ProcessRunner,
    RunResult,
    RunTimeoutError,
    run_failure,
    write_text_atomic,
)

MAPDL_EXEC_ENV = "PYMAPDL_MAPDL_EXEC"
MAPDL_INSTALL_HINT = (
    f"Set `executable` in the MapdlAdapter config to the MAPDL launcher (e.g. /ansys_inc/v241/ansys/bin/ansys241) "
    f"or set the {MAPDL_EXEC_ENV} environment variable."
)
INPUT_NAME = "in.inp"
OUTPUT_NAME = "out.out"
TABLE_NAME = "modal_table.txt"
JOB_NAME = "job"
ERROR_MARKER = "*** ERROR ***"

TABLE_TITLE = "NLUPDATE MODAL TABLE"
_AXES = {"ux": "X", "uy": "Y", "uz": "Z"}
_APDL_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,31}")
_ROW_FORMAT = "(F8.0,1X,E24.16)"
_BLOCK_VERSION = "mapdl-block-1"

Coordinates = Mapping[str, tuple[int | str, str]]


def substitute_parameters(deck: str, values: Mapping[str, float], apdl_names: Mapping[str, str] | None = None) -> str:
    """Replace the value of ``*SET,NAME,value`` for every parameter in ``values``.

    Raises ValueError when a parameter has no ``*SET`` line, more than one, or is
    also assigned with ``NAME = value``.
    """
    apdl_names = apdl_names or {}
    lines = deck.splitlines(keepends=True)
    for name, value in values.items():
        apdl = apdl_names.get(name, name)
        set_line = re.compile(rf"^(\s*\*SET\s*,\s*){re.escape(apdl)}(\s*,\s*)([^,!\r\n]*)(.*)$", re.IGNORECASE | re.DOTALL)
        assignment = re.compile(rf"^\s*{re.escape(apdl)}\s*=", re.IGNORECASE)
        hits = [number for number, line in enumerate(lines) if set_line.match(line)]
        if not hits:
            raise ValueError(f"APDL deck: parameter {name!r} has no '*SET,{apdl},<value>' line to substitute")
        if len(hits) > 1:
            raise ValueError(f"APDL deck: parameter {name!r} has {len(hits)} '*SET,{apdl},…' lines (lines {[h + 1 for h in hits]}); expected one")
        assigned = [number + 1 for number, line in enumerate(lines) if assignment.match(line)]
        if assigned:
            raise ValueError(f"APDL deck: parameter {name!r} is also assigned with '{apdl} = …' on line(s) {assigned}; define it only by one *SET line")
        match = set_line.match(lines[hits[0]])
        assert match is not None
        old_value = match.group(3)
        spacing = old_value[len(old_value.rstrip()) :]
        lines[hits[0]] = f"{match.group(1)}{apdl}{match.group(2)}{float(value)!r}{spacing}{match.group(4)}"
    return "".join(lines)


def modal_block(n_modes: int, coordinates: Sequence[tuple[int | str, str]]) -> str:
    """The APDL block appended to the user's deck (documented in the module docstring)."""
    out = [
        "! ---- nlupdate modal block (generated) ----",
        "FINISH",
        "/SOLU",
        "ANTYPE,MODAL",
        f"MODOPT,LANB,{n_modes},,,,OFF",
        f"MXPAND,{n_modes}",
        "SOLVE",
        f"*DIM,NLU_FRQ,ARRAY,{n_modes}",
    ]
    out += [f"*GET,NLU_FRQ({i}),MODE,{i},FREQ" for i in range(1, n_modes + 1)]
    out += ["FINISH", "/POST1", "ALLSEL,ALL", "*GET,NLU_NEL,ELEM,0,COUNT"]
    out += [f"NLU_N{c}={node}" for c, (node, _) in enumerate(coordinates, start=1)]
    out += [f"*DIM,NLU_U{c},ARRAY,{n_modes}" for c in range(1, len(coordinates) + 1)]
    for i in range(1, n_modes + 1):
        out.append(f"SET,1,{i}")
        out += [f"*GET,NLU_U{c}({i}),NODE,NLU_N{c},U,{_AXES[direction]}" for c, (_, direction) in enumerate(coordinates, start=1)]
    out += [
        f"*CFOPEN,{Path(TABLE_NAME).stem},{Path(TABLE_NAME).suffix[1:]}",
        "*VWRITE",
        f"('{TABLE_TITLE}')",
        "*VWRITE,NLU_NEL",
        "('ELEMENTS',1X,F12.0)",
        "*VWRITE",
        "('FREQUENCIES')",
        "*VWRITE,SEQU,NLU_FRQ(1)",
        _ROW_FORMAT,
    ]
    for c in range(1, len(coordinates) + 1):
        out += ["*VWRITE", f"('COORDINATE {c}')", f"*VWRITE,SEQU,NLU_U{c}(1)", _ROW_FORMAT]
    out += ["*CFCLOS", "FINISH"]
    return "\n".join(out) + "\n"


def parse_modal_table(text: str, n_modes: int, n_coordinates: int, source: str = TABLE_NAME) -> tuple[np.ndarray, np.ndarray, int]:
    """Frequencies (Hz, (n_modes,)), shapes ((n_coordinates, n_modes)) and element count.

    Raises ValueError naming ``source``, the line and the expected form.
    """
    lines = [(number, line.strip()) for number, line in enumerate(text.splitlines(), start=1) if line.strip()]
    expected_lines = 2 + (1 + n_coordinates) * (1 + n_modes)
    position = 0

    def take_title(title: str) -> None:
        nonlocal position
        if position >= len(lines):
            raise ValueError(f"{source}: ends after {len(text.splitlines())} lines; expected a {title!r} line next ({expected_lines} non-blank lines in all)")
        number, line = lines[position]
        if line != title:
            raise ValueError(f"{source}, line {number}: expected {title!r}, got {line!r}")
        position += 1

    def take_rows(section: str) -> np.ndarray:
        nonlocal position
        values = np.empty(n_modes)
        for mode in range(1, n_modes + 1):
            if position >= len(lines):
                raise ValueError(f"{source}: section {section!r} ends after {mode - 1} of {n_modes} rows")
            number, line = lines[position]
            fields = line.split()
            try:
                if len(fields) != 2:
                    raise ValueError
                index, value = fortran_float(fields[0]), fortran_float(fields[1])
            except ValueError:
                raise ValueError(f"{source}, line {number}: expected '<mode>. <value>' (mode {mode} of section {section!r}), got {line!r}") from None
            if index != mode:
                raise ValueError(f"{source}, line {number}: expected mode {mode} in section {section!r}, got {fields[0]!r}")
            if not np.isfinite(value):
                raise ValueError(f"{source}, line {number}: value {fields[1]!r} is not finite")
            values[mode - 1] = value
            position += 1
        return values

    take_title(TABLE_TITLE)
    if position >= len(lines):
        raise ValueError(f"{source}: ends after the title; expected 'ELEMENTS <count>.' next")
    number, line = lines[position]
    fields = line.split()
    try:
        if len(fields) != 2 or fields[0] != "ELEMENTS":
            raise ValueError
        elements = fortran_float(fields[1])
    except ValueError:
        raise ValueError(f"{source}, line {number}: expected 'ELEMENTS <count>.', got {line!r}") from None
    if elements != int(elements) or elements < 0:
        raise ValueError(f"{source}, line {number}: element count {fields[1]!r} is not a non-negative whole number")
    position += 1
    take_title("FREQUENCIES")
    frequencies = take_rows("FREQUENCIES")
    shapes = np.empty((n_coordinates, n_modes))
    for c in range(1, n_coordinates + 1):
        take_title(f"COORDINATE {c}")
        shapes[c - 1] = take_rows(f"COORDINATE {c}")
    if position != len(lines):
        number, line = lines[position]
        raise ValueError(f"{source}, line {number}: unexpected content after the last coordinate section: {line!r}")
    return frequencies, shapes, int(elements)


class MapdlAdapter(FEAdapter):
    """Modal analysis with MAPDL batch runs (see module docstring for the contract).

    deck_text: the user's parametric APDL deck (model only, SI units).
    parameter_names: updating parameters; each needs one ``*SET`` line in the deck.
    coordinates: ``{name: (node number or APDL expression, "ux"|"uy"|"uz")}``.
    n_modes: modes extracted (LANB) and expanded.
    executable: MAPDL launcher; default: environment variable ``PYMAPDL_MAPDL_EXEC``.
    n_processors: ``-np`` value.
    apdl_names: optional ``{parameter name: APDL parameter name}`` (default identity).
    """

    name = "mapdl"

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
    ) -> None:
        super().__init__(parameter_names)
        if not (isinstance(n_modes, int) and n_modes >= 1):
            raise ValueError(f"n_modes must be a positive integer, got {n_modes!r}")
        if not (isinstance(n_processors, int) and n_processors >= 1):
            raise ValueError(f"n_processors must be a positive integer, got {n_processors!r}")
        self.apdl_names = dict(apdl_names or {})
        unknown = set(self.apdl_names) - set(self.parameter_names)
        if unknown:
            raise ValueError(f"apdl_names: {sorted(unknown)} are not parameters of this adapter ({list(self.parameter_names)})")
        for name in self.parameter_names:
            apdl = self.apdl_names.get(name, name)
            if not _APDL_NAME.fullmatch(apdl):
                raise ValueError(f"APDL name {apdl!r} of parameter {name!r}: expected a letter then up to 31 letters, digits or '_'")
        if not coordinates:
            raise ValueError("coordinates: give at least one {name: (node, 'ux'|'uy'|'uz')}")
        checked: dict[str, tuple[int | str, str]] = {}
        for name, spec in coordinates.items():
            if not (isinstance(spec, tuple) and len(spec) == 2):
                raise ValueError(f"coordinate {name!r}: expected (node, direction), got {spec!r}")
            node, direction = spec
            if direction not in _AXES:
                raise ValueError(f"coordinate {name!r}: direction {direction!r} is not one of {sorted(_AXES)}")
            if isinstance(node, bool) or not (isinstance(node, (int, np.integer)) and node >= 1 or isinstance(node, str) and node.strip()):
                raise ValueError(f"coordinate {name!r}: node must be a positive node number or an APDL expression, got {node!r}")
            checked[name] = (int(node) if isinstance(node, (int, np.integer)) else node.strip(), direction)
        self.coordinates = checked
        self.deck_text = deck_text
        self.n_modes = n_modes
        self.n_processors = n_processors
        # Validate the *SET lines now (with placeholder values) so a bad deck fails early.
        substitute_parameters(deck_text, {name: 0.0 for name in self.parameter_names}, self.apdl_names)
        root = Path(work_root) if work_root is not None else Path(tempfile.mkdtemp(prefix="nlupdate-mapdl-"))
        self.runner = ProcessRunner(
            executable=executable or os.environ.get(MAPDL_EXEC_ENV, ""),
            work_root=root,
            timeout_s=timeout_s,
            install_hint=MAPDL_INSTALL_HINT,
            log_name="mapdl.log",
        )

    @classmethod
    def from_file(cls, deck_path: str | Path, parameter_names: Sequence[str], coordinates: Coordinates, **options: object) -> "MapdlAdapter":
        """Adapter for the APDL deck stored in ``deck_path``."""
        return cls(Path(deck_path).read_text(), parameter_names, coordinates, **options)  # type: ignore[arg-type]

    def solver_version(self) -> str:
        executable = self.runner.executable or "(no executable configured)"
        return f"ANSYS MAPDL batch: {executable}"

    def model_fingerprint(self) -> str:
        payload = repr((_BLOCK_VERSION, self.deck_text, self.n_modes, list(self.coordinates.items()), sorted(self.apdl_names.items())))
        return hashlib.sha256(payload.encode()).hexdigest()[:16]

    def input_deck(self, parameters: Mapping[str, float]) -> str:
        """The complete input file for ``parameters``: substituted deck + modal block."""
        deck = substitute_parameters(self.deck_text, parameters, self.apdl_names)
        return deck.rstrip("\n") + "\n" + modal_block(self.n_modes, list(self.coordinates.values()))

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
            raise run_failure(f"MAPDL failed: {reason} (launcher log: {run_dir / self.runner.log_name})", run_dir, output) from error
        return self._read_result(run, output)

    def _read_result(self, run: RunResult, output: Path) -> ModalResult:
        if not output.exists():
            raise run_failure(f"MAPDL exited with code 0 but wrote no {OUTPUT_NAME}", run.run_dir, run.log_path)
        error_lines = [number for number, line in enumerate(output.read_text(errors="replace").splitlines(), start=1) if ERROR_MARKER in line]
        if error_lines:
            raise run_failure(f"MAPDL reported {ERROR_MARKER} in {OUTPUT_NAME} (line {error_lines[0]}) although it exited with code 0", run.run_dir, output)
        table = run.run_dir / TABLE_NAME
        if not table.exists():
            raise run_failure(f"MAPDL finished without writing {TABLE_NAME}", run.run_dir, output)
        try:
            frequencies, shapes, elements = parse_modal_table(table.read_text(errors="replace"), self.n_modes, len(self.coordinates), str(table))
        except ValueError as error:
            raise run_failure(f"could not read the MAPDL modal table: {error}", run.run_dir, output) from error
        metadata = {
            "solver": "mapdl",
            "mesh_size": elements,
            "wall_time_s": run.wall_time_s,
            "log_path": str(output),
            "launcher_log_path": str(run.log_path),
            "run_dir": str(run.run_dir),
            "normalisation": "mass (MAPDL MODOPT Nrmkey=OFF)",
        }
        return ModalResult(natural_frequencies_hz=frequencies, mode_shapes=shapes, coordinates=tuple(self.coordinates), metadata=metadata)
