"""A study's ``[validation] hold_out_type`` (issue 37): a whole test type held out in the
study's validation step, its result in the archive's validation.json as
``nlupdate validate --hold-out-type`` writes it.

Truth, independent of the code under test (tests/test_validate_held_type.py's): the SDOF with
an Iwan joint of tests/test_ring_down.py (m = 2 kg, 10.5 Hz stuck, ζ = 0.5 % viscous); its
ring-down from RK4 time integration of the joint's own force law, its stepped sine (six force
levels, 0.01–0.25 N, 0.5 % noise) from describing-function continuation. The study fits the
stepped sine and predicts the ring-down's frequency and damping against amplitude: within the
issue's 0.2 % (frequency) and 5 % (damping) where the ring-down's amplitudes lie inside the
stepped sine's.
"""
from __future__ import annotations

import json

import pytest

from cli_runs import run_cli
from test_validate_held_type import PHI, assert_ring_down_predicted, two_tests  # noqa: F401  (the fixture: the two simulated tests)

STUDY = """
[study]
name = "held-type"

[measured]
file = "{folder}/stepped.parquet"

[validation]
hold_out = "top"
models = ["amplitude-polynomial"]
hold_out_type = "ring-down"
ring_down = ["{folder}/decay.csv"]
shapes = {{ "0" = {phi!r} }}
"""


def test_the_study_holds_out_the_ring_down_and_the_archive_carries_it(two_tests, tmp_path, capsys):  # noqa: F811
    study = tmp_path / "study.toml"
    study.write_text(STUDY.format(folder=two_tests, phi=float(PHI)))
    code, _, err = run_cli(capsys, "update", study, "--out", tmp_path / "out", "--quiet")
    assert code == 0, err
    summary = json.loads((tmp_path / "out" / "validation.json").read_text())
    assert summary["held_out"], "the levels are still held out beside the type"
    assert_ring_down_predicted(summary["held_out_type"])
    # the report tells what the study was run for (it showed the held-out levels alone): the
    # verdict and the largest errors within the fitted amplitudes, in the summary and a section
    held = summary["held_out_type"]
    within = [s for s in held["samples"] if s["within_fit"]]
    largest = {key: max(abs(s[key]["relative_error"]) for s in within) for key in ("natural_frequency_hz",
                                                                                    "damping_ratio")}
    report = (tmp_path / "out" / "report.md").read_text()
    summary_text = report.split("## Summary", 1)[1].split("\n## ", 1)[0]
    (line,) = [line for line in summary_text.splitlines() if "Held-out test type" in line]
    assert "ring-down held out" in line and "fitted on stepped-sine" in line, line
    assert (f"natural frequency {100 * largest['natural_frequency_hz']:.3g} %, damping ratio "
            f"{100 * largest['damping_ratio']:.3g} %") in line, line
    assert "### A whole test type held out: ring-down" in report
    # and compare (so rerun) sees it: another run whose model predicted the ring-down worse differs
    import shutil

    root = tmp_path / "results"
    shutil.copytree(tmp_path / "out", root / "held-type" / "20261129T000000Z-0000000a")
    other = root / "held-type" / "20261129T000001Z-0000000b"
    shutil.copytree(tmp_path / "out", other)
    held["worst_within_fit"]["damping_ratio"] *= 2
    (other / "validation.json").write_text(json.dumps({**summary, "held_out_type": held}))
    code, out, err = run_cli(capsys, "archive", "compare", "20261129T000000Z", "20261129T000001Z", "--root", root,
                             "--json")
    assert code == 0, err
    changed = [row["field"] for row in json.loads(out)["results"] if row["status"] == "changed"]
    assert changed == ["ring-down held out: largest |relative error| of damping_ratio within the fit"]


@pytest.mark.parametrize("change, message", [
    ('hold_out_type = "ring-down"', None),
    ('hold_out_type = "sweep"', "[validation] key 'hold_out_type': expected one of ['stepped-sine', "),
    ('models = ["lines"]', "[validation] key 'models': expected with hold_out_type, a first model among"),
    ("shapes = {{}}", "[validation] key 'shapes': expected with hold_out_type, the mode shape"),
    # a shape of 0 was taken, and every modal amplitude divided by it (as --shape and [amplitude] refuse it)
    ('shapes = {{ "0" = 0.0 }}', "[validation] key 'shapes': expected a table { coordinate = shape }, each a finite "
                                 "shape ≠ 0 (1/√kg), got {'0': 0.0}"),
])
def test_a_wrong_hold_out_type_table_is_one_line(two_tests, tmp_path, capsys, change, message):  # noqa: F811
    text = STUDY.format(folder=two_tests, phi=float(PHI))
    key = change.split(" = ")[0]
    lines = [line for line in text.splitlines() if not line.startswith(f"{key} = ")]
    study = tmp_path / "study.toml"
    study.write_text("\n".join(lines + [change.format()]) + "\n")
    from nlupdate.study.loading import load_study
    from nlupdate.study.reader import StudyError

    if message is None:
        assert load_study(study).validation.hold_out_type == "ring-down"
        return
    with pytest.raises(StudyError) as raised:
        load_study(study)
    assert message in str(raised.value) and len(str(raised.value).splitlines()) == 1


def test_keys_of_the_type_hold_out_need_it(two_tests, tmp_path):  # noqa: F811
    from nlupdate.study.loading import load_study
    from nlupdate.study.reader import StudyError

    study = tmp_path / "study.toml"
    study.write_text(f'[measured]\nfile = "{two_tests}/stepped.parquet"\n[validation]\nshapes = {{ "0" = 1.0 }}\n')
    with pytest.raises(StudyError, match=r"\[validation\] key 'shapes': expected nothing unless hold_out_type"):
        load_study(study)


def test_a_shape_missing_at_the_stepped_sines_input_is_named_by_study_and_command(two_tests, tmp_path, capsys):  # noqa: F811
    """One rule (held_type.stepped_sine_source) for the study's [validation] and validate
    --hold-out-type: the stepped sine's modal amplitudes need the shape at its input '0'; each
    says so in its own words (the key, the option)."""
    study = tmp_path / "study.toml"
    study.write_text(STUDY.format(folder=two_tests, phi=float(PHI)).replace('shapes = { "0" =', 'shapes = { "x" ='))
    code, _, err = run_cli(capsys, "update", study, "--out", tmp_path / "out", "--quiet")
    (line,) = [line for line in err.splitlines() if "error" in line]
    assert code == 2 and line.endswith(
        "study.toml: [validation] key 'shapes': the stepped sine's modal amplitude needs the mass-normalised shape "
        "(1/√kg) at its input '0'; got ['x']"), err
    code, _, err = run_cli(capsys, "validate", "--measured", two_tests / "stepped.parquet", "--ring-down",
                           two_tests / "decay.csv", "--shape", f"x={float(PHI)}", "--model", "amplitude-polynomial",
                           "--hold-out-type", "ring-down", "--out", tmp_path / "v")
    assert code == 2 and err.strip().splitlines()[-1] == (
        "nlupdate validate: error: --shape 0=VALUE: the stepped sine's modal amplitude needs the mass-normalised "
        "shape (1/√kg) at its input '0'"), err


def test_a_ring_down_without_its_shape_is_refused_as_the_command_refuses_it(two_tests, tmp_path, capsys):  # noqa: F811
    """The study reads its sources as ``validate --hold-out-type`` does (amplitude_inputs.read_sources):
    a ring-down at a channel without a shape has amplitudes in m, which cannot join the stepped
    sine's modal ones. It was read as modal (φ = 1 at its channel assumed), and, held out, predicted
    at its amplitude in m as if modal; the scale is now checked over every source, held ones too."""
    import pandas as pd

    decay = pd.read_csv(two_tests / "decay.csv").rename(columns={"0": "x"})
    decay.to_csv(tmp_path / "decay_x.csv", index=False)
    study = tmp_path / "study.toml"
    study.write_text(STUDY.format(folder=two_tests, phi=float(PHI)).replace(str(two_tests / "decay.csv"),
                                                                            str(tmp_path / "decay_x.csv")))
    code, _, err = run_cli(capsys, "update", study, "--out", tmp_path / "out", "--quiet")
    (line,) = [line for line in err.splitlines() if "error" in line]
    assert code == 2 and f"[validation]: {tmp_path / 'decay_x.csv'}: no mode shape at channel x, so its amplitudes " \
                         f"are in m, not modal" in line, err
