"""``validate``'s single-mode models at the force each line achieved, with response-controlled
runs kept as evidence, and the bands' form (issue 34).

References, independent of the code under test: one mode with a hardening cubic spring and a
damping that grows as a² (the Brake–Reuss beam's grows ~a^1.8), solved in closed form by
single-harmonic balance line by line — ``a·|ω₀² + ¾k₃a² − Ω² + 2iζ(a)ω₀Ω| = F`` with
``ζ(a) = ζ₀ + γa²`` (bisection; the root is unique here, asserted) — for a force-controlled
sweep whose force dips by 30 % at resonance as a shaker's does, and for response-controlled
runs, which hold a and are linear at it; and (slow) the describing-function simulation of an
Iwan joint measured as the BRB was, for the bands' coverage.
"""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import scipy.stats

from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.response_controlled import HeldRun
from nlupdate.core.measurement.frf_table import frf_table
from nlupdate.core.validation.forced_runs import ForcedRun, runs_repeatability
from nlupdate.core.validation.held_out import Repeatability, bands, repeatability, resonance_amplitudes, validate
from nlupdate.core.validation.models import model_fitter
from nlupdate.core.validation.resonance import resonance

W0, ZETA0, K3, GAMMA = 2 * np.pi * 80.0, 0.002, 1.5e10, 2.0e4
LEVELS = (0.2, 0.5, 1.0, 1.5)
F = np.linspace(79.2, 81.2, 41)


def denominator(a, omega):
    return W0**2 + 0.75 * K3 * a**2 - omega**2 + 2j * (ZETA0 + GAMMA * a**2) * W0 * omega


def amplitude(force, omega):
    """The root of a·|D(a, Ω)| = F (unique: a·|D| rises with a on the grid, asserted)."""
    grid = np.geomspace(1e-9, 1e-2, 4000)
    g = grid * np.abs(denominator(grid, omega))
    assert np.all(np.diff(g) > 0)
    return float(np.interp(np.log(force), np.log(g), grid))


def shaker_force(level):
    """A force-controlled sweep's achieved force: 30 % below its level at resonance."""
    return level * (1 - 0.3 * np.exp(-(((F - 80.3) / 0.3) ** 2)))


def force_controlled(levels=LEVELS):
    rows = []
    for level in levels:
        force = shaker_force(level)
        h = np.array([1 / denominator(amplitude(fk, 2 * np.pi * f), 2 * np.pi * f) for f, fk in zip(F, force)])
        rows.append(frf_table(F, level, "0", "0", h).assign(level_achieved=force))
    return FRFLevels.from_table(pd.concat(rows, ignore_index=True), "0", "0")


def response_controlled(held):
    runs = []
    for k, x in enumerate(held):
        h = 1 / denominator(x, 2 * np.pi * F)
        runs.append(HeldRun(f"run{k}", "0", "0", F.copy(), h, x, x / np.abs(h)))
    return runs


@pytest.fixture(scope="module")
def data():
    return force_controlled()


def test_the_force_at_each_line_predicts_a_held_out_level(data):
    """The line model fitted on three levels predicts the fourth as the closed form has it —
    at the force each of its lines achieved; at the nominal level it misses by more."""
    kept = data.subset(LEVELS[:2] + LEVELS[3:])
    fitted = model_fitter("lines")(kept)
    level = LEVELS[2]
    f, h = data.curve(level)
    truth = resonance(f, h)
    at_lines = resonance(f, fitted(f, level, data.force_at(level, f)))
    nominal = resonance(f, fitted(f, level))
    assert at_lines.resonance_hz == pytest.approx(truth.resonance_hz, abs=0.02)  # the levels span 0.25 Hz
    assert at_lines.damping_ratio == pytest.approx(truth.damping_ratio, rel=0.08)  # measured +5.8 %
    assert at_lines.peak_abs == pytest.approx(truth.peak_abs, rel=0.05)  # measured −3.5 %
    for name in ("damping_ratio", "peak_abs"):  # at the nominal level: +48 % and −18 %
        assert abs(getattr(nominal, name) / getattr(truth, name) - 1) > 3 * abs(getattr(at_lines, name) /
                                                                               getattr(truth, name) - 1)


def test_response_controlled_runs_kept_carry_the_top_level(data):
    """Runs held at amplitudes up to beyond the top level, kept beside the two lowest levels:
    the top level held out is predicted as the closed form has it, and the test's
    repeatability, pooled over nine curves instead of three, narrows every band."""
    data = data.subset([0.2, 0.5, 1.5])
    top = 1.5
    x_top = max(np.abs(data.curve(top)[1]) * data.force_at(top, F))
    runs = response_controlled(np.geomspace(0.2, 1.2, 6) * x_top)
    without = validate(data, "top", ["lines"]).held_out[0].compared
    kept = validate(data, "top", ["lines"], runs=runs)
    withr = kept.held_out[0].compared
    assert kept.kept_runs == tuple(run.name for run in runs) and kept.repeatability.levels == 9
    assert abs(withr["resonance_hz"].error) < 0.02  # measured −0.011 Hz
    assert abs(withr["damping_ratio"].relative_error) < 0.08  # +5.3 %
    assert abs(withr["peak_abs"].relative_error) < 0.04  # −2.1 %
    for name in ("resonance_hz", "damping_ratio", "peak_abs"):
        assert withr[name].inside
        assert withr[name].high - withr[name].low < 0.7 * (without[name].high - without[name].low), name
    with pytest.raises(ValueError, match="only lines, lines-background can"):
        model_fitter("amplitude-iwan", runs)


def test_damping_and_peak_bands_are_relative_and_positive():
    """Refits whose damping ratios scatter by a factor: the band is the closed form
    ζ̂·exp(∓t·√(σ_J∓² + σ_R²)) in log ζ (Welch–Satterthwaite t; σ_J− and σ_J+ the jackknife
    spread below and above the refits' mean, √(2·(n−1)/n·Σ_side d²)), never below 0 and
    wider above; the resonance band, whose refits agree, stays symmetric in Hz."""
    w = 2 * np.pi * F

    def mode(fn, zeta):
        wn = 2 * np.pi * fn
        return 1 / (wn**2 - w**2 + 2j * zeta * wn * w)

    zetas = np.array([0.002, 0.004, 0.008])  # half-power ζ of each refit (exact to the grid)
    curves = [mode(80.2, z) for z in zetas]
    predicted = mode(80.2, 0.004)
    repeat = Repeatability(0.05, 0.0005, 6, damping_relative=0.2, peak_relative=0.1, degree=1)
    measured = {"resonance_hz": 80.2, "damping_ratio": 0.004, "peak_abs": float(np.abs(predicted).max())}
    compared, low, high = bands(F, measured, predicted, curves, repeat, noise=0.0)
    shown = np.log([resonance(F, c).damping_ratio for c in curves])
    d = shown - shown.mean()
    zeta = compared["damping_ratio"]
    for sign, edge in ((-1, zeta.low), (1, zeta.high)):
        sigma_j = np.sqrt(2 * 2 / 3 * np.sum(d[sign * d > 0] ** 2))
        total = np.hypot(sigma_j, 0.2)
        dof = total**4 / (sigma_j**4 / 2 + 0.2**4 / 4)
        assert edge == pytest.approx(zeta.predicted * np.exp(sign * scipy.stats.t.ppf(0.975, dof) * total), rel=1e-9)
    assert 0 < zeta.low and zeta.high - zeta.predicted > zeta.predicted - zeta.low
    res = compared["resonance_hz"]
    # the refits' resonances differ only by the damping's shift of the peak: nearly symmetric
    assert res.high - res.predicted == pytest.approx(res.predicted - res.low, rel=1e-3)
    assert np.all(low >= 0) and np.all(low <= np.abs(predicted)) and np.all(np.abs(predicted) <= high)


def test_a_quantity_without_three_refits_keeps_a_model_term():
    """A refit whose curve peaks at the band's edge has no damping ratio (the circle fit's
    rule): with two damping values left the band's model term is the model's misfit at its
    kept levels, ζ̂·exp(±t·√(σ_m² + σ_R²)) at the Welch–Satterthwaite degrees of freedom —
    without a misfit there is no damping band, never one of the test's scatter alone; the
    resonance, which every refit gives, keeps the jackknife."""
    w = 2 * np.pi * F

    def mode(fn, zeta):
        wn = 2 * np.pi * fn
        return 1 / (wn**2 - w**2 + 2j * zeta * wn * w)

    curves = [mode(80.2, 0.004), mode(80.25, 0.0045), mode(81.2, 0.004)]  # the last peaks at the edge
    assert [np.isfinite(resonance(F, c).damping_ratio) for c in curves] == [True, True, False]
    predicted = mode(80.2, 0.004)
    repeat = Repeatability(0.05, 0.0005, 6, damping_relative=0.2, peak_relative=0.1, degree=1)
    measured = {"resonance_hz": 80.2, "damping_ratio": 0.004, "peak_abs": float(np.abs(predicted).max())}
    without = bands(F, measured, predicted, curves, repeat, noise=0.0)[0]
    assert np.isnan(without["damping_ratio"].low) and np.isnan(without["damping_ratio"].high)
    assert np.isfinite(without["resonance_hz"].low)
    misfit = {"damping_ratio": (0.1, 3)}
    zeta = bands(F, measured, predicted, curves, repeat, noise=0.0, misfit=misfit)[0]["damping_ratio"]
    total = np.hypot(0.1, 0.2)
    dof = total**4 / (0.1**4 / 3 + 0.2**4 / 4)
    half = scipy.stats.t.ppf(0.975, dof) * total
    assert zeta.low == pytest.approx(zeta.predicted * np.exp(-half), rel=1e-9)
    assert zeta.high == pytest.approx(zeta.predicted * np.exp(half), rel=1e-9)


def test_the_repeatability_pools_the_runs_about_a_parabola():
    """Linear modes whose resonances lie on a parabola in log amplitude plus known offsets:
    the pooled repeatability is the offsets' residual standard deviation about that
    parabola (N − 3 degrees of freedom), the same whichever test type a curve came from."""
    rng = np.random.default_rng(3)
    offsets = rng.normal(0.0, 0.05, 7)
    x = np.geomspace(1e-5, 1e-3, 7)  # response amplitudes (m)
    fn = 80.2 - 0.02 * np.log(x / 1e-4) ** 2 + offsets
    w = 2 * np.pi * F
    curves = [1 / ((2 * np.pi * f) ** 2 - w**2 + 2j * 0.004 * 2 * np.pi * f * w) for f in fn]
    peaks = np.array([resonance(F, c).peak_abs for c in curves])
    levels = tuple(x[:3] / peaks[:3])
    table = pd.concat([frf_table(F, lv, "0", "0", c) for lv, c in zip(levels, curves[:3])], ignore_index=True)
    data = FRFLevels.from_table(table, "0", "0")
    runs = [HeldRun(f"r{k}", "0", "0", F.copy(), c, float(xk), xk / np.abs(c)) for k, (c, xk) in
            enumerate(zip(curves[3:], x[3:]))]
    repeat = repeatability(data, runs)
    shown = np.array([resonance(F, c).resonance_hz for c in curves])  # the estimator's own values
    amplitudes = np.r_[peaks[:3] * np.array(levels), x[3:]]
    residual = shown - np.polyval(np.polyfit(np.log(amplitudes), shown, 2), np.log(amplitudes))
    assert repeat.levels == 7 and repeat.degree == 2 and repeat.dof == 4
    assert repeat.resonance_hz == pytest.approx(np.sqrt(np.sum(residual**2) / 4), rel=1e-6)
    assert repeat.resonance_hz == pytest.approx(np.std(offsets, ddof=3), rel=0.6)


def test_a_level_sits_at_the_amplitude_it_reached_not_at_its_nominal_force(data):
    """The repeatability's trend places each force-controlled curve at the response it
    reached at resonance, as a response-controlled run at the amplitude it held: the closed
    form at the resonance with the force achieved there (30 % below the level at 80.3 Hz),
    not peak × nominal level (17–43 % above it here)."""
    reached = resonance_amplitudes(data)
    for level, x, (f, h) in zip(data.levels, reached, zip(data.frequencies, data.receptances)):
        r = resonance(f, h)
        truth = amplitude(float(np.interp(r.resonance_hz, F, shaker_force(level))), 2 * np.pi * r.resonance_hz)
        assert x == pytest.approx(truth, rel=2e-3)
        assert level * r.peak_abs > 1.15 * truth

def test_forced_runs_scatter_places_each_run_at_the_force_it_achieved(data):
    """[fe_validation]'s test scatter (forced_runs.runs_repeatability) places each
    force-controlled run as validate does: the residual standard deviation of the resonance
    about a straight line in log amplitude (4 − 2 degrees of freedom) at the closed-form
    amplitude reached with the force achieved at resonance — not at peak × nominal level."""
    runs = [ForcedRun(f"FRdata.ForceControl({k})", "force", level, f, h, shaker_force(level))
            for k, (level, f, h) in enumerate(zip(data.levels, data.frequencies, data.receptances), start=1)]
    shown = [resonance(f, h) for f, h in zip(data.frequencies, data.receptances)]
    y = np.array([r.resonance_hz for r in shown])

    def scatter(x):
        residual = y - np.polyval(np.polyfit(x, y, 1), x)
        return float(np.sqrt(np.sum(residual**2) / (y.size - 2)))

    reached = np.log([amplitude(float(np.interp(r.resonance_hz, F, shaker_force(level))), 2 * np.pi * r.resonance_hz)
                      for level, r in zip(data.levels, shown)])
    nominal = np.log([level * r.peak_abs for level, r in zip(data.levels, shown)])
    found = runs_repeatability(runs).resonance_hz
    assert found == pytest.approx(scatter(reached), rel=0.01)  # measured 0.24 %
    assert abs(found / scatter(nominal) - 1) > 0.02  # at the nominal level 3.7 % off (the sag is alike at each)


@pytest.mark.slow
def test_held_out_bands_cover_the_measured_level_on_simulated_tests():
    """benchmarks/validate_band_coverage.py on 60 seeds (an Iwan joint fitted by the
    quadratic line models, four levels, the test's own scatter of 0.1 Hz and 10 % in
    damping): the 95 % bands hold the measured held-out value in 85–99 % of the levels for
    each quantity (measured over seeds 0–59: resonance 93.3 %, damping 98.2 %, peak 93.8 %).
    Sixty seeds, not twenty: twenty give about 74 damping bands, and a band that truly covers
    97 % holds all 74 one time in ten (0.97^74), so 100 % on twenty seeds does not tell an
    over-wide band from a right one (seeds 0–19 held all 74, seeds 20–39 and 40–59 missed 1
    and 3); with about 220 bands fewer than three misses is a real over-coverage."""
    from benchmarks.validate_band_coverage import one_seed

    rows = [row for seed in range(60) for row in one_seed((seed, ("lines-background",), 0.1))]
    for quantity in ("resonance_hz", "damping_ratio", "peak_abs"):
        inside = [row["inside"] for row in rows if row["quantity"] == quantity and row["inside"] is not None]
        assert len(inside) >= 200 and 0.85 <= np.mean(inside) <= 0.99, (quantity, np.mean(inside))


@pytest.mark.parametrize("stiffening", [0.0, 0.02])
def test_the_force_per_line_is_the_sweep_read_line_by_line(stiffening):
    """frf_at_forces is, by definition, line k of the upward stepped-sine sweep at force[k];
    its direct root (one root per line) and its sweep (a fold: several) give that exactly,
    without a fold and with one (a 4.5 % stiffening at 0.2 % damping jumps down)."""
    from nlupdate.core.model.amplitude_modal import AmplitudeModalModel
    from nlupdate.core.validation.models import frf_at_forces

    model = AmplitudeModalModel(80.0, 0.002, (("0", 1.0),), frequency_coefficients=(0.0, stiffening),
                                damping_coefficients=(0.0, 0.001), reference_amplitude=1e-3,
                                beyond_reference="continued")
    f = np.linspace(78.0, 86.0, 161)
    force = 1.5 * (1 - 0.3 * np.exp(-(((f - 81.0) / 1.0) ** 2)))
    reference = np.array([model.frf(f[:k + 1], float(force[k]), "0", "0")[-1] for k in range(f.size)])
    ours = frf_at_forces(model, f, force, "0")
    np.testing.assert_allclose(ours, reference, rtol=1e-9)
    jump = np.max(np.abs(reference[:-1]) / np.abs(reference[1:]))
    assert (jump > 3) == (stiffening > 0)  # the fold is there, and read as the sweep reads it
