"""The driving-point truth of the simulated Jenkins systems (tests/periodic_truth.py) against
RK4 time integration of the forced system and against the records the systems' tests make:
it is what the simulated 2-DOF does at phase resonance, where the closed-form single-mode
backbone (tests/test_test_type_truth.py ``truth``) is 0.2–0.4 % low in damping. The 2-DOF
Iwan system's records at the benchmark's levels are checked against it too."""
from __future__ import annotations

import numpy as np
import pytest
from periodic_truth import describing_function_truth, periodic_truth, phase_resonance_state
from test_backbone_forms import locked_points
from test_stepped_sine_truth import IWAN_LEVELS, LEVELS, stepped_sine_table
from test_test_type_truth import system, truth

from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.modal_samples import samples_from_frfs

STEPS = 200  # RK4 steps a period


def forced_rk4(s: dict, omega: float, force: float, x: np.ndarray, v: np.ndarray, slider, periods: int) -> np.ndarray:
    """RK4 of ``M ẍ + C ẋ + K x + g = F cos(Ωt) e₀`` from (x, v, the joint's slider) at t = 0,
    the joint by its element's time-domain law (state committed once a step, as
    ``test_test_type_truth.free_decay``): dof 0 at every step (m)."""
    minv, k, c, joint = np.linalg.inv(s["M"]), s["K"], s["C"], s["joint"]
    n, dt = k.shape[0], 2 * np.pi / omega / STEPS
    y, state, out, unit = np.concatenate([x, v]), np.asarray(slider, float), [x[0]], np.eye(k.shape[0])[0]

    def rate(t, y, st):
        g = np.zeros(n)
        g[0] = float(joint.force(np.array(y[0]), np.array(y[n]), st)[0])
        return np.concatenate([y[n:], minv @ (force * np.cos(omega * t) * unit - c @ y[n:] - k @ y[:n] - g)])

    for i in range(periods * STEPS):
        t = i * dt
        k1 = rate(t, y, state)
        k2 = rate(t + dt / 2, y + dt / 2 * k1, state)
        k3 = rate(t + dt / 2, y + dt / 2 * k2, state)
        k4 = rate(t + dt, y + dt * k3, state)
        y = y + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        state = joint.force(np.array(y[0]), np.array(y[n]), state)[1]
        out.append(y[0])
    return np.array(out)


def first_harmonic(x: np.ndarray, period: int) -> complex:
    """The first harmonic (m) of dof 0 over one period (counted from 1) of ``forced_rk4``'s record."""
    segment = x[(period - 1) * STEPS:period * STEPS]
    return complex(2 * np.mean(segment * np.exp(-2j * np.pi * np.arange(STEPS) / STEPS)))


def start_on_orbit(s: dict, a: float):
    """(Ω, F, x(0), v(0), the joint's slider at t = 0) of the truth's phase-resonance orbit at
    modal amplitude ``a``: every dof from the balance's harmonics, the slider by the element's
    law run over two periods of dof 0's motion ending at t = 0."""
    omega, force, problem, state = phase_resonance_state(s, a)
    harmonics = problem.harmonics_at(omega, state, list(range(s["M"].shape[0])))[0]  # (H+1, n)
    k = np.arange(harmonics.shape[0])[:, None]
    x, v = np.real(harmonics.sum(0)), np.real((1j * k * omega * harmonics).sum(0))
    slider = s["joint"].initial_state(())
    for t in np.linspace(-2, 0, 4001) * 2 * np.pi / omega:
        u = np.real(np.exp(1j * t * omega * k[:, 0]) @ harmonics[:, 0])
        slider = s["joint"].force(np.array(u), np.array(0.0), slider)[1]
    return omega, force, x, v, slider


@pytest.mark.parametrize("dofs, ratio", [(2, 3.0), (2, 15.0), (1, 3.0)])
def test_time_integration_stays_on_the_truths_phase_resonance(dofs, ratio):
    """Started on the truth's orbit at its (Ω, F), RK4 (200 steps a period) holds dof 0's
    first harmonic at ψa within 5e-5 and 90° behind the force within 0.005° after 100 periods
    (measured ≤ 1.6e-5 and 4e-4°), where a damping 0.1 % off the truth would have moved the
    amplitude by about 0.1 % · (1 − e^{−2πζ·100}) ≈ 0.98e-3 (2-DOF, 15 a_s)."""
    s = system(dofs, "jenkins")
    a = ratio * s["slip"]
    omega, force, x, v, slider = start_on_orbit(s, a)
    response = forced_rk4(s, omega, force, x, v, slider, 100)
    for period in (50, 100):
        x1 = first_harmonic(response, period)
        assert abs(abs(x1) / (s["phi"][0] * a) - 1) < 5e-5, period
        assert abs(np.degrees(np.angle(x1)) + 90) < 0.005, period


def test_the_closed_form_misses_what_time_integration_does_on_the_two_dof():
    """At the force and frequency the closed form gives for 15 a_s, RK4 run 300 periods (the
    start's transient decays by e^{−12}) settles at an amplitude a' where its own damping
    reading ψF sin φ/(2Ω²a') is the periodic truth's at a' within 0.02 % and 0.25–0.5 %
    above the closed form's (measured +0.007 % and +0.40 %)."""
    s = system(2, "jenkins")
    psi, a = s["phi"][0], 15 * s["slip"]
    f_c, z_c = truth(s, np.array([a]))
    omega_c = 2 * np.pi * float(f_c[0])
    force_c = 2 * float(z_c[0]) * omega_c**2 * a / psi
    _, _, x, v, slider = start_on_orbit(s, a)
    x1 = first_harmonic(forced_rk4(s, omega_c, force_c, x, v, slider, 300), 300)
    held = abs(x1) / psi
    reading = psi * force_c * abs(np.sin(np.angle(x1))) / (2 * omega_c**2 * held)
    assert abs(reading / periodic_truth(s, held)[1][0] - 1) < 2e-4
    assert 0.0025 < reading / truth(s, np.array([held]))[1][0] - 1 < 0.005


def test_the_two_dofs_driving_point_records_lie_on_the_truth():
    """The records the benchmarks fit, noise-free, are the simulated 2-DOF's: the stepped sine's
    six peaks (3-harmonic balance, ``samples_from_frfs``) and the phase-resonance points
    (5 harmonics, 90° by interpolation between traced points) lie within 0.2 % and 0.1 % of
    the periodic truth in damping (measured 0.17 %, 0.09 %: those estimators' own errors),
    where the points are 0.20–0.41 % above the closed form in macroslip. The peaks were 0.28–0.42 %
    above it while the other modes' share came from a one-mode fit of the lowest level (stuck,
    linear: exact here); read from every level (issue 34, a closed form whose lowest level is
    not linear read 3.8–7.5 % off before) they are 0.10–0.17 % below the periodic truth
    (measured): −0.05 … +0.28 % against the closed form, still rising above it into macroslip
    — the mode's shape changes as the joint slips, which the single-mode share takes in part."""
    s = system(2, "jenkins")
    psi = s["phi"][0]
    omega, force, x1 = locked_points(s, LEVELS * s["slip"])  # as benchmarks/test_type_truth.py records
    peaks = samples_from_frfs(FRFLevels.from_table(stepped_sine_table(s, force), "0", "0"), psi)
    amplitude = np.abs(x1) / psi
    for a, z, bound, above in ((peaks.amplitude, peaks.damping_ratio, 0.002, (-0.001, 0.0025)),
                               (amplitude, psi * force / (2 * omega**2 * amplitude), 0.001, (0.0019, 0.004))):
        slipping = a > 1.5 * s["slip"]
        assert np.abs(z / periodic_truth(s, a)[1] - 1).max() < bound
        closed = z[slipping] / truth(s, a[slipping])[1] - 1
        assert closed.min() > above[0] and closed.max() > above[1]


def test_the_one_harmonic_truth_is_the_closed_form_on_the_sdof_and_near_the_truth_on_the_two_dof():
    """The whole system's single-harmonic phase resonance: on the SDOF the closed form (no
    shape to change) to 1e-12; on the 2-DOF off the kink within 0.05 % of the periodic truth
    (measured 0.036 %: the harmonics), 0.1–0.4 % above the closed form over 2–15 a_s (measured
    0.12–0.39 %: the shape's change)."""
    s = system(1, "jenkins")
    a = np.geomspace(0.5, 15, 12) * s["slip"]
    np.testing.assert_allclose(describing_function_truth(s, a)[1], truth(s, a)[1], rtol=1e-12)
    s = system(2, "jenkins")
    a = np.concatenate([np.geomspace(0.5, 0.95, 3), np.geomspace(1.5, 15, 8)]) * s["slip"]
    one = describing_function_truth(s, a)[1]
    assert np.abs(one / periodic_truth(s, a)[1] - 1).max() < 5e-4
    above = one / truth(s, a)[1] - 1
    slipping = a >= 2 * s["slip"]
    assert np.all(above[slipping] > 0.001) and above.max() < 0.004


def test_the_two_dof_iwan_records_lie_on_the_truth():
    """The 2-DOF Iwan system's noise-free records at the benchmark's six levels (0.3–6 a_s =
    0.17–3.3 φ_max, from microslip into macroslip): the phase-resonance points (5 harmonics)
    within 1e-5 in frequency and 0.1 % in damping of the periodic truth (measured 9e-7 and
    0.064 %), the stepped sine's peaks (3-harmonic FRFs, ``samples_from_frfs``; 7 harmonics move
    them by < 1e-5) within 1e-4 and, but at φ_max, 0.3 % (measured 4.9e-5 and 0.18 %); the level
    at φ_max (1.8 a_s), where the truth's ζ(a) has a kink (flat below, steep above: the joint's
    last sliders let go), is read 1.06 % low from its FRF (the peak estimator's, over a
    resonance that spans the kink): within 2 %."""
    s = system(2, "iwan")
    psi = s["phi"][0]
    omega, force, x1 = locked_points(s, IWAN_LEVELS * s["slip"])  # as benchmarks/test_type_truth.py records
    amplitude = np.abs(x1) / psi
    f, z = periodic_truth(s, amplitude)
    assert np.abs(omega / (2 * np.pi) / f - 1).max() < 1e-5
    assert np.abs(psi * force / (2 * omega**2 * amplitude) / z - 1).max() < 1e-3
    peaks = samples_from_frfs(FRFLevels.from_table(stepped_sine_table(s, force), "0", "0"), psi)
    f, z = periodic_truth(s, peaks.amplitude)
    error = peaks.damping_ratio / z - 1
    at_phi_max = np.abs(peaks.amplitude * psi / s["joint"].phi_max - 1) < 0.1
    assert np.abs(peaks.frequency_hz / f - 1).max() < 1e-4
    assert at_phi_max.sum() == 1 and np.abs(error[~at_phi_max]).max() < 3e-3 and np.abs(error).max() < 0.02
