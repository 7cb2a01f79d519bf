"""MAPDL adapter: deck generation, table parser and process handling (with a fake MAPDL).

MAPDL is not installed here. The appended block and the parser are checked against
hand-written files in tests/data/mapdl/; process handling runs a fake ``mapdl``
(a Python script written into tmp_path) through the same runner as CalculiX.
"""
from __future__ import annotations

import stat
import sys
import textwrap
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

from nlupdate.adapters.base import AdapterError
from nlupdate.adapters.mapdl import (
    MAPDL_EXEC_ENV,
    MapdlAdapter,
    modal_block,
    parse_modal_table,
    substitute_parameters,
)
from nlupdate.adapters.runner import ExecutableNotFoundError, RunTimeoutError

DATA = Path(__file__).parent / "data" / "mapdl"
COORDINATES = {"tip:uz": (101, "uz"), "mid:uy": ("NODE(0.2,0,0)", "uy")}


# --------------------------------------------------------------------------- deck generation


def test_modal_block_is_exactly_the_documented_one() -> None:
    expected = (DATA / "expected_block_3modes_2coords.inp").read_text()
    assert modal_block(3, list(COORDINATES.values())) == expected


def test_input_deck_substitutes_set_lines_and_appends_block(tmp_path: Path) -> None:
    adapter = MapdlAdapter.from_file(DATA / "tbeam_parametric.inp", ["E", "h1", "h2"], COORDINATES, n_modes=3, executable="unused", work_root=tmp_path)
    deck = adapter.input_deck({"E": 190e9, "h1": 0.0079, "h2": 0.00155})
    expected = (DATA / "tbeam_parametric_substituted.inp").read_text() + (DATA / "expected_block_3modes_2coords.inp").read_text()
    assert deck == expected


def test_substitution_is_case_insensitive_and_maps_apdl_names() -> None:
    deck = (DATA / "tbeam_parametric.inp").read_text()
    out = substitute_parameters(deck, {"density": 7800.0, "nu": 0.29}, {"density": "RHO"})
    assert "*set,RHO,7800.0        ! lower-case command" in out
    assert "*SET,nu,0.29\n" in out


@pytest.mark.parametrize(
    ("deck", "message"),
    [
        ("*SET,NU,0.3\n", r"parameter 'E' has no '\*SET,E,<value>' line"),
        ("*SET,E,1\n*SET,E,2\n", r"has 2 '\*SET,E,…' lines \(lines \[1, 2\]\)"),
        ("*SET,E,1\nE = 2.1e11\n", r"also assigned with 'E = …' on line\(s\) \[2\]"),
        ("*SET,ELAST,1\n", r"parameter 'E' has no"),  # a longer name is another parameter
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


# --------------------------------------------------------------------------- table parser


def test_parser_reads_the_documented_table() -> None:
    frequencies, shapes, elements = parse_modal_table((DATA / "modal_table_3modes_2coords.txt").read_text(), 3, 2)
    np.testing.assert_array_equal(frequencies, [46.48, 198.05, 266.0])
    np.testing.assert_array_equal(shapes, [[2.756, -1.176, 2.388], [0.12345e-99, -0.5e-100, -0.75]])
    assert elements == 336


@pytest.mark.parametrize(
    ("name", "n_modes", "message"),
    [
        ("modal_table_truncated.txt", 3, r"modal_table_truncated\.txt: section 'COORDINATE 1' ends after 2 of 3 rows"),
        ("modal_table_wrong_mode.txt", 3, r"modal_table_wrong_mode\.txt, line 5: expected mode 2 in section 'FREQUENCIES', got '3\.'"),
        ("modal_table_stars.txt", 3, r"modal_table_stars\.txt, line 5: expected '<mode>\. <value>'"),
        ("modal_table_3modes_2coords.txt", 2, r"line 6: expected 'COORDINATE 1', got '3\.   0\.2660000000000000E\+03'"),
        ("modal_table_3modes_2coords.txt", 4, r"line 7: expected '<mode>\. <value>' \(mode 4 of section 'FREQUENCIES'\), got 'COORDINATE 1'"),
    ],
)
def test_parser_rejects_malformed_tables(name: str, n_modes: int, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        parse_modal_table((DATA / name).read_text(), n_modes, 2, name)


def test_parser_rejects_extra_coordinates() -> None:
    with pytest.raises(ValueError, match="line 11: unexpected content after the last coordinate section: 'COORDINATE 2'"):
        parse_modal_table((DATA / "modal_table_3modes_2coords.txt").read_text(), 3, 1, "t.txt")


# --------------------------------------------------------------------------- fake MAPDL runs


FAKE_MAPDL = """
import os, re, shutil, sys, time
args = sys.argv[1:]
open("argv.txt", "w").write("\\n".join(args))
deck = open(args[args.index("-i") + 1]).read()
out = args[args.index("-o") + 1]
behaviour = os.environ.get("FAKE_MAPDL_BEHAVIOUR", "ok")
print("fake MAPDL launcher", behaviour, flush=True)
if behaviour == "hang":
    time.sleep(60)
if behaviour == "exit8":
    open(out, "w").write(" *** ERROR ***  license checkout failed\\n")
    sys.exit(8)
if behaviour == "error0":
    shutil.copy(os.path.join(DATA, "out_with_error.out"), out)
    sys.exit(0)
time.sleep(float(os.environ.get("FAKE_MAPDL_DELAY", "0")))
modulus = float(re.search(r"^\\*SET,E,([^\\s!]+)", deck, re.M | re.I).group(1))
n_modes = int(re.search(r"^MODOPT,LANB,(\\d+),,,,OFF$", deck, re.M).group(1))
n_coords = len(re.findall(r"^NLU_N\\d+=", deck, re.M))
# A model whose frequencies scale with sqrt(E): f_i = 46.48 i sqrt(E / 210 GPa).
rows = ["NLUPDATE MODAL TABLE", "ELEMENTS {:12.0f}.".format(336), "FREQUENCIES"]
rows += ["{:7d}. {:24.16E}".format(i, 46.48 * i * (modulus / 2.1e11) ** 0.5) for i in range(1, n_modes + 1)]
for c in range(1, n_coords + 1):
    rows.append("COORDINATE {}".format(c))
    rows += ["{:7d}. {:24.16E}".format(i, c + i / 10) for i in range(1, n_modes + 1)]
if behaviour != "no_table":
    open("modal_table.txt", "w").write("\\n".join(rows) + "\\n")
shutil.copy(os.path.join(DATA, "out_ok.out"), out)
"""


@pytest.fixture
def fake_mapdl(tmp_path: Path) -> Path:
    script = tmp_path / "bin" / "mapdl"
    script.parent.mkdir()
    script.write_text(f"#!{sys.executable}\nDATA = {str(DATA)!r}\n" + textwrap.dedent(FAKE_MAPDL))
    script.chmod(script.stat().st_mode | stat.S_IXUSR)
    return script


def make_adapter(tmp_path: Path, executable: str | None, **options) -> MapdlAdapter:
    return MapdlAdapter.from_file(
        DATA / "tbeam_parametric.inp", ["E", "h1"], COORDINATES, n_modes=3, executable=executable, work_root=tmp_path / "runs", **options
    )


def test_fake_run_parses_results_and_uses_substituted_values(tmp_path: Path, fake_mapdl: Path) -> None:
    adapter = make_adapter(tmp_path, str(fake_mapdl), n_processors=2)
    result = adapter.evaluate({"E": 190e9})
    np.testing.assert_allclose(result.natural_frequencies_hz, 46.48 * np.arange(1, 4) * np.sqrt(190e9 / 210e9), rtol=1e-15)
    np.testing.assert_allclose(result.mode_shapes, [[1.1, 1.2, 1.3], [2.1, 2.2, 2.3]], rtol=1e-15)
    assert result.coordinates == ("tip:uz", "mid:uy")
    meta = result.metadata
    assert meta["solver"] == "mapdl" and meta["mesh_size"] == 336
    run_dir = Path(meta["run_dir"])
    assert meta["log_path"] == str(run_dir / "out.out")
    assert (run_dir / "argv.txt").read_text().split() == ["-b", "-i", "in.inp", "-o", "out.out", "-j", "job", "-np", "2"]
    assert "*SET,E,190000000000.0" in (run_dir / "in.inp").read_text()
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
    run_dir = next((tmp_path / "runs").iterdir())
    assert r"*** ERROR *** in out.out (line 10) although it exited with code 0" in message
    assert f"run directory: {run_dir}" in message and f"log: {run_dir / 'out.out'}" in message
    assert "Element type 1 is not defined" in message


def test_nonzero_exit_fails_naming_out_file(tmp_path: Path, fake_mapdl: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("FAKE_MAPDL_BEHAVIOUR", "exit8")
    with pytest.raises(AdapterError, match="MAPDL failed: mapdl exited with code 8") as info:
        make_adapter(tmp_path, str(fake_mapdl)).evaluate({"E": 210e9})
    run_dir = next((tmp_path / "runs").iterdir())
    assert f"log: {run_dir / 'out.out'}" in str(info.value) and "license checkout failed" in str(info.value)
    assert f"launcher log: {run_dir / 'mapdl.log'}" in str(info.value)


def test_missing_table_fails(tmp_path: Path, fake_mapdl: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("FAKE_MAPDL_BEHAVIOUR", "no_table")
    with pytest.raises(AdapterError, match="without writing modal_table.txt"):
        make_adapter(tmp_path, str(fake_mapdl)).evaluate({"E": 210e9})


def test_timeout_kills_mapdl(tmp_path: Path, fake_mapdl: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("FAKE_MAPDL_BEHAVIOUR", "hang")
    start = time.perf_counter()
    with pytest.raises(RunTimeoutError, match="timed out after 0.5 s") as info:
        make_adapter(tmp_path, str(fake_mapdl), timeout_s=0.5).evaluate({"E": 210e9})
    assert time.perf_counter() - start < 10
    assert "fake MAPDL launcher hang" in str(info.value)


def test_parallel_runs_use_separate_directories(tmp_path: Path, fake_mapdl: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("FAKE_MAPDL_DELAY", "0.5")
    adapter = make_adapter(tmp_path, str(fake_mapdl))
    moduli = [150e9, 180e9, 210e9, 240e9]
    start = time.perf_counter()
    with ThreadPoolExecutor(max_workers=4) as pool:
        results = list(pool.map(lambda E: adapter.evaluate({"E": E}), moduli))
    elapsed = time.perf_counter() - start
    assert len({r.metadata["run_dir"] for r in results}) == 4
    for modulus, result in zip(moduli, results):
        assert result.natural_frequencies_hz[0] == pytest.approx(46.48 * np.sqrt(modulus / 210e9), rel=1e-15)
    assert elapsed < 4 * 0.5, f"runs did not overlap ({elapsed:.2f} s)"
