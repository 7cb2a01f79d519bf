"""Ansys Mechanical APDL (MAPDL) in batch mode behind the FEAdapter interface.

The user supplies a parametric APDL deck that builds the model (geometry, mesh,
materials, supports) in one consistent unit system (``units``, below) and does not
solve. Every updating parameter must be defined by exactly one ``*SET,NAME,value`` line
(one value, on a line of its own, at most a ``!`` comment after it); ``NAME`` is the
parameter's APDL name in the deck, by default the parameter name itself, see
``apdl_names``. Decks where a parameter has no such line, several, or is also assigned
with ``NAME = …``, ``*GET,NAME,…``, ``*DIM,NAME,…``, ``*DO,NAME,…``, ``*ASK,NAME,…`` or
``*VGET,NAME,…`` are refused, and so are decks using names that start with ``NLU_``
(reserved for the generated commands).

Parameter values
----------------
The adapter never uses a project parameter name, nor the deck's own name, as the name
it sets. Parameter ``i`` (1-based, in ``parameter_names`` order) is carried by the safe
APDL name ``NLU_P<i>`` (a letter first, letters/digits/underscore, ≤ 32 characters),
and the deck's line is rewritten in place into two lines::

    *SET,NLU_P1,190000000000.0   ! nlupdate parameter E     (generated)
    *SET,E,NLU_P1        ! Young's modulus (Pa)             (the user's line)

so the deck's name (``E`` here, which is also an APDL command) keeps its spelling,
position and comment — whatever the deck computes from it before and after is
unchanged — and gets the value through the generated name, defined on the line just
before (so a ``/CLEAR`` earlier in the deck cannot delete it). Values are written with
``repr(float)``: the shortest text that reads back as the same double. They are written
as given: state them in the deck's units (E in MPa for an ``mm-t-s`` deck).

Appended block
--------------
After the deck the adapter appends, for ``n`` modes and coordinates ``c = 1..m`` given
as ``{name: (node, direction)}`` (direction ``ux|uy|uz`` → ``U,X|Y|Z``; node: a node
number, an APDL expression such as ``NODE(0.43,0,0)`` or ``TIPNODE`` evaluated as
written, in the deck's units, or a point ``(x, y, z)`` in metres, written as
``NODE(x', y', z')`` in the deck's length unit)::

    ! ---- nlupdate modal block (generated) ----
    FINISH
    /SOLU
    ANTYPE,MODAL
    MODOPT,LANB,<n>,<FREQB>,,,OFF        (FREQB: min_frequency_hz, blank by default)
    MXPAND,<n>
    ALLSEL,ALL                           (solve the whole model, whatever the deck
    SOLVE                                 selected last)
    FINISH
    /POST1
    ALLSEL,ALL
    CSYS,0                               (NODE(x,y,z) and *GET …LOC in global Cartesian,
    DSYS,0                                whatever system the deck left active; listings
    RSYS,0                                too; results in global Cartesian)
    *GET,NLU_NEL,ELEM,0,COUNT
    *GET,NLU_NSET,ACTIVE,0,SET,NSET      (data sets = modes found and expanded)
    NLU_NM=NLU_NSET                      (NLU_NM = min(NLU_NSET, n): never ask for a
    *IF,NLU_NM,GT,<n>,THEN                set that is not on the result file)
    NLU_NM=<n>
    *ENDIF
    NLU_N1=<node of coordinate 1>        (for each coordinate c = 1..m: its node and
    *GET,NLU_X1,NODE,NLU_N1,LOC,X         the node's location)
    *GET,NLU_Y1,NODE,NLU_N1,LOC,Y
    *GET,NLU_Z1,NODE,NLU_N1,LOC,Z
    *DIM,NLU_FRQ,ARRAY,<n>
    *DIM,NLU_U1,ARRAY,<n>                (one line per coordinate 1..m)
    *DO,NLU_I,1,NLU_NM
    SET,1,NLU_I
    *GET,NLU_FRQ(NLU_I),ACTIVE,0,SET,FREQ
    *GET,NLU_U1(NLU_I),NODE,NLU_N1,U,Z   (one *GET per coordinate 1..m)
    *ENDDO
    *CFOPEN,modal_table,txt
    *VWRITE
    ('NLUPDATE MODAL TABLE')
    *VWRITE,NLU_NEL
    ('ELEMENTS',1X,F12.0)
    *VWRITE,NLU_NSET
    ('MODES',1X,F12.0)
    *VWRITE
    ('FREQUENCIES')
    *VWRITE,SEQU,NLU_FRQ(1)
    (F8.0,1X,E24.16)
    *VWRITE                              (for each coordinate c = 1..m: a title line,
    ('COORDINATE c')                      the node line and its n values)
    *VWRITE,NLU_Nc,NLU_Xc,NLU_Yc,NLU_Zc
    ('NODE',1X,F12.0,1X,E24.16,1X,E24.16,1X,E24.16)
    *VWRITE,SEQU,NLU_Uc(1)
    (F8.0,1X,E24.16)
    *CFCLOS
    FINISH

``*GET`` returns locations in the active coordinate system (CSYS) and results in the
active results system (RSYS), hence the resets. ``MODOPT`` with Nrmkey = OFF keeps
MAPDL's normalisation of the mode shapes to the mass matrix (ΦᵀMΦ = I), and
``*GET …SET,FREQ`` is the frequency of the current data set in Hz. A positive
``min_frequency_hz`` makes Block Lanczos start there (FREQB), e.g. above the rigid-body
modes of a free-free model.

Table layout (``modal_table.txt``)
----------------------------------
Line 1 ``NLUPDATE MODAL TABLE``; ``ELEMENTS <number of elements>.``; ``MODES <data sets
on the result file>.``; a ``FREQUENCIES`` title and ``n`` rows ``<mode>. <frequency
Hz>``; then for each coordinate, in the adapter's coordinate order, a ``COORDINATE <c>``
title, ``NODE <node>. <x> <y> <z>`` (global Cartesian, deck length unit) and ``n`` rows
``<mode>. <displacement>`` (deck units). Numbers are Fortran ``E24.16``; Fortran drops
the ``E`` of 3-digit exponents (``0.12-100``), which the parser accepts. Rows of modes
beyond those found are 0.

Checks on every run
-------------------
* ``*** ERROR ***`` in ``out.out`` **or** in ``job.err`` (and the ``job<N>.err`` files of
  distributed runs): MAPDL writes every error to the ``.err`` file, also when a
  ``/OUTPUT`` in the deck hides it from ``out.out``. The error names the file, the line
  and quotes the message.
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

Units
-----
``units`` names the deck's consistent unit system (MAPDL itself has none):

=========  ======  =====  =====  =====  ===============
units      length  mass   time   force  stress, modulus
=========  ======  =====  =====  =====  ===============
SI         m       kg     s      N      Pa
mm-t-s     mm      t      s      N      MPa (N/mm²)
mm-kg-s    mm      kg     s      mN     kPa (mN/mm²)
=========  ======  =====  =====  =====  ===============

(mm-kg-s is consistent: 1 kg·mm/s² = 1e-3 N = 1 mN and 1 mN/mm² = 1 kPa; densities in
kg/mm³.) Results are converted to the adapter's SI interface:

* frequencies: every system uses the second, so Hz need no conversion.
* mass-normalised shapes: MAPDL scales each mode to φᵀMφ = 1 with M in the deck's mass
  unit. For a translational coordinate M holds masses, so φ² has the unit 1/mass:
  ``[φ] = 1/√(deck mass unit)``, whatever the length unit. With ``c`` = deck mass units
  per kilogram (1e-3 for tonnes: 2 kg = 0.002 t), M_deck = c·M_SI and
  φ_deckᵀ M_deck φ_deck = 1 = φ_SIᵀ M_SI φ_SI, so **φ_SI = √c · φ_deck**: × 1/√1000 =
  × 0.0316228 for mm-t-s, × 1 for mm-kg-s and SI. Check by the receptance
  H = Σ φ_j φ_k / (ω_r² − ω²) (displacement per force): in mm-t-s it comes out in
  mm/N = 1e-3 m/N, so φ_SI² = 1e-3 φ_deck², the same factor; in mm-kg-s it comes out in
  mm/mN = m/N, factor 1. (A factor 1e-3/√1000 would treat φ as a length; it is not — the
  displacement is φ times a modal coordinate in √mass·length. A rotation would carry a
  length factor; only ux|uy|uz are read.)
* points: ``(x, y, z)`` in metres are written into ``NODE()`` × 1000 for mm decks;
  locations read back are converted to metres; ``location_tolerance_m`` is in metres.
* parameter values: not converted (see above).

Run folders
-----------
The run: ``<exe> -b -i in.inp -o out.out -j job -np <N>`` in a fresh directory (see
:mod:`nlupdate.adapters.runner`); a non-zero exit or any failed check above is an
:class:`AdapterError` naming the run directory and the file to read. After a successful
run the large binary files of the job (``job*.rst``, ``.full``, ``.mode``, ``.esav``,
``.emat``, ``.db``, ``.page``, ``.osav``, ``.ldhi``, ``.LNxx``, ``.rNNN``, … see
:data:`SCRATCH_FILE`) are deleted unless ``keep_files=True``; the input deck, ``out.out``,
the ``.err``/``.log`` files, the modal table and the launcher log stay. Failed runs keep
everything.

Status: no MAPDL installation was available when this was written; the block, the
parser and the process handling are tested against hand-written files and a fake
``mapdl`` executable that interprets the few commands that matter (selection, ``CSYS``,
``LOCAL``, ``N``, ``*SET``, ``NODE()``, tests/test_mapdl.py), not against a real MAPDL run.
"""
from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from nlupdate.fingerprints import fingerprint
from nlupdate.input_files import read_input_text
from nlupdate.adapters.base import AdapterError, FEAdapter, ModalResult, check_frequencies
from nlupdate.adapters.calculix import fortran_float
from nlupdate.adapters.runner import (
    ExecutableNotFoundError,
    ProcessRunner,
    RunResult,
    RunTimeoutError,
    log_lines,
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
DEFAULT_LOCATION_TOLERANCE_M = 1e-3
#: Relative slack of the "ascending frequencies" check: the precision of the table the
#: generated block writes (E24.16), so repeated roots a last digit apart pass.
FREQUENCY_ORDER_RTOL = 1e-9
#: Files of a job deleted after a successful run unless ``keep_files``: the result,
#: matrix, element, database, page, restart and scratch files, also the ``job<N>.*``
#: files of distributed runs.
SCRATCH_FILE = re.compile(
    rf"{JOB_NAME}\d*\.(rst|rstp|rth|full|mode|lmode|esav|emat|db|dbb|page|osav|ldhi|rdb|mlv|sub|dsub|mnf|modesym|lock|ln\d\d|r\d\d\d)",
    re.IGNORECASE,
)
_ERROR_FILE = re.compile(rf"{JOB_NAME}\d*\.err", re.IGNORECASE)

TABLE_TITLE = "NLUPDATE MODAL TABLE"
_AXES = {"ux": "X", "uy": "Y", "uz": "Z"}
_APDL_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,31}")
_RESERVED_PREFIX = "NLU_"
_RESERVED_USE = re.compile(r"(?<![A-Za-z0-9_])NLU_\w*", re.IGNORECASE)
_ROW_FORMAT = "(F8.0,1X,E24.16)"
_NODE_FORMAT = "('NODE',1X,F12.0,1X,E24.16,1X,E24.16,1X,E24.16)"
_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eEdD][-+]?\d+)?"
_NODE_POINT = re.compile(rf"NODE\(\s*({_NUMBER})\s*,\s*({_NUMBER})\s*,\s*({_NUMBER})\s*\)", re.IGNORECASE)
_DEFINING_COMMANDS = ("*GET", "*DIM", "*DO", "*ASK", "*VGET")
_BLOCK_VERSION = "mapdl-block-2"

NodeSpec = int | str | tuple[float, float, float]
Coordinates = Mapping[str, tuple[int | str | Sequence[float], str]]


@dataclass(frozen=True)
class DeckUnits:
    """A consistent unit system of an APDL deck.

    per_metre: deck length units per metre (1 for m, 1000 for mm).
    per_kilogram: deck mass units per kilogram (1 for kg, 1e-3 for t).
    """

    name: str
    per_metre: float
    per_kilogram: float
    description: str

    @property
    def shape_factor(self) -> float:
        """φ_SI (1/√kg) = shape_factor × φ_deck (1/√deck mass unit): √per_kilogram (module docstring)."""
        return math.sqrt(self.per_kilogram)


UNIT_SYSTEMS: dict[str, DeckUnits] = {
    "SI": DeckUnits("SI", 1.0, 1.0, "m, kg, s, N, Pa"),
    "mm-t-s": DeckUnits("mm-t-s", 1000.0, 1e-3, "mm, t, s, N, MPa"),
    "mm-kg-s": DeckUnits("mm-kg-s", 1000.0, 1.0, "mm, kg, s, mN, kPa"),
}


def deck_units(name: str) -> DeckUnits:
    """The :class:`DeckUnits` called ``name`` (case-insensitive), or ValueError."""
    for key, units in UNIT_SYSTEMS.items():
        if isinstance(name, str) and name.lower() == key.lower():
            return units
    raise ValueError(f"units: expected one of {list(UNIT_SYSTEMS)}, got {name!r}")


def safe_parameter_name(index: int) -> str:
    """The APDL name that carries parameter number ``index`` (1-based): ``NLU_P<index>``."""
    return f"{_RESERVED_PREFIX}P{index}"


def _statements(line: str) -> list[str]:
    """The ``$``-separated statements of one APDL line, without its ``!`` comment."""
    return [part.strip() for part in line.split("!", 1)[0].split("$")]


def _comment_text(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.:+-]", "_", name)[:60]


def check_reserved_names(deck: str) -> None:
    """ValueError when the deck uses a name starting with ``NLU_`` (reserved)."""
    for number, line in enumerate(deck.splitlines(), start=1):
        match = _RESERVED_USE.search(line.split("!", 1)[0])
        if match:
            raise ValueError(
                f"APDL deck, line {number}: {match.group(0)!r} — names starting with {_RESERVED_PREFIX!r} are reserved "
                f"for the adapter's generated commands; rename it"
            )


def substitute_parameters(
    deck: str,
    values: Mapping[str, float],
    apdl_names: Mapping[str, str] | None = None,
    safe_names: Mapping[str, str] | None = None,
) -> str:
    """Set every parameter in ``values`` through its safe name (module docstring).

    The deck's ``*SET,NAME,value`` line of a parameter becomes ``*SET,<safe>,<value>``
    followed by ``*SET,NAME,<safe>`` (the line's own spacing and comment kept).
    apdl_names: ``{parameter: name in the deck}`` (default: the parameter name).
    safe_names: ``{parameter: generated name}`` (default ``NLU_P<i>`` in ``values``
    order; the adapter passes its own, numbered in ``parameter_names`` order).

    Raises ValueError when a parameter has no ``*SET`` line, more than one, one with
    more than one value or statement, or is also defined another way.
    """
    apdl_names = apdl_names or {}
    safe_names = safe_names or {name: safe_parameter_name(i) for i, name in enumerate(values, start=1)}
    lines = deck.splitlines(keepends=True)
    statements = [_statements(line) for line in lines]
    replacements: dict[int, str] = {}
    for name, value in values.items():
        apdl = apdl_names.get(name, name)
        safe = safe_names[name]
        value = float(value)
        if not math.isfinite(value):
            raise ValueError(f"parameter {name!r}: value {value} is not finite")
        name_pattern = re.escape(apdl)
        set_statement = re.compile(rf"\*SET\s*,\s*{name_pattern}\s*(,|$)", re.IGNORECASE)
        assignment = re.compile(rf"{name_pattern}\s*=", re.IGNORECASE)
        defining = re.compile(rf"({'|'.join(re.escape(c) for c in _DEFINING_COMMANDS)})\s*,\s*{name_pattern}\s*(,|\(|$)", re.IGNORECASE)
        hits = [number for number, parts in enumerate(statements) if any(set_statement.match(part) for part in parts)]
        if not hits:
            raise ValueError(f"APDL deck: parameter {name!r} has no '*SET,{apdl},<value>' line to substitute")
        if len(hits) > 1:
            raise ValueError(f"APDL deck: parameter {name!r} has {len(hits)} '*SET,{apdl},…' lines (lines {[h + 1 for h in hits]}); expected one")
        assigned = [number + 1 for number, parts in enumerate(statements) if any(assignment.match(part) for part in parts)]
        if assigned:
            raise ValueError(f"APDL deck: parameter {name!r} is also assigned with '{apdl} = …' on line(s) {assigned}; define it only by one *SET line")
        redefined = [(number + 1, m.group(1).upper()) for number, parts in enumerate(statements) for part in parts if (m := defining.match(part))]
        if redefined:
            raise ValueError(
                f"APDL deck: parameter {name!r} is also defined by {redefined[0][1]} on line(s) {[n for n, _ in redefined]}; "
                f"define it only by one *SET line"
            )
        number = hits[0]
        body = lines[number].rstrip("\r\n")
        ending = lines[number][len(body) :]
        match = re.fullmatch(rf"(\s*\*SET\s*,\s*)({name_pattern})(\s*,\s*)([^,!$]*?)(\s*)((?:!.*)?)", body, re.IGNORECASE | re.DOTALL)
        if match is None or len(statements[number]) > 1:
            raise ValueError(
                f"APDL deck, line {number + 1}: the *SET line of parameter {name!r} must hold one value, on a line of its own "
                f"(no further values, no '$' separators; a '!' comment is fine), got {body.strip()!r}"
            )
        prefix, deck_name, separator, _, spacing, comment = match.groups()
        replacements[number] = (
            f"{prefix}{safe}{separator}{value!r}   ! nlupdate parameter {_comment_text(name)}\n"
            f"{prefix}{deck_name}{separator}{safe}{spacing}{comment}{ending or ''}"
        )
    return "".join(replacements.get(number, line) for number, line in enumerate(lines))


def modal_block(n_modes: int, coordinates: Sequence[tuple[int | str, str]], min_frequency_hz: float | None = None) -> str:
    """The APDL block appended to the user's deck (documented in the module docstring).

    coordinates: ``(node number or APDL expression in deck units, "ux"|"uy"|"uz")``.
    min_frequency_hz: FREQB of MODOPT (Hz), None for MAPDL's default.
    """
    freqb = "" if min_frequency_hz is None else repr(float(min_frequency_hz))
    m = len(coordinates)
    out = [
        "! ---- nlupdate modal block (generated) ----",
        "FINISH",
        "/SOLU",
        "ANTYPE,MODAL",
        f"MODOPT,LANB,{n_modes},{freqb},,,OFF",
        f"MXPAND,{n_modes}",
        "ALLSEL,ALL",
        "SOLVE",
        "FINISH",
        "/POST1",
        "ALLSEL,ALL",
        "CSYS,0",
        "DSYS,0",
        "RSYS,0",
        "*GET,NLU_NEL,ELEM,0,COUNT",
        "*GET,NLU_NSET,ACTIVE,0,SET,NSET",
        "NLU_NM=NLU_NSET",
        f"*IF,NLU_NM,GT,{n_modes},THEN",
        f"NLU_NM={n_modes}",
        "*ENDIF",
    ]
    for c, (node, _) in enumerate(coordinates, start=1):
        out.append(f"NLU_N{c}={node}")
        out += [f"*GET,NLU_{axis}{c},NODE,NLU_N{c},LOC,{axis}" for axis in "XYZ"]
    out.append(f"*DIM,NLU_FRQ,ARRAY,{n_modes}")
    out += [f"*DIM,NLU_U{c},ARRAY,{n_modes}" for c in range(1, m + 1)]
    out += ["*DO,NLU_I,1,NLU_NM", "SET,1,NLU_I", "*GET,NLU_FRQ(NLU_I),ACTIVE,0,SET,FREQ"]
    out += [f"*GET,NLU_U{c}(NLU_I),NODE,NLU_N{c},U,{_AXES[direction]}" for c, (_, direction) in enumerate(coordinates, start=1)]
    out.append("*ENDDO")
    out += [
        f"*CFOPEN,{Path(TABLE_NAME).stem},{Path(TABLE_NAME).suffix[1:]}",
        "*VWRITE",
        f"('{TABLE_TITLE}')",
        "*VWRITE,NLU_NEL",
        "('ELEMENTS',1X,F12.0)",
        "*VWRITE,NLU_NSET",
        "('MODES',1X,F12.0)",
        "*VWRITE",
        "('FREQUENCIES')",
        "*VWRITE,SEQU,NLU_FRQ(1)",
        _ROW_FORMAT,
    ]
    for c in range(1, m + 1):
        out += ["*VWRITE", f"('COORDINATE {c}')", f"*VWRITE,NLU_N{c},NLU_X{c},NLU_Y{c},NLU_Z{c}", _NODE_FORMAT]
        out += [f"*VWRITE,SEQU,NLU_U{c}(1)", _ROW_FORMAT]
    out += ["*CFCLOS", "FINISH"]
    return "\n".join(out) + "\n"


@dataclass(frozen=True, eq=False)
class ModalTable:
    """Contents of ``modal_table.txt``, in the deck's units.

    frequencies_hz: (n_modes,), Hz. shapes: (n_coordinates, n_modes), mass-normalised in
    1/√(deck mass unit). elements: element count. modes_found: data sets on the result
    file. nodes: the node of each coordinate. locations: (n_coordinates, 3), global
    Cartesian, deck length unit.
    """

    frequencies_hz: np.ndarray
    shapes: np.ndarray
    elements: int
    modes_found: int
    nodes: tuple[int, ...]
    locations: np.ndarray


def parse_modal_table(text: str, n_modes: int, n_coordinates: int, source: str = TABLE_NAME) -> ModalTable:
    """Read the table the block writes (layout in the module docstring).

    Raises ValueError naming ``source``, the line and the expected form.
    """
    lines = [(number, line.strip()) for number, line in enumerate(text.splitlines(), start=1) if line.strip()]
    expected_lines = 4 + n_modes + n_coordinates * (2 + n_modes)
    position = 0

    def next_line(what: str) -> tuple[int, str]:
        if position >= len(lines):
            raise ValueError(f"{source}: ends after {len(text.splitlines())} lines; expected {what} next ({expected_lines} non-blank lines in all)")
        return lines[position]

    def take_title(title: str) -> None:
        nonlocal position
        number, line = next_line(repr(title))
        if line != title:
            raise ValueError(f"{source}, line {number}: expected {title!r}, got {line!r}")
        position += 1

    def take_fields(label: str, count: int, form: str) -> tuple[int, list[float]]:
        nonlocal position
        number, line = next_line(repr(form))
        fields = line.split()
        try:
            if len(fields) != count + 1 or fields[0] != label:
                raise ValueError
            values = [fortran_float(field) for field in fields[1:]]
        except ValueError:
            raise ValueError(f"{source}, line {number}: expected {form!r}, got {line!r}") from None
        position += 1
        return number, values

    def take_count(label: str) -> int:
        number, (value,) = take_fields(label, 1, f"{label} <count>.")
        if value != int(value) or value < 0:
            raise ValueError(f"{source}, line {number}: {label.lower()} count {value!r} is not a non-negative whole number")
        return int(value)

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
    elements = take_count("ELEMENTS")
    modes_found = take_count("MODES")
    take_title("FREQUENCIES")
    frequencies = take_rows("FREQUENCIES")
    shapes = np.empty((n_coordinates, n_modes))
    locations = np.empty((n_coordinates, 3))
    nodes = []
    for c in range(1, n_coordinates + 1):
        take_title(f"COORDINATE {c}")
        number, (node, *location) = take_fields("NODE", 4, "NODE <node>. <x> <y> <z>")
        if node != int(node) or node < 1:
            raise ValueError(
                f"{source}, line {number}: coordinate {c} has node {node!r}: no node was found (NODE() with no nodes "
                f"selected, or an undefined node number)"
            )
        if not np.all(np.isfinite(location)):
            raise ValueError(f"{source}, line {number}: location of node {int(node)} is not finite: {location}")
        nodes.append(int(node))
        locations[c - 1] = location
        shapes[c - 1] = take_rows(f"COORDINATE {c}")
    if position != len(lines):
        number, line = lines[position]
        raise ValueError(f"{source}, line {number}: unexpected content after the last coordinate section: {line!r}")
    return ModalTable(frequencies, shapes, elements, modes_found, tuple(nodes), locations)


def check_modes(frequencies_hz: np.ndarray, modes_found: int, n_modes: int) -> None:
    """ValueError unless exactly ``n_modes`` modes were found with finite, positive,
    ascending frequencies (Hz; ascending within :data:`FREQUENCY_ORDER_RTOL`)."""
    if modes_found != n_modes:
        if modes_found < n_modes:
            raise ValueError(
                f"MAPDL found {modes_found} of the {n_modes} requested modes (data sets on the result file). Block Lanczos "
                f"returns fewer when the model has fewer free degrees of freedom than requested (or fewer above "
                f"min_frequency_hz): request fewer modes (n_modes) or check the supports and the mesh"
            )
        raise ValueError(f"the result file holds {modes_found} data sets where {n_modes} modes were requested: does the deck solve before the generated block?")
    frequencies = np.asarray(frequencies_hz, dtype=float)
    if frequencies.shape != (n_modes,):
        raise ValueError(f"expected {n_modes} frequencies, got shape {frequencies.shape}")
    check_frequencies(frequencies, FREQUENCY_ORDER_RTOL, positive_hint="rigid-body modes of an unsupported model? set "
                      "min_frequency_hz above them, or support the model")


def requested_point(node: NodeSpec, units: DeckUnits) -> tuple[float, float, float] | None:
    """The point (m) a node spec asks for: a point itself, a literal ``NODE(x,y,z)`` (deck
    units) converted to metres, else None (node numbers, other expressions)."""
    if isinstance(node, tuple):
        return node
    if isinstance(node, str):
        match = _NODE_POINT.fullmatch(node.strip())
        if match:
            return tuple(fortran_float(v) / units.per_metre for v in match.groups())  # type: ignore[return-value]
    return None


#: The most errors :func:`find_errors` reports from one file.
MAX_ERRORS = 20


def find_errors(path: Path) -> list[tuple[int, str]]:
    """``(line, message)`` of the ``*** ERROR ***`` in a MAPDL output or error file (the
    first :data:`MAX_ERRORS`), scanned line by line with every line cut to a bounded length.

    The message is the marker line without its ``CP = … TIME= …`` stamp, followed by the
    next lines up to a blank line or the next ``***`` marker (at most 4 lines).
    """
    found: list[tuple[int, str]] = []
    collecting: list[str] | None = None
    try:
        for number, line in enumerate(log_lines(path), start=1):
            if collecting is not None:
                if not line.strip() or line.strip().startswith("***") or len(collecting) == 5:
                    found[-1] = (found[-1][0], " ".join(collecting) or "(no message text)")
                    collecting = None
                else:
                    collecting.append(line.strip())
                    continue
            if ERROR_MARKER in line and len(found) < MAX_ERRORS:
                head = re.sub(r"CP\s*=\s*\S+|TIME\s*=\s*\S+", "", line.split(ERROR_MARKER, 1)[1]).strip()
                collecting = [head] if head else []
                found.append((number, ""))
    except OSError:
        return found
    if collecting is not None:
        found[-1] = (found[-1][0], " ".join(collecting) or "(no message text)")
    return found


def error_files(run_dir: Path) -> list[Path]:
    """``out.out``, then ``job.err`` and the ``job<N>.err`` files of distributed runs."""
    errs = sorted(p for p in run_dir.iterdir() if _ERROR_FILE.fullmatch(p.name)) if run_dir.is_dir() else []
    return [run_dir / OUTPUT_NAME, *errs]


@dataclass(frozen=True)
class MapdlError:
    """The first ``*** ERROR ***`` of a run: file, line, message, and how many in all."""

    path: Path
    line: int
    message: str
    total: int
    files: tuple[str, ...]

    def describe(self, after_location: str = "") -> str:
        """``*** ERROR *** in job.err (line 3)<after_location>: 'message'`` (+ how many more)."""
        more = f" (and {self.total - 1} more error message(s) in {', '.join(self.files)})" if self.total > 1 else ""
        return f"{ERROR_MARKER} in {self.path.name} (line {self.line}){after_location}: {self.message!r}{more}"


def first_error(run_dir: Path) -> MapdlError | None:
    """The first ``*** ERROR ***`` in ``out.out``, ``job.err`` or ``job<N>.err``, or None."""
    found = [(path, line, message) for path in error_files(run_dir) for line, message in find_errors(path)]
    if not found:
        return None
    path, line, message = found[0]
    files = tuple(dict.fromkeys(p.name for p, _, _ in found))
    return MapdlError(path, line, message, len(found), files)


def remove_scratch_files(run_dir: Path) -> list[str]:
    """Delete the job's large files (:data:`SCRATCH_FILE`); return their names.

    A file that cannot be deleted (e.g. still locked on Windows) is left in place."""
    removed = []
    for path in sorted(run_dir.iterdir()):
        if path.is_file() and SCRATCH_FILE.fullmatch(path.name):
            try:
                path.unlink()
            except OSError:
                continue
            removed.append(path.name)
    return removed


class MapdlAdapter(FEAdapter):
    """Modal analysis with MAPDL batch runs (see module docstring for the contract).

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
            if not _APDL_NAME.fullmatch(apdl):
                raise ValueError(f"APDL name {apdl!r} of parameter {name!r}: expected a letter then up to 31 letters, digits or '_'")
            if apdl.upper().startswith(_RESERVED_PREFIX):
                raise ValueError(f"APDL name {apdl!r} of parameter {name!r}: names starting with {_RESERVED_PREFIX!r} are reserved for the adapter")
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
        if direction not in _AXES:
            raise ValueError(f"coordinate {name!r}: direction {direction!r} is not one of {sorted(_AXES)}")
        if isinstance(node, (tuple, list)):
            if len(node) != 3 or not all(isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool) and np.isfinite(v) for v in node):
                raise ValueError(f"coordinate {name!r}: a point must be three finite numbers (x, y, z) in metres, got {node!r}")
            return (tuple(float(v) for v in node), direction)  # type: ignore[return-value]
        if isinstance(node, bool) or not (isinstance(node, (int, np.integer)) and node >= 1 or isinstance(node, str) and node.strip()):
            raise ValueError(f"coordinate {name!r}: node must be a positive node number, an APDL expression or a point (x, y, z) in metres, got {node!r}")
        if isinstance(node, str) and not _single_expression(node):
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


def _single_expression(text: str) -> bool:
    """True when ``text`` can stand alone after ``NAME=``: no statement separator, comment,
    line break, or comma outside parentheses (which would assign several values)."""
    if any(ch in text for ch in "$!\r\n"):
        return False
    depth = 0
    for ch in text:
        depth += ch == "("
        depth -= ch == ")"
        if depth < 0 or (ch == "," and depth == 0):
            return False
    return depth == 0


def _format_point(point: Sequence[float] | np.ndarray) -> str:
    return "(" + ", ".join(f"{float(v):.6g}" for v in point) + ")"


def from_options(model: str | None, options: dict) -> MapdlAdapter:
    """The adapter of a study's ``[adapter] kind = "mapdl"`` (:mod:`nlupdate.adapters.registry`)."""
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
