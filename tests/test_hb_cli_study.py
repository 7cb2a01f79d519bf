"""Harmonic balance chosen by the user: ``simulate --method hb``, ``discover --method hb`` and
a study's ``[prediction] method = "hb"``.

References: the describing-function continuation (``--method continuation``, its own solver:
the single-harmonic balance equals it for symmetric elements), direct time integration
(``--method time``, no harmonic truncation at all) and, for the study, the settings written in
the file.
"""
from __future__ import annotations

import contextlib
import io
import json
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from nlupdate.app.cli import main
from nlupdate.core.response.harmonic_balance import HarmonicSettings, HarmonicTruncationWarning
from nlupdate.study import StudyError, run_study, study_from_text
from studies import small_two_dof_study, study_text

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"

# Duffing oscillator, ζ = 0.1: at 50 N the cubic force is of the order of the linear one
# near resonance (a jump between 26 and 28 Hz sweeping up) and steady state comes quickly.
DUFFING = """
[model]
kind = "lumped"
mass = [[1.0]]
stiffness = [[1e4]]
damping = [[20.0]]
[[nonlinear]]
type = "cubic"
dofs = [0]
k3 = 1e8
"""


@pytest.fixture(scope="module")
def duffing(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("hb") / "duffing.toml"
    path.write_text(DUFFING)
    return path


def cli(*args: str) -> tuple[int, str, str]:
    """Run ``nlupdate`` in this process: exit code, stdout, stderr (argparse's exit included)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(list(args))
        except SystemExit as exit_:
            code = exit_.code
    return code, out.getvalue(), err.getvalue()


def simulated(model: Path, folder: Path, name: str, freqs: str, forces: str, *method: str) -> tuple[pd.DataFrame, str, str]:
    path = folder / f"{name}.csv"
    code, out, err = cli("simulate", str(model), "--input-dof", "0", "--freqs", freqs, "--forces", forces,
                         "--out", str(path), *method)
    assert code == 0, err
    table = pd.read_csv(path).sort_values(["force_level_n", "response_dof", "frequency_hz"]).reset_index(drop=True)
    return table, out, err


def h(table: pd.DataFrame) -> np.ndarray:
    return (table["h_real"] + 1j * table["h_imag"]).to_numpy()


GRID = "18:29:12"  # 1 Hz steps through the jump
UPPER = slice(0, 9)  # 18 … 26 Hz: the upper branch, where the harmonics matter


@pytest.fixture(scope="module")
def time_reference(duffing, tmp_path_factory):
    """Direct time integration of the Duffing oscillator at 50 N sweeping up through the
    jump — no harmonic is truncated; its table and its output."""
    table, out, _ = simulated(duffing, tmp_path_factory.mktemp("time"), "time", GRID, "50", "--method", "time")
    return table, out


# --------------------------------------------------------------------------- simulate
def test_one_harmonic_reproduces_the_describing_function(duffing, tmp_path):
    """For a cubic spring the balance of one harmonic (by alternating frequency–time, with a
    constant term) is the describing-function balance: the same curve, jump included."""
    grid, forces = "12:34:23", "10,50"
    hb, out, err = simulated(duffing, tmp_path, "hb1", grid, forces, "--method", "hb", "--harmonics", "1")
    df, df_out, _ = simulated(duffing, tmp_path, "df", grid, forces, "--method", "continuation")
    assert len(hb) == len(df) == 2 * 23
    np.testing.assert_allclose(hb["frequency_hz"], df["frequency_hz"])
    np.testing.assert_allclose(h(hb), h(df), rtol=1e-9)
    # the describing-function run says the jump on its own line; the hb run per level
    assert "jumps (Hz): 50 N: 27.00" in df_out
    lines = out.splitlines()
    assert "10 N: H = 1 (one harmonic); bifurcations: none; jumps: none" in lines
    assert "50 N: H = 1 (one harmonic); bifurcations: none; jumps: 27.00 Hz" in lines
    assert "warning" not in err


def test_five_harmonics_follow_time_integration_where_the_describing_function_is_off(duffing, tmp_path, time_reference):
    """Near resonance the third and fifth harmonics change the first by a few per cent; with
    five harmonics the first harmonic agrees with time integration to 1e-4 everywhere and
    ten times better than the describing function on the upper branch; the jump it reports
    is the one the time integration meets."""
    reference_table, time_out = time_reference
    hb, out, err = simulated(duffing, tmp_path, "hb5", GRID, "50", "--method", "hb", "--harmonics", "5")
    df, _, _ = simulated(duffing, tmp_path, "df", GRID, "50")
    np.testing.assert_allclose(hb["frequency_hz"], reference_table["frequency_hz"])
    reference = h(reference_table)
    hb_error = np.abs(h(hb) - reference) / np.abs(reference)
    df_error = np.abs(h(df) - reference) / np.abs(reference)
    assert np.all(hb_error < 1e-4), hb_error
    assert np.all(hb_error[UPPER] < 0.1 * df_error[UPPER]), (hb_error, df_error)
    difference = np.abs(h(df) - h(hb)) / np.abs(h(hb))
    assert 0.005 < difference[6] < 0.05 and 0.01 < difference[8] < 0.1, difference  # 24 and 26 Hz
    assert "jumps (Hz): 50 N: 27.00" in time_out
    assert out.splitlines()[0].startswith("50 N: H = 5 (highest harmonics ≤ ")
    assert out.splitlines()[0].endswith("; bifurcations: none; jumps: 27.00 Hz")
    assert "highest harmonics carry" not in err


def test_a_truncation_warning_is_one_line_naming_its_force_level(duffing, tmp_path):
    """Three harmonics are not enough at either level (the fifth carries more than 0.1 %)."""
    _, out, err = simulated(duffing, tmp_path, "hb3", "12:34:12", "10,50", "--method", "hb", "--harmonics", "3")
    warned = [line for line in err.splitlines() if "highest harmonics carry" in line]
    assert len(warned) == 2, err
    assert warned[0].startswith("nlupdate: warning: 10 N: harmonic balance with H = 3: the highest harmonics carry")
    assert warned[1].startswith("nlupdate: warning: 50 N: harmonic balance with H = 3: the highest harmonics carry")
    assert all(line.startswith("nlupdate: warning: ") for line in err.splitlines()), err
    assert [line.split(":")[0] for line in out.splitlines()[:2]] == ["10 N", "50 N"]


@pytest.mark.parametrize(
    "options,message",
    [
        (["--method", "hb", "--harmonics", "0"], "argument --harmonics: expected an integer from 1 to 64, or \"auto\", got '0'"),
        (["--method", "hb", "--harmonics", "x"], "argument --harmonics: expected an integer from 1 to 64, or \"auto\", got 'x'"),
        (["--method", "hb", "--harmonics", "5", "--samples", "10"],
         "argument --samples: expected an integer from 11 to 65536 (samples per period; 5 harmonics need more than 10), got 10"),
        (["--method", "hb", "--samples", "6"], "argument --samples: expected an integer from 7 to 65536"),
        (["--method", "hb", "--harmonics", "auto", "--samples", "62"], "argument --samples: expected an integer from 63 to 65536"),
        (["--method", "hb", "--samples", "many"], "argument --samples: expected an integer"),
        (["--harmonics", "3"], "--harmonics applies to --method hb (harmonic balance), not --method continuation"),
        (["--method", "time", "--no-stability"], "--no-stability applies to --method hb (harmonic balance), not --method time"),
        (["--method", "fixed-point", "--samples", "64"], "--samples applies to --method hb"),
    ],
)
def test_bad_harmonic_balance_options_are_one_line_with_exit_2(duffing, tmp_path, options, message):
    out = tmp_path / "x.csv"
    code, stdout, err = cli("simulate", str(duffing), "--input-dof", "0", "--freqs", "10:20:3", "--forces", "1",
                            "--out", str(out), *options)
    assert code == 2
    lines = err.strip().splitlines()
    assert 1 <= len(lines) <= 2 and lines[0].startswith("nlupdate simulate: error: ") and message in lines[0], err
    assert not out.exists() and stdout == ""


def test_discover_takes_the_same_options_and_checks_them(tmp_path):
    model, measured = EXAMPLES / "discovery" / "sdof_linear.toml", EXAMPLES / "discovery" / "sdof_friction_cubic.csv"
    for options, message in ((["--harmonics", "2"], "--harmonics applies to --method hb"),
                             (["--method", "hb", "--harmonics", "0"], "argument --harmonics: expected an integer from 1 to 64"),
                             (["--method", "hb", "--harmonics", "4", "--samples", "8"], "expected an integer from 9 to 65536")):
        code, _, err = cli("discover", "--model", str(model), "--measured", str(measured), "--out", str(tmp_path / "d"),
                           *options)
        assert code == 2 and message in err.splitlines()[0], err
        assert not (tmp_path / "d").exists()


def test_discovery_simulates_by_harmonic_balance_when_told(duffing, time_reference):
    """``simulate_points`` (the discovery's model response) with five harmonics agrees with
    time integration; by default it stays the describing function."""
    from nlupdate.core.discovery.simulation import simulate_points
    from nlupdate.core.model.model_file import load_system

    system = load_system(duffing)
    reference_table, _ = time_reference
    omega = 2 * np.pi * reference_table["frequency_hz"].to_numpy()
    force = np.full(omega.size, 50.0)
    reference = h(reference_table)
    with warnings.catch_warnings():
        warnings.simplefilter("error", HarmonicTruncationWarning)
        balanced = simulate_points(system, 0, force, omega, [0], harmonic_balance=HarmonicSettings(5))[:, 0] / 50.0
    default = simulate_points(system, 0, force, omega, [0])[:, 0] / 50.0
    assert np.all(np.abs(balanced - reference) / np.abs(reference) < 1e-4)
    assert np.all(np.abs(default - reference)[UPPER] > 10 * np.abs(balanced - reference)[UPPER])


# --------------------------------------------------------------------------- studies
#: The flow tests' 2-DOF study made small (:func:`studies.small_two_dof_study`); its text
#: ends in the ``[prediction]`` table, so the tests append prediction keys to it.
STUDY = study_text(small_two_dof_study())
assert STUDY.endswith('[prediction]\ncandidates = "best"\n')
HB = 'method = "hb"\nharmonics = 3\n'


def test_study_reads_the_prediction_method():
    spec = study_from_text(STUDY + 'method = "hb"\nharmonics = 5\nsamples = 48\nstability = false\n', "s.toml").prediction
    assert spec.harmonic_balance == HarmonicSettings(harmonics=5, samples=48, stability=False)
    assert study_from_text(STUDY + 'method = "hb"\nharmonics = "auto"\n', "s.toml").prediction.harmonic_balance == \
        HarmonicSettings(harmonics="auto")
    assert study_from_text(STUDY + 'method = "hb"\n', "s.toml").prediction.harmonic_balance == HarmonicSettings()
    assert study_from_text(STUDY, "s.toml").prediction.harmonic_balance is None
    assert study_from_text(STUDY + 'method = "continuation"\n', "s.toml").prediction.harmonic_balance is None


@pytest.mark.parametrize(
    "extra,message",
    [
        ('method = "time"', "[prediction] key 'method': expected one of ['continuation', 'hb'], got 'time'"),
        ('method = "hb"\nharmonics = 0', "[prediction] key 'harmonics': expected an integer from 1 to 64, or \"auto\""),
        ('method = "hb"\nharmonics = "many"', "[prediction] key 'harmonics': expected an integer from 1 to 64, or \"auto\""),
        ('method = "hb"\nharmonics = 2.0', "[prediction] key 'harmonics'"),
        ('method = "hb"\nharmonics = 5\nsamples = 10',
         "[prediction] key 'samples': expected an integer from 11 to 65536 (samples per period; 5 harmonics need more than 10), got 10"),
        ('method = "hb"\nharmonics = "auto"\nsamples = 32', "[prediction] key 'samples': expected an integer from 63 to 65536"),
        ('method = "hb"\nstability = "yes"', "[prediction] key 'stability': expected true or false"),
        ("harmonics = 5", "[prediction] key 'harmonics': expected nothing unless method = \"hb\""),
        ('method = "continuation"\nsamples = 64', "[prediction] key 'samples': expected nothing unless method = \"hb\""),
    ],
)
def test_study_errors_for_the_prediction_method_name_file_table_and_key(tmp_path, extra, message):
    path = tmp_path / "bad.toml"
    with pytest.raises(StudyError) as error:
        study_from_text(STUDY + extra + "\n", path)
    assert str(error.value).startswith(f"{path}: ") and message in str(error.value), error.value


def test_predict_uses_the_harmonic_balance_it_is_given(duffing, time_reference):
    """``predict`` (the prediction step's simulation) with five harmonics follows time
    integration; without settings it is the describing function, as before."""
    from nlupdate.core.model.model_file import load_system
    from nlupdate.core.prediction.predict import predict

    system = load_system(duffing)
    reference_table, _ = time_reference
    frequency, reference = reference_table["frequency_hz"].to_numpy(), h(reference_table)
    balanced = h(predict(system, "0", frequency, [50.0], "up", HarmonicSettings(5)).sort_values("frequency_hz"))
    default = h(predict(system, "0", frequency, [50.0]).sort_values("frequency_hz"))
    assert np.all(np.abs(balanced - reference) / np.abs(reference) < 1e-4)
    assert np.all(np.abs(default - reference)[UPPER] > 10 * np.abs(balanced - reference)[UPPER])


def test_the_prediction_step_gets_the_settings_and_the_report_names_them(monkeypatch, tmp_path):
    """``nlupdate update`` on a study with ``method = "hb"``: the loss-factor fit and the
    prediction of both models are called with the file's settings, and the report names
    the method."""
    from nlupdate.core.prediction import predict as prediction
    from nlupdate.study.steps import prediction as prediction_step

    calls = []
    for module, name in ((prediction_step, "predict_measured"), (prediction, "fit_loss_factor")):
        original = getattr(module, name)

        def recording(*args, _original=original, _name=name, **kwargs):
            calls.append((_name, kwargs["harmonic_balance"] if "harmonic_balance" in kwargs else args[-1]))
            return _original(*args, **kwargs)

        monkeypatch.setattr(module, name, recording)
    path = tmp_path / "study.toml"
    path.write_text(STUDY + 'method = "hb"\nharmonics = 3\nsamples = 32\n')
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HarmonicTruncationWarning)
        assert main(["update", str(path), "--out", str(tmp_path / "out")]) == 0
    assert sorted(name for name, _ in calls) == ["fit_loss_factor"] * 2 + ["predict_measured"] * 2
    assert all(settings == HarmonicSettings(harmonics=3, samples=32) for _, settings in calls), calls
    report = (tmp_path / "out" / "report.md").read_text()
    assert "Response method ([prediction] `method`): harmonic balance (H = 3, 32 samples per period, " \
           "Floquet stability)." in report
    calls.clear()
    run_study(study_from_text(STUDY, tmp_path / "df.toml"))
    assert [settings for _, settings in calls] == [None] * 4


def test_the_prediction_cache_key_follows_the_method_and_its_settings():
    from nlupdate.study.chain import STEPS
    from nlupdate.study.steps.prediction import PredictionJob
    from nlupdate.orchestration.tasks import keys

    def key(extra: str) -> str:
        study = study_from_text(STUDY + extra, "s.toml")
        return keys.job_key(STEPS["predictions"], study, PredictionJob("initial", {"k1": 0.8e6}), "model",
                            ["updating", "comparison", "identification", "measured"])

    variants = ["", 'method = "continuation"\n', HB, 'method = "hb"\nharmonics = 5\n',
                'method = "hb"\nharmonics = 3\nsamples = 128\n', 'method = "hb"\nharmonics = 3\nstability = false\n',
                'method = "hb"\nharmonics = "auto"\n']
    found = [key(extra) for extra in variants]
    assert found[0] == found[1]  # the default, written or not
    assert len(set(found[1:])) == len(variants) - 1
    assert key(HB) == found[2]  # the same settings, the same key


def test_under_prefect_a_changed_harmonics_recomputes_only_the_predictions(prefect_server, tmp_path):
    from nlupdate.orchestration.flows.status_lines import Progress
    from nlupdate.orchestration.flows.run import run_study_flow

    def flow_run(text: str) -> tuple[Path, dict]:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", HarmonicTruncationWarning)
            archive = run_study_flow(study_from_text(text, tmp_path / "study.toml"), tmp_path / "results",
                                     cache_dir=tmp_path / "cache", progress=Progress(quiet=True))
        return archive, json.loads((archive / "manifest.json").read_text())

    def tally(manifest: dict, step: str) -> tuple[int, int]:
        job = {"predictions": "prediction"}.get(step, step)  # a job is recorded as "prediction: <model>"
        counts = [c for name, c in manifest["run"]["tasks"].items() if name == step or name.startswith(job + ": ")]
        return sum(c["computed"] for c in counts), sum(c["cached"] for c in counts)

    given = STUDY + "loss_factor = 0.005\n"
    _, first = flow_run(given + 'method = "hb"\nharmonics = 1\n')
    assert tally(first, "predictions") == (2, 0)
    archive, second = flow_run(given + 'method = "hb"\nharmonics = 2\n')
    assert tally(second, "predictions") == (2, 0)
    for step in ("measured data", "identification", "targets", "updating", "comparison"):
        computed, cached = tally(second, step)
        assert computed == 0 and cached > 0, (step, second["run"]["tasks"])
    computed = {name: c["computed"] for name, c in second["run"]["tasks"].items() if c["computed"]}
    # the two predictions, and the warnings, which compare the best one's with the initial one's
    assert sum(computed.values()) == 3 and computed.get("warnings") == 1, computed
    assert 'harmonics = 2' in (archive / "study.toml").read_text()
    assert "harmonic balance (H = 2," in (archive / "report.md").read_text()
