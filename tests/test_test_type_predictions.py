"""What an amplitude-dependent modal model predicts for each test type
(nlupdate.core.model.amplitude_modal: phase_resonance_point, ring_down_envelope, held_frf).

The model is the Iwan SDOF's exact modal counterpart (mass-normalised: φ = 1/√m, K_T = k_t/m,
F_S = F_s/√m, ω₀² = (k + k_t)/m, ζ₀ = c/(2mω₀), viscous); the references simulate the
physical SDOF independently of the model: multi-harmonic balance locked at 90°
(tests/test_phase_resonance.py), RK4 time integration of a free decay (tests/test_ring_down.py)
and a held-amplitude sweep with the joint's own time-domain law (tests/test_response_controlled.py).
"""
from __future__ import annotations

import numpy as np
import pytest
import scipy.signal

from nlupdate.core.model.amplitude_modal import AmplitudeModalModel
from nlupdate.core.model.elements import IwanJoint
import test_phase_resonance as pr
import test_ring_down as rd
from test_response_controlled import held_sweep


def modal_model(joint: IwanJoint, m: float, k: float, c: float) -> AmplitudeModalModel:
    w0 = np.sqrt((k + joint.kt) / m)
    modal = IwanJoint((0,), slip_force=joint.slip_force / np.sqrt(m), kt=joint.kt / m, chi=joint.chi, beta=joint.beta)
    return AmplitudeModalModel(w0 / (2 * np.pi), c / (2 * m * w0), (("mass", 1 / np.sqrt(m)),), joint=modal)


def test_phase_resonance_points_predicted_against_harmonic_balance():
    model = modal_model(pr.IWAN, pr.M, pr.K, pr.C)
    omega, force, x = pr.locked_points(pr.IWAN, pr.FORCES)
    f, a = model.phase_resonance_point(force, "mass")
    assert np.max(np.abs(f / (omega / (2 * np.pi)) - 1)) < 2e-4  # measured 3.9e-6
    assert np.max(np.abs(a * pr.PHI / np.abs(x) - 1)) < 5e-3  # measured 4.5e-4


def test_ring_down_envelope_predicted_against_time_integration():
    model = modal_model(rd.IWAN, rd.M, rd.K, rd.C)
    t, x = rd.free_decay(rd.IWAN, 3e-3, 60)
    turns = scipy.signal.find_peaks(np.abs(x))[0]  # the turning points, each half period
    # half of each swing from one turning point to the next (a stuck slider leaves an offset)
    swing, middle = 0.5 * np.abs(np.diff(x[turns])), 0.5 * (t[turns][1:] + t[turns][:-1])
    predicted = model.ring_down_envelope(middle, swing[0] * np.sqrt(rd.M)) / np.sqrt(rd.M)
    error = swing / predicted - 1
    assert swing[-1] < 0.05 * swing[0]  # the decay covers a factor 23
    # measured up to 3.2 %: the describing function's slow flow (ζ within 1.4 % of the record's,
    # docs/ring-down.md) integrated over the decay, and the joint's 200 sliders
    assert np.max(np.abs(error)) < 0.04


@pytest.mark.parametrize("held_m", [2e-4, 1e-3])
def test_held_amplitude_sweep_predicted_against_the_joint_law(held_m):
    model = modal_model(rd.IWAN, rd.M, rd.K, rd.C)
    f = model.frequency_hz(held_m * np.sqrt(rd.M)) * np.linspace(0.98, 1.02, 41)
    run = held_sweep(held_m, f, element=rd.IWAN)
    h = model.held_frf(f, held_m, "mass", "mass")
    # measured 1.7e-3 at 0.2 mm, 3.8e-3 at 1 mm: the time-domain joint has 200 sliders, the describing
    # function the continuum
    assert np.max(np.abs(h / run.h - 1)) < 1e-2
