"""The [fe_validation] summary judges each model by the test's own repeatability: runs whose
resonance error exceeds twice it are counted and the line is bold (a result that cannot be
trusted says so first). Reference: the errors worked out by hand for a four-run table."""
from __future__ import annotations

from types import SimpleNamespace

import pandas as pd
import pytest

from nlupdate.core.validation.forced_runs import run_errors
from nlupdate.reporting.fe_validation_report import fe_validation_summary

TABLE = pd.DataFrame({
    "model": ["initial"] * 2 + ["updated"] * 2,
    "resonance_hz_measured": [80.0, 80.2, 80.0, 80.2],
    "resonance_hz_predicted": [78.0, 78.5, 80.05, 80.1],
    "damping_ratio_measured": [0.002, 0.004, 0.002, 0.004],
    "damping_ratio_predicted": [0.003, 0.002, 0.0021, 0.0044],
})


def test_errors_per_model_by_hand():
    errors = run_errors(TABLE, repeatability_hz=0.1)
    assert errors["initial"].largest_resonance_error_hz == pytest.approx(2.0)
    assert errors["initial"].median_damping_error_percent == pytest.approx(50.0)  # |+50|, |−50|
    assert errors["initial"].beyond_repeatability == 2
    assert errors["updated"].largest_resonance_error_hz == pytest.approx(0.1)
    assert errors["updated"].median_damping_error_percent == pytest.approx(7.5)  # 5 and 10
    assert errors["updated"].beyond_repeatability == 0


def test_a_model_missing_runs_beyond_the_repeatability_says_so_in_bold():
    found = SimpleNamespace(errors=run_errors(TABLE, repeatability_hz=0.1))
    initial, updated = fe_validation_summary(found)
    assert "**2 of 2 forced runs miss their resonance by more than 2× the test's repeatability" in initial
    assert "does not predict them**" in initial
    assert "**" not in updated and "0 of 2 forced runs" in updated
