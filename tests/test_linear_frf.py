"""The linear FRF from every force level (nlupdate.core.identification.linear_frf).

An oscillator with a cubic spring and a Jenkins slider (m = 0.1 kg, k = 2e6 N/m, loss factor
0.01) is solved at seven levels from stuck to gross slip; with the true describing
function each level gives the linear receptance, so their weighted combination must be the
analytic 1/(k(1 + iη) − mω²) on every line. With noise, the combination must beat the
low level alone where the stuck slider stiffens it.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest

from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.linear_frf import from_all_levels
from nlupdate.core.identification.pipeline import IdentificationSettings
from nlupdate.core.measurement.frf_table import frf_table
from nlupdate.core.model.elements import CubicStiffness, JenkinsFriction
from nlupdate.core.model.linear import LumpedModel
from nlupdate.core.model.system import NonlinearSystem
from nlupdate.core.response.fixed_point import fixed_point_response

MASS, STIFFNESS, LOSS = 0.1, 2e6, 0.01
ELEMENTS = (CubicStiffness((0,), 1e10), JenkinsFriction((0,), 3e5, 1.0))
GRID = np.arange(690.0, 717.0)
LEVELS = (0.01, 100.0, 160.0, 220.0, 280.0, 340.0, 400.0)


def linear_receptance(frequency_hz):
    omega = 2 * np.pi * np.asarray(frequency_hz)
    return 1.0 / (STIFFNESS * (1 + 1j * LOSS) - MASS * omega**2)


def true_df(level: float):
    return lambda amplitude, omega: sum(e.describing_function(amplitude, omega) for e in ELEMENTS)


@pytest.fixture(scope="module")
def levels() -> FRFLevels:
    system = NonlinearSystem(LumpedModel.with_loss_factor([[MASS]], [[STIFFNESS]], LOSS), ELEMENTS)
    parts = []
    for level in LEVELS:
        result = fixed_point_response(system, {0: level}, 2 * np.pi * GRID, tolerance=1e-13)
        assert result.converged.all()
        parts.append(frf_table(GRID, level, "0", "0", result.response([0])[:, 0] / level))
    return FRFLevels.from_table(pd.concat(parts, ignore_index=True), "0", "0")


def test_every_level_with_the_true_describing_function_gives_the_analytic_receptance(levels):
    extraction = from_all_levels(levels, true_df)
    assert extraction.levels_n == LEVELS and extraction.reference_level_n == 0.01
    np.testing.assert_allclose(extraction.receptance, linear_receptance(GRID), rtol=1e-8)
    assert np.all(np.isfinite(extraction.inverse_noise)) and np.all(extraction.inverse_noise > 0)


def test_a_line_missing_at_some_levels_is_taken_from_the_others(levels):
    keep = [np.ones(f.size, bool) for f in levels.frequencies]
    keep[0][5] = False        # not at the reference level: the line is not on the grid at all
    keep[3][10] = False       # missing at one level only: the others give it
    thinned = levels._masked(keep)
    extraction = from_all_levels(thinned, true_df)
    assert extraction.frequency_hz.size == GRID.size - 1
    np.testing.assert_allclose(extraction.receptance, linear_receptance(extraction.frequency_hz), rtol=1e-8)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_with_noise_every_level_beats_the_stuck_low_level(levels, seed):
    """5 % noise: the low level alone (stuck slider, 1/H_1 ≈ 1/H^L + 3e5 N/m) against all
    levels, both with the true DF: the combination's mean error is under 0.3× (seed 1:
    6.4 % against 29.5 %)."""
    noisy = levels.with_noise(0.05, np.random.default_rng(seed))
    f, h_low = noisy.curve(0.01)
    alone = 1.0 / (1.0 / h_low - true_df(0.01)(np.abs(h_low) * 0.01, 2 * np.pi * f))
    combined = from_all_levels(noisy, true_df).receptance
    error = lambda h: np.mean(np.abs(h / linear_receptance(f) - 1))  # noqa: E731
    assert error(combined) < 0.3 * error(alone), (error(combined), error(alone))


def test_settings_refuse_all_levels_without_physical_elements_or_with_low_force_options():
    with pytest.raises(ValueError, match="needs physical elements"):
        IdentificationSettings("0", "0", linear_from="all levels")
    with pytest.raises(ValueError, match="apply to linear_from = 'low force'"):
        IdentificationSettings("0", "0", elements=("cubic",), linear_from="all levels", smoothing_window=5)
    with pytest.raises(ValueError, match="linear_from must be one of"):
        IdentificationSettings("0", "0", elements=("cubic",), linear_from="highest")
    with pytest.raises(ValueError, match="apply to the PRD method"):
        IdentificationSettings("0", "0", method="ddf", linear_from="low force")
    assert dataclasses.replace(IdentificationSettings("0", "0", elements=("cubic",)), linear_from="low force")


def test_stated_standard_deviations_weight_each_level():
    """Two levels in gross slip, one with 20× the noise of the other: with the stated h_std
    the combination follows the quiet level; without them (relative noise assumed equal)
    the noisy level spoils it. Seeds 1-3."""
    system = NonlinearSystem(LumpedModel.with_loss_factor([[MASS]], [[STIFFNESS]], LOSS), ELEMENTS)
    parts = []
    for level in (220.0, 400.0):
        result = fixed_point_response(system, {0: level}, 2 * np.pi * GRID, tolerance=1e-13)
        parts.append(frf_table(GRID, level, "0", "0", result.response([0])[:, 0] / level))
    exact = FRFLevels.from_table(pd.concat(parts, ignore_index=True), "0", "0")
    for seed in (1, 2, 3):
        rng = np.random.default_rng(seed)
        fractions = (0.005, 0.1)
        noisy = [h * (1 + fraction * (rng.standard_normal(h.size) + 1j * rng.standard_normal(h.size)) / np.sqrt(2))
                 for h, fraction in zip(exact.receptances, fractions)]
        stds = tuple(fraction * np.abs(h) for h, fraction in zip(exact.receptances, fractions))
        unstated = dataclasses.replace(exact, receptances=tuple(noisy))
        stated = dataclasses.replace(unstated, h_stds=stds)
        error = lambda data: np.mean(np.abs(from_all_levels(data, true_df).receptance / linear_receptance(GRID) - 1))  # noqa: E731
        assert error(stated) < 0.2 * error(unstated), (seed, error(stated), error(unstated))
