"""MAPDL adapter: deck generation, table parser and process handling (with a fake MAPDL).

MAPDL is not installed here. The appended block and the parser are checked against
hand-written text (below, and the deck and output files in tests/data/mapdl/); process
handling runs a fake ``mapdl`` (a Python script written into tmp_path) through the same
runner as CalculiX. The fake interprets the few APDL commands whose semantics the
adapter relies on — ``*SET`` and ``NAME=value``, ``N``, ``LOCAL`` (rotation about Z),
``CSYS``, the selection commands before ``SOLVE``, ``NODE(x,y,z)`` and
``*GET,…,NODE,n,LOC,…`` — and returns results of two models with hand-derivable
answers.
"""
from __future__ import annotations

import dataclasses
import math
import re
import stat
import sys
import textwrap
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest
from patience import HANG_S, timed_out_once_ready

from nlupdate.fe.adapters.base import AdapterError
from nlupdate.fe.adapters.mapdl import MAPDL_EXEC_ENV, MapdlAdapter
from nlupdate.fe.adapters.mapdl_block import check_modes, modal_block, parse_modal_table
from nlupdate.fe.adapters.mapdl_deck import substitute_parameters
from nlupdate.fe.adapters.runner import ExecutableNotFoundError, RunTimeoutError

DATA = Path(__file__).parent / "data" / "mapdl"
COORDINATES = {"tip:uz": (101, "uz"), "mid:uy": ("NODE(0.215,0,0)", "uy")}

# The block for 3 modes and COORDINATES, written by hand from nlupdate.fe.adapters.mapdl_block's docstring.
EXPECTED_BLOCK = """\
! ---- nlupdate modal block (generated) ----
FINISH
/SOLU
ANTYPE,MODAL
MODOPT,LANB,3,,,,OFF
MXPAND,3
ALLSEL,ALL
SOLVE
FINISH
/POST1
ALLSEL,ALL
CSYS,0
DSYS,0
RSYS,0
*GET,NLU_NEL,ELEM,0,COUNT
*GET,NLU_NSET,ACTIVE,0,SET,NSET
NLU_NM=NLU_NSET
*IF,NLU_NM,GT,3,THEN
NLU_NM=3
*ENDIF
NLU_N1=101
*GET,NLU_X1,NODE,NLU_N1,LOC,X
*GET,NLU_Y1,NODE,NLU_N1,LOC,Y
*GET,NLU_Z1,NODE,NLU_N1,LOC,Z
NLU_N2=NODE(0.215,0,0)
*GET,NLU_X2,NODE,NLU_N2,LOC,X
*GET,NLU_Y2,NODE,NLU_N2,LOC,Y
*GET,NLU_Z2,NODE,NLU_N2,LOC,Z
*DIM,NLU_FRQ,ARRAY,3
*DIM,NLU_U1,ARRAY,3
*DIM,NLU_U2,ARRAY,3
*DO,NLU_I,1,NLU_NM
SET,1,NLU_I
*GET,NLU_FRQ(NLU_I),ACTIVE,0,SET,FREQ
*GET,NLU_U1(NLU_I),NODE,NLU_N1,U,Z
*GET,NLU_U2(NLU_I),NODE,NLU_N2,U,Y
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
*VWRITE
('COORDINATE 1')
*VWRITE,NLU_N1,NLU_X1,NLU_Y1,NLU_Z1
('NODE',1X,F12.0,1X,E24.16,1X,E24.16,1X,E24.16)
*VWRITE,SEQU,NLU_U1(1)
(F8.0,1X,E24.16)
*VWRITE
('COORDINATE 2')
*VWRITE,NLU_N2,NLU_X2,NLU_Y2,NLU_Z2
('NODE',1X,F12.0,1X,E24.16,1X,E24.16,1X,E24.16)
*VWRITE,SEQU,NLU_U2(1)
(F8.0,1X,E24.16)
*CFCLOS
FINISH
"""

# A table as the block writes it (3 modes, 2 coordinates), written by hand.
TABLE = """\
NLUPDATE MODAL TABLE
ELEMENTS         336.
MODES              3.
FREQUENCIES
      1.   0.4648000000000000E+02
      2.   0.1980500000000000E+03
      3.   0.2660000000000000E+03
COORDINATE 1
NODE         101.   0.4300000000000000E+00   0.0000000000000000E+00   0.4000000000000000E-02
      1.   0.2756000000000000E+01
      2.  -0.1176000000000000E+01
      3.   0.2388000000000000E+01
COORDINATE 2
NODE          51.   0.2150000000000000E+00  -0.1000000000000000-100   0.0000000000000000E+00
      1.   0.1234500000000000E-99
      2.  -0.5000000000000000-100
      3.  -0.7500000000000000E+00
"""


def table_with(replacements: dict[int, str | None]) -> str:
    """TABLE with line ``number`` (1-based) replaced, or dropped when None."""
    lines = TABLE.splitlines()
    out = [replacements.get(n, line) for n, line in enumerate(lines, start=1)]
    return "\n".join(line for line in out if line is not None) + "\n"


# --------------------------------------------------------------------------- deck generation


def test_modal_block_is_exactly_the_documented_one() -> None:
    assert modal_block(3, list(COORDINATES.values())) == EXPECTED_BLOCK
    assert "MODOPT,LANB,3,12.5,,,OFF\n" in modal_block(3, list(COORDINATES.values()), min_frequency_hz=12.5)


def test_input_deck_sets_parameters_through_safe_names_and_appends_block(tmp_path: Path) -> None:
    deck = (DATA / "tbeam_parametric.inp").read_text()
    adapter = MapdlAdapter(deck, ["E", "h1", "h2"], COORDINATES, n_modes=3, executable="unused", work_root=tmp_path)
    expected = (
        deck.replace(
            "*SET,E,2.1e11        ! Young's modulus (Pa)\n",
            "*SET,NLU_P1,190000000000.0   ! nlupdate parameter E\n*SET,E,NLU_P1        ! Young's modulus (Pa)\n",
        )
        .replace("*SET,h1,0.008\n", "*SET,NLU_P2,0.0079   ! nlupdate parameter h1\n*SET,h1,NLU_P2\n")
        .replace("*SET , h2 , 0.0015\n", "*SET , NLU_P3 , 0.00155   ! nlupdate parameter h2\n*SET , h2 , NLU_P3\n")
    )
    assert expected != deck
    assert adapter.input_deck({"E": 190e9, "h1": 0.0079, "h2": 0.00155}) == expected + EXPECTED_BLOCK


def _apdl_parameters(deck: str) -> dict[str, float]:
    """Scalar parameters a deck defines by *SET and NAME=value (numbers or names), in order."""
    values: dict[str, float] = {}
    for line in deck.splitlines():
        for statement in line.split("!", 1)[0].split("$"):
            statement = statement.strip()
            match = re.fullmatch(r"\*SET\s*,\s*(\w+)\s*,\s*([^,]*)", statement, re.I) or re.fullmatch(r"(\w+)\s*=\s*([^,]*)", statement)
            if not match:
                continue
            name, text = match.group(1).upper(), match.group(2).strip()
            try:
                values[name] = float(text)
            except ValueError:
                if text.upper() in values:
                    values[name] = values[text.upper()]
    return values


def test_generated_set_names_are_safe_and_the_deck_names_get_the_values(tmp_path: Path) -> None:
    """'E' is also an APDL command: the adapter's own *SET names are NLU_P<i>, and the deck's
    *SET,E line reads its value from there (project names need not be APDL names)."""
    deck = (DATA / "tbeam_parametric.inp").read_text()
    adapter = MapdlAdapter(
        deck, ["E", "flange thickness", "density"], COORDINATES, n_modes=3, apdl_names={"flange thickness": "h1", "density": "RHO"}, work_root=tmp_path
    )
    generated = adapter.input_deck({"E": 190e9, "flange thickness": 0.0079, "density": 7800.0})
    new_lines = [line for line in generated.splitlines() if line not in deck.splitlines()]
    defined = []
    for line in new_lines:
        for statement in line.split("!", 1)[0].split("$"):
            statement = statement.strip()
            match = re.match(r"\*(?:SET|GET|DIM|DO)\s*,\s*(\w+)", statement, re.I) or re.match(r"(\w+)\s*=", statement)
            if match and not re.fullmatch(r"\*SET\s*,\s*(E|h1|rho)\s*,\s*NLU_P\d", statement, re.I):
                defined.append(match.group(1))
    assert defined and all(re.fullmatch(r"NLU_[A-Z0-9_]{1,28}", name) for name in defined), defined
    assert {"NLU_P1", "NLU_P2", "NLU_P3"} <= set(defined)
    values = _apdl_parameters(generated)
    assert values["E"] == 190e9 and values["H1"] == 0.0079 and values["RHO"] == 7800.0
    assert values["NU"] == 0.3 and values["H2"] == 0.0015  # untouched
    assert "*set,NLU_P3,7800.0   ! nlupdate parameter density\n*set,rho,NLU_P3        ! lower-case command" in generated
    assert "! nlupdate parameter flange_thickness" in generated


def test_substitution_is_case_insensitive_and_maps_apdl_names() -> None:
    deck = (DATA / "tbeam_parametric.inp").read_text()
    out = substitute_parameters(deck, {"density": 7800.0, "nu": 0.29}, {"density": "RHO"})
    assert "*set,NLU_P1,7800.0   ! nlupdate parameter density\n*set,rho,NLU_P1        ! lower-case command" in out
    assert "*SET,NLU_P2,0.29   ! nlupdate parameter nu\n*SET,NU,NLU_P2\n" in out


@pytest.mark.parametrize(
    ("deck", "message"),
    [
        ("*SET,NU,0.3\n", r"parameter 'E' has no '\*SET,E,<value>' line"),
        ("*SET,E,1\n*SET,E,2\n", r"has 2 '\*SET,E,…' lines \(lines \[1, 2\]\)"),
        ("*SET,E,1\nE = 2.1e11\n", r"also assigned with 'E = …' on line\(s\) \[2\]"),
        ("*SET,ELAST,1\n", r"parameter 'E' has no"),  # a longer name is another parameter
        ("*SET,E,1 $ *SET,NU,0.3\n", r"line 1: the \*SET line of parameter 'E' must hold one value, on a line of its own"),
        ("*SET,NU,0.3 $ *SET,E,1\n", r"line 1: the \*SET line of parameter 'E' must hold one value"),
        ("*SET,E,1,2,3\n", r"line 1: the \*SET line of parameter 'E' must hold one value"),
        ("*SET,E,1\n*SET,NU,0.3 $ E=2\n", r"also assigned with 'E = …' on line\(s\) \[2\]"),
        ("*SET,E,1\n*GET,E,NODE,1,LOC,X\n", r"also defined by \*GET on line\(s\) \[2\]"),
    ],
)
def test_bad_set_lines_are_rejected(deck: str, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        substitute_parameters(deck, {"E": 2e11})


def test_adapter_checks_its_configuration(tmp_path: Path) -> None:
    deck = "*SET,E,2e11\n"
    with pytest.raises(ValueError, match="no '\\*SET,RHO"):
        MapdlAdapter(deck, ["E", "RHO"], COORDINATES, work_root=tmp_path)
    with pytest.raises(ValueError, match="APDL name '2E'"):
        MapdlAdapter("*SET,2E,1\n", ["E"], COORDINATES, apdl_names={"E": "2E"}, work_root=tmp_path)
    with pytest.raises(ValueError, match="apdl_names: \\['G'\\] are not parameters"):
        MapdlAdapter(deck, ["E"], COORDINATES, apdl_names={"G": "G1"}, work_root=tmp_path)
    with pytest.raises(ValueError, match="direction 'rz'"):
        MapdlAdapter(deck, ["E"], {"tip:rz": (5, "rz")}, work_root=tmp_path)
    with pytest.raises(ValueError, match="positive node number"):
        MapdlAdapter(deck, ["E"], {"tip:uz": (0, "uz")}, work_root=tmp_path)
    with pytest.raises(ValueError, match="n_modes"):
        MapdlAdapter(deck, ["E"], COORDINATES, n_modes=0, work_root=tmp_path)
    with pytest.raises(ValueError, match=r"units: expected one of \['SI', 'mm-t-s', 'mm-kg-s'\], got 'mm'"):
        MapdlAdapter(deck, ["E"], COORDINATES, units="mm", work_root=tmp_path)
    with pytest.raises(ValueError, match="location_tolerance_m must be a positive distance in metres"):
        MapdlAdapter(deck, ["E"], COORDINATES, location_tolerance_m=0.0, work_root=tmp_path)
    with pytest.raises(ValueError, match=r"a point must be three finite numbers \(x, y, z\) in metres"):
        MapdlAdapter(deck, ["E"], {"p:ux": ((0.1, 0.2), "ux")}, work_root=tmp_path)
    with pytest.raises(ValueError, match="not a single APDL expression"):
        MapdlAdapter(deck, ["E"], {"p:ux": ("12 $ /CLEAR", "ux")}, work_root=tmp_path)
    with pytest.raises(ValueError, match="APDL deck, line 2: 'NLU_P1' — names starting with 'NLU_' are reserved"):
        MapdlAdapter(deck + "*SET,NLU_P1,3\n", ["E"], COORDINATES, work_root=tmp_path)
    with pytest.raises(ValueError, match="min_frequency_hz"):
        MapdlAdapter(deck, ["E"], COORDINATES, min_frequency_hz=-1.0, work_root=tmp_path)
    assert MapdlAdapter(deck, ["E"], COORDINATES, units="MM-T-S", work_root=tmp_path).units.name == "mm-t-s"


def test_units_and_options_come_from_the_study_file(tmp_path: Path) -> None:
    """[adapter.options] of a study reach the adapter: units, tolerance, keep_files, points in metres."""
    from nlupdate.study import load_study
    from nlupdate.fe.adapters.registry import build_adapter

    (tmp_path / "springs.inp").write_text(SPRING_DECKS["mm-t-s"])
    study = tmp_path / "mapdl.toml"
    study.write_text(textwrap.dedent("""
        [adapter]
        kind = "mapdl"
        [adapter.options]
        deck = "springs.inp"
        parameter_names = ["K"]
        coordinates = {m1 = [[1.0, 0.0, 0.0], "ux"], m2 = [3, "ux"]}
        n_modes = 2
        units = "mm-t-s"
        location_tolerance_m = 0.002
        keep_files = true
        [[parameters]]
        name = "K"
        start = 8.0
        lower = 1.0
        upper = 20.0
        [targets]
        frequencies_hz = [10.0]
        [eigensensitivity]
    """))
    spec = load_study(study).adapter
    adapter = build_adapter(dataclasses.replace(spec, options={**spec.options, "work_root": str(tmp_path / "runs")}))
    assert isinstance(adapter, MapdlAdapter)
    assert adapter.units.name == "mm-t-s" and adapter.location_tolerance_m == 0.002 and adapter.keep_files is True
    assert adapter.coordinates == {"m1": ((1.0, 0.0, 0.0), "ux"), "m2": (3, "ux")}
    assert "NLU_N1=NODE(1000.0,0.0,0.0)\n" in adapter.input_deck({"K": 8.0})


# --------------------------------------------------------------------------- table parser


def test_parser_reads_the_documented_table() -> None:
    table = parse_modal_table(TABLE, 3, 2)
    np.testing.assert_array_equal(table.frequencies_hz, [46.48, 198.05, 266.0])
    np.testing.assert_array_equal(table.shapes, [[2.756, -1.176, 2.388], [0.12345e-99, -0.5e-100, -0.75]])
    assert table.elements == 336 and table.modes_found == 3 and table.nodes == (101, 51)
    np.testing.assert_array_equal(table.locations, [[0.43, 0.0, 0.004], [0.215, -1e-101, 0.0]])


@pytest.mark.parametrize(
    ("text", "n_modes", "message"),
    [
        (table_with({n: None for n in range(12, 18)}), 3, r"t\.txt: section 'COORDINATE 1' ends after 2 of 3 rows"),
        (table_with({6: "      3.   0.1980500000000000E+03"}), 3, r"t\.txt, line 6: expected mode 2 in section 'FREQUENCIES', got '3\.'"),
        (table_with({6: "      2.   ************************"}), 3, r"t\.txt, line 6: expected '<mode>\. <value>'"),
        (TABLE, 2, r"line 7: expected 'COORDINATE 1', got '3\.   0\.2660000000000000E\+03'"),
        (TABLE, 4, r"line 8: expected '<mode>\. <value>' \(mode 4 of section 'FREQUENCIES'\), got 'COORDINATE 1'"),
        (table_with({3: None}), 3, r"line 3: expected 'MODES <count>\.', got 'FREQUENCIES'"),
        (table_with({9: None}), 3, r"line 9: expected 'NODE <node>\. <x> <y> <z>', got '1\.   0\.2756000000000000E\+01'"),
        (table_with({14: "NODE           0.   0.0E+00   0.0E+00   0.0E+00"}), 3, r"line 14: coordinate 2 has node 0\.0: no node was found"),
    ],
)
def test_parser_rejects_malformed_tables(text: str, n_modes: int, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        parse_modal_table(text, n_modes, 2, "t.txt")


def test_parser_rejects_extra_coordinates() -> None:
    with pytest.raises(ValueError, match="line 13: unexpected content after the last coordinate section: 'COORDINATE 2'"):
        parse_modal_table(TABLE, 3, 1, "t.txt")


def test_mode_checks() -> None:
    check_modes(np.array([10.0, 10.0 * (1 - 1e-12), 20.0]), 3, 3)  # a repeated root printed in either order
    for frequencies, found, message in [
        ([10.0, 20.0, 0.0], 2, "MAPDL found 2 of the 3 requested modes"),
        ([10.0, 20.0, 30.0], 4, "holds 4 data sets where 3 modes were requested"),
        ([10.0, 9.9, 20.0], 3, r"not ascending \(mode\(s\) \[2\] below the previous one\)"),
        ([-1e-4, 9.9, 20.0], 3, r"mode\(s\) \[1\] are not positive.*min_frequency_hz"),
        ([10.0, float("nan"), 20.0], 3, r"mode\(s\) \[2\] are not finite"),
    ]:
        with pytest.raises(ValueError, match=message):
            check_modes(np.array(frequencies), found, 3)


# --------------------------------------------------------------------------- fake MAPDL runs


FAKE_MAPDL = r'''
import math, os, re, shutil, sys, time
args = sys.argv[1:]
open("argv.txt", "w").write("\n".join(args))
deck = open(args[args.index("-i") + 1]).read()
out = args[args.index("-o") + 1]
job = args[args.index("-j") + 1]
behaviour = os.environ.get("FAKE_MAPDL_BEHAVIOUR", "ok")
model = os.environ.get("FAKE_MAPDL_MODEL", "beam")
print("fake MAPDL launcher", behaviour, flush=True)
if behaviour == "hang":
    time.sleep(600)
if behaviour == "exit8":
    open(out, "w").write(" *** ERROR ***  license checkout failed\n")
    sys.exit(8)
if behaviour == "error0":
    shutil.copy(os.path.join(DATA, "out_with_error.out"), out)
    sys.exit(0)
together = os.environ.get("FAKE_MAPDL_TOGETHER")  # "<folder>:<n>": wait until n runs have started
if together:
    folder, n = together.rsplit(":", 1)
    open(os.path.join(folder, str(os.getpid())), "w").close()
    patience = time.monotonic() + HANG_S
    while len(os.listdir(folder)) < int(n):
        if time.monotonic() > patience:
            sys.exit(f"the {n} runs were not in flight together")
        time.sleep(0.01)

# ---- a tiny APDL interpreter: the state the adapter's block depends on
params, nodes, systems = {}, {}, {0: (0.0, (0.0, 0.0, 0.0))}
csys, all_selected, solved_all, in_post1 = 0, True, None, False
n_modes, coordinate_nodes = None, {}
if not re.search(r"^\s*N\s*,", deck, re.M | re.I):  # a meshed deck: nodes 1..101 along X, 4.3 mm apart
    nodes = {n: (0.0043 * (n - 1), 0.0, 0.0) for n in range(1, 102)}

def value(token):
    token = token.strip()
    if not token:
        return 0.0
    try:
        return float(token)
    except ValueError:
        if token.upper() in params:
            return params[token.upper()]
        sys.exit("fake MAPDL cannot evaluate " + repr(token))

def to_global(point, system):
    angle, origin = systems[system]
    c, s = math.cos(math.radians(angle)), math.sin(math.radians(angle))
    x, y, z = point
    return (origin[0] + c * x - s * y, origin[1] + s * x + c * y, origin[2] + z)

def to_local(point, system):
    angle, origin = systems[system]
    c, s = math.cos(math.radians(angle)), math.sin(math.radians(angle))
    x, y, z = (point[i] - origin[i] for i in range(3))
    return (c * x + s * y, -s * x + c * y, z)

def nearest_node(point):
    target = to_global(point, csys)
    return min(sorted(nodes), key=lambda n: math.dist(nodes[n], target))

for raw in deck.splitlines():
    for statement in raw.split("!", 1)[0].split("$"):
        statement = statement.strip()
        if not statement:
            continue
        assignment = re.fullmatch(r"([A-Za-z]\w*)\s*=\s*(.+)", statement)
        if assignment:
            name, expression = assignment.group(1).upper(), assignment.group(2).strip()
            point = re.fullmatch(r"NODE\((.*)\)", expression, re.I)
            if point:
                params[name] = nearest_node([value(v) for v in point.group(1).split(",")])
            elif re.fullmatch(r"NLU_N\d+", name):
                params[name] = value(expression)
            if re.fullmatch(r"NLU_N\d+", name):
                coordinate_nodes[int(name[5:])] = int(params[name])
            continue
        fields = [f.strip() for f in statement.split(",")]
        command = fields[0].upper()
        if command == "*SET":
            params[fields[1].upper()] = value(fields[2])
        elif command == "N":
            fields += [""] * 5
            nodes[int(value(fields[1]))] = to_global([value(v) for v in fields[2:5]], csys)
        elif command == "LOCAL":
            fields += [""] * 9
            assert fields[2] in ("", "0") and all(value(v) == 0 for v in fields[7:9]), "fake: only Cartesian systems rotated about Z"
            systems[int(value(fields[1]))] = (value(fields[6]), tuple(value(v) for v in fields[3:6]))
        elif command == "CSYS":
            if not (in_post1 and behaviour == "stuck_csys"):  # this one stays in the deck's system
                csys = int(value(fields[1])) if len(fields) > 1 else 0
        elif command == "ALLSEL":
            all_selected = True
        elif command in ("NSEL", "ESEL"):
            all_selected = len(fields) > 1 and fields[1].upper() == "ALL"
        elif command == "SOLVE":
            solved_all = all_selected
        elif command == "/POST1":
            in_post1 = True
        elif command == "MODOPT":
            n_modes = int(fields[2])
        elif command == "*GET" and fields[2].upper() == "NODE" and fields[4].upper() == "LOC":
            location = to_local(nodes[int(value(fields[3]))], csys)
            params[fields[1].upper()] = location["XYZ".index(fields[5].upper())]

directions = {int(c): axis for c, axis in re.findall(r"^\*GET,NLU_U(\d+)\(NLU_I\),NODE,NLU_N\d+,U,([XYZ])$", deck, re.M)}
assert sorted(directions) == sorted(coordinate_nodes) == list(range(1, len(directions) + 1))

# ---- the models, in the deck's units
if model == "beam":
    # f_i = 46.48 i sqrt(E / 210 GPa); shape of coordinate c in mode i: c + i/10
    frequencies = [46.48 * i * (params["E"] / 2.1e11) ** 0.5 for i in range(1, n_modes + 1)]
    shapes = {c: [c + i / 10 for i in range(1, n_modes + 1)] for c in directions}
    if not solved_all:  # only the selected part was solved: another model
        frequencies = [2 * f for f in frequencies]
else:
    # two masses M at nodes 2 and 3, springs K ground-2, 2-3, 3-ground along X
    import numpy as np
    m, k = params["M"], params["K"]
    w2, v = np.linalg.eigh(np.array([[2 * k, -k], [-k, 2 * k]]) / m)
    phi = v / math.sqrt(m)  # mass-normalised in the deck's units
    phi = phi * np.sign(phi[0])
    frequencies = list(np.sqrt(w2) / (2 * math.pi))
    dof = {2: 0, 3: 1}
    shapes = {c: list(phi[dof[coordinate_nodes[c]]]) if directions[c] == "X" and coordinate_nodes[c] in dof else [0.0] * n_modes for c in directions}
found = n_modes
if behaviour == "fewer_modes":
    found = n_modes - 1
    frequencies[found:] = [0.0] * (n_modes - found)
    for c in shapes:
        shapes[c][found:] = [0.0] * (n_modes - found)
elif behaviour == "descending":
    frequencies = frequencies[::-1]
elif behaviour == "negative":
    frequencies[0] = -1.5e-3
elif behaviour == "nan":
    frequencies[1] = float("nan")

rows = ["NLUPDATE MODAL TABLE", "ELEMENTS {:11.0f}.".format(336), "MODES {:11.0f}.".format(found), "FREQUENCIES"]
rows += ["{:7d}. {:24.16E}".format(i, f) for i, f in enumerate(frequencies, start=1)]
for c in sorted(directions):
    rows.append("COORDINATE {}".format(c))
    location = [params["NLU_{}{}".format(axis, c)] for axis in "XYZ"]
    rows.append("NODE {:11.0f}. {:24.16E} {:24.16E} {:24.16E}".format(coordinate_nodes[c], *location))
    rows += ["{:7d}. {:24.16E}".format(i, u) for i, u in enumerate(shapes[c], start=1)]
if behaviour != "no_table":
    open("modal_table.txt", "w").write("\n".join(rows) + "\n")
shutil.copy(os.path.join(DATA, "out_ok.out"), out)
# what MAPDL leaves in its working directory: an error file, a log, and large binaries
err = " *** WARNING ***                         CP =       0.250   TIME= 10:15:01\n Coefficient ratio exceeds 1.0e8 - Check results.\n"
if behaviour.startswith("err_file_only"):
    err += "\n *** ERROR ***                           CP =       0.312   TIME= 10:15:02\n Material 1 has no density (DENS); the mass matrix is singular.\n"
open(job + ".err", "w").write(err)
open(job + ".log", "w").write("/BATCH\n")
for extension in ("rst", "full", "mode", "esav", "emat", "db", "page", "osav", "ldhi", "LN22", "r001"):
    open(job + "." + extension, "wb").write(b"\0" * 4096)
open(job + "0.rst", "wb").write(b"\0" * 4096)
if behaviour == "err_file_only_exit8":
    sys.exit(8)
'''

SPRING_DECKS = {
    # Two masses M, three springs K (ground-1-2-ground) along X, nodes 1 m apart.
    units: textwrap.dedent(f"""\
        ! two-mass spring chain, {units}
        /PREP7
        *SET,M,{mass}          ! each mass ({mass_unit})
        *SET,K,{stiffness}     ! each spring ({stiffness_unit})
        ET,1,MASS21
        ET,2,COMBIN14
        N,1,0,0,0
        N,2,{length},0,0
        N,3,{2 * length},0,0
        N,4,{3 * length},0,0
        """)
    for units, mass, mass_unit, stiffness, stiffness_unit, length in [
        ("SI", 2.0, "kg", 8000.0, "N/m", 1.0),
        ("mm-t-s", 0.002, "t", 8.0, "N/mm", 1000.0),
        ("mm-kg-s", 2.0, "kg", 8000.0, "mN/mm", 1000.0),
    ]
}
SPRING_K = {"SI": 8000.0, "mm-t-s": 8.0, "mm-kg-s": 8000.0}
SPRING_POINTS = {"m1:ux": ((1.0, 0.0, 0.0), "ux"), "m2:ux": ((2.0, 0.0, 0.0), "ux")}

# A beam of five nodes along X whose deck leaves a local system (rotated 90° about Z) active.
ROTATED_CSYS_DECK = """\
/PREP7
*SET,E,2.1e11
ET,1,BEAM188
N,1,0,0,0
N,2,0.1,0,0
N,3,0.2,0,0
N,4,0.3,0,0
N,5,0.4,0,0
LOCAL,11,0,0,0,0,90      ! local Cartesian system rotated 90 degrees about Z
CSYS,11                  ! ... and left active
"""


@pytest.fixture
def fake_mapdl(tmp_path: Path) -> Path:
    script = tmp_path / "bin" / "mapdl"
    script.parent.mkdir()
    script.write_text(f"#!{sys.executable}\nDATA = {str(DATA)!r}\nHANG_S = {HANG_S}\n" + textwrap.dedent(FAKE_MAPDL))
    script.chmod(script.stat().st_mode | stat.S_IXUSR)
    return script


def make_adapter(tmp_path: Path, executable: str | None, **options) -> MapdlAdapter:
    return MapdlAdapter((DATA / "tbeam_parametric.inp").read_text(), ["E", "h1"], COORDINATES, n_modes=3,
                        executable=executable, work_root=tmp_path / "runs", **options)


def only_run_dir(tmp_path: Path) -> Path:
    (run_dir,) = (tmp_path / "runs").iterdir()
    return run_dir


def test_fake_run_parses_results_and_uses_substituted_values(tmp_path: Path, fake_mapdl: Path) -> None:
    adapter = make_adapter(tmp_path, str(fake_mapdl), n_processors=2)
    result = adapter.evaluate({"E": 190e9})
    np.testing.assert_allclose(result.natural_frequencies_hz, 46.48 * np.arange(1, 4) * np.sqrt(190e9 / 210e9), rtol=1e-15)
    np.testing.assert_allclose(result.mode_shapes, [[1.1, 1.2, 1.3], [2.1, 2.2, 2.3]], rtol=1e-15)
    assert result.coordinates == ("tip:uz", "mid:uy")
    meta = result.metadata
    assert meta["solver"] == "mapdl" and meta["mesh_size"] == 336 and meta["units"] == "SI"
    # the fake's default mesh: nodes 1..101 at x = 4.3 mm·(n − 1); NODE(0.215,0,0) is node 51
    assert meta["nodes"] == {"tip:uz": 101, "mid:uy": 51}
    np.testing.assert_allclose(meta["node_locations_m"]["mid:uy"], (0.215, 0.0, 0.0), atol=1e-15)
    assert meta["node_distances_m"]["tip:uz"] is None and meta["node_distances_m"]["mid:uy"] < 1e-15
    run_dir = Path(meta["run_dir"])
    assert meta["log_path"] == str(run_dir / "out.out")
    assert (run_dir / "argv.txt").read_text().split() == ["-b", "-i", "in.inp", "-o", "out.out", "-j", "job", "-np", "2"]
    assert "*SET,NLU_P1,190000000000.0   ! nlupdate parameter E\n*SET,E,NLU_P1" in (run_dir / "in.inp").read_text()
    assert adapter.key({"E": 190e9}) == adapter.key({"E": 190.0e9}) != adapter.key({"E": 191e9})


def test_executable_from_environment(tmp_path: Path, fake_mapdl: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(MAPDL_EXEC_ENV, str(fake_mapdl))
    result = make_adapter(tmp_path, None).evaluate({"E": 210e9})
    assert result.natural_frequencies_hz[0] == pytest.approx(46.48)


def test_missing_executable_says_how_to_configure(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(MAPDL_EXEC_ENV, raising=False)
    with pytest.raises(ExecutableNotFoundError, match=rf"`executable`.*{MAPDL_EXEC_ENV}"):
        make_adapter(tmp_path, None).evaluate({"E": 210e9})
    monkeypatch.setenv(MAPDL_EXEC_ENV, str(tmp_path / "nowhere" / "ansys241"))
    with pytest.raises(ExecutableNotFoundError, match=rf"does not exist.*{MAPDL_EXEC_ENV}"):
        make_adapter(tmp_path, None).evaluate({"E": 210e9})


def test_error_in_output_with_exit_zero_fails(tmp_path: Path, fake_mapdl: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("FAKE_MAPDL_BEHAVIOUR", "error0")
    with pytest.raises(AdapterError) as info:
        make_adapter(tmp_path, str(fake_mapdl)).evaluate({"E": 210e9})
    message = str(info.value)
    run_dir = only_run_dir(tmp_path)
    assert r"*** ERROR *** in out.out (line 10) although it exited with code 0" in message
    assert f"run directory: {run_dir}" in message and f"log: {run_dir / 'out.out'}" in message
    assert "'Element type 1 is not defined.  The VMESH command is ignored.'" in message


def test_error_only_in_err_file_fails_with_exit_zero(tmp_path: Path, fake_mapdl: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A deck with /OUTPUT hides errors from out.out; MAPDL still writes them to job.err."""
    monkeypatch.setenv("FAKE_MAPDL_BEHAVIOUR", "err_file_only")
    with pytest.raises(AdapterError) as info:
        make_adapter(tmp_path, str(fake_mapdl)).evaluate({"E": 210e9})
    message = str(info.value)
    run_dir = only_run_dir(tmp_path)
    assert (
        "MAPDL reported *** ERROR *** in job.err (line 4) although it exited with code 0: "
        "'Material 1 has no density (DENS); the mass matrix is singular.'"
    ) in message
    assert f"run directory: {run_dir}" in message and f"log: {run_dir / 'job.err'}" in message
    assert (run_dir / "job.rst").exists(), "a failed run keeps its files"


def test_error_in_err_file_is_quoted_when_mapdl_exits_nonzero(tmp_path: Path, fake_mapdl: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("FAKE_MAPDL_BEHAVIOUR", "err_file_only_exit8")
    with pytest.raises(AdapterError) as info:
        make_adapter(tmp_path, str(fake_mapdl)).evaluate({"E": 210e9})
    message = str(info.value)
    run_dir = only_run_dir(tmp_path)
    assert message.startswith("MAPDL failed: mapdl exited with code 8")
    assert "; *** ERROR *** in job.err (line 4): 'Material 1 has no density (DENS); the mass matrix is singular.'" in message
    assert f"run directory: {run_dir}" in message


def test_nonzero_exit_fails_naming_out_file(tmp_path: Path, fake_mapdl: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("FAKE_MAPDL_BEHAVIOUR", "exit8")
    with pytest.raises(AdapterError, match="MAPDL failed: mapdl exited with code 8") as info:
        make_adapter(tmp_path, str(fake_mapdl)).evaluate({"E": 210e9})
    run_dir = only_run_dir(tmp_path)
    assert f"log: {run_dir / 'out.out'}" in str(info.value) and "license checkout failed" in str(info.value)
    assert f"launcher log: {run_dir / 'mapdl.log'}" in str(info.value)


def test_missing_table_fails(tmp_path: Path, fake_mapdl: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("FAKE_MAPDL_BEHAVIOUR", "no_table")
    with pytest.raises(AdapterError, match="without writing modal_table.txt"):
        make_adapter(tmp_path, str(fake_mapdl)).evaluate({"E": 210e9})


@pytest.mark.parametrize(
    ("behaviour", "message"),
    [
        ("fewer_modes", r"implausible MAPDL modes in .*modal_table\.txt: MAPDL found 2 of the 3 requested modes"),
        ("descending", r"frequencies are not ascending \(mode\(s\) \[2, 3\] below the previous one\)"),
        ("negative", r"frequencies of mode\(s\) \[1\] are not positive: \[-0\.0015, "),
        ("nan", r"could not read the MAPDL modal table: .*modal_table\.txt, line 6: value 'NAN' is not finite"),
    ],
)
def test_implausible_modes_fail(tmp_path: Path, fake_mapdl: Path, monkeypatch: pytest.MonkeyPatch, behaviour: str, message: str) -> None:
    monkeypatch.setenv("FAKE_MAPDL_BEHAVIOUR", behaviour)
    with pytest.raises(AdapterError, match=message) as info:
        make_adapter(tmp_path, str(fake_mapdl)).evaluate({"E": 210e9})
    assert f"run directory: {only_run_dir(tmp_path)}" in str(info.value)


def test_solve_does_not_depend_on_the_decks_last_selection(tmp_path: Path, fake_mapdl: Path) -> None:
    """The deck ends with its support nodes selected; the fake (like MAPDL) would solve only
    the selection, giving other frequencies, without the block's ALLSEL before SOLVE."""
    deck = (DATA / "tbeam_parametric.inp").read_text()
    assert deck.endswith("D,ALL,ALL\nALLSEL,ALL\n")
    adapter = MapdlAdapter(deck.removesuffix("ALLSEL,ALL\n"), ["E"], COORDINATES, n_modes=3, executable=str(fake_mapdl), work_root=tmp_path / "runs")
    result = adapter.evaluate({"E": 190e9})
    np.testing.assert_allclose(result.natural_frequencies_hz, 46.48 * np.arange(1, 4) * np.sqrt(190e9 / 210e9), rtol=1e-15)


@pytest.mark.parametrize("node", [(0.3, 0.0, 0.0), "NODE(0.3,0,0)"])
def test_node_selection_in_global_cartesian_whatever_the_deck_left_active(tmp_path: Path, fake_mapdl: Path, node) -> None:
    """In the deck's rotated system NODE(0.3,0,0) would be global (0, 0.3, 0), i.e. node 1."""
    adapter = MapdlAdapter(ROTATED_CSYS_DECK, ["E"], {"p:uz": (node, "uz")}, n_modes=2, executable=str(fake_mapdl), work_root=tmp_path / "runs")
    meta = adapter.evaluate({"E": 2.1e11}).metadata
    assert meta["nodes"] == {"p:uz": 4}
    np.testing.assert_allclose(meta["node_locations_m"]["p:uz"], (0.3, 0.0, 0.0), atol=1e-15)


@pytest.mark.parametrize("node", [(0.3, 0.0, 0.0), "NODE(0.3,0,0)"])
def test_node_far_from_the_requested_point_fails(tmp_path: Path, fake_mapdl: Path, monkeypatch: pytest.MonkeyPatch, node) -> None:
    """A MAPDL that stays in a rotated coordinate system picks node 1 at the origin, 0.3 m away."""
    monkeypatch.setenv("FAKE_MAPDL_BEHAVIOUR", "stuck_csys")
    adapter = MapdlAdapter(ROTATED_CSYS_DECK, ["E"], {"p:uz": (node, "uz")}, n_modes=2, executable=str(fake_mapdl), work_root=tmp_path / "runs")
    with pytest.raises(AdapterError) as info:
        adapter.evaluate({"E": 2.1e11})
    message = str(info.value)
    expression = "NODE(0.3,0.0,0.0)" if isinstance(node, tuple) else node
    assert (
        f"coordinate 'p:uz': MAPDL chose node 1 for {expression} (requested point (0.3, 0, 0) m); the node lies at (0, 0, 0) m, "
        f"0.3 m away — more than location_tolerance_m = 0.001 m"
    ) in message
    assert f"run directory: {only_run_dir(tmp_path)}" in message
    # the same point with a tolerance above the distance is accepted
    loose = MapdlAdapter(ROTATED_CSYS_DECK, ["E"], {"p:uz": (node, "uz")}, n_modes=2, executable=str(fake_mapdl), work_root=tmp_path / "runs", location_tolerance_m=0.31)
    assert loose.evaluate({"E": 2.1e11}).metadata["node_distances_m"]["p:uz"] == pytest.approx(0.3, rel=1e-12)


@pytest.mark.parametrize("units", ["SI", "mm-t-s", "mm-kg-s"])
def test_units_are_converted_to_si(tmp_path: Path, fake_mapdl: Path, monkeypatch: pytest.MonkeyPatch, units: str) -> None:
    """Two masses m = 2 kg between three springs k = 8000 N/m, in three unit systems.

    By hand: K = k[[2, -1], [-1, 2]], M = m I: ω₁² = k/m, φ₁ = [1, 1]/√(2m); ω₂² = 3k/m,
    φ₂ = [1, -1]/√(2m). With k/m = 4000 s⁻² and 2m = 4 kg: f = (√4000, √12000)/2π Hz and
    φ = ±0.5 /√kg — in every unit system once converted (mm-t-s: MAPDL returns
    1/√(0.004 t) = 15.81 /√t)."""
    monkeypatch.setenv("FAKE_MAPDL_MODEL", "springs")
    adapter = MapdlAdapter(
        SPRING_DECKS[units], ["K"], SPRING_POINTS, n_modes=2, units=units, executable=str(fake_mapdl), work_root=tmp_path / "runs"
    )
    result = adapter.evaluate({"K": SPRING_K[units]})
    np.testing.assert_allclose(result.natural_frequencies_hz, np.sqrt([4000.0, 12000.0]) / (2 * np.pi), rtol=1e-12)
    np.testing.assert_allclose(result.mode_shapes, [[0.5, 0.5], [0.5, -0.5]], rtol=1e-12)
    meta = result.metadata
    assert meta["units"] == units and meta["nodes"] == {"m1:ux": 2, "m2:ux": 3}
    np.testing.assert_allclose([meta["node_locations_m"][c] for c in SPRING_POINTS], [(1.0, 0, 0), (2.0, 0, 0)], atol=1e-15)
    scale = {"SI": "1.0", "mm-t-s": "1000.0", "mm-kg-s": "1000.0"}[units]
    assert f"NLU_N1=NODE({scale},0.0,0.0)\n" in (Path(meta["run_dir"]) / "in.inp").read_text()


def test_location_tolerance_is_in_metres_for_a_mm_deck(tmp_path: Path, fake_mapdl: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Node 2 sits at 1000 mm: a point 0.5 mm off passes the default 1 mm, one 2 mm off fails."""
    monkeypatch.setenv("FAKE_MAPDL_MODEL", "springs")

    def adapter(x_m: float, **options) -> MapdlAdapter:
        return MapdlAdapter(
            SPRING_DECKS["mm-t-s"], ["K"], {"m1:ux": ((x_m, 0.0, 0.0), "ux")}, n_modes=2, units="mm-t-s",
            executable=str(fake_mapdl), work_root=tmp_path / "runs", **options,
        )

    meta = adapter(1.0005).evaluate({"K": 8.0}).metadata
    assert meta["nodes"] == {"m1:ux": 2} and meta["node_distances_m"]["m1:ux"] == pytest.approx(5e-4, rel=1e-9)
    with pytest.raises(AdapterError, match=r"chose node 2 for NODE\(1002\.0,0\.0,0\.0\) \(requested point \(1\.002, 0, 0\) m\); the node lies at \(1, 0, 0\) m, 0\.002 m away"):
        adapter(1.002).evaluate({"K": 8.0})
    assert adapter(1.002, location_tolerance_m=0.003).evaluate({"K": 8.0}).metadata["nodes"] == {"m1:ux": 2}


LARGE_FILES = {"job.rst", "job.full", "job.mode", "job.esav", "job.emat", "job.db", "job.page", "job.osav", "job.ldhi", "job.LN22", "job.r001", "job0.rst"}
KEPT_FILES = {"in.inp", "out.out", "job.err", "job.log", "modal_table.txt", "mapdl.log", "argv.txt"}


def test_large_files_are_deleted_after_a_successful_run(tmp_path: Path, fake_mapdl: Path) -> None:
    result = make_adapter(tmp_path, str(fake_mapdl)).evaluate({"E": 210e9})
    assert {p.name for p in Path(result.metadata["run_dir"]).iterdir()} == KEPT_FILES


def test_keep_files_keeps_them(tmp_path: Path, fake_mapdl: Path) -> None:
    result = make_adapter(tmp_path, str(fake_mapdl), keep_files=True).evaluate({"E": 210e9})
    assert {p.name for p in Path(result.metadata["run_dir"]).iterdir()} == KEPT_FILES | LARGE_FILES


def test_timeout_kills_mapdl(tmp_path: Path, fake_mapdl: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The launcher hangs (600 s) after its first line: killed at the timeout, the error
    quotes that line (a timeout that fired before the launcher printed it on a loaded
    machine is made longer: patience.timed_out_once_ready)."""
    monkeypatch.setenv("FAKE_MAPDL_BEHAVIOUR", "hang")

    def attempt(timeout_s: float) -> str:
        # killed at its timeout: a launcher waited for would have ended its 600 s and raised no timeout
        with pytest.raises(RunTimeoutError, match=f"timed out after {timeout_s} s") as info:
            make_adapter(tmp_path, str(fake_mapdl), timeout_s=timeout_s).evaluate({"E": 210e9})
        return str(info.value)

    timed_out_once_ready(attempt, lambda message: "fake MAPDL launcher hang" in message, 0.5)


def test_parallel_runs_use_separate_directories(tmp_path: Path, fake_mapdl: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Four evaluations on four threads: each launcher waits until all four have started
    (an adapter that ran them in turn fails them), each in its own directory with its own result."""
    (tmp_path / "started").mkdir()
    monkeypatch.setenv("FAKE_MAPDL_TOGETHER", f"{tmp_path / 'started'}:4")
    adapter = make_adapter(tmp_path, str(fake_mapdl))
    moduli = [150e9, 180e9, 210e9, 240e9]
    with ThreadPoolExecutor(max_workers=4) as pool:
        results = list(pool.map(lambda E: adapter.evaluate({"E": E}), moduli))
    assert len({r.metadata["run_dir"] for r in results}) == 4
    for modulus, result in zip(moduli, results):
        assert result.natural_frequencies_hz[0] == pytest.approx(46.48 * math.sqrt(modulus / 210e9), rel=1e-15)
