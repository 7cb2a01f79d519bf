"""TOML model files, the simulate command and its error messages."""

import numpy as np
import pandas as pd
import pytest

from nlupdate.app.cli import main
from nlupdate.core.model.elements import CubicStiffness, JenkinsFriction
from nlupdate.core.model.model_file import ModelFileError, load_system

from cli_runs import run_cli

ISSUE_EXAMPLE = """
[model]
kind = "lumped"
mass = [[0.1, 0.0], [0.0, 0.5]]        # kg
stiffness = [[2e6, -1e6], [-1e6, 2e6]] # N/m
damping = [[0.0, 0.0], [0.0, 0.0]]     # viscous, N s/m (optional)
loss_factor = 0.005                    # structural, D = loss_factor * K (optional)
[[nonlinear]]
type = "cubic"            # cubic | jenkins | coulomb | quadratic_damping | gap | polynomial
dofs = [0]                # one dof = to ground, two dofs = between them
k3 = 1e10
[[nonlinear]]
type = "jenkins"
dofs = [0]
kf = 8e4
slip_force = 1.0
"""


@pytest.fixture
def model_file(tmp_path):
    path = tmp_path / "model.toml"
    path.write_text(ISSUE_EXAMPLE)
    return path


def test_issue_example_model_file_loads(model_file):
    system = load_system(model_file)
    np.testing.assert_allclose(system.model.structural_damping, 0.005 * np.array([[2e6, -1e6], [-1e6, 2e6]]))
    assert system.elements == (CubicStiffness((0,), 1e10), JenkinsFriction((0,), 8e4, 1.0))


def test_modal_model_file_gives_modal_superposition(tmp_path):
    path = tmp_path / "modal.toml"
    path.write_text(
        '[model]\nkind = "modal"\nnatural_frequencies_hz = [10.0]\nmode_shapes = [[2.0]]\nloss_factors = 0.02\n'
        'dof_names = ["tip"]\n[[nonlinear]]\ntype = "polynomial"\ndofs = ["tip"]\nreal = [1e6, 0, 0]\n'
    )
    system = load_system(path)
    w = 2 * np.pi * 7.0
    wr = 2 * np.pi * 10.0
    expected = 4.0 / (wr**2 - w**2 + 0.02j * wr**2)
    assert complex(system.model.receptance(w, [0], [0])[0, 0, 0]) == pytest.approx(expected)
    assert system.elements[0].imag == (0.0,)


@pytest.mark.parametrize(
    "edit,message",
    [
        (("k3 = 1e10", "k33 = 1e10"), r"\[\[nonlinear\]\] #1: unknown key\(s\) \['k33'\]"),
        (('type = "jenkins"', 'type = "velcro"'), r"#2: unknown type 'velcro'"),
        (("dofs = [0]                # one", "dofs = [4]                # one"), r"#1: unknown dof 4"),
        (("mass = [[0.1, 0.0], [0.0, 0.5]]", "mass = [[0.1, 0.0]]"), r"\[model\]: 'mass' must be a square matrix"),
        (("slip_force = 1.0", "slip_force = -1.0"), r"#2: slip_force must be a positive number"),
        (('kind = "lumped"', 'kind = "shell"'), r"kind must be"),
    ],
)
def test_bad_model_files_name_file_table_and_key(tmp_path, edit, message):
    path = tmp_path / "bad.toml"
    path.write_text(ISSUE_EXAMPLE.replace(*edit))
    with pytest.raises(ModelFileError, match=message) as info:
        load_system(path)
    assert str(path) in str(info.value)


def test_simulate_cli_writes_all_dofs_and_matches_the_linear_receptance_at_low_force(model_file, tmp_path):
    out = tmp_path / "frf.parquet"
    code = main(["simulate", str(model_file), "--input-dof", "0", "--freqs", "600:850:26", "--forces", "1e-6,100", "--out", str(out)])
    assert code == 0
    table = pd.read_parquet(out)
    assert set(table["response_dof"]) == {"0", "1"} and set(table["force_level_n"]) == {1e-6, 100.0}
    assert len(table) == 2 * 2 * 26
    # at 1 µN the Jenkins element is stuck: the system is linear with kf added at dof 0
    low = table[(table.force_level_n == 1e-6) & (table.response_dof == "1")].sort_values("frequency_hz")
    w = 2 * np.pi * low["frequency_hz"].to_numpy()
    k = np.array([[2e6, -1e6], [-1e6, 2e6]])
    expected = [np.linalg.inv(k * (1 + 0.005j) + np.diag([8e4, 0]) - wi**2 * np.diag([0.1, 0.5]))[1, 0] for wi in w]
    np.testing.assert_allclose(low["h_real"] + 1j * low["h_imag"], expected, rtol=1e-9)


def test_simulate_noise_is_reproducible_and_methods_agree(model_file, tmp_path):
    args = ["simulate", str(model_file), "--input-dof", "0", "--freqs", "600,650,700", "--forces", "10"]
    for name, extra in (("a", ["--noise", "0.05", "--seed", "3"]), ("b", ["--noise", "0.05", "--seed", "3"]), ("c", ["--method", "fixed-point"]), ("d", [])):
        assert main(args + extra + ["--out", str(tmp_path / f"{name}.csv")]) == 0
    a, b, c, d = (pd.read_csv(tmp_path / f"{n}.csv") for n in "abcd")
    pd.testing.assert_frame_equal(a, b)
    assert not np.allclose(a["h_real"], d["h_real"])
    np.testing.assert_allclose(c[["h_real", "h_imag"]], d[["h_real", "h_imag"]], rtol=1e-6)


@pytest.mark.parametrize(
    "args,message",
    [
        (["--input-dof", "7", "--freqs", "600:850:5", "--forces", "1"], "unknown dof 7"),
        (["--input-dof", "0", "--freqs", "600-850", "--forces", "1"], "START:STOP:COUNT"),
        (["--input-dof", "0", "--freqs", "600:850:5", "--forces", "1,-2"], "--forces '1,-2'"),
        (["--input-dof", "0", "--freqs", "600:850:5", "--forces", "1", "--noise", "-1"], "argument --noise: expected a number ≥ 0"),
    ],
)
def test_simulate_errors_are_one_clear_line(model_file, tmp_path, args, message, capsys):
    code, _, stderr = run_cli(capsys, "simulate", model_file, *args, "--out", tmp_path / "x.parquet")
    assert code == 2
    lines = stderr.strip().splitlines()
    assert len(lines) in (1, 2) and message in lines[0], stderr
    assert not (tmp_path / "x.parquet").exists()


def test_missing_model_file(tmp_path):
    assert main(["simulate", str(tmp_path / "nope.toml"), "--input-dof", "0", "--freqs", "1:2:3", "--forces", "1", "--out", str(tmp_path / "o.csv")]) == 2


def test_simulate_by_time_integration_agrees_with_continuation(tmp_path):
    """A well-damped Duffing oscillator: few periods to steady state, so this stays quick."""
    path = tmp_path / "duffing.toml"
    path.write_text(
        '[model]\nkind = "lumped"\nmass = [[1.0]]\nstiffness = [[1e4]]\ndamping = [[40.0]]\n'
        '[[nonlinear]]\ntype = "cubic"\ndofs = [0]\nk3 = 1e8\n'
    )
    common = ["simulate", str(path), "--input-dof", "0", "--freqs", "12,16,20", "--forces", "50"]
    assert main(common + ["--method", "time", "--out", str(tmp_path / "t.csv")]) == 0
    assert main(common + ["--out", str(tmp_path / "c.csv")]) == 0
    t, c = pd.read_csv(tmp_path / "t.csv"), pd.read_csv(tmp_path / "c.csv")
    ratio = np.hypot(t.h_real, t.h_imag) / np.hypot(c.h_real, c.h_imag)
    assert np.all(np.abs(ratio - 1) < 0.02)
