"""A study's ``[amplitude]`` table (issue 37): one mode's amplitude-dependent modal model from
a ring-down and an impact, run through the study runner, against the time-integration truth
and against what ``nlupdate amplitude`` writes for the same inputs.

Records: the Iwan SDOF of tests/test_test_type_truth.py (m = 2 kg, 10 Hz, ζ₀ = 0.5 %,
k_t = 0.1k, F_s = k_t·1 mm), RK4-integrated there — a ring-down from 3 mm and a light tap
(50 µm), white noise of 2 % of each record's peak. Truth: the single-nonlinear-mode backbone
of its modal Iwan joint in closed form (the describing function), independent of the fit.
"""
from __future__ import annotations

import json
import tomllib
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import tomli_w

from nlupdate.app import api
from nlupdate.app.cli import main
from nlupdate.reporting.archive import write_archive
from nlupdate.reporting.catalogue import find_runs
from nlupdate.reporting.compare import result_fields
from nlupdate.study.loading import load_study
from nlupdate.study.reader import StudyError

from test_test_type_truth import band, free_decay, noisy, system, truth

FILES = ("amplitude_model.json", "backbone.csv", "backbone_points.csv", "consistency.csv", "backbone.png",
         "damping.png")


@pytest.fixture(scope="module")
def records(tmp_path_factory):
    """(the system, the folder of decay.csv, tap.csv, a second tap tap2.csv (another noise
    seed) and tap_stiff.csv: a tap of the structure 2 % stiffer, 1 % higher in frequency —
    a source that disagrees)."""
    s, folder = system(1, "iwan"), tmp_path_factory.mktemp("amplitude-study")
    t, x = free_decay(s, 3e-3 * np.sqrt(2), 80)
    pd.DataFrame({"time_s": t, "m1": noisy(x, 0)}).to_csv(folder / "decay.csv", index=False)
    t, x = free_decay(s, 0.05 * s["slip"], 40)
    pd.DataFrame({"time_s": t, "m1": noisy(x, 1)}).to_csv(folder / "tap.csv", index=False)
    pd.DataFrame({"time_s": t, "m1": noisy(x, 2)}).to_csv(folder / "tap2.csv", index=False)
    t, x = free_decay(dict(s, K=1.02 * s["K"]), 0.05 * s["slip"], 40)
    pd.DataFrame({"time_s": t, "m1": noisy(x, 3)}).to_csv(folder / "tap_stiff.csv", index=False)
    return s, folder


def amplitude_table(s: dict, **extra) -> dict:
    low, high = band(s)
    return {"ring_down": ["decay.csv"], "ring_down_fit": "segments", "impact": ["tap.csv"],
            "shapes": {"m1": float(s["phi"][0])}, "band_hz": [float(low), float(high)], "backbone": "polynomial",
            "bootstrap": 0, **extra}


def write_study(folder: Path, name: str, table: dict) -> Path:
    path = folder / f"{name}.toml"
    path.write_text(tomli_w.dumps({"study": {"name": name}, "amplitude": table}))
    return path


def command(s: dict, out: Path, *impacts: str) -> list[str]:
    """The ``nlupdate amplitude`` line of :func:`amplitude_table` (paths relative to its folder)."""
    low, high = (float(v) for v in band(s))
    return ["amplitude", "--ring-down", "decay.csv", "--ring-down-fit", "segments",
            *[part for path in impacts or ("tap.csv",) for part in ("--impact", path)],
            "--shape", f"m1={float(s['phi'][0])!r}", "--band", f"{low!r}:{high!r}", "--backbone", "polynomial",
            "--bootstrap", "0", "--out", str(out)]


def test_the_archive_holds_the_commands_files_and_the_backbone_of_the_truth(records, tmp_path, monkeypatch):
    """The study's archive: the six files ``nlupdate amplitude`` writes, byte for byte the
    command's for the same inputs; its backbone within the issue's 0.2 % (frequency) and 5 %
    (damping) of the truth from the tap's amplitude to the ring-down's largest (measured:
    0.022 % and 4.4 %); the report's section and summary line."""
    s, folder = records
    result = api.run_study(write_study(folder, "ring-down-and-tap", amplitude_table(s)))
    archive = write_archive(result, tmp_path / "archive", {"orchestration": "test"})
    written = archive / "amplitude"
    assert sorted(p.name for p in written.iterdir()) == sorted(FILES)

    backbone = pd.read_csv(written / "backbone.csv")
    f, z = truth(s, backbone["modal_amplitude"].to_numpy())
    assert backbone["modal_amplitude"].min() < 0.05 * s["slip"] < 0.5e-3 < 1e-3 < backbone["modal_amplitude"].max()
    assert np.abs(backbone["natural_frequency_hz"] / f - 1).max() < 2e-3
    assert np.abs(backbone["damping_ratio"] / z - 1).max() < 0.05
    points = pd.read_csv(written / "backbone_points.csv")
    assert set(zip(points["source"], points["test_type"])) == {("decay.csv", "ring-down"), ("tap.csv", "impact")}

    monkeypatch.chdir(folder)
    assert main(command(s, tmp_path / "cli")) == 0
    for name in FILES:
        assert (tmp_path / "cli" / name).read_bytes() == (written / name).read_bytes(), name

    report = (archive / "report.md").read_text()
    summary = report.split("## Summary", 1)[1].split("\n## ", 1)[0]
    # the model's own warning first (its f₀ the backbone's extrapolation below the tap, as the command
    # prints it), then the model
    first, second = [line for line in summary.splitlines() if line.startswith("* ")][:2]
    assert first.startswith("* **Amplitude model: the linear limit ") and "extrapolation below every sample" in first
    assert second.startswith("* **Amplitude model** (mode 1, polynomial backbone, ring-down, impact): linear limit ")
    assert "disagree" not in summary and "## Amplitude-dependent modal model" in report
    assert "![amplitude backbone](amplitude/backbone.png)" in report
    model = json.loads((written / "amplitude_model.json").read_text())
    assert abs(model["natural_frequency_hz"] / truth(s, 0.0)[0] - 1) < 2e-3


def test_a_source_that_disagrees_opens_the_summary(records, tmp_path):
    """Two taps of the structure and one of a 2 % stiffer one (1 % higher in frequency):
    consistency.csv names the stiff tap alone, and the report's summary says so first."""
    s, folder = records
    table = amplitude_table(s, impact=["tap.csv", "tap2.csv", "tap_stiff.csv"])
    result = api.run_study(write_study(folder, "three-taps", table))
    archive = write_archive(result, tmp_path / "archive", {"orchestration": "test"})
    agreement = pd.read_csv(archive / "amplitude" / "consistency.csv")
    assert dict(zip(agreement["source"], agreement["consistent"])) == {
        "decay.csv": True, "tap.csv": True, "tap2.csv": True, "tap_stiff.csv": False}
    summary = (archive / "report.md").read_text().split("## Summary", 1)[1]
    first = next(line for line in summary.splitlines() if line.startswith("* "))
    assert first.startswith("* **Amplitude model: tap_stiff.csv disagrees with the joint fit"), first


def test_a_held_out_type_is_predicted_as_the_command_predicts_it(records, tmp_path, monkeypatch):
    """``hold_out_type = "impact"``: the ring-down alone predicts the tap (held_out.csv, the
    command's ``--hold-out impact``), within 0.2 % and 5 % of the tap's own sample."""
    s, folder = records
    result = api.run_study(write_study(folder, "held-tap", amplitude_table(s, hold_out_type="impact")))
    archive = write_archive(result, tmp_path / "archive", {"orchestration": "test"})
    held = pd.read_csv(archive / "amplitude" / "held_out.csv")
    assert list(held["test_type"]) == ["impact"]
    assert abs(held["frequency_error"].iloc[0]) < 2e-3 and abs(held["damping_error"].iloc[0]) < 0.05
    monkeypatch.chdir(folder)
    assert main([*command(s, tmp_path / "cli"), "--hold-out", "impact"]) == 0
    assert (tmp_path / "cli" / "held_out.csv").read_bytes() == (archive / "amplitude" / "held_out.csv").read_bytes()


@pytest.mark.parametrize("change, message", [
    ({"ring_down": [], "impact": []},
     "[amplitude]: expected a source: `measured = true` or a file in ring_down, impact, response_controlled or "
     "phase_resonance"),
    ({"ring_down": ["missing.csv"]},
     "[amplitude] key 'ring_down': expected existing files (relative to the study file), got 'missing.csv'"),
    ({"measured": True}, "[amplitude] key 'measured': expected false without a [measured] table"),
    ({"band_hz": [13.0, 7.0]}, "[amplitude] key 'band_hz': expected [LOW, HIGH] in Hz with LOW < HIGH, got [13.0, 7.0]"),
    ({"shapes": {"m1": 0.0}}, "[amplitude] key 'shapes': expected a table { coordinate = shape }, each a finite shape "
                              "≠ 0 (1/√kg)"),
    ({"input_dof": "m1"}, "[amplitude] key 'input_dof': expected nothing unless measured = true, got 'm1'"),
    ({"coordinates": {"run.mat": ["acc3:y"]}},
     "[amplitude] key 'coordinates': expected a table { FILE = [\"RESPONSE\", \"INPUT\"] }"),
    ({"hold_out_type": "modal-table"}, "[amplitude] key 'hold_out_type': expected one of ["),
])
def test_a_bad_table_is_one_line_naming_the_file_table_and_key(records, change, message):
    s, folder = records
    path = write_study(folder, "bad", amplitude_table(s, **change))
    with pytest.raises(StudyError) as raised:
        load_study(path)
    text = str(raised.value)
    assert text.startswith(f"{path}: ") and message in text and "\n" not in text, text


def test_a_source_that_cannot_be_read_fails_the_step_in_one_line(records):
    """A channel the record does not hold is found when the step reads it: one line naming
    the study file, the table and the record."""
    s, folder = records
    path = write_study(folder, "no-channel", amplitude_table(s, channel="tip"))
    with pytest.raises(StudyError) as raised:
        api.run_study(path)
    text = str(raised.value)
    assert text.startswith(f"{path}: [amplitude]: ") and "tip" in text and "\n" not in text, text


def test_an_amplitude_table_alone_is_a_study(records):
    s, folder = records
    study = load_study(write_study(folder, "alone", amplitude_table(s)))
    assert study.measured is None and study.adapter is None
    assert study.amplitude.ring_down == ("decay.csv",) and study.amplitude.shapes == {"m1": float(s["phi"][0])}
    assert set(study.input_files) == {"decay.csv", "tap.csv"}
    assert tomllib.loads(study.text)["amplitude"]["backbone"] == "polynomial"


def test_nlupdate_run_computes_the_step_once_and_archives_the_commands_files(records, prefect_server, tmp_path,
                                                                             monkeypatch):
    """``nlupdate run`` twice: the step is computed, then taken from the cache (the manifest's
    task counts), and both archives hold the command's files byte for byte, with the
    records copied into ``inputs/``."""
    s, folder = records
    path = write_study(folder, "run-twice", amplitude_table(s))
    results, cache = tmp_path / "results", tmp_path / "cache"
    archives = []
    for _ in range(2):
        assert main(["run", str(path), "--out", str(results), "--cache-dir", str(cache), "--quiet"]) == 0
        archives.append(max((results / "run-twice").iterdir(), key=lambda p: p.stat().st_mtime))
    tasks = [json.loads((a / "manifest.json").read_text())["run"]["tasks"]["amplitude"] for a in archives]
    assert (tasks[0]["computed"], tasks[0]["cached"]) == (1, 0) and (tasks[1]["computed"], tasks[1]["cached"]) == (0, 1)
    monkeypatch.chdir(folder)
    assert main(command(s, tmp_path / "cli")) == 0
    for name in FILES:
        expected = (tmp_path / "cli" / name).read_bytes()
        assert all((a / "amplitude" / name).read_bytes() == expected for a in archives), name
    fields = [result_fields(run)["amplitude backbone"] for run in find_runs(results)]
    backbone = pd.read_csv(archives[0] / "amplitude" / "backbone.csv")
    first = f"a = {backbone['modal_amplitude'].iloc[0]:.4g} m·√kg: natural frequency (Hz)"
    assert len(fields) == 2 and fields[0] == fields[1] and len(fields[0]) == 6  # what archive compare/rerun check
    assert fields[0][first].value == pytest.approx(backbone["natural_frequency_hz"].iloc[0], rel=1e-12)
    copied = json.loads((archives[0] / "manifest.json").read_text())["inputs"]["files"]
    assert sorted(entry["as_written"] for entry in copied) == ["decay.csv", "tap.csv"]
    assert all((archives[0] / entry["archived"]).read_bytes() == (folder / entry["as_written"]).read_bytes()
               for entry in copied)


BRB = Path(__file__).resolve().parent / "data" / "brb"


def test_the_studys_own_stepped_sine_is_read_as_the_commands_measured(tmp_path, monkeypatch):
    """``measured = true`` takes the study's ``[measured]`` FRF table — the Brake–Reuss beam's
    four force-controlled levels — beside its hammer record's linear limit: the archive's
    files equal ``nlupdate amplitude --measured … --impact …``'s byte for byte, one
    stepped-sine sample per level."""
    for name in ("ForcedFrequencyResponses.mat", "HammerImpact_1600Hz.mat"):
        (tmp_path / name).write_bytes((BRB / name).read_bytes())
    study = {"study": {"name": "brb-measured"},
             "measured": {"file": "ForcedFrequencyResponses.mat",
                          "coordinates": {"ForcedFrequencyResponses.mat": ["acc3:-y", "acc3:y"]}},
             "amplitude": {"measured": True, "impact": ["HammerImpact_1600Hz.mat"], "channel": "acc3",
                           "band_hz": [60.0, 100.0], "response_unit": "m/s^2",
                           "shapes": {"acc3": 0.7271, "acc3:y": 0.7271}, "backbone": "polynomial", "bootstrap": 20}}
    (tmp_path / "brb.toml").write_text(tomli_w.dumps(study))
    archive = write_archive(api.run_study(tmp_path / "brb.toml"), tmp_path / "archive", {"orchestration": "test"})
    monkeypatch.chdir(tmp_path)
    assert main(["amplitude", "--measured", "ForcedFrequencyResponses.mat", "--coordinates",
                 "ForcedFrequencyResponses.mat=acc3:-y,acc3:y", "--impact", "HammerImpact_1600Hz.mat", "--channel",
                 "acc3", "--band", "60:100", "--response-unit", "m/s^2", "--shape", "acc3=0.7271", "--shape",
                 "acc3:y=0.7271", "--backbone", "polynomial", "--bootstrap", "20", "--out", "cli"]) == 0
    for name in FILES:
        assert (tmp_path / "cli" / name).read_bytes() == (archive / "amplitude" / name).read_bytes(), name
    points = pd.read_csv(archive / "amplitude" / "backbone_points.csv")
    assert points["test_type"].value_counts().to_dict() == {"stepped-sine": 4, "impact": 1}
    assert pd.read_csv(archive / "amplitude" / "backbone.csv")["natural_frequency_hz_low"].notna().all()



def test_the_response_controlled_runs_of_the_measured_file_are_read_with_its_coordinates(tmp_path, monkeypatch):
    """The Brake–Reuss beam's MATLAB file holds force-controlled levels and response-controlled
    runs, neither naming its coordinates: ``[measured] coordinates`` states them once, and
    ``[amplitude] response_controlled`` on the same file reads the runs with them (it refused:
    'the run names no coordinates'), as ``nlupdate amplitude --measured F --response-controlled F
    --coordinates F=…`` reads both with one declaration - the archive's files equal the
    command's byte for byte. An ``[amplitude]`` coordinate that contradicts ``[measured]``'s
    for that file (read the runs with the sensor's sign reversed while the levels were not) is
    refused."""
    name = "ForcedFrequencyResponses.mat"
    (tmp_path / name).write_bytes((BRB / name).read_bytes())
    study = {"study": {"name": "brb-rc"},
             "measured": {"file": name, "coordinates": {name: ["acc3:-y", "acc3:y"]}},
             "amplitude": {"measured": True, "response_controlled": [name], "band_hz": [60.0, 100.0],
                           "shapes": {"acc3:y": 0.7271}, "backbone": "polynomial", "bootstrap": 20}}
    (tmp_path / "brb.toml").write_text(tomli_w.dumps(study))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = api.run_study(tmp_path / "brb.toml")
    # the runs [amplitude] reads are not said to be lost (the command reads them apart too)
    assert not [w for w in caught if "response-controlled stepped sine, not FRFs" in str(w.message)]
    archive = write_archive(result, tmp_path / "archive", {"orchestration": "test"})
    monkeypatch.chdir(tmp_path)
    assert main(["amplitude", "--measured", name, "--response-controlled", name, "--coordinates",
                 f"{name}=acc3:-y,acc3:y", "--band", "60:100", "--shape", "acc3:y=0.7271", "--backbone",
                 "polynomial", "--bootstrap", "20", "--out", "cli"]) == 0
    for file in FILES:
        assert (tmp_path / "cli" / file).read_bytes() == (archive / "amplitude" / file).read_bytes(), file
    points = pd.read_csv(archive / "amplitude" / "backbone_points.csv")
    assert points["test_type"].value_counts().to_dict() == {"stepped-sine": 4, "response-controlled": 8}
    study["amplitude"]["coordinates"] = {name: ["acc3:y", "acc3:y"]}
    (tmp_path / "brb.toml").write_text(tomli_w.dumps(study))
    with pytest.raises(StudyError, match=r"brb.toml: \[amplitude\] key 'coordinates': expected nothing for a file "
                                         r"\[measured\] states them for"):
        load_study(tmp_path / "brb.toml")


def test_the_brb_examples_summary_states_the_linear_limits_extrapolation_before_it(tmp_path):
    """examples/brb/amplitude.toml (the published hammer record and response-controlled runs):
    its linear limit lies above the impact's own pole, an extrapolation of the backbone below
    every sample (amplitude_model.json's warnings). The report's summary gave the linear limit
    and said nothing of it; it now opens with it, as `nlupdate amplitude` does."""
    study = Path(__file__).parent.parent / "examples" / "brb" / "amplitude.toml"
    result = api.run_study(study)
    archive = write_archive(result, tmp_path / "archive", {"orchestration": "test"})
    warnings = json.loads((archive / "amplitude" / "amplitude_model.json").read_text())["warnings"]
    assert any("extrapolation below every sample" in w for w in warnings)
    summary = (archive / "report.md").read_text().split("## Summary", 1)[1].split("\n## ", 1)[0].splitlines()
    number = next(k for k, line in enumerate(summary) if line.startswith("* **Amplitude model** (mode 1"))
    assert all(f"* **Amplitude model: {w}**" in summary[:number] for w in warnings), summary
