"""The Iwan fit's microslip rule and the modal Jenkins backbone (issue 37), against harmonic
balance and the closed-form single-nonlinear-mode backbone.

Systems and truth: tests/test_test_type_truth.py (SDOF m = 2 kg, 10 Hz, ζ₀ = 0.5 %, a joint
from the mass to ground; the truth ``ω(a)² = ω₀² − ψ²k_t + ψ² Re ν(ψa)``,
``ζ(a) = (2ζ₀ω₀ + ψ² Im ν(ψa)/ω)/(2ω)`` from the element's closed-form describing function).
Phase-resonance points: the multi-harmonic balance (5 harmonics, AFT from the element's own
force law) at the force that holds each amplitude, interpolated to 90°.
"""
from __future__ import annotations

import re

import json
import warnings

import numpy as np
import pandas as pd
import pytest
from periodic_truth import periodic_truth
from test_test_type_truth import phase_resonance_point, system, truth

from nlupdate.app.cli import main
from nlupdate.core.identification.amplitude_modal_fit import fit_amplitude_model, microslip_test
from nlupdate.core.identification.backbone_samples import own_fit_for, source_noise
from nlupdate.core.identification.iwan_backbone_fit import JENKINS_BETA, JENKINS_CHI
from nlupdate.core.identification.phase_resonance import PhaseResonancePoints, samples_from_phase_resonance
from nlupdate.core.model.elements import IwanJoint, JenkinsFriction
from nlupdate.core.model.linear import LumpedModel
from nlupdate.core.model.system import NonlinearSystem
from nlupdate.core.response.harmonic_balance import trace_harmonic_balance

from reference_cache import session_cached


@session_cached  # computed once per session: other modules take the same reference
def locked_points(s: dict, amplitude: np.ndarray, harmonics: int = 5) -> list[np.ndarray]:
    """(Ω rad/s, force N, complex first harmonic of dof 0, m) at 90° for the forces that hold the
    modal ``amplitude`` at resonance on the truth."""
    psi = s["phi"][0]
    f, z = truth(s, amplitude)
    model = NonlinearSystem(LumpedModel(s["M"], s["K"], s["C"]), (s["joint"],))
    points = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for force in 2 * z * (2 * np.pi * f) ** 2 * amplitude / psi:
            curve = trace_harmonic_balance(model, {0: force}, 0.85 * s["w0"], 1.1 * s["w0"], harmonics=harmonics,
                                           stability=False)
            omega, x1 = phase_resonance_point(curve)
            points.append((omega, force, x1))
    return [np.array(v) for v in zip(*points)]


def pr_samples(s: dict, points: list[np.ndarray], noise: float = 0.0, seed: int = 0):
    omega, force, x = points
    rng = np.random.default_rng(seed)
    psi = s["phi"][0]
    return samples_from_phase_resonance(PhaseResonancePoints(
        "pr", "m1", "m1", omega / (2 * np.pi), force * (1 + noise * rng.standard_normal(force.size)),
        x * (1 + noise * rng.standard_normal(force.size))), psi, psi)


def curve_error(s: dict, model, low: float, high: float) -> tuple[float, float]:
    a = np.geomspace(low, high, 60)
    f, z = truth(s, a)
    return float(np.max(np.abs(model.frequency_hz(a) / f - 1))), float(np.max(np.abs(model.damping(a) / z - 1)))


def test_the_jenkins_limit_of_the_iwan_joint_is_the_jenkins_elements_closed_loop():
    """β = JENKINS_BETA: stuck (ν = k_t) below F_s/k_t, and above it the closed hysteresis loop's
    energy ``W = 4F_s(A − F_s/k_t)``, ``Im ν = W/(πA²)``; Re ν as the Jenkins element's."""
    kt, slip = 400.0, 0.5
    joint = IwanJoint((0,), slip_force=slip, kt=kt, chi=JENKINS_CHI, beta=JENKINS_BETA)
    amplitude = np.geomspace(0.2, 30, 80) * slip / kt
    nu = joint.describing_function(amplitude)
    jenkins = JenkinsFriction((0,), kf=kt, slip_force=slip).describing_function(amplitude)
    energy = np.where(amplitude > slip / kt, 4 * slip * (amplitude - slip / kt), 0.0)
    assert np.max(np.abs(nu.real / jenkins.real - 1)) < 1e-5
    assert np.max(np.abs(nu.imag - energy / (np.pi * amplitude**2))) < 1e-5 * kt


@pytest.fixture(scope="module")
def iwan_sdof():
    s = system(1, "iwan")
    amplitude = np.geomspace(0.05, 1.7, 6) * s["joint"].phi_max / s["phi"][0]  # up to 1.7 φ_max
    return s, locked_points(s, amplitude)


def test_the_free_iwan_fit_is_kept_where_beta_zero_misses_the_points(iwan_sdof):
    """Noise-free phase resonance of the Iwan SDOF (χ = −0.5, β = 0.5) up to 1.7 φ_max, below the
    2 × φ_max that used to force β = 0 (which missed the damping by 12 %): the F-test rejects
    β = 0 and the free fit recovers χ and β and the backbone (measured 2.6e-5, 0.34 %)."""
    s, points = iwan_sdof
    samples = pr_samples(s, points)
    model = fit_amplitude_model(samples, (("m1", float(s["phi"][0])),), "iwan")
    assert "all parameters fitted" in model.note and "F-test" in model.note
    assert model.joint.chi == pytest.approx(-0.5, abs=0.02) and model.joint.beta == pytest.approx(0.5, rel=0.05)
    error_f, error_z = curve_error(s, model, samples.amplitude.min(), samples.amplitude.max())
    assert error_f < 1e-4 and error_z < 0.01


def test_beta_zero_is_taken_where_the_samples_cannot_tell(iwan_sdof):
    """Microslip only (the three lowest points, up to 0.34 φ_max) with 2 % noise: too few values
    to test the free fit, β = 0 is fixed; the backbone still within 0.2 % / 5 % of the truth."""
    s, points = iwan_sdof
    samples = pr_samples(s, [p[:3] for p in points], noise=0.02, seed=3)
    model = fit_amplitude_model(samples, (("m1", float(s["phi"][0])),), "iwan")
    assert "fixed beta = 0" in model.note and model.joint.beta == 0
    error_f, error_z = curve_error(s, model, samples.amplitude.min(), samples.amplitude.max())
    assert error_f < 2e-3 and error_z < 0.05
    # the note gives the law chosen by the free fits' chi² and then the kept (beta = 0) fit's own,
    # not the kept fit's beside the other law's free fit (which read as if the worse law were kept)
    free = re.search(r"the free fits' chi² (\w+) ([\d.e+-]+), (\w+) ([\d.e+-]+)", model.note)
    kept = re.search(r"the kept fit with beta = 0: chi² ([\d.e+-]+)", model.note)
    assert free and kept, model.note
    assert free[1] == model.linear_damping and float(free[2]) <= float(free[4])
    assert float(kept[1]) >= float(free[2]) * (1 - 1e-2)  # fewer unknowns: no better than the free fit


def test_the_f_test_of_the_microslip_rule():
    """Equal χ²: nothing gained by the free fit (p = 1); a χ² 3 × larger over 10 degrees of
    freedom: F = 10, p = (1 + F·2/ν)^(−ν/2) = 3^−5 for the F(2, ν) distribution."""
    assert microslip_test(4.0, 4.0, 10) == 1.0
    assert microslip_test(4.0, 12.0, 10) == pytest.approx(3.0**-5, rel=1e-9)
    assert microslip_test(4.0, 12.0, 0) == 1.0


def test_an_iwan_fit_of_points_all_in_macroslip_is_not_held_under_the_softening_cap():
    """Phase resonance of the 2-DOF Iwan system (its 745 Hz mode) at six levels, 12–240 × the
    slip amplitude (7–133 φ_max), 2 % noise on force and response (ζ to ~3 %, the frequency to
    1e-4): the stuck mode's 745.08 Hz lies 1.7 % above the lowest point, which the points do
    not show (they soften by 0.01 % among themselves). The linear limit's cap (above the lowest
    sample by at most that softening) held f₀ at 733.4 Hz, and the fit, its joint distorted to
    reach the points, missed the damping by 12.2 %; the cap is now tested against the samples
    (F-test, p = 4e-5 here) and dropped: 1.4 %. Against the exact driving-point truth of the
    simulated system (tests/periodic_truth.py: multi-harmonic balance of the whole 2-DOF, 7
    harmonics) over the points' range: 0.2 % / 5 %."""
    s = system(2, "iwan")
    points = locked_points(s, np.geomspace(0.05, 1.0, 6) * 240 * s["slip"])
    samples = pr_samples(s, points, noise=0.02, seed=1)
    model = fit_amplitude_model(samples, (("m1", float(s["phi"][0])),), "iwan", frequency_std=1e-4, damping_std=0.03)
    a = np.geomspace(samples.amplitude.min(), samples.amplitude.max(), 12)
    f, z = periodic_truth(s, a, harmonics=7, samples=512)
    assert np.max(np.abs(model.frequency_hz(a) / f - 1)) < 2e-3
    assert np.max(np.abs(model.damping(a) / z - 1)) < 0.05
    assert "softening cap" in model.note
    assert any("linear limit" in w and "not determine" in w for w in model.warnings)  # f₀ below them: a guess


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_jenkins_backbone_follows_the_stick_slip_kink(seed):
    """Phase resonance of the Jenkins SDOF at six levels, 0.5–15 × its slip amplitude a_s, 2 %
    noise on force and response: the modal Jenkins backbone within 0.2 % in frequency over the
    points' range and 5 % in damping at the points and over the curve outside [a_s/1.2, 1.5 a_s]
    (within it the truth's ζ(a) rises from ζ₀ steeply, and a slip amplitude off by the few per
    cent six noisy points allow is ζ off by up to 13 %: docs/ring-down.md)."""
    s = system(1, "jenkins")
    points = locked_points(s, np.geomspace(0.5, 15, 6) * s["slip"])
    samples = pr_samples(s, points, noise=0.02, seed=seed)
    model = fit_amplitude_model(samples, (("m1", float(s["phi"][0])),), "jenkins")
    assert model.joint.beta == JENKINS_BETA and "Jenkins" in model.note
    error_f, _ = curve_error(s, model, samples.amplitude.min(), samples.amplitude.max())
    _, slipping = curve_error(s, model, 1.5 * s["slip"], samples.amplitude.max())
    _, stuck = curve_error(s, model, samples.amplitude.min(), s["slip"] / 1.2)
    away = samples.amplitude[(samples.amplitude <= s["slip"] / 1.2) | (samples.amplitude >= 1.5 * s["slip"])]
    _, z = truth(s, away)
    assert error_f < 2e-3 and slipping < 0.05 and stuck < 0.05
    assert away.size >= 4 and np.max(np.abs(model.damping(away) / z - 1)) < 0.05


def test_nlupdate_amplitude_fits_the_jenkins_backbone_from_csvs(tmp_path):
    """``--backbone jenkins`` on two phase-resonance files of the Jenkins SDOF (noise-free, and
    2 % noise on force and response), fitted jointly with each weighted by its scatter about its
    own Jenkins fit: the model written is the Iwan joint in its Jenkins limit with the truth's
    modal joint (k_t ψ², F_s ψ) within 1 %, and both sources agree."""
    s = system(1, "jenkins")
    omega, force, x = locked_points(s, np.geomspace(0.5, 15, 6) * s["slip"])
    rng = np.random.default_rng(5)
    paths = [tmp_path / "pr.csv", tmp_path / "pr_noisy.csv"]
    for path, noise in zip(paths, (0.0, 0.02)):
        pd.DataFrame({"frequency_hz": omega / (2 * np.pi),
                      "force_n": force * (1 + noise * rng.standard_normal(force.size)),
                      "response_amplitude": np.abs(x) * (1 + noise * rng.standard_normal(force.size)),
                      "response_phase_deg": np.degrees(np.angle(x)), "response_dof": "m1", "input_dof": "m1"}
                     ).to_csv(path, index=False)
    psi = float(s["phi"][0])
    assert main(["amplitude", "--phase-resonance", str(paths[0]), "--phase-resonance", str(paths[1]),
                 "--shape", f"m1={psi}", "--backbone", "jenkins", "--out", str(tmp_path / "amm")]) == 0
    joint = json.loads((tmp_path / "amm" / "amplitude_model.json").read_text())["joint"]
    assert joint["beta"] == JENKINS_BETA
    assert joint["kt"] == pytest.approx(psi**2 * s["kt"], rel=0.01)
    assert joint["slip_force"] == pytest.approx(psi * s["joint"].slip_force, rel=0.01)
    assert pd.read_csv(tmp_path / "amm" / "consistency.csv")["consistent"].all()


@pytest.mark.parametrize("seed", [0, 1])
def test_a_jenkins_sources_noise_is_its_scatter_about_its_own_jenkins_fit(seed):
    """The joint fit weighs each source by its noise: about a quadratic in ln a, six phase-resonance
    points of the Jenkins SDOF (2 % noise on force and response) seemed 0.7 % noisy in frequency
    and 40 % in damping (the kink, not noise); about the source's own Jenkins fit, their scatter
    is that of the points about the truth (asserted within a factor 2.5)."""
    s = system(1, "jenkins")
    samples = pr_samples(s, locked_points(s, np.geomspace(0.5, 15, 6) * s["slip"]), noise=0.02, seed=seed)
    f, z = truth(s, samples.amplitude)
    scatter = (np.sqrt(np.mean(np.log(samples.frequency_hz / f) ** 2)),
               np.sqrt(np.mean(np.log(samples.damping_ratio / z) ** 2)))
    quadratic = source_noise(samples)
    own = source_noise(samples, own_fit=own_fit_for("jenkins", (("m1", float(s["phi"][0])),)))
    assert quadratic[1] > 0.2 and quadratic[0] > 5 * scatter[0]
    assert scatter[1] / 2.5 < own[1] < 2.5 * scatter[1]
    assert own[0] < 2.5 * max(scatter[0], 1e-5)
