"""The excited band: a broadband export whose lines outside the excited range are noise.

The METHODS 2-DOF test (600–850 Hz, stepped sine at 0.01 N and three high levels) is
exported over 300–1100 Hz as an analyser would: outside 600–850 Hz the "FRF" is the
ratio of two noises. Identification must stay inside the excited band (found from the
coherence, or from where the FRF is smooth) and pick its excitation frequency there.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.pipeline import IdentificationSettings, identify
from nlupdate.core.measurement.band import excited_band
from nlupdate.core.model.model_file import load_system
from nlupdate.core.response.simulate import simulate_frf_table

TWO_DOF = Path(__file__).resolve().parents[1] / "examples" / "two_dof.toml"


@pytest.fixture(scope="module")
def broadband():
    table, _ = simulate_frf_table(load_system(TWO_DOF), 0, np.arange(600.0, 851.0, 1.0), [0.01, 100.0, 150.0, 200.0],
                                  noise=0.01, seed=2)
    table = table[table["response_dof"] == "0"]
    rng = np.random.default_rng(5)
    outside = np.r_[np.arange(300.0, 600.0, 1.0), np.arange(851.0, 1101.0, 1.0)]
    noise_rows = []
    for level in sorted(set(table["force_level_n"])):
        scale = np.abs(table["h_real"] + 1j * table["h_imag"]).median()
        h = scale * (rng.standard_normal(outside.size) + 1j * rng.standard_normal(outside.size))
        noise_rows.append(pd.DataFrame({"frequency_hz": outside, "force_level_n": level, "response_dof": "0",
                                        "input_dof": "0", "h_real": h.real, "h_imag": h.imag, "coherence": 0.05}))
    table = table.assign(coherence=0.99)
    return pd.concat([table, *noise_rows], ignore_index=True).sort_values(["force_level_n", "frequency_hz"])


@pytest.mark.parametrize("with_coherence", [True, False])
def test_the_excited_band_is_found(broadband, with_coherence):
    curve = broadband[broadband["force_level_n"] == 0.01]
    band = excited_band(curve["frequency_hz"].to_numpy(), (curve["h_real"] + 1j * curve["h_imag"]).to_numpy(),
                        curve["coherence"].to_numpy() if with_coherence else None)
    assert 598 <= band.low_hz <= 615 and 835 <= band.high_hz <= 852, band


@pytest.mark.parametrize("with_coherence", [True, False])
def test_prd_stays_inside_the_excited_band(broadband, with_coherence):
    table = broadband if with_coherence else broadband.drop(columns="coherence")
    data = FRFLevels.from_table(table, "0", "0")
    result = identify(data, IdentificationSettings("0", "0", samples=4, seed=1))
    low, high = result.band_hz
    assert 598 <= low and high <= 852
    assert low <= result.result.setup.frequency_hz <= high
    assert abs(result.natural_frequencies_hz[0] / 732.2 - 1) < 0.01  # docs/methods.md §8: the m1 mode near 732 Hz
