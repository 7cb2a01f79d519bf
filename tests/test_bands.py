"""95 % bands of identified values (src/nlupdate/core/identification/bands.py, docs/methods.md §4).

References, each independent of the code under test:

* the band's parts against their closed forms: Student's t times the jackknife standard
  deviation, added in quadrature to the noise band; Birge's ratio scaling the noise band;
* a value on a limit against the limit and the parameter's other end;
* a model that is the wrong form (a cubic spring fitted to a clearance simulated by the
  multi-harmonic balance of the true joint, 1 % noise): its band against the Monte-Carlo
  noise band and against the noise-free fit;
* coverage over 20 seeds (slow): benchmarks/band_coverage.py.
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest
import scipy.stats

from nlupdate.core.identification.bands import Bound, band, parameter_bounds
from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.dfmodels import PhysicalModel
from nlupdate.core.identification.uncertainty import monte_carlo

NOISE_SAMPLES = np.random.default_rng(4).normal(2.0, 0.01, 400)  # Monte-Carlo re-identifications about 2.0
JACKKNIFE = [1.8, 2.1, 2.0, 2.2]


def test_at_the_noise_the_band_is_the_basic_bootstrap_interval():
    low, median, high = np.percentile(NOISE_SAMPLES, [2.5, 50, 97.5])
    for ratio in (None, 0.7, 1.0):
        assert band(2.0, NOISE_SAMPLES, ratio, JACKKNIFE) == pytest.approx((2 * 2.0 - high, 2 * 2.0 - low))


def test_a_misfit_widens_the_band_by_its_leave_one_level_out_spread():
    """Half-width² = noise half-width² + (t₀.₉₇₅,₃·σ_J)²·(1 − 1/R²): grows with R towards the
    whole jackknife spread."""
    sigma = np.sqrt(3 / 4 * np.sum((np.array(JACKKNIFE) - np.mean(JACKKNIFE)) ** 2))
    low, median, high = np.percentile(NOISE_SAMPLES, [2.5, 50, 97.5])
    widths = []
    for ratio in (1.5, 3.0, 10.0, 100.0):
        model = scipy.stats.t.ppf(0.975, 3) * sigma * np.sqrt(1 - 1 / ratio**2)
        lo, hi = band(2.0, NOISE_SAMPLES, ratio, JACKKNIFE)
        centre = 2 * 2.0 - median
        assert centre - lo == pytest.approx(np.hypot(high - median, model))
        assert hi - centre == pytest.approx(np.hypot(median - low, model))
        widths.append(hi - lo)
    assert np.all(np.diff(widths) > 0) and widths[-1] > 20 * (high - low)


def test_a_positive_value_has_a_band_that_stops_at_zero():
    """A slip force whose refits spread wider than it is large: the band stops at 0, as the
    positive parameters' names say (a physical model's and the linear modes')."""
    from nlupdate.core.identification.bands import positive_names

    assert band(1.0, NOISE_SAMPLES - 1.0, 50.0, [0.2, 1.5, 1.0, 2.0])[0] < 0
    low, high = band(1.0, NOISE_SAMPLES - 1.0, 50.0, [0.2, 1.5, 1.0, 2.0], positive=True)
    assert low == 0.0 and high > 3.0
    assert positive_names(PhysicalModel(("cubic", "jenkins")), {"k3": 1e9, "kf": 1e5, "slip_force": 1.0,
                                                                "linear_f1_hz": 80.0, "linear_eta1": 0.01}) == {
        "kf", "slip_force", "linear_f1_hz", "linear_eta1"}


def test_without_refits_the_residual_scales_the_noise_band():
    """Fewer than three leave-one-level-out refits: the noise band times R (Birge's ratio)."""
    low, high = band(2.0, NOISE_SAMPLES)
    for refits in ((), JACKKNIFE[:2]):
        lo, hi = band(2.0, NOISE_SAMPLES, 7.0, refits)
        assert hi - lo == pytest.approx(7.0 * (high - low))


def test_the_band_holds_the_estimate_when_the_samples_move_away_from_it():
    """Samples 0.1 above the value with a spread of 0.01: reflected, the band lies below the
    value; it is widened to reach it."""
    samples = NOISE_SAMPLES + 0.1
    low, high = band(2.0, samples)
    assert high == 2.0 and low == pytest.approx(2.0 - 0.1 - 1.96 * 0.01, abs=0.005)
    assert band(2.0, samples, 4.0, JACKKNIFE)[0] <= 2.0 <= band(2.0, samples, 4.0, JACKKNIFE)[1]


def test_a_value_on_a_limit_has_a_one_sided_band_named():
    """χ of an Iwan joint at −1 (its Jenkins end): the band starts at −1; it reaches the
    samples' far end, or χ's other end 0 when every sample sits at −1 too (the zero-width
    band it had). Log-parameters on the fit's box take the side the samples leave free."""
    model = PhysicalModel(("iwan",))
    values = {"slip_force": 1.0, "kt": 3e5, "chi": -1.0 + 1e-9, "beta": 0.5}
    bounds = parameter_bounds(model, values, at_bound=("kt",))
    assert set(bounds) == {"chi", "kt"}
    assert (bounds["chi"].side, bounds["chi"].limit, bounds["chi"].far) == ("lower", -1.0, 0.0)
    assert "-1" in bounds["chi"].why
    assert band(values["chi"], np.full(50, values["chi"]), bound=bounds["chi"]) == (-1.0, 0.0)
    spread = -1.0 + np.abs(np.random.default_rng(1).normal(0.0, 0.02, 200))
    low, high = band(values["chi"], spread, bound=bounds["chi"])
    assert low == -1.0 and 0.0 < high + 1.0 < 0.1
    assert band(3e5, np.full(50, 3e5), bound=bounds["kt"]) == (3e5, np.inf)
    assert band(3e5, 3e5 * (1 - np.abs(np.random.default_rng(2).normal(0, 0.1, 50))), bound=bounds["kt"])[1] == 3e5
    assert parameter_bounds(model, {**values, "chi": -0.5}) == {}
    assert parameter_bounds(None, values) == {}


def test_parameters_fixed_because_no_level_slips_are_lower_bounds():
    """An Iwan refit with β = 0 and φ_max fixed (no level reaches macroslip): β ≥ 0, and K_T and
    F_S are lower bounds (:func:`~nlupdate.core.identification.dfmodels.iwan_identifiability`)."""
    model = PhysicalModel(("iwan",), (("beta", 0.0), ("phi_max", 1e-5)), "no macroslip")
    bounds = parameter_bounds(model, {"slip_force": 0.4, "kt": 2e5, "chi": -0.5, "beta": 0.0})
    assert {name: (b.side, b.limit, b.far, b.open) for name, b in bounds.items()} == {
        "beta": ("lower", 0.0, np.inf, True), "kt": ("lower", 2e5, np.inf, True),
        "slip_force": ("lower", 0.4, np.inf, True)}
    spread = 2e5 * (1 + np.abs(np.random.default_rng(3).normal(0, 0.05, 50)))  # the samples move kt up a little
    assert band(2e5, spread, bound=bounds["kt"]) == (2e5, np.inf)  # but a lower bound says nothing above it


def test_monte_carlo_reports_the_bound_and_its_one_sided_interval():
    """Through :func:`monte_carlo`: a χ every sample returns at −1 had the zero-width interval
    [−1, −1]; now [−1, 0] with the bound in its dictionary."""
    f = np.linspace(1.0, 2.0, 10)
    data = FRFLevels("0", "0", np.array([1.0]), (f,), (np.ones(10, dtype=complex),))
    chi = -1.0 + 1e-9
    bound = Bound("lower", -1.0, 0.0, "at the end -1 of its interval (-1, 0)")
    stats = monte_carlo(lambda d: {"chi": chi}, data, {"chi": chi}, 0.01, n_samples=10, bounds={"chi": bound})
    assert stats.parameters["chi"].ci95 == (-1.0, 0.0)
    assert stats.parameters["chi"].as_dict()["bound"]["side"] == "lower"


@pytest.fixture(scope="module")
def clearance_fitted_with_a_cubic():
    """A clearance (contact spring beyond ±g) simulated by the multi-harmonic balance of the
    true joint, 1 % noise, fitted with a cubic spring (benchmarks/band_coverage.py's case)."""
    from benchmarks.band_coverage import gap_design, noise_free_fit, simulate
    from nlupdate.core.identification.pipeline import IdentificationSettings, identify
    from nlupdate.core.measurement.noise import add_table_noise

    design = gap_design(np.random.default_rng([0, 1]))
    table = simulate(design.system, design.levels)
    clean = FRFLevels.from_table(table, "0", "0")
    data = FRFLevels.from_table(add_table_noise(table, 0.01, 7), "0", "0")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the poor fit's own warnings
        fitted = identify(data, IdentificationSettings("0", "0", elements=("cubic",), samples=8, seed=1))
        truth = noise_free_fit(clean, ("cubic",))
    return fitted, truth


def test_a_model_of_the_wrong_form_gets_a_band_wider_than_its_noise_band(clearance_fitted_with_a_cubic):
    """The cubic misses the clearance by several times the noise; its band widens beyond the
    Monte-Carlo noise band by the leave-one-level-out spread, holds the estimate and the
    noise-free fit, and says what it allowed for."""
    fitted, truth = clearance_fitted_with_a_cubic
    u = fitted.uncertainty
    assert u.residual_ratio > 3 and u.jackknife_fits == 4
    k3 = u.parameters["k3"]
    assert k3.ci95[1] - k3.ci95[0] > 3 * (2 * 1.96 * k3.std)
    for name, stats in u.parameters.items():
        assert stats.ci95[0] <= stats.value <= stats.ci95[1], name
        assert stats.ci95[0] <= truth.uncertainty.parameters[name].value <= stats.ci95[1], name
    summary = u.as_dict()
    assert summary["residual_ratio"] == pytest.approx(u.residual_ratio) and summary["jackknife_fits"] == 4


@pytest.mark.slow
def test_over_20_seeds_the_bands_hold_the_truth_in_85_to_99_percent_with_a_model_form_error():
    """benchmarks/band_coverage.py's study on its first 20 seeds (both cases: Jenkins fitted
    to Iwan data, cubic fitted to clearance data; multi-harmonic-balance data, 1 % noise).
    Pooled over both cases, the parameters' bands hold the value a dense test over the same
    range converges to, and the held-out predictions' bands the noise-free held-out
    resonance, damping and peak, in 85–99 % of the bands; no estimate lies outside its own
    band. (The noise-free fit at the same levels is held more often: the model-form part is
    not an error with respect to it.)

    Rows without a band: since validate reads damping by the circle fit (261067d), a curve
    whose resonance spans fewer than 5 lines at 0.4 max|H| has no damping ratio (NaN), and a
    Jenkins fit's top level can be that narrow (seed 3: ζ ≈ 1e-3 on 0.1 Hz lines, 3 lines
    in the run; half-power had read 9.7e-4 from 1 line inside its band). Measured at be10d27
    (python benchmarks/band_coverage.py --seeds 20 --samples 10, 04:22-04:29 UTC, load 5-6):
    5 of the 520 rows have no band, each the top level's predicted damping of an
    iwan→jenkins seed (3, 7, 11, 12, 13; the noise-free truth is NaN too but for seed 12,
    1.2e-3) — the estimator declining a curve that does not resolve it, not a band missing
    its value; at 3777d80 (half-power) seed 3's row had a band. Such rows are asserted to be
    exactly that, at most a fifth of the 40 top-level damping rows (so the damping coverage
    still speaks for most of them), and left out of the coverage, as
    validate_band_coverage.py counts only levels with a damping band. With them left out:
    predictions 91.1 % of 235, parameters (dense levels) 96.4 % of 140, none outside its band."""
    import pandas as pd

    from benchmarks.band_coverage import CASES, one_seed

    frame = pd.DataFrame([row for seed in range(20) for case in CASES for row in one_seed(case, seed, 10)])
    unbanded = frame[~frame["has_band"]]
    assert (unbanded.quantity == "damping_ratio").all() and (unbanded.truth_kind == "top level").all()
    assert unbanded.value.isna().all() and len(unbanded) <= 8, unbanded[["case", "seed", "value", "truth"]]
    frame = frame[frame["has_band"]]
    assert frame["contains_value"].all()
    parameters = frame[(frame.kind == "parameter") & (frame.truth_kind == "dense levels")]
    predictions = frame[frame.kind == "prediction"]
    for bands in (parameters, predictions):
        assert len(bands) >= 100 and 0.85 <= bands["covered"].mean() <= 0.99, bands.groupby(
            ["case", "quantity", "truth_kind"])["covered"].mean()
