"""Every tutorial script ``examples/*.py`` runs (in-process, in a temporary working folder,
writing only into the folder given on its command line) and what it prints or computes is
checked against a reference it did not compute: the analytic linear receptance, the truth
of the simulated rig, f ∝ √E, the documented truth of a measured data set.
(``tests/test_examples.py`` runs the ``examples/*.toml`` headers.)"""
from __future__ import annotations

import runpy
import sys
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
CHECKED = {"simulate_nonlinear_frf.py", "identify_nonlinearity.py", "update_linear_model.py", "predict_levels.py",
           "discover_missing_effect.py", "run_study.py"}


def run_example(name: str, tmp_path: Path, monkeypatch, *options: str) -> tuple[dict, Path]:
    """Run ``examples/name`` as ``python examples/name OUT [options]`` from an empty
    working folder; returns its globals and OUT. Nothing else may appear in the folder."""
    work = tmp_path / "cwd"
    work.mkdir(parents=True)
    out = tmp_path / "out"
    monkeypatch.chdir(work)
    monkeypatch.setattr(sys, "argv", [str(EXAMPLES / name), str(out), *options])
    namespace = runpy.run_path(str(EXAMPLES / name), run_name="__main__")
    assert sorted(p.name for p in work.iterdir()) == [], f"{name} wrote into the working folder"
    return namespace, out


def test_every_tutorial_script_is_checked_here():
    assert {p.name for p in EXAMPLES.glob("*.py")} == CHECKED


def test_simulate_low_level_is_the_stuck_linear_receptance(tmp_path, monkeypatch, capsys):
    """At 0.01 N the Jenkins joint sticks and the cubic spring is negligible: the simulated
    FRFs are the receptance of K + kf (at dof 0) with structural damping η·K."""
    namespace, out = run_example("simulate_nonlinear_frf.py", tmp_path, monkeypatch)
    printed = capsys.readouterr().out
    assert "0.01 N: resonance peak at  745.00 Hz" in printed
    data = tomllib.loads((EXAMPLES / "two_dof.toml").read_text())
    m, k = np.array(data["model"]["mass"]), np.array(data["model"]["stiffness"])
    eta, kf = data["model"]["loss_factor"], data["nonlinear"][1]["kf"]
    measured = pd.read_parquet(out / "two_dof_frf.parquet")
    low = measured[measured["force_level_n"] == 0.01]
    for dof in (0, 1):
        curve = low[low["response_dof"] == str(dof)].sort_values("frequency_hz")
        omega = 2 * np.pi * curve["frequency_hz"].to_numpy()
        stuck = k + np.diag([kf, 0.0])
        h = np.array([np.linalg.solve(stuck + 1j * eta * k - w**2 * m, [1.0, 0.0])[dof] for w in omega])
        simulated = curve["h_real"].to_numpy() + 1j * curve["h_imag"].to_numpy()
        assert np.max(np.abs(simulated - h) / np.abs(h)) < 1e-3
    # slipping softens the resonance (1 N, 5 N below 745 Hz), the cubic spring hardens it (100 N)
    peaks = namespace["peaks"]
    assert peaks[1.0][0] < peaks[0.01][0] and peaks[5.0][0] < peaks[0.01][0] < peaks[100.0][0]


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_identify_finds_the_rigs_joint_and_cubic_spring(tmp_path, monkeypatch, capsys, seed):
    """Over three noise seeds every parameter lies within 2 % and 4σ of the model file's
    truth, and the extracted linear mode within 0.05 % of √(k/m)/2π."""
    namespace, out = run_example("identify_nonlinearity.py", tmp_path, monkeypatch, "--seed", str(seed))
    printed = capsys.readouterr().out
    truth = {"k3": 1e10, "kf": 3e5, "slip_force": 1.0}  # examples/sdof.toml
    stats = namespace["found"].uncertainty.parameters
    for name, value in truth.items():
        assert abs(stats[name].value / value - 1) < 0.02, (name, stats[name].value)
        assert abs(stats[name].value - value) < 4 * stats[name].std, (name, stats[name].value, stats[name].std)
        assert f"{name:>10} = {stats[name].value:.4g}" in printed
    assert namespace["found"].natural_frequencies_hz[0] == pytest.approx(np.sqrt(2e6 / 0.1) / (2 * np.pi), rel=5e-4)
    assert "warning" not in printed
    assert (out / "identification.json").is_file()


def test_update_gives_the_modulus_that_f_proportional_to_sqrt_e_gives(tmp_path, monkeypatch, capsys):
    import nlupdate as nlu

    namespace, _ = run_example("update_linear_model.py", tmp_path, monkeypatch)
    tbeam = nlu.fe_model("surrogate", "tbeam", n_modes=2, global_modes_only=True)
    f1 = tbeam.evaluate({"E": 210e9}).natural_frequencies_hz[0]
    exact = 210e9 * (40.75 / f1) ** 2
    assert exact == pytest.approx(161.8e9, rel=1e-3)  # the benchmark's figure (source: 161.5 GPa)
    for formula, result in namespace["results"].items():
        assert result.converged, formula
        assert result.parameters["E"] == pytest.approx(exact, rel=1e-6), formula
    assert f"exact (f ∝ √E): E = {exact / 1e9:.4f} GPa" in capsys.readouterr().out


def test_chain_step_by_step_recovers_k1_and_predicts_every_level(tmp_path, monkeypatch, capsys):
    namespace, _ = run_example("predict_levels.py", tmp_path, monkeypatch)
    printed = capsys.readouterr().out
    truth = tomllib.loads((EXAMPLES / "two_dof.toml").read_text())
    k1_true = truth["model"]["stiffness"][0][0] + truth["model"]["stiffness"][0][1]  # ground spring of mass 1
    assert namespace["updated"].parameters["k1"] == pytest.approx(k1_true, rel=5e-3)
    prediction = namespace["prediction"]  # the updated model's, printed last
    assert prediction.loss_factor == pytest.approx(truth["model"]["loss_factor"], rel=0.1)
    assert prediction.correlation["frac"].min() > 0.99
    assert len(prediction.correlation) == 6
    assert "updated model (loss factor 0.0050)" in printed


def test_discovery_names_the_hidden_joint_and_cubic_spring(tmp_path, monkeypatch, capsys):
    """Truth of sdof_friction_cubic.csv (examples/discovery/README.md): kf = 1.40e5 N/m,
    slip force 11.1 N, k3 = 1.20e11 N/m³."""
    import nlupdate as nlu

    namespace, out = run_example("discover_missing_effect.py", tmp_path, monkeypatch)
    found = namespace["found"]
    parameters = {name: value for effect in found.effects for name, value in effect.parameters.items()}
    assert {effect.name for effect in found.effects} == {"dry_friction", "cubic_stiffness"}
    assert parameters["kf"] == pytest.approx(1.40e5, rel=0.02)
    assert parameters["slip_force"] == pytest.approx(11.1, rel=0.02)
    assert parameters["k3"] == pytest.approx(1.20e11, rel=0.02)
    assert found.gap_after.gap < 0.01 * found.gap_before.gap
    written = nlu.load_model(out / "augmented_model.toml")
    assert [type(e).__name__ for e in written.elements] == [type(e).__name__ for e in found.augmented.elements]
    assert "found dry_friction on dofs [0]" in capsys.readouterr().out


def _study_archive_checks(archive: Path) -> pd.DataFrame:
    runs = pd.read_parquet(archive / "tables" / "runs.parquet")
    correlation = pd.read_parquet(archive / "tables" / "correlation.parquet")
    assert (archive / "report.md").is_file()
    assert runs["converged"].all()
    assert np.allclose(runs["p:k1"], 1e6, rtol=5e-3)  # examples/two_dof.toml: k1 = 1e6 N/m
    best = correlation[correlation["model"] != "initial"]
    assert len(best) == 6 and best["frac"].min() > 0.99
    return runs


@pytest.fixture(scope="module")
def study_in_process(tmp_path_factory):
    """``python examples/run_study.py OUT``: (its globals, OUT, what it printed)."""
    with pytest.MonkeyPatch.context() as monkeypatch:
        import contextlib
        import io

        printed = io.StringIO()
        with contextlib.redirect_stdout(printed):
            namespace, out = run_example("run_study.py", tmp_path_factory.mktemp("study"), monkeypatch)
    return namespace, out, printed.getvalue()


def test_study_in_process(study_in_process):
    namespace, out, printed = study_in_process
    _study_archive_checks(namespace["archive"])
    assert namespace["archive"].parent == out
    assert "best ranked: optimisation {k1}" in printed


def test_study_as_prefect_flows_gives_the_same_numbers(tmp_path, monkeypatch, prefect_server, study_in_process):
    flows, out = run_example("run_study.py", tmp_path, monkeypatch, "--prefect")
    assert flows["archive"].is_relative_to(out / "results")
    in_process = _study_archive_checks(study_in_process[0]["archive"])
    as_flows = _study_archive_checks(flows["archive"])
    assert np.array_equal(in_process["p:k1"].to_numpy(), as_flows["p:k1"].to_numpy())
