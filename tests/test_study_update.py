"""Study files (updating part) and ``nlupdate update``: the sequential, Prefect-free run."""
from __future__ import annotations

import dataclasses
import json
import textwrap
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import scipy.linalg

from nlupdate.fe.adapters.lumped import LumpedAdapter
from nlupdate.app.cli import main
from nlupdate.core.model.linear import LumpedModel
from nlupdate.core.measurement.frf_table import frf_table
from nlupdate.core.measurement.frf_files import write_frf_table
from nlupdate.study import StudyError, load_study

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
MASSES = [0.1, 0.3, 0.2]
NOMINAL_K = [1e6, 1e6, 1e6, 1e6]
TRUTH = {"k1": 1.25e6, "k2": 0.8e6, "k3": 1.1e6, "k4": 1e6}
GAMMA = 0.002  # the |H| peaks are biased by ~γ² (neighbouring modes): 4e-5 here

STUDY = """
[study]
name = "lumped truth"

[adapter]
kind = "lumped"
[adapter.options]
masses = [0.1, 0.3, 0.2]
stiffnesses = [1e6, 1e6, 1e6, 1e6]
[adapter.fixed]
k3 = 1.1e6

[[parameters]]
name = "k1"
unit = "N/m"
start = 0.7e6
lower = 0.4e6
upper = 2.5e6
relative_step = 1e-4

[[parameters]]
name = "k2"
unit = "N/m"
start = 1.4e6
lower = 0.4e6
upper = 2.5e6
relative_step = 1e-4

[targets]
identification = "ident"
n_modes = 3
response_dof = "x1"
input_dof = "x1"

[eigensensitivity]
formulas = ["forward", "backward", "central2", "central4"]

[optimisation]
formula = "central2"

[[optimisation.candidates]]
name = "k1 only"
parameters = ["k1"]

[[optimisation.candidates]]
name = "k1 and k2, mode 3 first"
parameters = ["k1", "k2"]
weights = [0.1, 0.1, 1.0]
start = {k2 = 1.0e6}

[comparison]
loss_factors = 0.002
user_weights = {mode1 = 1.0}
"""


def chain_frequencies(k1, k2, k3=TRUTH["k3"], k4=TRUTH["k4"]):
    """Natural frequencies (Hz) of the chain, solved here (not by the adapter)."""
    stiffness = np.array([[k1 + k2, -k2, 0.0], [-k2, k2 + k3, -k3], [0.0, -k3, k3 + k4]])
    return np.sqrt(scipy.linalg.eigh(stiffness, np.diag(MASSES), eigvals_only=True)) / (2 * np.pi)


def write_identification(directory: Path) -> None:
    """Linear FRF of the truth model (direct solve, D = γK) as an identification result."""
    mass, stiffness = LumpedAdapter(MASSES, NOMINAL_K).matrices(TRUTH)
    frequencies = np.arange(100.0, 1000.0, 0.05)
    h = LumpedModel.with_loss_factor(mass, stiffness, GAMMA).receptance(2 * np.pi * frequencies, [0], [0])[:, 0, 0]
    directory.mkdir()
    write_frf_table(frf_table(frequencies, 1.0, "x1", "x1", h), directory / "linear_frf.parquet")


@pytest.fixture
def study_file(tmp_path):
    write_identification(tmp_path / "ident")
    path = tmp_path / "study.toml"
    path.write_text(STUDY)
    return path


def test_cli_runs_a_study_from_an_identification_result(study_file, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["update", str(study_file), "--out", str(out)]) == 0
    assert "converged (frequency)" in capsys.readouterr().out

    assert {p.name for p in out.iterdir()} == {"manifest.json", "report.md", "study.toml", "tables", "plots", "inputs",
                                            ".nlupdate-output.json"}
    assert {p.name for p in (out / "tables").iterdir()} == {
        "targets.parquet", "runs.parquet", "histories.parquet", "comparison.parquet", "ranking.parquet"}
    assert {p.name for p in (out / "plots").iterdir()} == {"convergence.png", "frequency_errors.png", "candidate_frfs.png"}
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".tmp")]  # temporary directory renamed
    for png in (out / "plots").glob("*.png"):
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    report = (out / "report.md").read_text()
    assert "## Updating" in report and all(f"]({name})" in report for name in ("plots/convergence.png",))

    truth_frequencies = LumpedAdapter(MASSES, NOMINAL_K).evaluate(TRUTH).natural_frequencies_hz
    targets = pd.read_parquet(out / "tables" / "targets.parquet")
    np.testing.assert_allclose(targets["frequency_hz"], truth_frequencies, rtol=1e-4)  # peaks of the FRF
    assert json.loads((out / "manifest.json").read_text())["study"]["name"] == "lumped truth"

    candidates = pd.read_parquet(out / "tables" / "runs.parquet").set_index("candidate")
    formulas = ["forward O(h)", "backward O(h)", "central O(h²)", "central O(h⁴)"]
    for formula in formulas:
        row = candidates.loc[f"eigensensitivity {formula} {{k1, k2}}"]
        assert row["converged"] and row["reason"] == "frequency"
        assert row["iterations"] <= 5  # Gauss–Newton from (0.7, 1.4) MN/m; with the Jacobian ×2: 12
        assert row["p:k1"] == pytest.approx(TRUTH["k1"], rel=5e-3)
        assert row["p:k2"] == pytest.approx(TRUTH["k2"], rel=5e-3)
    # the weighted optimisation meets every target too: the truth is the optimum of any weighting
    assert candidates.loc["k1 and k2, mode 3 first", "p:k1"] == pytest.approx(TRUTH["k1"], rel=5e-3)
    assert candidates.loc["k1 and k2, mode 3 first", "p:k2"] == pytest.approx(TRUTH["k2"], rel=5e-3)
    assert np.isnan(candidates.loc["k1 only", "p:k2"])

    # what the tables report of each {k1, k2} model is that model, solved here
    target_hz = targets["frequency_hz"].to_numpy()
    comparison = pd.read_parquet(out / "tables" / "comparison.parquet")
    history = pd.read_parquet(out / "tables" / "histories.parquet")
    assert set(history["run"]) == set(candidates.index)
    labels = ["mode1", "mode2", "mode3"]
    points = {"initial": (0.7e6, 1.4e6)}  # every {k1, k2} run starts there (the study's starts)
    points.update({name: (row["p:k1"], row["p:k2"]) for name, row in candidates.iterrows() if name != "k1 only"})
    # a run that does not update k2 holds it at its [[parameters]] start, as its prediction does
    points["k1 only"] = (candidates.loc["k1 only", "p:k1"], 1.4e6)
    for name, (k1, k2) in points.items():
        rows = comparison[comparison["candidate"] == name].set_index("mode").loc[labels]
        expected = chain_frequencies(k1, k2)
        np.testing.assert_allclose(rows["f_hz"], expected, rtol=1e-10, err_msg=name)
        np.testing.assert_allclose(rows["error_pct"], 100 * (expected / target_hz - 1), rtol=1e-8, atol=1e-10, err_msg=name)
    for name in points.keys() - {"initial"}:
        run = history[history["run"] == name]
        k2 = run["p:k2"] if name != "k1 only" else pd.Series(1.4e6, index=run.index)
        assert [run["p:k1"].iloc[-1], k2.iloc[-1]] == pytest.approx(list(points[name]), rel=1e-12)
        for index, step in run.iterrows():  # every iterate of the history
            np.testing.assert_allclose(step[[f"f_hz:{m}" for m in labels]].to_numpy(float),
                                       chain_frequencies(step["p:k1"], k2[index]), rtol=1e-10)

    # FRAC against the truth's FRF: the updated models ≈ 1, the initial one far from it
    updated = comparison[comparison["candidate"] == "eigensensitivity central O(h⁴) {k1, k2}"]
    assert updated["frac"].min() > 0.999
    initial = comparison[comparison["candidate"] == "initial"]
    assert initial["frac"].max() < 0.1
    assert (initial["frac"].to_numpy() < updated["frac"].to_numpy()).all()

    # user weights {mode1 = 1}: ranked by |f1 error|, which for the {k1, k2} models is known here
    ranking = pd.read_parquet(out / "tables" / "ranking.parquet").set_index("candidate")
    assert ranking["weighted_abs_error_pct"].is_monotonic_increasing and ranking["rank"].tolist() == list(range(1, 8))
    for name, (k1, k2) in points.items():
        expected_error = abs(100 * (chain_frequencies(k1, k2)[0] / target_hz[0] - 1))
        assert ranking.loc[name, "weighted_abs_error_pct"] == pytest.approx(expected_error, rel=1e-8)
    assert ranking.index[-1] == "initial"

    assert main(["update", str(study_file), "--out", str(out)]) == 2
    assert "--overwrite" in capsys.readouterr().err
    assert main(["update", str(study_file), "--out", str(out), "--overwrite"]) == 0


@pytest.mark.parametrize(
    "edit, message",
    [
        (lambda s: s.replace("formulas =", "formulae ="), "unknown key(s) ['formulae'] in [eigensensitivity]"),
        (lambda s: s.replace('"central4"]', '"central6"]'), "[eigensensitivity] key 'formulas': expected distinct names"),
        (lambda s: s.replace('kind = "lumped"', 'kind = "abaqus"'), "[adapter] key 'kind': expected one of"),
        (lambda s: s.replace("start = 0.7e6", 'start = "0.7e6"'), "[parameters #1] key 'start': expected a finite number"),
        (lambda s: s.replace("start = 0.7e6", "start = 3e6"), "[parameters #1]: parameter 'k1': start"),
        (lambda s: s.replace("n_modes = 3", 'frequencies_hz = [1.0]\nn_modes = 3'), "[targets]: expected exactly one of"),
        (lambda s: s.replace("[comparison]", "[updating]\nmax_workers = 2\n[comparison]"),
         "[updating] key 'max_workers': expected nothing: this key was removed (parallel runs are chosen when running"),
        (lambda s: s.replace('identification = "ident"', "from_identification = true"),
         "[targets] key 'from_identification': expected an [identification] table"),
        (lambda s: s.replace("formulas =", 'parameter_sets = [["k1"], ["k9"]]\nformulas ='),
         "[eigensensitivity] key 'parameter_sets': expected distinct names of [[parameters]]"),
        (lambda s: s.replace("n_modes = 3", 'n_modes = 3\nfrf_method = "circle"'), "[targets] key 'frf_method': expected one of"),
        (lambda s: s.replace('parameters = ["k1"]', 'parameters = ["k9"]'), "[optimisation.candidates #1] key 'parameters'"),
        (lambda s: s.replace("k3 = 1.1e6", "k1 = 1.1e6"), "[adapter.fixed] key 'k1'"),
        (lambda s: s.replace("[comparison]", "[comparison]\nband_fraction = -1"), "[comparison] key 'band_fraction': expected a number > 0"),
        (lambda s: s.replace("{mode1 = 1.0}", "{mode9 = 1.0}"), "[comparison] key 'user_weights': expected weights of target modes"),
        (lambda s: s.replace("weights = [0.1, 0.1, 1.0]", "weights = [0.1, 1.0]"),
         "[optimisation.candidates #2] key 'weights': expected a list of 3 numbers"),
        (lambda s: s.split("[eigensensitivity]")[0], "needs an [eigensensitivity] table, an [optimisation] table or both"),
        (lambda s: s.replace("[study]", "[study\n"), "not valid TOML"),
    ],
)
def test_study_errors_name_the_file_table_and_expected_form(tmp_path, edit, message):
    (tmp_path / "ident").mkdir()  # the identify output the study names exists; the mistake is elsewhere
    path = tmp_path / "bad.toml"
    path.write_text(edit(STUDY))
    with pytest.raises(StudyError) as error:
        load_study(path)
    assert str(path) in str(error.value)
    assert message in str(error.value)


def test_an_identify_output_that_is_not_there_is_named_when_the_study_is_read(tmp_path):
    path = tmp_path / "study.toml"
    path.write_text(STUDY)
    with pytest.raises(StudyError, match="key 'identification': expected an existing identify output .*got 'ident'"):
        load_study(path)


def test_cli_reports_study_errors_in_one_line(tmp_path, capsys):
    path = tmp_path / "bad.toml"
    path.write_text(STUDY.replace('kind = "lumped"', ""))
    assert main(["update", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "[adapter] key 'kind'" in err
    assert not (tmp_path / "out").exists()


#: the case data of docs/methods.md §8 each example study must carry: targets (Hz), fixed values,
#: (start, lower, upper) per parameter, eigensensitivity formulas, candidate parameter
#: sets, and the initial f1 (Hz) its header states for the surrogate
EXAMPLE_CASES = {
    "tbeam_single_mode.toml": dict(
        targets=[40.75], fixed={}, parameters={"E": (210e9, 100e9, 300e9)},
        formulas=["central4", "central2", "backward", "forward"], sets=[], f1=46.42),
    "tbeam_three_modes.toml": dict(
        targets=[40.75, 178.0, 260.5], fixed={"transducer_mass": 0.0302, "accelerometer_mass": 0.0048},
        parameters={"E": (210e9, 185e9, 210e9), "h1": (8e-3, 7.7e-3, 8.3e-3), "h2": (1.5e-3, 1.35e-3, 1.65e-3),
                    "w1": (12e-3, 11.7e-3, 12.3e-3)},
        formulas=None, sets=[("E", "h1", "h2")] * 2 + [("E", "h2", "w1")] * 3, f1=None),
    "gunbarrel_motor_stiffness.toml": dict(
        targets=[7.46875], fixed={}, parameters={"motor_stiffness": (140e6, 10e6, 5e9)},
        formulas=["forward"], sets=[], f1=6.34),
}


@pytest.mark.parametrize("name", list(EXAMPLE_CASES))
def test_example_studies_are_valid(name):
    """Each example encodes the source's case (docs/methods.md §8), not just a loadable file."""
    case = EXAMPLE_CASES[name]
    study = load_study(EXAMPLES / name)
    assert study.adapter.kind == "surrogate"
    assert list(study.targets.frequencies_hz) == case["targets"]
    assert dict(study.fixed) == case["fixed"]
    assert {p.name: (p.start, p.lower, p.upper) for p in study.parameters} == case["parameters"]
    if case["formulas"] is None:
        assert study.eigensensitivity is None
    else:
        assert list(study.eigensensitivity.formulas) == case["formulas"]
    assert [tuple(c.parameters) for c in study.candidates] == case["sets"]
    if case["f1"] is not None:
        from nlupdate.fe.adapters.registry import build_adapter

        start = {**study.fixed, **{p.name: p.start for p in study.parameters}}
        assert build_adapter(study.adapter).evaluate(start).natural_frequencies_hz[0] == pytest.approx(case["f1"], abs=0.005)


def test_single_mode_example_reaches_the_target(tmp_path):
    """Every surrogate frequency scales with √E, so the updated E is known,
    E* = 210 GPa·(40.75/f1(210 GPa))², and so is the path of an exact-Jacobian update:
    Newton's map e → 2√(1+e) − 2 − e of e = E/E* − 1. From f1 = 46.42 Hz it meets the
    0.01 % tolerance (|√(1+e) − 1| ≤ 1e-4) after 2 iterations, with every formula."""
    out = tmp_path / "single"
    assert main(["update", str(EXAMPLES / "tbeam_single_mode.toml"), "--out", str(out)]) == 0
    comparison = pd.read_parquet(out / "tables" / "comparison.parquet")
    f_initial = comparison.loc[comparison["candidate"] == "initial", "f_hz"].item()
    assert f_initial == pytest.approx(46.42, abs=0.005)  # as the example's header says
    e_star = 210e9 * (40.75 / f_initial) ** 2
    newton = [210e9 / e_star - 1]
    while abs(np.sqrt(1 + newton[-1]) - 1) > 1e-4:
        newton.append(2 * np.sqrt(1 + newton[-1]) - 2 - newton[-1])
    assert len(newton) - 1 == 2

    runs = pd.read_parquet(out / "tables" / "runs.parquet").set_index("candidate")
    history = pd.read_parquet(out / "tables" / "histories.parquet")
    assert sorted(runs["formula"]) == sorted(["central O(h⁴)", "central O(h²)", "backward O(h)", "forward O(h)"])
    for name, run in runs.iterrows():
        assert run["converged"] and run["iterations"] == len(newton) - 1, name
        errors = history.loc[history["run"] == name, "p:E"].to_numpy() / e_star - 1
        # one-sided formulas: the Jacobian is off by h/4 = 2.5e-4, each step by that fraction
        allowed = 1e-3 * np.abs(np.r_[0.0, newton[:-1]]) + 1e-9
        assert np.all(np.abs(errors - newton) <= allowed), (name, errors, newton)
        assert run["p:E"] == pytest.approx(e_star, rel=3e-4)
    updated = comparison[comparison["candidate"] != "initial"]
    np.testing.assert_allclose(updated["f_hz"], f_initial * np.sqrt(runs.loc[updated["candidate"], "p:E"] / 210e9), rtol=1e-9)
    assert updated["error_pct"].abs().max() <= 0.01


CALCULIX_STUDY = (Path(__file__).parent / "data" / "studies" / "calculix_tbeam_E.toml").read_text()


@pytest.mark.calculix
def test_calculix_study_follows_the_square_root_law(tmp_path):
    """Solid T-beam in CalculiX: every frequency scales with √E, so E for f1 = 40.75 Hz
    is 210 GPa · (40.75 / f1(210 GPa))²."""
    path = tmp_path / "ccx.toml"
    path.write_text(CALCULIX_STUDY.replace('"ccx_runs"', repr(str(tmp_path / "runs")).replace("'", '"')))
    out = tmp_path / "out"
    assert main(["update", str(path), "--out", str(out)]) == 0
    history = pd.read_parquet(out / "tables" / "histories.parquet")
    f_initial = history["f_hz:mode1"].iloc[0]
    expected = 210e9 * (40.75 / f_initial) ** 2
    assert history["p:E"].iloc[-1] == pytest.approx(expected, rel=1e-5)
    assert history["new_evaluations"].iloc[1:].eq(2).all() and history["cached_evaluations"].iloc[1:].eq(1).all()


def test_mapdl_adapter_is_built_from_a_study(tmp_path):
    """Construction only (no MAPDL here): deck path relative to the study, coordinates."""
    (tmp_path / "beam.inp").write_text("/PREP7\n*SET,E,2.1e11\nET,1,BEAM188\n")
    study = tmp_path / "mapdl.toml"
    study.write_text(textwrap.dedent("""
        [adapter]
        kind = "mapdl"
        [adapter.options]
        deck = "beam.inp"
        parameter_names = ["E"]
        coordinates = {tip = [12, "uz"]}
        n_modes = 4
        [[parameters]]
        name = "E"
        start = 2.1e11
        lower = 1e11
        upper = 3e11
        [targets]
        frequencies_hz = [10.0]
        [eigensensitivity]
    """))
    from nlupdate.fe.adapters.mapdl import MapdlAdapter
    from nlupdate.fe.adapters.registry import build_adapter

    spec = load_study(study).adapter
    spec = dataclasses.replace(spec, options={**spec.options, "work_root": str(tmp_path / "runs")})
    adapter = build_adapter(spec)
    assert isinstance(adapter, MapdlAdapter)
    assert adapter.coordinates == {"tip": (12, "uz")} and adapter.n_modes == 4
