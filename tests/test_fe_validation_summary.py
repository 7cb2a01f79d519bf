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


def test_the_figure_draws_every_run_measured_and_predicted():
    from nlupdate.reporting.fe_validation_plots import fe_validation_figure

    table = TABLE.assign(run=["F1", "R1"] * 2, control=["force", "response"] * 2, level=[0.2, 2e-5] * 2,
                         peak_measured=[1e-3, 2e-3] * 2, peak_predicted=[1.1e-3, 1.9e-3, 0.9e-3, 2.1e-3])
    found = SimpleNamespace(table=table, repeatability=SimpleNamespace(resonance_hz=0.1, damping_ratio=0.001))
    resonance_axes = fe_validation_figure(found).axes[0]
    drawn = {line.get_label(): list(line.get_ydata()) for line in resonance_axes.get_lines() if line.get_label()[0] != "_"}
    assert drawn["measured"] == [80.0, 80.2]
    assert drawn["initial model"] == [78.0, 78.5] and drawn["updated model"] == [80.05, 80.1]
    assert [t.get_text() for t in resonance_axes.get_xticklabels()] == ["F 0.2 N", "R 20 µm"]


def test_every_joint_element_the_table_offers_has_a_fit_parametrisation():
    from nlupdate.core.validation.fe_settings import JOINT_ELEMENTS
    from nlupdate.fe.joint_validation import JOINT_LAWS

    assert set(JOINT_LAWS) == set(JOINT_ELEMENTS)
    for name, kind in JOINT_LAWS.items():
        assert len({len(kind.shape), len(kind.start), len(kind.low), len(kind.high), len(kind.scale),
                    len(kind.step)}) == 1, name
        assert kind.law(1e8, {"slip_force": 10.0, "chi": -0.5, "beta": 0.0})["type"] == name
