"""The issue's "weak" messages, one table per cause: each mistake ends as one line that blames
the right thing (file, field, expected form), exit code 2, no traceback, nothing written;
each signal that is not an error is a warning, not an information line.

Every case runs the real command line in this process (:func:`cli_runs.run_cli`).
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from cli_runs import run_cli
from test_time_history import stepped_record

FREQUENCIES = [18.0, 20.0, 22.0]


def assert_refused(result: tuple[int, str, str], folder: Path, *fragments: str) -> str:
    """Exit code 2, one line on stderr holding every fragment, no traceback, nothing in ``folder``."""
    code, _, err = result
    lines = err.strip().splitlines()
    assert code == 2, (code, err)
    assert "Traceback" not in err, err
    assert len(lines) == 1, err
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])
    assert sorted(p.name for p in folder.iterdir()) == [], "something was written"
    return lines[0]


def _clipped(values: np.ndarray, fraction: float) -> np.ndarray:
    limit = fraction * np.abs(values).max()
    return np.clip(values, -limit, limit)


def clipped_sine_distortion(fraction: float) -> float:
    """√Σ_{h=2,3}|X_h|²/|X_1| of cos clipped at ``fraction`` of its amplitude (FFT of one period)."""
    spectrum = np.abs(np.fft.rfft(_clipped(np.cos(2 * np.pi * np.arange(4096) / 4096), fraction)))
    return float(np.hypot(spectrum[2], spectrum[3]) / spectrum[1])


# ------------------------------------------------------------------ time histories: the signal is not what was blamed
def _record(change, **options) -> pd.DataFrame:
    frame = stepped_record(FREQUENCIES, [1.0], dwell_s=4.0, **options)
    return change(frame.copy())


def _without_time(frame: pd.DataFrame) -> pd.DataFrame:
    return frame.drop(columns="time_s")


def _zero(column):
    def change(frame):
        frame[column] = 0.0
        return frame
    return change


def _varying_fs(frame):
    frame = _without_time(frame)
    frame["Fs"] = 2000.0
    frame.loc[5, "Fs"] = 1000.0
    return frame


def _logged_times_three(frame):
    frame["frequency_hz"] = 3 * frame["frequency_hz"]
    return frame


TIME_HISTORY_MISTAKES = {
    "force is 0": (_zero("force"), [], ("record.csv: column 'force' (the reference) is 0 at every sample",)),
    "response is 0": (_zero("tip"), [], ("record.csv: column 'tip' (the response) is 0 at every sample",)),
    "header only": (lambda f: f.iloc[:0], [], ("record.csv: no samples", "a header without data rows")),
    "Fs varies": (_varying_fs, [], ("record.csv: column 'Fs' (sample rate) varies (1000…2000 Hz)",)),
    "--sample-rate 0": (_without_time, ["--sample-rate", "0"], ("--sample-rate 0: expected a number > 0",)),
    "--reference-calibration 0": (lambda f: f.rename(columns={"force": "voltage"}), ["--reference-calibration", "0"],
                                  ("--reference-calibration 0: expected a number > 0",)),
    "logged frequency x3": (_logged_times_three, [], (
        "record.csv: the dwell at 54 Hz: the reference's first harmonic", "oscillates at about 1",
        "is the logged 'frequency_hz' or the sample rate wrong?")),
    "sample rate x100": (_without_time, ["--sample-rate", "200000"], (
        "record.csv: the dwell at 18 Hz", "oscillates at about 1800 Hz")),
}


@pytest.mark.parametrize("case", TIME_HISTORY_MISTAKES, ids=list(TIME_HISTORY_MISTAKES))
def test_time_history_mistakes_blame_the_signal(tmp_path, capsys, case):
    change, options, fragments = TIME_HISTORY_MISTAKES[case]
    _record(change).to_csv(tmp_path / "record.csv", index=False)
    out = tmp_path / "out"
    out.mkdir()
    result = run_cli(capsys, "frf", tmp_path / "record.csv", *options, "--out", out / "frf.csv")
    assert_refused(result, out, "nlupdate frf: error:", *fragments)


@pytest.mark.parametrize("column, warning", [
    ("tip", r"the dwell at 20 Hz: the harmonic distortion of 'tip' is ([0-9.]+) % \(above 10 %\)"),
    ("force", r"the dwell at 20 Hz: the reference's harmonic distortion is ([0-9.]+) % \(above 10 %\)"),
])
def test_a_clipped_channel_is_a_warning(tmp_path, capsys, column, warning):
    frame = _record(lambda f: f, noise=0.0, distortion=0.0)
    dwell = frame["frequency_hz"] == 20.0  # clipped at half its own amplitude in the resonant dwell
    frame.loc[dwell, column] = _clipped(frame.loc[dwell, column].to_numpy(), 0.5)
    frame.to_csv(tmp_path / "record.csv", index=False)
    code, out, err = run_cli(capsys, "frf", tmp_path / "record.csv", "--out", tmp_path / "frf.csv")
    assert code == 0, err
    found = re.search(re.escape(f"nlupdate: warning: {tmp_path / 'record.csv'}: ") + warning, err)
    assert found, err
    # harmonic 3 of the clipped sine, 22.6 % (the transient left in the dwell moves the clipping level slightly)
    assert float(found.group(1)) == pytest.approx(100 * clipped_sine_distortion(0.5), rel=0.02)
    assert err.count("distortion") == 1, err  # the other dwells are not clipped


def test_a_dwell_whose_harmonics_outweigh_the_first_is_left_out(tmp_path, capsys):
    frame = _record(lambda f: f)
    dwell = frame["frequency_hz"] == 22.0
    t = frame.loc[dwell, "time_s"].to_numpy()
    size = frame.loc[dwell, "tip"].abs().max()
    frame.loc[dwell, "tip"] += 2 * size * np.cos(2 * np.pi * 66.0 * t)  # harmonic 3 twice the first
    frame.to_csv(tmp_path / "record.csv", index=False)
    code, out, err = run_cli(capsys, "frf", tmp_path / "record.csv", "--out", tmp_path / "frf.csv")
    assert code == 0, err
    assert "the dwell at 22 Hz left out: the harmonic distortion of 'tip' is" in err, err
    assert sorted(pd.read_csv(tmp_path / "frf.csv")["frequency_hz"].round(3)) == [18.0, 20.0]
