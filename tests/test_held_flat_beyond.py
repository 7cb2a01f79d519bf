"""A level predicted above the kept ones by the ``amplitude-polynomial`` model says that its
backbone is held flat beyond the largest kept sample (the transmitter beam's 0.45 V prediction
kinked at 42.725 and 42.787 Hz where its response crossed it, unsaid). Truth: the closed-form
single-harmonic mode of tests/test_validate_auto_extrapolation.py, whose top level (0.35 N)
reaches 3.3 a₁ at resonance against the kept levels' 1.4 a₁."""
from __future__ import annotations

from test_validate_auto_extrapolation import LEVELS, data  # noqa: F401  (the module's fixture)

from nlupdate.core.validation.held_out import FLAT_BEYOND, validate
from nlupdate.reporting.validation_plots import held_out_figure


def test_a_polynomial_prediction_above_the_kept_levels_says_it_is_flat_there(data):  # noqa: F811
    result = validate(data, "top", ["amplitude-polynomial"])
    (row,) = [r for r in result.held_out if r.level == LEVELS[-1]]
    assert row.extrapolation.endswith(FLAT_BEYOND) and "above the highest kept level" in row.extrapolation
    title = held_out_figure(row, "N").axes[0].get_title()
    assert "held flat beyond the largest kept sample" in title, title
    lines = validate(data, "top", ["lines"]).held_out[0]
    assert FLAT_BEYOND not in lines.extrapolation  # another model's extrapolation is not said to be flat
