"""``nlupdate archive compare`` between runs of different studies (issue 25, rough edges).

Three small studies run by ``nlupdate update`` (no Prefect): A the 2-DOF study, B a
variant of it (another name, k1 alone, other force levels), T a T-beam study (another FE
model, coordinate and band). Comparing runs of different studies must exit 0, say what
each run is (study, parameters, targets, steps, measured curves and levels) and compare
only what both have: the plot is drawn at the force levels both runs measured and
predicted, and not at all when the runs share no curve. Expected values come from the
study dicts the test wrote, not from the code under test.
"""
from __future__ import annotations

import json

import pytest

from nlupdate.app.cli import main
from studies import small_two_dof_study, write_study

TWO_DOF_FORCES = [0.01, 20.0, 60.0]
VARIANT_FORCES = [0.01, 20.0, 40.0]


def tbeam_study() -> dict:
    """A small T-beam chain: mode 1 of the surrogate with a cubic spring at the tip."""
    return {
        "study": {"name": "tbeam-small"},
        "measured": {"simulate": {
            "input_dof": "tip:uz", "forces_n": [0.01, 20.0], "frequencies_hz": [34.0, 54.0, 81], "noise": 0.01,
            "seed": 1, "parameters": {"E": 195e9}, "loss_factor": 0.02,
            "adapter": {"kind": "surrogate", "model": "tbeam", "options": {"coordinates": ["tip:uz"], "n_modes": 4}},
            "nonlinear": [{"type": "cubic", "dofs": ["tip:uz"], "k3": 3e9}]}},
        "identification": {"response_dof": "tip:uz", "input_dof": "tip:uz", "elements": ["cubic"],
                           "half_window": 0.05, "samples": 4, "seed": 1},
        "adapter": {"kind": "surrogate", "model": "tbeam",
                    "options": {"coordinates": ["tip:uz"], "n_modes": 2, "global_modes_only": True}},
        "parameters": [{"name": "E", "unit": "Pa", "start": 210e9, "lower": 150e9, "upper": 260e9}],
        "targets": {"from_identification": True, "modes": [1]},
        "eigensensitivity": {"formulas": ["central2"]},
        "prediction": {"adapter_options": {"n_modes": 4, "global_modes_only": False}, "candidates": "best"},
    }


@pytest.fixture(scope="module")
def archives(tmp_path_factory):
    folder = tmp_path_factory.mktemp("compare-studies")
    two_dof = small_two_dof_study()
    two_dof["measured"]["simulate"]["forces_n"] = TWO_DOF_FORCES
    variant = small_two_dof_study()
    variant["study"]["name"] = "two-dof-variant"
    variant["measured"]["simulate"]["forces_n"] = VARIANT_FORCES
    variant["parameters"] = [{**variant["parameters"][0], "start": 0.9e6}]
    studies = {"a": two_dof, "b": variant, "t": tbeam_study()}
    out = {}
    for name, study in studies.items():
        path = write_study(folder / f"{name}.toml", study)
        assert main(["update", str(path), "--out", str(folder / "runs" / name), "--quiet"]) == 0
        out[name] = folder / "runs" / name
    return folder, studies, out


def compare_json(capsys, a, b, plot) -> dict:
    assert main(["archive", "compare", str(a), str(b), "--json", "--plot", str(plot)]) == 0
    return json.loads(capsys.readouterr().out)


def test_runs_of_different_models_are_listed_not_refused(archives, capsys, tmp_path):
    _, studies, runs = archives
    report = compare_json(capsys, runs["a"], runs["t"], tmp_path / "a-vs-t.png")
    assert report["same_study"] is False
    overview = {row["field"]: row for row in report["overview"]}
    assert (overview["study"]["a"], overview["study"]["b"]) == ("two-dof", "tbeam-small")
    assert overview["parameters"]["a"].startswith("k1") and overview["parameters"]["b"] == "E (Pa)"
    assert overview["FE model"]["a"] == "lumped" and overview["FE model"]["b"] == "surrogate tbeam"
    assert (overview["measured curves (response/input)"]["b"]) == "tip:uz/tip:uz"
    assert overview["force levels (N)"]["a"] == "0.01, 20, 60" and overview["force levels (N)"]["b"] == "0.01, 20"
    assert "Hz" in overview["targets"]["a"] and overview["targets"]["status"] == "changed"
    assert overview["chain steps"]["a"].endswith("predictions") and overview["chain steps"]["status"] == "same"
    # results both runs have are compared; the identified k3 of both (truths 1e10 and 3e9 N/m³)
    k3 = next(row for row in report["results"] if row["section"] == "identified" and row["field"] == "k3")
    assert k3["status"] == "changed" and k3["a"][0] == pytest.approx(1e10, rel=0.1) and k3["b"][0] == pytest.approx(3e9, rel=0.1)
    # no curve in common: no plot, and the reason names both runs' curves
    assert report["plot"] is None and not (tmp_path / "a-vs-t.png").exists()
    assert "no curve in common" in report["plot_note"] and "tip:uz/tip:uz" in report["plot_note"]
    assert main(["archive", "compare", str(runs["a"]), str(runs["t"]), "--plot", str(tmp_path / "x.png")]) == 0
    text = capsys.readouterr().out
    assert "different studies (two-dof, tbeam-small)" in text and "only in A" in text and "--all lists them" in text
    assert "plot: none — the runs measured and predicted no curve in common" in text
    assert "      A: k1 (N/m)\n      B: E (Pa)" in text


def test_the_plot_holds_only_the_force_levels_both_runs_have(archives, capsys, tmp_path):
    _, _, runs = archives
    report = compare_json(capsys, runs["a"], runs["b"], tmp_path / "a-vs-b.png")
    common = sorted(set(TWO_DOF_FORCES) & set(VARIANT_FORCES))
    left_out = sorted(set(TWO_DOF_FORCES) ^ set(VARIANT_FORCES))
    assert report["plot"] == str(tmp_path / "a-vs-b.png") and (tmp_path / "a-vs-b.png").is_file()
    assert report["plot_note"] == (f"response 0, input 0 at {', '.join(f'{f:g}' for f in common)} N (the force levels "
                                   f"both runs have; {', '.join(f'{f:g}' for f in left_out)} N left out); each run's "
                                   f"updated model its study ranked best")
    overview = {row["field"]: row for row in report["overview"]}
    assert overview["study"]["b"] == "two-dof-variant" and overview["parameters"]["status"] == "same"
