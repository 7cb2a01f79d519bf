"""Every mistake a user can make ends as one clear line, the right exit code and nothing half-written.

Each case runs the real ``nlupdate`` command line — in this process, through
:func:`nlupdate.app.cli.main` with stdout and stderr captured (what a user sees: stderr, exit
code; starting a Python process per case cost a minute and checks nothing more), or in a
subprocess where the process itself is the point (the traceback of ``--debug``, the
umask) — and checks: exit code 2 for a mistake in the input, 1 for a failure of the
work; one or two lines on stderr naming the file, field or option; no traceback; and
nothing left in the output location.
"""
from __future__ import annotations

import contextlib
import io
import os
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from nlupdate.app.cli import main
from studies import two_dof_study, study_text, write_study

ROOT = Path(__file__).resolve().parents[1]
TWO_DOF = ROOT / "examples" / "two_dof.toml"
STUDY = ROOT / "tests" / "data" / "studies" / "two_dof.toml"
SIMULATE = ["--input-dof", "0", "--freqs", "650:800:16", "--forces", "0.01,100"]


def nlupdate(*args: object, cwd: Path | None = None, env: dict | None = None, timeout: float = 120):
    """``nlupdate ARGS`` in this process: (returncode, stdout, stderr) as a subprocess gives them."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.ExitStack() as stack:
        if cwd is not None:
            stack.enter_context(contextlib.chdir(cwd))
        if env is not None:
            stack.enter_context(_environment(env))
        stack.enter_context(contextlib.redirect_stdout(out))
        stack.enter_context(contextlib.redirect_stderr(err))
        try:
            code = main([str(a) for a in args])
        except SystemExit as stop:  # argparse's errors, --help and --version
            code = stop.code
    return SimpleNamespace(returncode=code, stdout=out.getvalue(), stderr=err.getvalue())


def nlupdate_process(*args: object, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "nlupdate", *map(str, args)], capture_output=True, text=True,
                          timeout=timeout)


@contextlib.contextmanager
def _environment(env: dict):
    saved = dict(os.environ)
    os.environ.clear()
    os.environ.update(env)
    try:
        yield
    finally:
        os.environ.clear()
        os.environ.update(saved)


def assert_one_clear_line(result, code: int, *fragments: str) -> str:
    stderr = result.stderr.strip()
    lines = stderr.splitlines()
    assert result.returncode == code, (result.returncode, stderr)
    assert "Traceback" not in stderr, stderr
    assert 1 <= len(lines) <= 2, stderr
    for fragment in fragments:
        assert fragment in lines[0], (fragment, stderr)
    return lines[0]


def assert_nothing_written(folder: Path, *keep: str) -> None:
    left = sorted(p.name for p in folder.iterdir() if p.name not in keep)
    assert left == [], left


@pytest.fixture(scope="module")
def measured(tmp_path_factory) -> Path:
    """A small measured-FRF table of the 2-DOF of docs/methods.md §8 case (0.01 and 100 N)."""
    folder = tmp_path_factory.mktemp("measured")
    result = nlupdate("simulate", TWO_DOF, *SIMULATE, "--noise", "0.01", "--seed", "1", "--out", folder / "frf.parquet")
    assert result.returncode == 0, result.stderr
    return folder / "frf.parquet"


def model_variant(tmp_path: Path, old: str, new: str) -> Path:
    text = TWO_DOF.read_text()
    assert old in text
    path = tmp_path / "model.toml"
    path.write_text(text.replace(old, new))
    return path


# ------------------------------------------------------------------ model files
@pytest.mark.parametrize("old, new, fragments", [
    ("mass = [[0.1, 0.0]", "mass = [[0.0, 0.0]", ("model.toml [model]", "'mass' has 0 on the diagonal at dof 0")),
    ("mass = [[0.1, 0.0]", "mass = [[-0.1, 0.0]", ("'mass' has -0.1 on the diagonal",)),
    ("stiffness = [[2e6, -1e6], [-1e6, 2e6]]", "stiffness = [[1e6, -2e6], [-2e6, 1e6]]",
     ("'stiffness' must be positive semi-definite", "lowest eigenvalue is -1e+06")),
    ("stiffness = [[2e6, -1e6], [-1e6, 2e6]]", "stiffness = [[2e6, -1e6], [-0.5e6, 2e6]]", ("'stiffness' must be symmetric",)),
    ("loss_factor = 0.005", "loss_factor = -0.005", ("'loss_factor' must be ≥ 0",)),
    ("k3 = 1e10", 'k3 = "1e10"', ("[[nonlinear]] #1", "'k3' must be a number", "'1e10' (str)")),
    ("mass = [[0.1, 0.0]", 'mass = [["0.1", 0.0]', ("'mass' must be a square matrix of numbers", "'0.1' (str)")),
    ("kind = \"lumped\"", "kind = \"lumped\"\nmystery = 3", ("unknown key(s) ['mystery']",)),
    ("[[nonlinear]]", "[[nonlinear]\n", ("model.toml: not valid TOML",)),
    ("stiffness = [[2e6, -1e6]", "stiffness = [[nan, -1e6]", ("'stiffness' row 0, column 0 is nan: not a finite number",)),
    ("stiffness = [[2e6, -1e6]", "stiffness = [[1e300, -1e6]", ("'stiffness' row 0, column 0 is 1e+300: larger",)),
    ("loss_factor = 0.005", 'loss_factor = 0.005\ndof_names = ["m", "m"]', ("'dof_names' names 'm' more than once",)),
])
def test_model_file_mistakes(tmp_path, old, new, fragments):
    model = model_variant(tmp_path, old, new)
    out = tmp_path / "out"
    out.mkdir()
    result = nlupdate("simulate", model, *SIMULATE, "--out", out / "frf.parquet")
    assert_one_clear_line(result, 2, "nlupdate simulate: error:", *fragments)
    assert_nothing_written(out)


def test_modal_model_with_negative_damping(tmp_path):
    model = tmp_path / "modal.toml"
    model.write_text('[model]\nkind = "modal"\nnatural_frequencies_hz = [10.0]\nmode_shapes = [[1.0]]\n'
                     'damping_ratios = [-0.01]\n')
    result = nlupdate("simulate", model, "--input-dof", "0", "--freqs", "5:15:5", "--forces", "1",
                      "--out", tmp_path / "x.csv")
    assert_one_clear_line(result, 2, "modal.toml [model]", "'damping_ratios' must be ≥ 0")


# ------------------------------------------------------------------ simulate options and outputs
@pytest.mark.parametrize("extra, fragments", [
    (["--seed", "-5"], ("argument --seed: expected an integer ≥ 0, got '-5'",)),
    (["--noise", "-1"], ("argument --noise: expected a number ≥ 0",)),
    (["--noise", "five"], ("argument --noise: expected a number ≥ 0, got 'five'",)),
    (["--input-dof", "7"], ("unknown dof 7",)),
    (["--freqs", "650-800"], ("START:STOP:COUNT",)),
    (["--forces", "1,-2"], ("--forces '1,-2'", "-2 is not a number > 0")),
    (["--forces", "0.01,nan"], ("--forces '0.01,nan'", "nan is not a number > 0")),
    (["--forces", "30,30"], ("--forces '30,30'", "30 N is given more than once")),
    (["--freqs", "650:nan:16"], ("--freqs '650:nan:16'", "nan is not a number > 0")),
    (["--freqs", "650:800:100000000"], ("--freqs '650:800:100000000'", "2 ≤ COUNT ≤ 200000")),
    (["--freqs", "800,650,700"], ("--freqs '800,650,700'", "increasing frequencies")),
    (["--method", "hb", "--samples", "100000000"], ("argument --samples: expected an integer from 7 to 65536",)),
    (["--method", "hb", "--harmonics", "1000"], ("argument --harmonics: expected an integer from 1 to 64",)),
])
def test_simulate_option_mistakes(tmp_path, extra, fragments):
    result = nlupdate("simulate", TWO_DOF, *SIMULATE, *extra, "--out", tmp_path / "frf.parquet")
    assert_one_clear_line(result, 2, *fragments)
    assert_nothing_written(tmp_path)


def test_unsupported_output_format_is_refused_before_the_work(tmp_path):
    result = nlupdate("simulate", TWO_DOF, *SIMULATE, "--out", tmp_path / "frf.xlsx")
    assert_one_clear_line(result, 2, "frf.xlsx: unsupported file type '.xlsx'", ".parquet")
    assert_nothing_written(tmp_path)


def test_existing_output_is_kept_without_overwrite(tmp_path):
    out = tmp_path / "frf.csv"
    out.write_text("precious")
    result = nlupdate("simulate", TWO_DOF, *SIMULATE, "--out", out)
    assert_one_clear_line(result, 2, f"--out {out} exists; pass --overwrite to replace it")
    assert out.read_text() == "precious"
    result = nlupdate("simulate", TWO_DOF, *SIMULATE, "--out", out, "--overwrite")
    assert_one_clear_line(result, 2, f"--out {out}: is not a file this command writes")  # not a table
    assert out.read_text() == "precious"
    out.unlink()
    assert nlupdate("simulate", TWO_DOF, *SIMULATE, "--out", out).returncode == 0
    assert nlupdate("simulate", TWO_DOF, *SIMULATE[:-1], "0.01,50", "--out", out, "--overwrite").returncode == 0
    assert len(pd.read_csv(out)) == 2 * 2 * 16 and set(pd.read_csv(out)["force_level_n"]) == {0.01, 50}


def test_output_folder_that_cannot_be_made(tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    result = nlupdate("simulate", TWO_DOF, *SIMULATE, "--out", blocker / "sub" / "frf.parquet")
    assert_one_clear_line(result, 2, f"--out {blocker / 'sub'}: cannot write there")


def test_written_files_follow_the_umask(tmp_path):
    result = subprocess.run(f"umask 022 && {sys.executable} -m nlupdate simulate {TWO_DOF} {' '.join(SIMULATE)} "
                            f"--out {tmp_path / 'frf.parquet'}", shell=True, capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "frf.parquet").stat().st_mode & 0o777 == 0o644


def test_missing_model_file(tmp_path):
    result = nlupdate("simulate", tmp_path / "nope.toml", *SIMULATE, "--out", tmp_path / "x.csv")
    assert_one_clear_line(result, 2, f"{tmp_path / 'nope.toml'}: no such file (model file)")


# ------------------------------------------------------------------ identify
def test_identify_input_dof_out_of_range_names_the_option(measured, tmp_path):
    result = nlupdate("identify", "--measured", measured, "--input-dof", "7", "--out", tmp_path / "id")
    assert_one_clear_line(result, 2, "--input-dof 7:", "has input_dof 0")
    assert_nothing_written(tmp_path)


def test_validate_input_dof_out_of_range_names_file_and_option(measured, tmp_path):
    """validate reads its curve's input by the rule identify reads it by (frf_table.table_input)."""
    result = nlupdate("validate", "--measured", measured, "--input-dof", "7", "--out", tmp_path / "v")
    assert_one_clear_line(result, 2, f"{measured}: --input-dof 7: the table has input_dof 0")
    assert_nothing_written(tmp_path)


@pytest.mark.parametrize("extra, fragment", [
    (["--seed", "-5"], "argument --seed: expected an integer ≥ 0"),
    (["--samples", "0"], "argument --samples: expected an integer in [2, 100000], got '0'"),
    (["--method", "magic"], "argument --method: invalid choice: 'magic'"),
    (["--band", "5:1"], "--band '5:1': expected LOW:HIGH in Hz with 0 ≤ LOW < HIGH"),
    (["--force-pair", "1,2"], "--force-pair applies to the DDF method"),
])
def test_identify_option_mistakes_fail_before_the_work(measured, tmp_path, extra, fragment):
    result = nlupdate("identify", "--measured", measured, *extra, "--out", tmp_path / "id", timeout=20)
    assert_one_clear_line(result, 2, fragment)
    assert_nothing_written(tmp_path)


def test_identify_refuses_to_replace_its_output_without_overwrite(measured, tmp_path):
    (tmp_path / "id").mkdir()
    result = nlupdate("identify", "--measured", measured, "--out", tmp_path / "id")
    assert_one_clear_line(result, 2, "exists; pass --overwrite")


def test_truncated_uff_names_the_incomplete_record(measured, tmp_path):
    uff = tmp_path / "frf.uff"
    assert nlupdate("simulate", TWO_DOF, *SIMULATE, "--out", uff).returncode == 0
    content = uff.read_bytes()
    (tmp_path / "cut.uff").write_bytes(content[: len(content) - 100])
    result = nlupdate("identify", "--measured", tmp_path / "cut.uff", "--out", tmp_path / "id")
    assert_one_clear_line(result, 2, "cut.uff: incomplete record: dataset 3", "truncated")
    assert not (tmp_path / "id").exists()


def test_measured_table_missing_a_column(measured, tmp_path):
    table = pd.read_parquet(measured).drop(columns="h_imag")
    table.to_csv(tmp_path / "frf.csv", index=False)
    result = nlupdate("identify", "--measured", tmp_path / "frf.csv", "--out", tmp_path / "id")
    assert_one_clear_line(result, 2, "frf.csv", "h_imag")


def test_missing_measured_file(tmp_path):
    result = nlupdate("identify", "--measured", tmp_path / "none.parquet", "--out", tmp_path / "id")
    assert_one_clear_line(result, 2, "none.parquet")


# ------------------------------------------------------------------ UFF mobility / accelerance
@pytest.mark.parametrize("ordinate, power", [(11, 1), (12, 2)])
def test_uff_mobility_and_accelerance_are_converted_to_receptance(tmp_path, ordinate, power):
    """An ASCII UFF 58 written by pyuff as another tool would: A = (iω)^p H, read back as H."""
    import pyuff

    from nlupdate.core.measurement.frf_files import read_frf_table
    from nlupdate.notices import NlupdateWarning

    f = np.linspace(10.0, 20.0, 11)
    h = 1.0 / (1e4 - (2 * np.pi * f) ** 2 + 50j)  # receptance of a unit mass on 1e4 N/m, m/N
    data = (1j * 2 * np.pi * f) ** power * h
    dataset = pyuff.prepare_58(
        binary=0, func_type=4, rsp_node=1, rsp_dir=3, ref_node=1, ref_dir=3, data=data, x=f,
        id1="measured", id2="force_level_n=2.5", abscissa_spacing=1, abscissa_spec_data_type=18,
        ordinate_spec_data_type=ordinate, orddenom_spec_data_type=13,
    )
    path = tmp_path / "mobility.uff"
    pyuff.UFF(str(path)).write_sets([dataset], mode="add")
    with pytest.warns(NlupdateWarning, match="converted .* to receptance"):
        table = read_frf_table(path)
    back = table["h_real"].to_numpy() + 1j * table["h_imag"].to_numpy()
    np.testing.assert_allclose(back, h, rtol=1e-5)  # ASCII UFF keeps about 6 significant digits of f


# ------------------------------------------------------------------ study files: update and run
def study_variant(tmp_path: Path, edit=lambda study: None) -> Path:
    """The 2-DOF study after ``edit`` (a function changing the study dict in place)."""
    study = two_dof_study()
    edit(study)
    return write_study(tmp_path / "study.toml", study)


@pytest.mark.parametrize("command", ["update", "run"])
@pytest.mark.parametrize("edit, fragments", [
    (lambda s: s["eigensensitivity"].update(formulas=["sideways"]),
     ("study.toml", "[eigensensitivity] key 'formulas'", "sideways")),
    (lambda s: s["parameters"][0].update(upper="big"), ("study.toml", "upper")),
    (lambda s: s["measured"]["simulate"].update(noise=-0.01), ("study.toml", "noise")),
    (lambda s: s["parameters"][0].update(name="k9"),
     ("[[parameters]] key 'name': expected a parameter of the lumped model", "'k9'")),
    (lambda s: s["parameters"][0].update(lower=0.0),
     ("[[parameters]] 'k1': lower = 0 is a value the lumped model cannot take", "must be positive")),
    (lambda s: s["adapter"].update(fixed={"k7": 1e6}), ("[adapter.fixed] key 'k7': expected a parameter",)),
    (lambda s: s["study"].update(name="../../escaped"), ("[study] key 'name': expected one folder name",)),
], ids=["formula", "upper", "noise", "name", "lower", "fixed", "study-name"])
def test_study_file_mistakes(tmp_path, command, edit, fragments):
    study = study_variant(tmp_path, edit)
    out = ["--out", tmp_path / "out"]
    result = nlupdate(command, study, *out, timeout=60)
    assert_one_clear_line(result, 2, f"nlupdate {command}: error:", *fragments)
    assert not (tmp_path / "out").exists()


def test_update_refuses_an_existing_output(tmp_path):
    (tmp_path / "out").mkdir()
    result = nlupdate("update", study_variant(tmp_path), "--out", tmp_path / "out")
    assert_one_clear_line(result, 2, "exists; pass --overwrite")


def test_missing_study_file(tmp_path):
    result = nlupdate("run", tmp_path / "nope.toml")
    assert_one_clear_line(result, 2, "nope.toml")


@pytest.mark.parametrize("command, extra, fragment", [
    ("run", [STUDY, "--workers", "0"], "argument --workers: expected an integer ≥ 1, got '0'"),
    ("demo", ["--workers", "-2"], "argument --workers: expected an integer ≥ 1"),
    ("demo", ["--seed", "-1"], "argument --seed: expected an integer ≥ 0"),
    ("demo", ["--dask", "--dask-address", "tcp://x:1"], "not allowed with argument"),
    ("discover", ["--model", TWO_DOF, "--measured", "x.csv", "--out", "d", "--max-effects", "0"],
     "argument --max-effects: expected an integer ≥ 1"),
])
def test_execution_option_mistakes(tmp_path, command, extra, fragment):
    result = nlupdate(command, *extra, cwd=tmp_path, timeout=20)
    assert_one_clear_line(result, 2, fragment)
    assert_nothing_written(tmp_path)


def test_demo_results_folder_that_cannot_be_written(tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    result = nlupdate("demo", "--results", blocker / "results", cwd=tmp_path, timeout=30)
    assert_one_clear_line(result, 2, f"--results {blocker / 'results'}: cannot write there")


# ------------------------------------------------------------------ failures of the work
CALCULIX_STUDY = (ROOT / "tests" / "data" / "studies" / "calculix_tbeam_E.toml").read_text()


def test_missing_ccx_is_one_line_saying_how_to_install_it(tmp_path):
    study = tmp_path / "ccx.toml"
    study.write_text(CALCULIX_STUDY.replace('work_root = "ccx_runs"', f'work_root = "{tmp_path / "runs"}"'))
    env = {**os.environ, "PATH": str(Path(sys.executable).parent)}  # python, but no ccx
    result = nlupdate("update", study, "--out", tmp_path / "out", env=env)
    assert_one_clear_line(result, 1, "ccx", "apt-get install")
    assert not (tmp_path / "out").exists()


def test_failing_solver_fails_the_command_naming_the_run_folder_and_log(tmp_path):
    study = tmp_path / "ccx.toml"
    study.write_text(CALCULIX_STUDY.replace('work_root = "ccx_runs"', f'executable = "/bin/false"\nwork_root = "{tmp_path / "runs"}"'))
    result = nlupdate("update", study, "--out", tmp_path / "out")
    line = assert_one_clear_line(result, 1, "1 updating run(s) failed", "eigensensitivity forward")
    assert f"log: {tmp_path / 'runs'}" in line and line.endswith("ccx.log)")
    assert "false exited with code 1" in (tmp_path / "out" / "report.md").read_text()  # the archive names it


def test_debug_shows_the_traceback(tmp_path):
    model = model_variant(tmp_path, "loss_factor = 0.005", "loss_factor = -0.005")
    result = nlupdate_process("--debug", "simulate", model, *SIMULATE, "--out", tmp_path / "x.csv")
    assert result.returncode != 0 and "Traceback" in result.stderr and "ModelFileError" in result.stderr


def test_an_unexpected_error_is_one_line_pointing_to_debug(tmp_path, monkeypatch, capsys):
    from nlupdate.app.cli import main

    def broken(*args, **kwargs):
        raise TypeError("unsupported operand")

    monkeypatch.setattr("nlupdate.app.cli.simulate.simulate_frf_table", broken)
    code = main(["simulate", str(TWO_DOF), *SIMULATE, "--out", str(tmp_path / "x.csv")])
    stderr = capsys.readouterr().err.strip()
    assert code == 1 and stderr.count("\n") == 0
    assert "internal error: TypeError: unsupported operand (rerun with --debug" in stderr


def test_version_and_help_are_plain_text():
    version = nlupdate("--version")
    assert version.returncode == 0 and version.stdout.startswith("nlupdate ")
    for command in ("demo", "run", "simulate", "identify", "update", "discover", "archive", "schedule", "serve"):
        page = nlupdate(command, "--help").stdout
        assert "``" not in page and ":func:" not in page and ":mod:" not in page, command
        assert len(page.split("\n\n")[1]) > 40, command  # a description, not only the usage


# ------------------------------------------------------------------ measured data as test systems export it (issue 20)
def _identify(tmp_path: Path, measured: Path, *extra: str):
    return nlupdate("identify", "--measured", measured, *extra, "--out", tmp_path / "id", timeout=60)


def _csv_variant(measured: Path, tmp_path: Path, transform) -> Path:
    table = pd.read_parquet(measured)
    path = tmp_path / "frf.csv"
    path.write_text(transform(table))
    return path


@pytest.mark.parametrize("transform, fragments", [
    (lambda t: t.to_csv(index=False, sep=";"), ("frf.csv: columns are separated by ';'", "comma-separated")),
    (lambda t: t.to_csv(index=False, sep=";", decimal=","), ("separated by ';' and decimal commas",)),
    (lambda t: t.iloc[:0].to_csv(index=False), ("frf.csv: holds no measurement (no data rows)",)),
    (lambda t: t.assign(force_level_n=t["force_level_n"].where(t["force_level_n"] > 1, 0.0)).to_csv(index=False),
     ("frf.csv: level 0 N: identification needs measured levels > 0",)),
    (lambda t: t.assign(h_real=t["h_real"] * 1e300, h_imag=t["h_imag"] * 1e300).to_csv(index=False),
     ("frf.csv: row 0 (line 2), columns 'h_real', 'h_imag'", "is no receptance")),
    (lambda t: t[t["frequency_hz"] <= 660].to_csv(index=False),
     ("frf.csv: no level is a sweep: the most lines a level has is 2, a sweep has at least 3",)),
])
def test_measured_table_mistakes_name_the_file(measured, tmp_path, transform, fragments):
    path = _csv_variant(measured, tmp_path, transform)
    result = _identify(tmp_path, path, "--samples", "2")
    assert_one_clear_line(result, 2, *fragments)
    assert_nothing_written(tmp_path, "frf.csv")


def test_a_folder_given_as_the_measured_file(tmp_path):
    (tmp_path / "frf.csv").mkdir()
    result = _identify(tmp_path, tmp_path / "frf.csv")
    assert_one_clear_line(result, 2, "frf.csv: is a folder; expected a regular file (measured-FRF file)")
    assert_nothing_written(tmp_path, "frf.csv")


def test_a_boolean_h_real_column_in_parquet(measured, tmp_path):
    table = pd.read_parquet(measured)
    table["h_real"] = table["h_real"] > 0
    table.to_parquet(tmp_path / "bool.parquet")
    result = _identify(tmp_path, tmp_path / "bool.parquet")
    assert_one_clear_line(result, 2, "bool.parquet: row 0, column 'h_real'", "is a boolean (True/False); expected a "
                                     "finite number")
    assert_nothing_written(tmp_path, "bool.parquet")


@pytest.mark.parametrize("fields, fragments", [
    (dict(abscissa_spec_data_type=17), ("dataset 0: abscissa specific data type 17 (time",
                                        "expected 18 (frequency, Hz)")),
    (dict(orddenom_spec_data_type=8), ("dataset 0: ordinate denominator specific data type 8 (displacement)",
                                       "transmissibility")),
    (dict(orddenom_spec_data_type=0, orddenom_axis_units_lab="V"), ("the FRF is per volt", "--reference-unit V")),
])
def test_uff_data_of_the_wrong_kind(tmp_path, fields, fragments):
    import pyuff

    f = np.linspace(10.0, 20.0, 11)
    base = dict(binary=0, func_type=4, rsp_node=1, rsp_dir=3, ref_node=1, ref_dir=3, data=1e-6 / (1 + 1j * f), x=f,
                id1="force_level_n=2.0", abscissa_spacing=1, abscissa_spec_data_type=18, ordinate_spec_data_type=8,
                orddenom_spec_data_type=13)
    base.update(fields)
    pyuff.UFF(str(tmp_path / "frf.uff")).write_sets([pyuff.prepare_58(**base)], mode="add")
    result = _identify(tmp_path, tmp_path / "frf.uff")
    assert_one_clear_line(result, 2, "frf.uff", *fragments)
    assert_nothing_written(tmp_path, "frf.uff")


@pytest.mark.parametrize("content, fragments", [
    ("t,force,tip\n0,1,2\n", ("rec.csv: no 'time_s' column",)),
    ("time_s;force;tip\n0;1;2\n", ("rec.csv: columns are separated by ';'",)),
])
def test_frf_command_time_record_mistakes(tmp_path, content, fragments):
    (tmp_path / "rec.csv").write_text(content)
    result = nlupdate("frf", tmp_path / "rec.csv", "--out", tmp_path / "frf.parquet", timeout=60)
    assert_one_clear_line(result, 2, *fragments)
    assert_nothing_written(tmp_path, "rec.csv")


def test_discover_band_without_measured_lines(measured, tmp_path):
    result = nlupdate("discover", "--model", TWO_DOF, "--measured", measured, "--band", "10:20", "--out",
                      tmp_path / "d", timeout=60)
    assert_one_clear_line(result, 2, "--band 10:20", "has no line between 10 and 20 Hz")
    assert_nothing_written(tmp_path)


@pytest.mark.parametrize("targets, fragment", [
    ("frequencies_hz = [178.0, 40.75, 260.5]", "[targets] key 'frequencies_hz': expected increasing natural frequencies"),
    ("frequencies_hz = [40.75, 40.75, 260.5]", "[targets] key 'frequencies_hz': expected increasing natural frequencies"),
])
def test_target_lists_in_another_order_or_twice_are_refused(tmp_path, targets, fragment):
    study = tmp_path / "study.toml"
    text = (ROOT / "examples" / "tbeam_three_modes.toml").read_text()
    assert "frequencies_hz = [40.75, 178.0, 260.5]" in text
    study.write_text(text.replace("frequencies_hz = [40.75, 178.0, 260.5]", targets))
    result = nlupdate("update", study, "--out", tmp_path / "out")
    assert_one_clear_line(result, 2, "study.toml", fragment)
    assert not (tmp_path / "out").exists()


def test_a_study_file_saved_with_a_byte_order_mark_is_read(tmp_path):
    """Windows editors save UTF-8 with a BOM; it was 'Invalid statement (at line 1, column 1)'."""
    study = tmp_path / "study.toml"
    study.write_bytes(b"\xef\xbb\xbf" + study_text(two_dof_study()).encode())
    from nlupdate.study import load_study

    assert load_study(study).name == "two-dof"
