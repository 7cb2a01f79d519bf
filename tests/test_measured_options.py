"""Every command that reads measurements takes the same measured-data options, and each
reads a test system's multi-run export per volt with them and says volts in its output."""
from __future__ import annotations

import contextlib
import io
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from test_measured_run_levels import LEVELS, multi_run_export, receptance, stiffness_of  # noqa: E402
from test_time_history import sdof_receptance, stepped_record  # noqa: E402

from nlupdate.app.cli import COMMANDS, build_parser, main  # noqa: E402

MEASURED_OPTIONS = {"--measured", "--reference-unit", "--reference-calibration", "--level", "--coordinates", "--band"}
READERS = [name for name in ("identify", "discover", "amplitude", "validate") if name in COMMANDS]


def options_of(command: str) -> dict[str, object]:
    parser = build_parser([command])
    sub = next(a for a in parser._actions if a.dest == "command").choices[command]
    return {option: action for action in sub._actions for option in action.option_strings}


@pytest.mark.parametrize("command", READERS)
def test_every_command_reading_measurements_takes_the_same_options(command):
    options = options_of(command)
    assert MEASURED_OPTIONS <= set(options)
    assert options["--measured"].nargs == "+"  # several files
    reference = options_of("identify")
    for name in MEASURED_OPTIONS:  # the same option: the same values and help
        assert options[name].choices == reference[name].choices and options[name].metavar == reference[name].metavar


def test_frf_takes_the_reference_and_band_options():
    options = options_of("frf")
    assert {"--reference-unit", "--reference-calibration", "--band"} <= set(options)
    assert options["--reference-unit"].choices == options_of("identify")["--reference-unit"].choices


def run(*args: object) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in args])
    return code, out.getvalue(), err.getvalue()


def test_amplitude_reads_a_multi_run_export_per_volt(tmp_path):
    names = [f"Run {chr(65 + k)}" for k in range(len(LEVELS))]
    path = multi_run_export(tmp_path / "export.uff", names)
    code, out, err = run("amplitude", "--measured", path, "--reference-unit", "V", "--backbone", "polynomial",
                         "--level", f"export.uff#{names[0]}={LEVELS[0]}",
                         *[arg for n, v in zip(names[1:], LEVELS[1:]) for arg in ("--level", f"{n}={v}")],
                         "--forces", "0.05,0.3", "--freqs", "80:100:41", "--out", tmp_path / "amp")
    assert code == 0, err
    assert "6 level(s) 0.05, 0.1, 0.15, 0.2, 0.25, 0.3 V" in out and "FRFs in m/V" in out
    # the linear limit: the lowest level's stiffness, k = 3.2e5·(1 − 0.05·0.05) V/m with m = 1
    assert float(out.split("linear limit ")[1].split(" Hz")[0]) == pytest.approx(
        np.sqrt(stiffness_of(0.0)) / (2 * np.pi), rel=0.01)
    predicted = pd.read_parquet(tmp_path / "amp" / "predicted_frf.parquet")
    assert set(predicted["reference_unit"]) == {"V"}


def test_frf_cuts_its_estimate_to_the_band(tmp_path):
    stepped_record([19.0, 20.0, 21.0], levels=[0.2]).to_csv(tmp_path / "dwells.csv", index=False)
    code, out, err = run("frf", tmp_path / "dwells.csv", "--reference-unit", "N", "--band", "19.5:21.5",
                         "--out", tmp_path / "frf.csv")
    assert code == 0, err
    table = pd.read_csv(tmp_path / "frf.csv")
    assert sorted(table["frequency_hz"]) == pytest.approx([20.0, 21.0], rel=1e-5)  # as the dwells measured them
    h = table["h_real"].to_numpy() + 1j * table["h_imag"].to_numpy()
    np.testing.assert_allclose(h, sdof_receptance(table["frequency_hz"].to_numpy()), rtol=0.02)
    assert "band 19.5–21.5 Hz (--band): 1 of 3 lines outside it left out" in out
    code, _, err = run("frf", tmp_path / "dwells.csv", "--reference", "voltage", "--reference-unit", "N",
                       "--out", tmp_path / "frf2.csv")
    assert code == 2 and "--reference voltage and --reference-unit N contradict each other" in err
