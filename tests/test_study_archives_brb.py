"""A study archive of the public Brake–Reuss beam (tests/data/brb: its four force-controlled
levels at acc3) read back later: ``nlupdate archive list`` and ``compare``, and what
``nlupdate update`` prints when the study ends.

The study identifies a Jenkins element (which does not describe the beam at acc3: the
identification is NOT TRUSTWORTHY, tests/test_real_measurements.py), updates k1 and m1 of a
one-mass model in two parameter sets, predicts every level with both runs and holds the top
level out (an extrapolation). Expected values come from the archive's own tables and JSON
read here (parquet, json), never from the code that reads them back.
"""
from __future__ import annotations

import contextlib
import hashlib
import io
import json
import re
import shutil
from pathlib import Path

import pandas as pd
import pytest
import tomli_w

import nlupdate
from nlupdate.app.cli import main

from cli_runs import run_cli
from test_real_measurements import BRB

RUN_ID = "20261129T000000Z-0000000a"


def brb_study() -> dict:
    return {"study": {"name": "brb-archive"},
            "measured": {"file": str(BRB), "coordinates": {str(BRB): ["acc3:-y", "acc3:y"]}},
            "identification": {"response_dof": "acc3:y", "input_dof": "acc3:y", "elements": ["jenkins"],
                               "samples": 4},
            "adapter": {"kind": "lumped", "options": {"masses": [1.8], "stiffnesses": [4.6e5]}},
            "parameters": [{"name": "k1", "unit": "N/m", "start": 4.6e5, "lower": 4.0e5, "upper": 5.0e5},
                           {"name": "m1", "unit": "kg", "start": 1.8, "lower": 1.7, "upper": 1.9}],
            "targets": {"from_identification": True, "modes": [1], "response_dof": "acc3:y", "input_dof": "acc3:y",
                        "model_response_dof": "x1", "model_input_dof": "x1"},
            "eigensensitivity": {"parameter_sets": [["k1"], ["m1"]]},
            "prediction": {"candidates": "all"},
            "validation": {"hold_out": "top", "models": ["lines"], "response_controlled": "off"}}


@pytest.fixture(scope="module")
def archive(tmp_path_factory):
    """(results root, the run's folder, what ``nlupdate update`` printed)."""
    folder = tmp_path_factory.mktemp("brb-archive")
    (folder / "study.toml").write_text(tomli_w.dumps(brb_study()))
    run = folder / "results" / "brb-archive" / RUN_ID
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        assert main(["update", str(folder / "study.toml"), "--out", str(run), "--quiet"]) == 0
    return folder / "results", run, printed.getvalue()


def test_compare_sees_the_held_out_predictions(archive, tmp_path, capsys):
    """The held-out level's prediction is a result of the run: a run whose prediction differs
    is not the same run (compare said '0 of 54 fields differ' and rerun 'REPRODUCED' whatever
    the held-out predictions were), and the chain steps name the validation."""
    root, run, _ = archive
    other = tmp_path / "results" / "brb-archive" / "20261129T000001Z-0000000b"
    shutil.copytree(run, other)
    validation = json.loads((run / "validation.json").read_text())
    (held,) = validation["held_out"]
    held["resonance_hz"]["predicted"] += 0.5  # Hz: the other run predicted the top level 0.5 Hz higher
    (other / "validation.json").write_text(json.dumps(validation))
    code, out, err = run_cli(capsys, "archive", "compare", run, other, "--root", root, "--json")
    assert code == 0, err
    compared = json.loads(out)
    steps = next(row for row in compared["overview"] if row["field"] == "chain steps")
    assert steps["a"].endswith("predictions, validation"), steps
    rows = {row["field"]: row for row in compared["results"] if row["section"] == "held-out levels"}
    name = f"lines at {held['level']:g}"
    changed = rows[f"{name}: resonance (Hz) predicted"]
    assert changed["status"] == "changed"
    assert changed["b"][0] - changed["a"][0] == pytest.approx(0.5, rel=1e-9)
    table = pd.read_parquet(run / "tables" / "validation.parquet")
    assert changed["a"][0] == pytest.approx(table["resonance_hz_predicted"].item(), rel=1e-12)
    assert rows[f"{name}: model"]["a"] == table["model"].item() == "lines"
    assert all(row["status"] == "same" for field, row in rows.items() if "resonance (Hz) predicted" not in field)


def test_list_quotes_the_best_runs_own_frac_and_counts_the_warnings(archive, capsys):
    """The line names the best run, so its FRAC is that run's lowest over the levels (it was the
    lowest of every predicted run: 0.716, the {m1} run's, beside the best {k1} whose lowest is
    0.721); and a run whose results are not to be trusted says so (the BRB's identification is
    NOT TRUSTWORTHY: the line read 'complete' and the numbers alone)."""
    root, run, _ = archive
    code, out, err = run_cli(capsys, "archive", "list", "--root", root, "--json")
    assert code == 0, err
    (entry,) = json.loads(out)
    ranking = pd.read_parquet(run / "tables" / "ranking.parquet")
    best = ranking.loc[ranking["rank"] == 1, "candidate"].item()
    correlation = pd.read_parquet(run / "tables" / "correlation.parquet")
    assert entry["best"] == best
    assert entry["min_frac"] == pytest.approx(correlation.loc[correlation["model"] == best, "frac"].min(), rel=1e-12)
    assert correlation.loc[correlation["model"] != "initial", "frac"].min() < entry["min_frac"]  # the case it was wrong
    manifest = json.loads((run / "manifest.json").read_text())
    # the identification's two; each run's stop at the default frequency tolerance (1e-4), coarser than the
    # resonance's 1.6e-6 (its ± was finer than where it stopped); the held-out top level's resonance band that tests
    # nothing (±1.3 Hz, wider than twice the levels' spread) and its extrapolation (the manifest kept the study's
    # warnings alone: a run whose held-out levels missed listed as 'complete')
    assert [w["source"] for w in manifest["warnings"]] == [
        "identification", "identification", "eigensensitivity forward O(h) {k1}", "eigensensitivity forward O(h) {m1}",
        "validation", "validation"]
    assert all("frequency_tolerance" in w["message"] for w in manifest["warnings"][2:4])
    assert "they test nothing" in manifest["warnings"][4]["message"]
    assert "held-out level 1.46 N lies above the highest kept level" in manifest["warnings"][5]["message"]
    assert entry["warnings"] == 6
    code, out, _ = run_cli(capsys, "archive", "list", "--root", root)
    (line,) = out.strip().splitlines()
    assert "complete, 6 warnings (archive show)" in line and f"min FRAC {entry['min_frac']:.3f}" in line


def test_update_says_what_not_to_trust_before_the_numbers(archive):
    """``nlupdate update``'s last lines: every warning of the archive's summary (the
    identification's, and the held-out top level's extrapolation, which the terminal did not
    print at all) before the targets and updated values they qualify (the identification's
    came after them, last)."""
    _, run, printed = archive
    lines = printed.strip().splitlines()
    first_number = next(i for i, line in enumerate(lines) if line.startswith("study 'brb-archive': targets"))
    warned = [line for line in lines if line.startswith("warning: ")]
    assert warned == lines[:len(warned)] and len(warned) <= first_number, printed
    manifest = json.loads((run / "manifest.json").read_text())
    for warning in manifest["warnings"]:
        assert f"warning: {warning['source']}: {warning['message']}" in warned
    validation = json.loads((run / "validation.json").read_text())
    (held,) = validation["held_out"]
    assert any(line.startswith(f"warning: validation: held-out level {held['level']:g} N lies above the highest kept "
                               "level") and "an extrapolation" in line for line in warned), printed


def test_a_loss_factor_fitted_onto_its_bound_is_a_warning(tmp_path, capsys):
    """The BRB read with the sensor's sign reversed (acc3:y against acc3:y): no modal loss
    factor reproduces the lowest level's curve, and the low-force fit ends on the upper end of
    its search, η = 0.2 (docs/study-files.md, [prediction] loss_factor; the correctly signed
    beam fits 0.0035). The summary said 'loss factor 0.2, fitted to the 0.1947 N measurement'
    without a word, in every prediction; now the report, the terminal and the manifest say the
    fit is on its bound."""
    study = brb_study()
    study["measured"]["coordinates"] = {str(BRB): ["acc3:y", "acc3:y"]}
    del study["validation"]  # the reversed curve has no driving-point resonance to validate
    (tmp_path / "study.toml").write_text(tomli_w.dumps(study))
    code, out, err = run_cli(capsys, "update", tmp_path / "study.toml", "--out", tmp_path / "run", "--quiet")
    assert code == 0, err
    manifest = json.loads((tmp_path / "run" / "manifest.json").read_text())
    (warning,) = [w for w in manifest["warnings"] if w["kind"] == "loss_factor_at_bound"]
    assert "upper bound of its search (0.0001–0.2)" in warning["message"]
    assert f"warning: prediction: {warning['message']}" in out.splitlines()
    report = (tmp_path / "run" / "report.md").read_text()
    lines = [line for line in report.splitlines() if line.startswith("* **Prediction**")]
    assert len(lines) == 3 and all("loss factor 0.2, fitted to the 0.1947 N measurement, on the upper bound" in line
                                   for line in lines), lines
    # the Jenkins fit ran off with kf (9e47 N/m, 1e41× its start): said so, not printed as a number, in the
    # summary, the identification table, the manifest and the terminal (it read 'kf = 8.955e+47')
    (diverged,) = [w for w in manifest["warnings"] if w["kind"] == "diverged"]
    assert diverged["subject"] == "kf" and f"warning: identification: {diverged['message']}" in out.splitlines()
    identified = next(line for line in report.splitlines() if line.startswith("* **Identified**"))
    assert re.search(r"kf diverged \(\d\.\d+e\+4\d N/m\): the data support no finite value of it;", identified)
    assert "kf = " not in identified and re.search(r"slip_force = \S+ ± \S+ N", identified)
    assert re.search(r"^\| kf \| N/m \| kf diverged \(.*\| – \| none \(diverged\) \|", report, re.MULTILINE)
    assert not re.search(r"8\.9\d*e\+47(?! N/m\): the data support no finite)", report)


def test_the_correctly_signed_beam_fits_its_loss_factor_inside_the_search(archive):
    _, run, _ = archive
    kinds = [w["kind"] for w in json.loads((run / "manifest.json").read_text())["warnings"]]
    assert kinds == ["levels_disagree", "residual_above_noise", "stopped_short", "stopped_short", "validation",
                     "validation"]


def package_sources_sha256() -> str:
    """SHA-256 over the nlupdate package's Python files in name order, each as its name
    ('nlupdate/…') and its bytes: computed here from the files themselves."""
    package = Path(nlupdate.__file__).parent
    digest = hashlib.sha256()
    for path in sorted(p for p in package.rglob("*.py") if "__pycache__" not in p.parts):
        digest.update(str(path.relative_to(package.parent)).encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def test_an_archive_names_the_code_that_ran(archive, tmp_path, capsys):
    """A git commit does not name the code of a tree with local changes (nor of an installed
    copy: version 0.1.0), so the manifest keeps a hash of the sources that ran, and compare
    (and rerun, which says 'the same ... package versions as the original run') tells two runs
    of different code apart; it compared the commit and 'local changes: True' alone."""
    root, run, _ = archive
    manifest = json.loads((run / "manifest.json").read_text())
    assert manifest["environment"]["code_sha256"] == package_sources_sha256()
    other = tmp_path / "results" / "brb-archive" / "20261129T000001Z-0000000b"
    shutil.copytree(run, other)
    manifest["environment"]["code_sha256"] = "0" * 64  # another tree at the same commit
    (other / "manifest.json").write_text(json.dumps(manifest))
    code, out, err = run_cli(capsys, "archive", "compare", run, other, "--root", root, "--json")
    assert code == 0, err
    changed = [(row["section"], row["field"]) for row in json.loads(out)["inputs"] if row["status"] != "same"]
    assert changed == [("versions", "nlupdate code sha256")]


def test_a_study_per_volt_names_its_levels_in_volts(tmp_path, capsys):
    """The BRB's table stated per volt (reference_unit = "V", as an amplifier-voltage test is
    read: levels in V, FRFs in m/V): every level the report and compare name is in V. The
    identification section read 'from the 0.1947 N (low)', the predictions 'fitted to the
    0.1947 N measurement' and 'force level (N)', compare 'FRAC … at 0.1947 N' and 'force
    levels (N)'."""
    from nlupdate.study import load_study
    from nlupdate.study.steps.measured import measured_table

    study = brb_study()
    (tmp_path / "brb.toml").write_text(tomli_w.dumps(study))
    with pytest.warns(Warning):  # the file's notes on its runs
        table = measured_table(load_study(tmp_path / "brb.toml"))
    assert set(table["reference_unit"]) == {"N"}
    table.assign(reference_unit="V").to_parquet(tmp_path / "brb_per_volt.parquet", index=False)
    study["study"]["name"] = "brb-per-volt"
    study["measured"] = {"file": "brb_per_volt.parquet"}
    del study["validation"]
    (tmp_path / "study.toml").write_text(tomli_w.dumps(study))
    run = tmp_path / "results" / "brb-per-volt" / RUN_ID
    code, _, err = run_cli(capsys, "update", tmp_path / "study.toml", "--out", run, "--quiet")
    assert code == 0, err
    report = (run / "report.md").read_text()
    assert "The reference is the excitation voltage" in report
    assert "0.1947 V (low) and 3 high levels (0.4886–1.46 V)" in report
    assert report.count("fitted to the 0.1947 V measurement") == 3 and "| force level (V) |" in report
    # the summary's values carry their units, per volt where the element's declares N (they had none)
    identified = next(line for line in report.splitlines() if line.startswith("* **Identified**"))
    assert re.search(r"kf = \S+ ± \S+ V/m;", identified) and re.search(r"slip_force = \S+ ± \S+ V\b", identified)
    # the updated model is physical: k1 in the N/m its [[parameters]] entry declares, the only N left
    physical = re.sub(r"\bk1 = [^;(|]*?N/m|\| k1 \(N/m\) \|", "", report)
    assert re.search(r"\bk1 = \S+ ± \S+ N/m", report)
    assert not re.search(r"\d N\b|\(N\)", physical), re.findall(r".{40}(?:\d N\b|\(N\)).{10}", physical)
    code, out, err = run_cli(capsys, "archive", "compare", run, run, "--root", tmp_path / "results", "--all")
    assert code == 0, err
    assert "force levels (V): 0.1947, 0.4886, 0.9699, 1.46" in out and "initial at 0.1947 V" in out
    assert not re.search(r"\d N\b|\(N\)", out)
    # the figures of the archive and of compare label the levels and |H| per volt too
    from nlupdate.reporting.catalogue import open_run
    from nlupdate.reporting.compare import best_prediction
    from nlupdate.reporting.prediction_plots import measured_frfs_figure, predictions_figure

    measured = pd.read_parquet(run / "tables" / "measured.parquet")
    (ax,) = measured_frfs_figure(measured, "acc3:y", "acc3:y").axes
    assert ax.get_ylabel().endswith("(m/V)") and ax.get_legend_handles_labels()[1][0] == "0.1947 V"
    figure = predictions_figure(measured, [best_prediction(open_run(run))], "acc3:y", "acc3:y")
    titles = [a.get_title() for a in figure.axes if a.get_title()]
    assert titles and all(re.match(r"[\d.]+ V — ", t) for t in titles), titles
    assert all("(m/N)" not in a.get_ylabel() for a in figure.axes)


def test_a_validation_on_the_reversed_sign_says_where_the_sign_is_stated(tmp_path, capsys):
    """[validation] on the BRB read with the sensor's sign reversed: the one line names the
    fault (a negative modal constant at the driving point) and where the direction is stated;
    it ended at 'no driving-point resonance to take φ_f from'."""
    study = brb_study()
    study["measured"]["coordinates"] = {str(BRB): ["acc3:y", "acc3:y"]}
    for table in ("identification", "adapter", "parameters", "targets", "eigensensitivity", "prediction"):
        del study[table]
    (tmp_path / "study.toml").write_text(tomli_w.dumps(study))
    code, _, err = run_cli(capsys, "update", tmp_path / "study.toml", "--out", tmp_path / "run", "--quiet")
    (line,) = [line for line in err.splitlines() if "error" in line]
    assert code == 2 and "[validation]" in line and "modal constant -0.39" in line and "NODE:-DIR" in line, err


def test_a_study_is_told_its_own_key_for_the_coordinates_of_a_run_file(tmp_path, capsys):
    """[amplitude] response_controlled = the BRB file, whose runs name no coordinates: the line
    gives the study's form of the fix, not only the command's option (--coordinates)."""
    (tmp_path / "study.toml").write_text(tomli_w.dumps(
        {"study": {"name": "brb-runs"}, "amplitude": {"response_controlled": [str(BRB)], "backbone": "polynomial"}}))
    code, _, err = run_cli(capsys, "update", tmp_path / "study.toml", "--out", tmp_path / "run", "--quiet")
    (line,) = [line for line in err.splitlines() if "error" in line]
    assert code == 2 and "study.toml: [amplitude]" in line, err
    assert 'coordinates = { "ForcedFrequencyResponses.mat" = ["RESPONSE", "INPUT"] }' in line, line


def test_the_best_updated_model_says_its_targets_are_not_trustworthy(archive):
    """The targets are the modes of the extracted linear FRF (from_identification), which the
    identification calls NOT TRUSTWORTHY: the summary's updated-model line says so where it
    gives the values (it gave k1 = 4.573e+05 ± 1.5 as if the targets were the beam's)."""
    _, run, _ = archive
    report = (run / "report.md").read_text()
    (line,) = [line for line in report.splitlines() if line.startswith("* **Best updated model**")]
    assert "targets are the modes of an identification that is not trustworthy" in line, line


IMPACT = Path(__file__).parent / "data" / "brb" / "HammerImpact_1600Hz.mat"


@pytest.mark.parametrize("table, expected", [
    # a model twice was fitted and judged twice, every warning said twice
    ({"validation": {"hold_out": "top", "models": ["lines", "lines"]}},
     "study.toml: [validation] key 'models': expected distinct names"),
    # an input the table does not have read 'no driving-point FRF at 'nope'; choose a response among []'
    ({"amplitude": {"measured": True, "input_dof": "nope", "shapes": {"acc3:y": 0.7271}}},
     "input_dof nope: the table has input_dof acc3:y"),
    # the held-out levels' input is chosen by the rule every reader of a measured table follows
    ({"validation": {"hold_out": "top", "input_dof": "nope"}},
     "study.toml: [validation] input_dof nope: the table has input_dof acc3:y"),
    # the hammer record holds three channels: a study names one with its table's key, not --channel
    ({"amplitude": {"ring_down": [str(IMPACT)]}}, "choose one with --channel NAME (in a study, the reading table's "
                                                  "channel)"),
    # a held amplitude with no response-controlled run to hold was accepted and never read
    ({"amplitude": {"measured": True, "shapes": {"acc3:y": 0.7271}, "held_amplitudes": {"Rc5": 20.0}}},
     "[amplitude] key 'held_amplitudes': expected nothing without response_controlled files"),
])
def test_bad_study_input_is_one_line_with_the_studys_own_words(tmp_path, capsys, table, expected):
    study = {"study": {"name": "brb-bad"},
             "measured": {"file": str(BRB), "coordinates": {str(BRB): ["acc3:-y", "acc3:y"]}}, **table}
    (tmp_path / "study.toml").write_text(tomli_w.dumps(study))
    code, _, err = run_cli(capsys, "update", tmp_path / "study.toml", "--out", tmp_path / "run", "--quiet")
    (line,) = [line for line in err.splitlines() if "error" in line]
    assert code == 2 and "study.toml: [" in line and expected in line, err


def test_compare_draws_the_run_the_study_ranked_best(tmp_path, capsys):
    """With the identified loss factor on the BRB, the study ranks the {k1} run first
    (weighted |frequency error| 0.0005 % against 0.0011 %) while the {m1} run's prediction
    has the higher mean FRAC (0.89456 against 0.89450): ``archive compare`` drew and named
    the higher mean FRAC as each run's best; it draws the run of the archived ranking's
    rank 1, as ``archive list`` and the report name it, and says so."""
    study = brb_study()
    study["prediction"]["loss_factor"] = "identified"
    del study["validation"]
    (tmp_path / "study.toml").write_text(tomli_w.dumps(study))
    run = tmp_path / "results" / "brb-archive" / RUN_ID
    assert run_cli(capsys, "update", tmp_path / "study.toml", "--out", run, "--quiet")[0] == 0
    ranking = pd.read_parquet(run / "tables" / "ranking.parquet")
    ranked = ranking.loc[ranking["rank"] == 1, "candidate"].item()
    mean_frac = pd.read_parquet(run / "tables" / "correlation.parquet").groupby("model")["frac"].mean()
    assert mean_frac.drop("initial").idxmax() != ranked  # the case that was drawn wrong
    from nlupdate.reporting.catalogue import open_run
    from nlupdate.reporting.compare import best_prediction

    best = best_prediction(open_run(run))
    assert best.name == ranked and set(best.correlation["model"]) == {ranked}
    code, out, err = run_cli(capsys, "archive", "compare", run, run, "--root", tmp_path / "results", "--json")
    assert code == 0, err
    assert json.loads(out)["plot_note"].endswith("each run's updated model its study ranked best")
    report = (run / "report.md").read_text()
    assert f"* **Best updated model** for the user weights: `{ranked}`" in report
