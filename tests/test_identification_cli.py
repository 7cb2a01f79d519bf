"""``nlupdate identify`` end to end on small generated tables: JSON keys, files, values,
and one-line errors for bad requests."""
from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from nlupdate.app.cli import main
from nlupdate.core.model.elements import CubicStiffness, JenkinsFriction
from nlupdate.core.response.fixed_point import fixed_point_response
from nlupdate.core.model.linear import LumpedModel
from nlupdate.core.measurement.frf_table import frf_table
from nlupdate.core.measurement.frf_files import write_frf_table
from nlupdate.core.model.system import NonlinearSystem

MODEL = LumpedModel.with_loss_factor([[0.1]], [[2e6]], 0.01)
GRID = np.arange(690.0, 717.0)  # single-valued responses (fixed point converges)
LEVELS = (0.01, 100.0, 160.0, 220.0, 280.0, 340.0, 400.0)


def make_table(elements, levels=LEVELS, grid=GRID) -> pd.DataFrame:
    system = NonlinearSystem(MODEL, elements)
    parts = []
    for level in levels:
        result = fixed_point_response(system, {0: level}, 2 * np.pi * grid)
        assert result.converged.all()
        parts.append(frf_table(grid, level, "0", "0", result.response([0])[:, 0] / level))
    return pd.concat(parts, ignore_index=True)


@pytest.fixture(scope="module")
def friction_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("identify") / "sdof.parquet"
    write_frf_table(make_table((CubicStiffness((0,), 1e10), JenkinsFriction((0,), 3e5, 1.0))), path)
    return path


def run(capsys, *arguments):
    code = main(["identify", *map(str, arguments)])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def test_prd_defaults_end_to_end(friction_file, tmp_path, capsys):
    out = tmp_path / "prd"
    code, stdout, stderr = run(capsys, "--measured", friction_file, "--out", out, "--samples", 10)
    assert code == 0, stderr
    summary = json.loads((out / "identification.json").read_text())
    for key in ("method", "excitation_frequency_hz", "describing_function", "parameters", "defaults_used",
                "prd_fit", "delta_f1", "linear_frf", "uncertainty", "noise_fraction"):
        assert key in summary
    assert summary["method"] == "prd"
    assert set(summary["describing_function"]) >= {"real", "imag"}
    for name in ("k3", "kf"):
        assert set(summary["parameters"][name]) >= {"value", "std", "ci95"}
    assert summary["parameters"]["k3"]["value"] == pytest.approx(1e10, rel=0.01)
    assert summary["parameters"]["kf"]["value"] == pytest.approx(3e5, rel=0.01)
    # the recommended frequency is the one nearest to the linear resonance (711.76 Hz)
    assert summary["excitation_frequency_hz"] == 712.0
    for key in ("frequency_hz", "low_force_n", "order", "estimator", "input_dof", "noise_fraction"):
        assert key in summary["defaults_used"]
        assert f"default {key}" in stdout
    for name in ("identification.json", "linear_frf.parquet", "fit.png", "linear_frf.png"):
        assert (out / name).stat().st_size > 0
    linear = pd.read_parquet(out / "linear_frf.parquet")
    assert list(linear.columns) == ["frequency_hz", "force_level_n", "response_dof", "input_dof", "h_real", "h_imag"]
    assert (linear["force_level_n"] == 0).all()
    h = linear["h_real"].to_numpy() + 1j * linear["h_imag"].to_numpy()
    exact = MODEL.receptance(2 * np.pi * linear["frequency_hz"].to_numpy(), [0], [0])[:, 0, 0]
    assert np.max(np.abs(h - exact) / np.abs(exact)) < 0.01
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".tmp-")]


def test_prd_with_elements_and_frequency(friction_file, tmp_path, capsys):
    out = tmp_path / "elements"
    code, _, stderr = run(capsys, "--measured", friction_file, "--method", "prd", "--input-dof", 0,
                          "--response-dof", 0, "--frequency", 710, "--low-force", 0.01,
                          "--elements", "cubic,jenkins", "--out", out, "--samples", 5)
    assert code == 0, stderr
    summary = json.loads((out / "identification.json").read_text())
    assert summary["excitation_frequency_hz"] == 710.0
    assert "frequency_hz" not in summary["defaults_used"]
    assert summary["parameters"]["slip_force"]["value"] == pytest.approx(1.0, rel=1e-4)
    assert [e["type"] for e in summary["elements"]] == ["cubic", "jenkins"]
    # rerunning into the same folder is refused, and replaces it with --overwrite
    code, _, stderr = run(capsys, "--measured", friction_file, "--frequency", 712, "--elements", "cubic,jenkins",
                          "--out", out, "--samples", 5)
    assert code == 2 and "--overwrite" in stderr
    code, _, stderr = run(capsys, "--measured", friction_file, "--frequency", 712, "--elements", "cubic,jenkins",
                          "--out", out, "--samples", 5, "--overwrite")
    assert code == 0, stderr
    assert json.loads((out / "identification.json").read_text())["excitation_frequency_hz"] == 712.0


def test_ddf_end_to_end(tmp_path, capsys):
    path = tmp_path / "cubic.csv"
    write_frf_table(make_table((CubicStiffness((0,), 1e10),), levels=(100.0, 150.0, 350.0),
                               grid=np.arange(600.0, 705.0)), path)
    out = tmp_path / "ddf"
    code, stdout, stderr = run(capsys, "--measured", path, "--method", "ddf", "--out", out, "--samples", 5)
    assert code == 0, stderr
    summary = json.loads((out / "identification.json").read_text())
    assert summary["method"] == "ddf" and summary["excitation_frequency_hz"] is None
    assert summary["parameters"]["k3"]["value"] == pytest.approx(1e10, rel=1e-6)
    assert summary["defaults_used"]["force_pair_n"] == [100.0, 350.0]
    assert "default band_hz" in stdout


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--frequency", "711.5"], "is not in the data"),
        (["--response-dof", "7"], "--response-dof 7: "),
        (["--order", "3", "--estimator", "naive", "--high-forces", "100,160", "--frequency", "710"],
         "high-force point(s) but the polynomial has 4"),
        (["--method", "ddf", "--frequency", "710"], "--frequency apply to the PRD method"),
        (["--estimator", "bogus"], "PRD estimators are"),
        (["--elements", "spring"], "unknown element(s) ['spring']"),
    ],
)
def test_bad_requests(friction_file, tmp_path, capsys, extra, message):
    out = tmp_path / "bad"
    code, _, stderr = run(capsys, "--measured", friction_file, "--out", out, "--samples", 5, *extra)
    assert code == 2
    assert message in stderr
    assert stderr.count("\n") == 1
    assert not out.exists()


def test_one_level_and_singular_fit(tmp_path, capsys):
    single = tmp_path / "single.parquet"
    write_frf_table(make_table((CubicStiffness((0,), 1e10),), levels=(100.0,)), single)
    code, _, stderr = run(capsys, "--measured", single, "--out", tmp_path / "o1", "--frequency", 710)
    assert code == 2 and "only 1 force level" in stderr
    # every level has the same response amplitude: the PRD regression is singular
    grid = np.arange(700.0, 721.0)
    levels = np.array([0.01, 100.0, 200.0, 300.0])
    table = frf_table(np.tile(grid, levels.size), np.repeat(levels, grid.size), "0", "0",
                      1e-3 / np.repeat(levels, grid.size) + 0j)
    flat = tmp_path / "flat.parquet"
    write_frf_table(table, flat)
    code, _, stderr = run(capsys, "--measured", flat, "--out", tmp_path / "o2", "--frequency", 710)
    assert code == 2 and "singular" in stderr


def test_refuses_to_replace_an_unrelated_folder(friction_file, tmp_path, capsys):
    out = tmp_path / "precious"
    out.mkdir()
    (out / "notes.txt").write_text("keep me")
    code, _, stderr = run(capsys, "--measured", friction_file, "--frequency", 712, "--out", out, "--samples", 5)
    assert code == 2 and "--overwrite" in stderr
    code, _, stderr = run(capsys, "--measured", friction_file, "--frequency", 712, "--out", out, "--samples", 5,
                          "--overwrite")
    assert code == 2 and "is not an nlupdate identification output (it holds notes.txt)" in stderr
    assert (out / "notes.txt").read_text() == "keep me"


def test_extracted_linear_frf_reads_back_through_the_project_reader(friction_file, tmp_path, capsys):
    """force_level_n = 0 marks the linear FRF; read_frf_table must accept what identify wrote."""
    from nlupdate.core.measurement.frf_files import read_frf_table

    code, _, stderr = run(capsys, "--measured", friction_file, "--out", tmp_path / "id", "--samples", 2)
    assert code == 0, stderr
    table = read_frf_table(tmp_path / "id" / "linear_frf.parquet")
    assert set(table["force_level_n"]) == {0.0} and len(table) > 10
