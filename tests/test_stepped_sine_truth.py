"""Force-controlled stepped sine of the Jenkins systems of tests/test_test_type_truth.py
against their closed-form truth (issue 37): one sample per level from the peak of each FRF
(``samples_from_frfs``, its peak by ``frf_peak.resonance_peak``), and the Jenkins backbone
fitted to them and refined on every line (``line_refine.refine_on_lines``).

Records: the multi-harmonic balance (3 harmonics, ``simulate_frf_table``'s default; AFT from the
element's time-domain law) of
each system at six force levels — those that hold 0.5–15 × the Jenkins slip amplitude a_s at
phase resonance (``locked_points``) — on 301 lines over 0.9–1.05 f₀, with 2 % complex noise
per line (``add_table_noise``): the benchmark's stepped sine (benchmarks/test_type_truth.py).
"""
from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest
from test_backbone_forms import locked_points
from test_test_type_truth import system, truth

from nlupdate.app.cli import main
from nlupdate.core.identification.amplitude_modal_fit import fit_amplitude_model
from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.line_refine import refine_on_lines, stepped_sine_lines
from nlupdate.core.identification.modal_samples import ModalSamples, samples_from_frfs
from nlupdate.core.measurement.noise import add_table_noise
from nlupdate.core.model.linear import LumpedModel
from nlupdate.core.model.system import NonlinearSystem
from nlupdate.core.response.simulate import simulate_frf_table

from reference_cache import session_cached

LEVELS = np.geomspace(0.5, 15, 6)  # × the slip amplitude: stuck, at the kink, into gross slip
#: the Iwan joint's six levels, × a_s (SDOF and 2-DOF; φ_max = 1.8 a_s on both): 0.3–6 a_s =
#: 0.17–3.3 φ_max, from microslip across the damping's peak into macroslip (the 2-DOF's were
#: 12–240 a_s until 2026-11-29, all macroslip: its joint's microslip had no sample)
IWAN_LEVELS = np.geomspace(0.05, 1.0, 6) * 6


@session_cached  # computed once per session: other modules take the same reference
def stepped_sine_table(s: dict, forces: np.ndarray) -> pd.DataFrame:
    """The system's driving-point FRFs at dof 0 by harmonic balance at ``forces`` (N), 301
    lines over 0.9–1.05 f₀ (module docstring)."""
    model = NonlinearSystem(LumpedModel(s["M"], s["K"], s["C"]), (s["joint"],))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        table, _ = simulate_frf_table(model, 0, s["w0"] / (2 * np.pi) * np.linspace(0.9, 1.05, 301), list(forces),
                                      method="hb")
    return table


def stepped_sine_samples(s: dict, table: pd.DataFrame, seed: int | None) -> ModalSamples:
    """One sample per level, with 2 % noise drawn from ``seed`` (None: noise-free)."""
    noisy = table if seed is None else add_table_noise(table, 0.02, seed)
    dof = str(noisy["response_dof"].iloc[0])
    return samples_from_frfs(FRFLevels.from_table(noisy, dof, dof), s["phi"][0])


@pytest.fixture(scope="module", params=[1, 2], ids=["sdof", "2dof"])
def jenkins(request):
    s = system(request.param, "jenkins")
    return s, stepped_sine_table(s, locked_points(s, LEVELS * s["slip"])[1])


def test_every_level_of_the_stepped_sine_on_the_truth(jenkins):
    """Each level's sample within 0.2 % in frequency and 5 % in damping of the truth at its
    own amplitude, the level at the kink (0.99 a_s) included, 8 noise seeds (measured: SDOF
    8.8e-4 / 1.1 %, 2-DOF 2.9e-4 / 1.5 %; the former three-point peak 5.2e-3 / 24 % and
    1.6e-3 / 13 %, its damping 1–5 % low on average at every level and its amplitude as
    much high, which at the kink put a stuck level on the slipping side); noise-free within
    7e-4 / 0.5 % (measured 6.2e-4 / 0.4 %, 1.2e-4 / 0.3 %). Since issue 34 the other modes'
    share is read from every level (nlupdate.core.identification.level_residual), not from
    a one-mode fit of the lowest level — exact here, where that level is stuck (linear), and
    2.8-4.9 % off in amplitude where it is not: the SDOF's level whose lines cross the kink
    (0.98-1.96 a_s) reads 6.2e-4 in frequency noise-free (4.2e-4 before, bound 5e-4), and
    with noise SDOF 1.1e-3 / 1.3 %, 2-DOF 3.6e-4 / 1.8 % (8 seeds, measured) — a small
    loss on this system, stated, for the bias removed on a nonlinear lowest level."""
    s, table = jenkins
    for seed, bounds in [(None, (7e-4, 0.005))] + [(seed, (2e-3, 0.05)) for seed in range(8)]:
        samples = stepped_sine_samples(s, table, seed)
        f, z = truth(s, samples.amplitude)
        assert samples.amplitude.size == LEVELS.size
        assert np.abs(samples.frequency_hz / f - 1).max() < bounds[0], seed
        assert np.abs(samples.damping_ratio / z - 1).max() < bounds[1], seed


def test_the_jenkins_backbone_of_the_stepped_sine_off_its_slip_amplitude():
    """The SDOF's Jenkins backbone fitted to its six levels (relative noise taken 1e-3 in
    frequency, 1 % in damping), 3 seeds, at 60 amplitudes over the samples' range: within
    0.2 % / 5 % of the truth outside [0.97, 1.5] × a_s, and the fitted slip amplitude within
    3 % of a_s (measured over 8 seeds: ≤ 3.9e-4 / 0.78 %, slip amplitude −0.42 … +0.85 %).
    Inside that band the damping is not resolved: the truth's ζ rises from ζ₀ at a_s with
    ∂ln ζ/∂ln a_s = −12.7 there, so a slip amplitude 1 % off is ζ up to 13 % off
    (docs/ring-down.md, "Near the stick–slip kink")."""
    s = system(1, "jenkins")
    table = stepped_sine_table(s, locked_points(s, LEVELS * s["slip"])[1])
    for seed in range(3):
        samples = stepped_sine_samples(s, table, seed)
        model = fit_amplitude_model(samples, (("m1", float(s["phi"][0])),), "jenkins", frequency_std=1e-3,
                                    damping_std=0.01)
        assert abs(model.joint.phi_max / s["slip"] - 1) < 0.03, seed
        a = np.geomspace(samples.amplitude.min(), samples.amplitude.max(), 60)
        a = a[(a < 0.97 * s["slip"]) | (a > 1.5 * s["slip"])]
        f, z = truth(s, a)
        assert np.abs(model.frequency_hz(a) / f - 1).max() < 2e-3, seed
        assert np.abs(model.damping(a) / z - 1).max() < 0.05, seed


def assert_refined_on_the_lines(s: dict, table: pd.DataFrame, seeds) -> None:
    """The Jenkins backbone fitted to the six peaks and refined on every line within half its
    level's peak by output error (``refine_on_lines``), noise-free and at each of ``seeds``,
    at 80 amplitudes over 0.5–15 × a_s, the stick–slip kink included: within 1e-4 in frequency and 2 % in damping of
    the truth, the slip amplitude within 0.5 % (measured over 8 seeds: SDOF 4.9e-5 / 1.15 %,
    slip +0.003 … +0.16 %; 2-DOF 6.2e-5 / 0.97 %, −0.14 … +0.27 %). The peaks alone, the start,
    place it −0.06 … +2.5 % and −1.3 … +2.0 % off and miss the damping by up to 19 % and 7.1 %
    next to a_s (docs/ring-down.md, "Near the stick–slip kink"); noise-free within 1e-4 / 1 %
    and 0.4 % (measured 2.3e-5 / 0.49 %, +0.06 %; 5.2e-5 / 0.67 %, +0.27 %)."""
    shapes = (("0", float(s["phi"][0])),)
    a = np.geomspace(0.5, 15, 80) * s["slip"]
    f, z = truth(s, a)
    for seed, bounds in [(None, (1e-4, 0.01, 0.004))] + [(seed, (1e-4, 0.02, 0.005)) for seed in seeds]:
        noisy = table if seed is None else add_table_noise(table, 0.02, seed)
        data = FRFLevels.from_table(noisy, "0", "0")
        start = fit_amplitude_model(samples_from_frfs(data, s["phi"][0]), shapes, "jenkins")
        model, noise = refine_on_lines(start, stepped_sine_lines(data, s["phi"][0]))
        assert abs(model.joint.phi_max / s["slip"] - 1) < bounds[2], seed
        assert np.abs(model.frequency_hz(a) / f - 1).max() < bounds[0], seed
        assert np.abs(model.damping(a) / z - 1).max() < bounds[1], seed
        if seed is not None:  # the lines' rms misfit is their noise: 2 % of |H|
            assert 0.017 < noise < 0.023, seed


def test_the_jenkins_backbone_refined_on_the_lines_through_the_kink(jenkins):
    """``assert_refined_on_the_lines`` on seeds 0–2 (all 8: the slow test below)."""
    assert_refined_on_the_lines(*jenkins, range(3))


@pytest.mark.slow  # 8 seeds of both systems: 40 s at load 11; the fast version is the test above
def test_the_jenkins_backbone_refined_on_the_lines_through_the_kink_eight_seeds(jenkins):
    """``assert_refined_on_the_lines`` on seeds 0–7 (the measured figures in its docstring)."""
    assert_refined_on_the_lines(*jenkins, range(8))


def test_nlupdate_amplitude_jenkins_stepped_sine_with_phase_resonance_through_the_kink(tmp_path):
    """``nlupdate amplitude --backbone jenkins`` on the SDOF's stepped sine (CSV, 2 % noise,
    seed 0) and its six phase-resonance points (2 % noise on force and response): the joint
    fit, refined on the stepped sine's lines, writes a backbone.csv within 2e-4 in frequency
    and 5 % in damping of the truth at every one of its amplitudes (0.5–15 × a_s, the kink
    included; measured 9.4e-5 / 3.6 %: the phase-resonance points, fitted at their noisy
    amplitudes, pull it from the lines' own 1 %); before the refinement the kink band was left
    out (the peaks' fits: up to 18 % inside it). With the phase resonance held out, the
    stepped sine's fit predicts it at its six points within the same bounds (against the
    truth at their amplitudes; measured 2.2e-5 / 0.21 %, the point read at 1.01 a_s included)."""
    s = system(1, "jenkins")
    omega, force, x = locked_points(s, LEVELS * s["slip"])
    rng = np.random.default_rng(7)
    pd.DataFrame({"frequency_hz": omega / (2 * np.pi), "force_n": force * (1 + 0.02 * rng.standard_normal(force.size)),
                  "response_amplitude": np.abs(x) * (1 + 0.02 * rng.standard_normal(force.size)),
                  "response_phase_deg": np.degrees(np.angle(x)), "response_unit": "m", "response_dof": "0",
                  "input_dof": "0"}).to_csv(tmp_path / "pr.csv", index=False)
    add_table_noise(stepped_sine_table(s, force), 0.02, 0).to_csv(tmp_path / "frf.csv", index=False)
    out = tmp_path / "amm"
    assert main(["amplitude", "--measured", str(tmp_path / "frf.csv"), "--phase-resonance", str(tmp_path / "pr.csv"),
                 "--shape", f"0={s['phi'][0]}", "--backbone", "jenkins", "--bootstrap", "0", "--out", str(out)]) == 0
    curve = pd.read_csv(out / "backbone.csv")
    a = curve["modal_amplitude"].to_numpy()
    f, z = truth(s, a)
    assert a.min() < 0.6 * s["slip"] and a.max() > 10 * s["slip"]
    assert np.count_nonzero((a > s["slip"]) & (a < 1.5 * s["slip"])) >= 3  # the kink band is in it
    assert np.abs(curve["natural_frequency_hz"].to_numpy() / f - 1).max() < 2e-4
    assert np.abs(curve["damping_ratio"].to_numpy() / z - 1).max() < 0.05
    assert "refined on" in (out / "amplitude_model.json").read_text()
    # its 95 % bands (the refinement's linearised covariance, tests/test_joint_band.py) hold the
    # truth: measured at 50 of 50 amplitudes in damping and in frequency, the 3.6 % point included
    held_z = (z >= curve["damping_ratio_low"].to_numpy()) & (z <= curve["damping_ratio_high"].to_numpy())
    held_f = (f >= curve["natural_frequency_hz_low"].to_numpy()) & (f <= curve["natural_frequency_hz_high"].to_numpy())
    assert held_z.mean() >= 0.9 and held_f.mean() >= 0.9
    # the phase resonance held out: the stepped sine's refined fit predicts it at its points,
    # the one at 0.99 a_s read at 1.01 a_s (its 2 % noise) and 1.92 a_s among them
    held = tmp_path / "held"
    assert main(["amplitude", "--measured", str(tmp_path / "frf.csv"), "--phase-resonance", str(tmp_path / "pr.csv"),
                 "--shape", f"0={s['phi'][0]}", "--backbone", "jenkins", "--bootstrap", "0", "--hold-out",
                 "phase-resonance", "--out", str(held)]) == 0
    frame = pd.read_csv(held / "held_out.csv")
    f, z = truth(s, frame["modal_amplitude"].to_numpy())
    assert len(frame) == LEVELS.size
    assert np.abs(frame["predicted_frequency_hz"].to_numpy() / f - 1).max() < 2e-4
    assert np.abs(frame["predicted_damping_ratio"].to_numpy() / z - 1).max() < 0.05
