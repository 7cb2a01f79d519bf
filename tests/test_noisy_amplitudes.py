"""The Iwan fit of phase-resonance points with their amplitudes as noisy as their damping (issue
37), against the closed-form single-nonlinear-mode backbone of tests/test_test_type_truth.py.

Points: multi-harmonic balance at 90° (5 harmonics, ``locked_points``) at the benchmark's six
Iwan levels (0.3–6 a_s, φ_max = 1.8 a_s), 2 % noise on force and on response drawn as
benchmarks/test_type_truth.py draws it (seed 1000 + s), weighted as it and ``nlupdate
amplitude`` weigh a source (``source_noise`` about the source's own fit, ``sample_noise``).
"""
from __future__ import annotations

import numpy as np
import pytest
from test_backbone_forms import curve_error, locked_points
from test_stepped_sine_truth import IWAN_LEVELS
from test_test_type_truth import system, truth

from nlupdate.core.identification.amplitude_modal_fit import fit_amplitude_model
from nlupdate.core.identification.backbone_samples import own_fit_for, source_noise
from nlupdate.core.identification.phase_resonance import PhaseResonancePoints, samples_from_phase_resonance
from nlupdate.core.identification.sample_residuals import EIV_BACKBONES, noisy_residual, sample_noise, sample_residual


@pytest.fixture(scope="module")
def iwan_points():
    out = {}
    for dofs in (1, 2):
        s = system(dofs, "iwan")
        out[dofs] = s, locked_points(s, IWAN_LEVELS * s["slip"])
    return out


def benchmark_samples(s: dict, points, seed: int):
    """The points with the benchmark's 2 % noise on force and response (its seed 1000 + ``seed``)."""
    omega, force, response = points
    rng = np.random.default_rng(1000 + seed)
    psi = float(s["phi"][0])
    return samples_from_phase_resonance(PhaseResonancePoints(
        "pr", "m1", "m1", omega / (2 * np.pi), force * (1 + 0.02 * rng.standard_normal(force.size)),
        response * (1 + 0.02 * rng.standard_normal(force.size))), psi, psi)


def own_fit(s: dict, samples, errors_in_variables: bool = True):
    """The points' own Iwan fit, weighted as the benchmark and ``nlupdate amplitude`` weigh them."""
    shapes = (("m1", float(s["phi"][0])),)
    noise = source_noise(samples, None, own_fit_for("iwan", shapes))
    f_std, z_std, a_std = sample_noise(["phase-resonance"], [samples.amplitude.size], [noise], errors_in_variables)
    return fit_amplitude_model(samples, shapes, "iwan", 2, f_std, z_std, amplitude_std=a_std)


def test_the_noisy_residual_is_the_plain_one_where_no_amplitude_is_noisy():
    """Without noisy samples the residual is :func:`sample_residual`'s; a noisy sample at its
    measured amplitude has its damping misfit over the force's share of the noise."""
    s = system(1, "iwan")
    a = np.geomspace(0.3, 6, 5) * s["slip"]
    f, z = truth(s, a)
    f, z = f * 1.001, z * 0.97

    class Samples:
        amplitude, frequency_hz, damping_ratio = a, f, z

    def curves(x):
        ft, zt = truth(s, x)
        return 2 * np.pi * ft, zt

    plain = sample_residual(curves, Samples, 1e-3, 0.05)
    none = np.zeros(5, bool)
    assert np.allclose(noisy_residual(curves, a, f, z, np.array([]), none, np.full(5, 1e-3), np.full(5, 0.05),
                                      np.zeros(5)), plain)
    one = none.copy()
    one[2] = True
    out = noisy_residual(curves, a, f, z, np.log(a[[2]]), one, np.full(5, 1e-3), np.full(5, 0.05), np.full(5, 0.03))
    assert out.size == 11 and out[-1] == 0.0 and np.allclose(out[:5], plain[:5])
    assert out[5 + 2] == pytest.approx(plain[5 + 2] * 0.05 / 0.04)


@pytest.mark.parametrize("seed", [0, 1])
def test_an_iwan_sources_noise_is_its_scatter_about_its_own_iwan_fit(iwan_points, seed):
    """About a quadratic in ln a, six phase-resonance points of the Iwan SDOF (2 % noise on force
    and response: ~2.8 % on each ζ) seemed 11–13 % noisy in damping — ζ(a)'s peak past φ_max,
    not noise — so a joint fit all but ignored them; about their own Iwan fit their scatter is
    that of the points about the truth (asserted within a factor 2.5)."""
    s, points = iwan_points[1]
    samples = benchmark_samples(s, points, seed)
    f, z = truth(s, samples.amplitude)
    scatter = np.sqrt(np.mean(np.log(samples.damping_ratio / z) ** 2))
    quadratic = source_noise(samples)
    own = source_noise(samples, own_fit=own_fit_for("iwan", (("m1", float(s["phi"][0])),)))
    assert quadratic[1] > 3 * scatter
    assert scatter / 2.5 < own[1] < 2.5 * scatter


def test_the_iwan_fit_takes_each_points_amplitude_as_noisy(iwan_points):
    """2-DOF Iwan, the benchmark's seed 3: with the points' amplitudes taken as exact the own fit
    missed the damping by 6.9 % (8.0 % with the noise about the own fit; the slow test below); with
    each point's true amplitude fitted, its frequency read to 1e-5, the fit is within 5 %
    (measured 4.2 %) and φ_max within 5 % of the truth."""
    s, points = iwan_points[2]
    samples = benchmark_samples(s, points, 3)
    noisy = own_fit(s, samples)
    error_f, error_z = curve_error(s, noisy, samples.amplitude.min(), samples.amplitude.max())
    assert error_f < 2e-3 and error_z < 0.05
    assert noisy.joint.phi_max == pytest.approx(1.8 * s["slip"], rel=0.05)


@pytest.mark.slow  # 16 Iwan fits each, half with the points' amplitudes unknown: ~3 min each at load 7
@pytest.mark.parametrize("dofs, bound, exact_above", [(1, 0.07, False), (2, 0.05, True)])
def test_the_iwan_fit_of_six_noisy_points_over_eight_seeds(iwan_points, dofs, bound, exact_above):
    """Largest damping error of the points' own fit over the benchmark's seeds 0–7: 2-DOF within
    5 % (measured 4.8 %; with the amplitudes taken as exact 8.0 %, asserted above 5 %); SDOF
    6.4 % (exact: 6.7 %; 7.7 % before the noise was taken about the own fit), at its Cramér–Rao
    bound — an efficient estimator's largest error over 8 seeds is 6.0 % in the median, 8.7 %
    at the 90th percentile, within 5 % one time in four (benchmarks/kink_information.py --joint
    iwan)."""
    s, points = iwan_points[dofs]
    errors, exact = [], []
    for seed in range(8):
        samples = benchmark_samples(s, points, seed)
        low, high = samples.amplitude.min(), samples.amplitude.max()
        errors.append(curve_error(s, own_fit(s, samples), low, high)[1])
        exact.append(curve_error(s, own_fit(s, samples, errors_in_variables=False), low, high)[1])
    assert max(errors) < bound
    assert max(exact) > bound or not exact_above


@pytest.mark.slow  # 16 harmonic-balance points and 8 Jenkins fits with 16 amplitudes unknown: ~40 s at load 4
def test_the_jenkins_fit_places_the_slip_amplitude_at_the_cramer_rao_bound():
    """The Jenkins SDOF's sixteen phase-resonance points over 0.3–6 a_s (the benchmark's design),
    2 % noise on force and response, seeds 0–7: the own Jenkins fit's ln(φ_max/a_s) has a
    standard deviation over the seeds (about its mean: its bias is not asserted here) of no
    more than 1.45 × the Cramér–Rao bound of those points, computed
    here from the noise model (``kink_information.bound``: every point's true amplitude an
    unknown, the frequency exact; 0.65 %). 1.45 is the 95 % point of an efficient estimator's
    sample deviation over 8 draws, √(χ²₇(0.95)/7) = 1.42, rounded up. Measured: 0.53 % (0.82 ×
    the bound) with each point's true amplitude fitted; 1.26 % (1.94 ×) with the amplitudes
    taken as exact, as the ``jenkins`` fits did until 2026-11-29, asserted above the limit."""
    from kink_information import bound
    from test_type_truth import ISSUE_LEVELS, ISSUE_SPAN

    s = system(1, "jenkins")
    levels = np.geomspace(*ISSUE_SPAN, ISSUE_LEVELS)
    points = locked_points(s, levels * s["slip"])
    shapes = (("m1", float(s["phi"][0])),)
    limit = 1.45 * bound(1, levels, frequency_noise=1e-6)
    slips = {"the tool's": [], "exact": []}
    for seed in range(8):
        samples = benchmark_samples(s, points, seed)
        noise = source_noise(samples, None, own_fit_for("jenkins", shapes))
        # as nlupdate amplitude weighs a source (amplitude_joint: sample_noise for the EIV_BACKBONES)
        for fit, eiv in (("the tool's", "jenkins" in EIV_BACKBONES), ("exact", False)):
            stds = sample_noise(["phase-resonance"], [samples.amplitude.size], [noise], eiv)
            model = fit_amplitude_model(samples, shapes, "jenkins", 2, stds[0], stds[1], amplitude_std=stds[2])
            slips[fit].append(np.log(model.joint.phi_max / s["slip"]))
    assert 0.005 < limit / 1.45 < 0.008  # the bound itself: 0.65 % (docs/ring-down.md, the information table)
    assert np.std(slips["the tool's"], ddof=1) < limit
    assert np.std(slips["exact"], ddof=1) > limit
