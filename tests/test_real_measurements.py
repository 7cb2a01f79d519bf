"""Public measurements of jointed structures, read from the files as published.

The data are not in this repository (their licences and sizes keep them out) and the
test machines have no network: each test reads a folder the user points to and skips,
saying how to get the data, when it is absent. docs/measured-data.md ("Real tests")
gives the fetch-and-run steps.

* UNESP-BERT bolted beam (SHM Lab, UNESP Ilha Solteira; CC BY-NC-SA; two aluminium
  beams bolted together, shaker 85 mm from the clamp, laser vibrometer at the free end,
  LMS SCADAS, levels 0.05…0.30 V of the amplifier voltage): ``NLUPDATE_UNESP_BERT`` = the
  folder of its exported FRF files (UFF 58, one per level).
* F-16 ground vibration test (nonlinearbenchmark.org; wing-to-payload joint; sine sweeps
  15 → 2 Hz at 0.05 Hz/s): ``NLUPDATE_F16_GVT`` = the folder holding
  ``F16Data_SineSw_Level*.csv`` (columns Force, Voltage, Acceleration1–3, Fs).
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow


def _folder(variable: str, what: str) -> Path:
    value = os.environ.get(variable)
    if not value or not Path(value).is_dir():
        pytest.skip(f"{what} not present: set {variable} to the folder of its files as published "
                    f"(see docs/measured-data.md, 'Real tests')")
    return Path(value)


def _nlupdate(*args):
    return subprocess.run([sys.executable, "-m", "nlupdate", *map(str, args)], capture_output=True, text=True,
                          timeout=1800)


def test_unesp_bert_bolted_beam_identify_and_discover(tmp_path):
    folder = _folder("NLUPDATE_UNESP_BERT", "the UNESP-BERT bolted-beam export")
    files = sorted(p for p in folder.iterdir() if p.suffix.lower() in (".uff", ".unv"))
    assert files, f"{folder}: no .uff/.unv files"
    result = _nlupdate("identify", "--measured", *files, "--reference-unit", "V", "--samples", "40",
                       "--out", tmp_path / "id")
    assert result.returncode == 0, result.stderr
    summary = json.loads((tmp_path / "id" / "identification.json").read_text())
    assert summary["units"]["receptance"] == "m/V"
    low, high = summary["band_hz"]
    assert low <= summary["excitation_frequency_hz"] <= high
    print(result.stdout)


def test_f16_gvt_sine_sweep_to_frf(tmp_path):
    folder = _folder("NLUPDATE_F16_GVT", "the F-16 ground-vibration-test benchmark")
    files = sorted(folder.glob("F16Data_SineSw_Level*.csv"))
    assert files, f"{folder}: no F16Data_SineSw_Level*.csv"
    result = _nlupdate("frf", files[-1], "--response-quantity", "acceleration", "--out", tmp_path / "frf.parquet")
    assert result.returncode == 0, result.stderr
    assert "sine sweep" in result.stdout and "sweep rate" in result.stderr
    print(result.stdout, result.stderr)
