"""Sign-agnostic resonances: a transfer FRF whose mode of interest has a negative modal constant.

A 3-mass chain (ground–m–m–m–ground, m = 0.1 kg, k = 1e6 N/m, loss factor 0.01) with a
cubic spring at mass 0: its second mode, (1, 0, −1), is at √(2k/m)/2π = 711.76 Hz. The
transfer FRF from mass 0 to mass 2 has a negative modal constant there (exciter and
sensor on opposite sides of the node at mass 1), so ``Re(1/H)`` rises through zero. The
extracted linear mode must come out within 0.5 % of the truth, as for the point FRF.
"""
from __future__ import annotations

import numpy as np
import pytest

from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.modal_fit import resonance_crossings
from nlupdate.core.identification.pipeline import IdentificationSettings, identify
from nlupdate.core.identification.trust import sign_warnings
from nlupdate.core.model.model_file import system_from_dict
from nlupdate.core.response.simulate import simulate_frf_table

TRUTH_HZ = np.sqrt(2 * 1e6 / 0.1) / (2 * np.pi)


@pytest.fixture(scope="module")
def chain_table():
    k, m = 1e6, 0.1
    system = system_from_dict({
        "model": {"kind": "lumped", "mass": [[m, 0, 0], [0, m, 0], [0, 0, m]],
                  "stiffness": [[2 * k, -k, 0], [-k, 2 * k, -k], [0, -k, 2 * k]], "loss_factor": 0.01},
        "nonlinear": [{"type": "cubic", "dofs": [0], "k3": 1e10}],
    })
    table, _ = simulate_frf_table(system, 0, np.linspace(660.0, 760.0, 201), [0.01, 20.0, 40.0, 60.0],
                                  noise=0.002, seed=3)
    return table


def test_resonance_crossings_accept_either_sign_and_skip_antiresonances():
    f = np.linspace(50.0, 150.0, 1001)
    w, wr = 2 * np.pi * f, 2 * np.pi * np.array([80.0, 120.0])
    point = (1.0 / (wr[0] ** 2 - w**2 + 0.02j * wr[0] ** 2) + 1.0 / (wr[1] ** 2 - w**2 + 0.02j * wr[1] ** 2))
    transfer = (1.0 / (wr[0] ** 2 - w**2 + 0.02j * wr[0] ** 2) - 1.0 / (wr[1] ** 2 - w**2 + 0.02j * wr[1] ** 2))
    np.testing.assert_allclose(resonance_crossings(f, point), [80.0, 120.0], rtol=2e-3)
    np.testing.assert_allclose(resonance_crossings(f, transfer), [80.0, 120.0], rtol=2e-3)
    np.testing.assert_allclose(resonance_crossings(f, -point), [80.0, 120.0], rtol=2e-3)  # reversed sensor


@pytest.mark.parametrize("response", ["0", "2"])
def test_extracted_linear_mode_of_point_and_transfer_frf(chain_table, response):
    data = FRFLevels.from_table(chain_table, response, "0")
    settings = IdentificationSettings(response_dof=response, input_dof="0", frequency_hz=711.5, samples=4, seed=1)
    identification = identify(data, settings)
    assert len(identification.modes) == 1
    found = identification.natural_frequencies_hz[0]
    assert abs(found / TRUTH_HZ - 1) < 0.005, (found, TRUTH_HZ)
    constant = identification.modes[0].modal_constants[0]
    assert (constant.real < 0) == (response == "2")  # the transfer FRF's modal constant is negative


def test_a_negative_kf_is_warned_about():
    warnings = sign_warnings({"k3": 1e9, "kf": -37.0}, "V")
    assert len(warnings) == 1 and warnings[0].subject == "kf" and warnings[0].kind == "negative"
    assert "kf = -37 V/m is negative" in warnings[0].message
    # a describing function that dissipates points to the lowest level slipping, not to a sign
    assert "the lowest level is not stuck" in warnings[0].message and "wrong sign" not in warnings[0].message
    reversed_sign = sign_warnings({"kf": -37.0}, "V", dissipates=False)[0].message
    assert "the describing function has the wrong sign" in reversed_sign
