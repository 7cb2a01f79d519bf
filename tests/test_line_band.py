"""The line refinement's linear-damping law and its 95 % band against the simulated system's truth
(issues 34 and 37): the 2-DOF Jenkins system's stepped sine (tests/test_stepped_sine_truth.py:
harmonic balance, six levels 0.5–15 × the slip amplitude a_s, 2 % complex noise per line), the
Jenkins backbone fitted to its six peaks and refined on its lines
(``line_refine.refine_on_lines``), its band from ``line_band.line_refinement_band``; the truth
the simulated system's driving-point phase-resonance backbone (tests/periodic_truth.py,
checked against time integration in tests/test_periodic_truth.py; the closed-form
single-mode backbone of tests/test_test_type_truth.py is 0.12–0.39 % low in damping on the
2-DOF over 2–15 a_s). Coverage off the kink
band [a_s/1.03, 1.5 a_s], where the old band held the truth at 35–50 % (docs/ring-down.md,
"Honest bands at the kink"); the full run: ``benchmarks/kink_band_coverage.py``."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import scipy.optimize
from periodic_truth import periodic_truth
from test_backbone_forms import locked_points
from test_stepped_sine_truth import LEVELS, stepped_sine_table
from test_test_type_truth import system

from nlupdate.core.identification.amplitude_modal_fit import fit_amplitude_model
from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.joint_band import covariance_band, joint_unknowns, mixed_law_residual
from nlupdate.core.identification.line_band import jackknife_halfwidth, line_refinement_band
from nlupdate.core.identification.modal_samples import samples_from_frfs
from nlupdate.core.identification.line_refine import (
    refine_at_law, refine_on_lines, refinement_residual, stepped_sine_lines,
)
from nlupdate.core.measurement.noise import add_table_noise


#: parameter draws per band (the product's 4000 give the same coverage here, in 4 × the time)
DRAWS = 1000


def _table(dofs: int):
    s = system(dofs, "jenkins")
    return s, stepped_sine_table(s, locked_points(s, LEVELS * s["slip"])[1])


@pytest.fixture(scope="module")
def two_dof():
    return _table(2)


def _own_fit(s: dict, table, seed: int) -> dict:
    """The stepped sine's own refinement at ``seed``: the lines' law and band, and the old
    estimator's (the sample fit's law kept, the covariance band alone), off and inside the
    kink band at 60 amplitudes over the levels' range."""
    data = FRFLevels.from_table(add_table_noise(table, 0.02, seed), "0", "0")
    samples = samples_from_frfs(data, s["phi"][0])
    lines = stepped_sine_lines(data, s["phi"][0])
    start = fit_amplitude_model(samples, (("0", float(s["phi"][0])),), "jenkins")
    a = np.geomspace(samples.amplitude.min(), samples.amplitude.max(), 60)
    _, z = periodic_truth(s, a)
    model, noise = refine_on_lines(start, lines)
    low, high = line_refinement_band(model, lines, noise, a, seed=seed, draws=DRAWS)[2:]
    old, old_noise = refine_at_law(start, lines)
    residual = refinement_residual(old, lines)
    old_low, old_high = covariance_band(old, lambda theta: residual(theta, old_noise), a, DRAWS, seed)[2:]
    fitted = model.damping(a)
    return {"off": (a < s["slip"] / 1.03) | (a > 1.5 * s["slip"]), "error": np.abs(fitted / z - 1),
            "held": (z >= low) & (z <= high), "old_held": (z >= old_low) & (z <= old_high),
            "half_width": (high - low) / 2 / fitted, "law": (start.linear_damping, model.linear_damping)}


def test_the_lines_choose_the_law_and_the_band_holds_the_truth_off_the_kink(two_dof):
    """Seeds 2 and 3 of the 2-DOF, where the peaks' sample fit picks the structural law (the
    truth's damping is viscous): the lines pick the viscous one, and the damping off the kink
    is within 0.5 % (measured 0.26, 0.34 %; against the closed form 0.21, 0.34 %, kept at the
    sample fit's law 0.87, 0.96 %). The band holds it at every one of the 104 amplitudes off
    the kink; the old band — the sample fit's law, the covariance alone, half-width 0.18 % —
    at 31 % and 29 % (15 % and 10 % of the closed form). The new band's median half-width
    0.33 % and 0.22 %: not a constant widening."""
    s, table = two_dof
    fits = [_own_fit(s, table, seed) for seed in (2, 3)]
    assert [f["law"] for f in fits] == [("structural", "viscous")] * 2
    off = np.concatenate([f["off"] for f in fits])
    for f in fits:
        assert f["error"][f["off"]].max() < 0.005
    assert np.concatenate([f["held"] for f in fits])[off].mean() >= 0.9
    assert np.concatenate([f["old_held"] for f in fits])[off].mean() < 0.5
    assert np.median(np.concatenate([f["half_width"] for f in fits])[off]) < 0.004


@pytest.mark.slow  # 8 seeds of two systems: 30 + 37 s at load 8; the fast version is the test above
@pytest.mark.parametrize("dofs, off_bound", [(1, 0.95), (2, 0.75)], ids=["sdof", "2dof"])
def test_the_line_band_covers_the_truth_off_the_kink_eight_seeds(dofs, off_bound):
    """Seeds 0–7, the stepped sine's own refinement: off the kink the band holds the damping
    truth at ≥ 95 % (SDOF) and ≥ 75 % (2-DOF) of the 60 × 8 amplitudes (measured 98.1 % and
    78.5 %; against the closed form 100 % and 85.2 %: on the 2-DOF the closed form is the
    lower, and the refinement, 0.1–0.15 % below the truth noise-free in macroslip, now misses
    on the seeds where the noise moves it down as well; over seeds 0–15 86.8 %,
    docs/ring-down.md), inside it at ≥ 90 % (100 % and 95.2 %)."""
    s, table = _table(dofs)
    fits = [_own_fit(s, table, seed) for seed in range(8)]
    off = np.concatenate([f["off"] for f in fits])
    held = np.concatenate([f["held"] for f in fits])
    assert held[off].mean() >= off_bound
    assert held[~off].mean() >= 0.9


def test_the_mixed_law_is_each_law_at_its_share(two_dof):
    """The band's mixed law at viscous share w = 1 and 0 is the viscous and the structural
    model (their residuals on the lines, to rounding), and at w = ½ it is, on the lowest
    level's lines (stuck: one amplitude per line), the misfit of the dynamic stiffness
    ``ω₀² − K_T + Re ν(a) − Ω² + i(2ζ₀ω₀²[(1 − w) + wΩ/ω₀] + Im ν(a))`` with each line's
    amplitude solved by root bracketing — linear in w within 1e-6 of a line's noise."""
    s, table = two_dof
    data = FRFLevels.from_table(add_table_noise(table, 0.02, 0), "0", "0")
    lines = stepped_sine_lines(data, s["phi"][0])
    start = fit_amplitude_model(samples_from_frfs(data, s["phi"][0]), (("0", float(s["phi"][0])),), "jenkins")
    model, noise = refine_on_lines(start, lines)
    theta = joint_unknowns(model)
    residual = mixed_law_residual(model, lambda m: (lambda t, r=refinement_residual(m, lines): r(t, noise)))
    for law, share in (("viscous", 1.0), ("structural", 0.0)):
        r = refinement_residual(replace(model, linear_damping=law), lines)
        np.testing.assert_allclose(residual(np.append(theta, share)), r(theta, noise), rtol=1e-9, atol=1e-9)
    w0, z0, joint, phi = 2 * np.pi * model.natural_frequency_hz, model.damping_ratio, model.joint, lines.input_shape

    def stiffness(a, omega):
        nu = joint.describing_function(np.array([a]))[0]
        return (w0**2 - joint.kt + nu.real - omega**2
                + 1j * (2 * z0 * w0**2 * (0.5 + 0.5 * omega / w0) + nu.imag))

    mixed = residual(np.append(theta, 0.5))
    n = lines.omega.size
    for i in np.flatnonzero(lines.level == 0)[::5]:
        omega, target = lines.omega[i], phi * lines.force[i]
        a = scipy.optimize.brentq(lambda x: x * abs(stiffness(x, omega)) - target, lines.amplitude[i] / 2,
                                  2 * lines.amplitude[i], xtol=1e-16, rtol=1e-13)
        measured = phi**2 / lines.receptance[i]
        exact = (measured - stiffness(a, omega)) / abs(measured) / (noise / np.sqrt(2))
        assert abs(mixed[i] - exact.real) < 1e-6 and abs(mixed[n + i] - exact.imag) < 1e-6


def test_jackknife_halfwidth_closed_form():
    """Six refits 0, 1, 0, 1, 0, 1: σ_J² = 5/6 · Σ(c − ½)² = 5/6 · 1.5, times t(5) = 2.5706."""
    refits = np.array([0.0, 1, 0, 1, 0, 1])[:, None]
    assert jackknife_halfwidth(refits)[0] == pytest.approx(2.5706 * np.sqrt(5 / 6 * 1.5), rel=1e-4)
    assert jackknife_halfwidth(refits[:2])[0] == 0.0
