"""``lines-background``: the line samples' model with a constant complex background fitted so
that every level's samples make one curve (nlupdate.core.identification.line_samples).

Reference: the closed-form first-harmonic receptance of a Duffing SDOF
(tests/test_full_band_export.py) plus a known constant complex receptance B (m/V) on every
level, four levels; the top level held out and predicted from the three below."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.line_samples import background_for_lines
from nlupdate.core.measurement.frf_table import frf_table
from nlupdate.core.validation.held_out import validate
from test_full_band_export import duffing_receptance

F = np.linspace(80.0, 100.0, 321)
LEVELS = (0.25, 0.5, 0.75, 1.0)


@pytest.mark.parametrize("share", [0.0, 0.05 + 0.05j, 0.1 - 0.05j])
def test_the_background_is_found_and_the_top_level_predicted(share):
    peak = float(np.abs(duffing_receptance(F, LEVELS[0])).max())
    background = share * peak
    table = pd.concat([frf_table(F, level, "x", "x", duffing_receptance(F, level) + background) for level in LEVELS],
                      ignore_index=True)
    data = FRFLevels.from_table(table, "x", "x")
    found, fit = background_for_lines(data.subset(LEVELS[:-1]))
    total = found + complex(fit.residual_receptance(np.array([90.0]))[0])  # the fit's residual terms and B
    assert abs(total - background) < 0.005 * peak  # measured ≤ 0.0036 × peak
    (top,) = validate(data, "top", ["lines-background"]).held_out
    c = top.compared
    assert abs(c["resonance_hz"].error) < 0.01  # measured ≤ 0.0022 Hz (0.0625 Hz lines)
    assert abs(c["damping_ratio"].relative_error) < 0.01  # measured ≤ 0.24 %
    assert abs(c["peak_abs"].relative_error) < 0.01  # measured ≤ 0.12 %
