"""The APDL block appended to the deck, and the modal table it writes.

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
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from nlupdate.fe.adapters.base import check_frequencies
from nlupdate.fe.adapters.calculix import fortran_float

TABLE_NAME = "modal_table.txt"
TABLE_TITLE = "NLUPDATE MODAL TABLE"
AXES = {"ux": "X", "uy": "Y", "uz": "Z"}
#: Relative slack of the "ascending frequencies" check: the precision of the table the
#: generated block writes (E24.16), so repeated roots a last digit apart pass.
FREQUENCY_ORDER_RTOL = 1e-9
_ROW_FORMAT = "(F8.0,1X,E24.16)"
_NODE_FORMAT = "('NODE',1X,F12.0,1X,E24.16,1X,E24.16,1X,E24.16)"


def modal_block(n_modes: int, coordinates: Sequence[tuple[int | str, str]], min_frequency_hz: float | None = None) -> str:
    """The APDL block appended to the user's deck (this module's docstring).

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
    out += [f"*GET,NLU_U{c}(NLU_I),NODE,NLU_N{c},U,{AXES[direction]}" for c, (_, direction) in enumerate(coordinates, start=1)]
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
    """Read the table the block writes (layout: this module's docstring).

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
