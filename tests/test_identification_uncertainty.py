"""Noise-level estimate and Monte-Carlo uncertainty against known noise statistics."""
from __future__ import annotations

import functools

import numpy as np
import pytest

from nlupdate.core.model.elements import CubicStiffness, JenkinsFriction
from nlupdate.core.response.fixed_point import fixed_point_response
from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.measurement.noise import estimate_noise_fraction, smooth_inverse_receptance
from nlupdate.core.identification.dfmodels import PolynomialModel
from nlupdate.core.identification.prd import identify_prd
from nlupdate.core.identification.uncertainty import monte_carlo
from nlupdate.core.model.linear import LumpedModel
from nlupdate.core.measurement.noise import add_frf_noise
from nlupdate.core.model.system import NonlinearSystem

F = np.arange(600.0, 900.0, 1.0)
H = 1.0 / (2.3e6 - 0.1 * (2 * np.pi * F) ** 2 + 0.01j * 2e6)


def test_noise_fraction_estimate():
    assert estimate_noise_fraction(F, H) < 1e-9
    estimates = [estimate_noise_fraction(F, add_frf_noise(H, 0.05, seed)) for seed in range(10)]
    assert np.mean(estimates) == pytest.approx(0.05, rel=0.1)


def test_smoothing_keeps_a_smooth_dynamic_stiffness_and_reduces_noise():
    assert np.allclose(smooth_inverse_receptance(F, H, 9), 1.0 / H, rtol=1e-9)
    noisy = add_frf_noise(H, 0.05, 1)
    raw = np.abs(1.0 / noisy - 1.0 / H) / np.abs(1.0 / H)
    smoothed = np.abs(smooth_inverse_receptance(F, noisy, 15) - 1.0 / H) / np.abs(1.0 / H)
    assert np.sqrt(np.mean(smoothed**2)) < 0.5 * np.sqrt(np.mean(raw**2))


def _real_part(data: FRFLevels):
    class Point:
        def parameters(self):
            return {"re": float(data.receptances[0][100].real)}
    return Point()


def test_monte_carlo_reproduces_known_spread():
    """Re H of one point has std fraction·|H|/√2 under the docs/methods.md §8 noise model."""
    data = FRFLevels("0", "0", np.array([1.0]), (F,), (H,))
    stats = monte_carlo(_real_part, data, {"re": float(H[100].real)}, 0.05, n_samples=400, seed=3)
    expected = 0.05 * abs(H[100]) / np.sqrt(2)
    assert stats.parameters["re"].std == pytest.approx(expected, rel=0.1)
    low, high = stats.parameters["re"].ci95
    assert high - low == pytest.approx(2 * 1.96 * expected, rel=0.15)
    assert stats.n_failed == 0


def _prd(data, model):
    return identify_prd(data, 710.0, model, estimator="naive")


def test_monte_carlo_spread_from_one_data_set_matches_spread_over_seeds():
    """The MC std computed from ONE noisy data set estimates the estimator's true spread
    (from many independent noise draws around the noise-free data) within 30 %."""
    system = NonlinearSystem(LumpedModel.with_loss_factor([[0.1]], [[2e6]], 0.01),
                             (CubicStiffness((0,), 1e10), JenkinsFriction((0,), 3e5, 1.0)))
    levels = (0.01,) + tuple(np.arange(100.0, 401.0, 30.0))
    h = tuple(fixed_point_response(system, {0: f}, [2 * np.pi * 710.0]).response([0])[:, 0] / f for f in levels)
    clean = FRFLevels("0", "0", np.array(levels), tuple(np.array([710.0]) for _ in levels), h)
    model = PolynomialModel((2, 0), (1, 0))
    estimate = functools.partial(_prd, model=model)
    rng = np.random.default_rng(11)
    over_seeds = np.array([estimate(clean.with_noise(0.05, rng)).parameters()["kf"] for _ in range(300)])
    noisy = clean.with_noise(0.05, rng)
    stats = monte_carlo(estimate, noisy, estimate(noisy).parameters(), 0.05, n_samples=300, seed=5)
    assert stats.parameters["kf"].std == pytest.approx(over_seeds.std(), rel=0.3)


def test_a_curve_band_covers_the_truth_95_percent_of_the_time():
    """The band of a curve the estimate returns (here the noisy curve itself) holds the
    noise-free curve at about 95 % of the frequencies — in Re, Im, |H| and phase."""
    noisy = add_frf_noise(H, 0.05, 7)
    data = FRFLevels("0", "0", np.array([1.0]), (F,), (noisy,))
    stats = monte_carlo(lambda d: {"curve": d.receptances[0]}, data, {}, 0.05, n_samples=400, seed=2,
                        curves={"curve": (F, noisy)})
    band = stats.curves["curve"]
    assert band.n_samples == 400 and np.array_equal(band.x, F)
    offset = np.degrees(np.angle(H / noisy))
    for (low, high), truth in ((band.real, H.real), (band.imag, H.imag), (band.magnitude, np.abs(H)),
                               (band.phase_offset_deg, offset)):
        assert 0.91 < np.mean((low <= truth) & (truth <= high)) < 0.99


def test_failed_samples_are_counted_with_their_reason():
    data = FRFLevels("0", "0", np.array([1.0]), (F,), (H,))

    def estimate(d):
        if d.receptances[0][0].real > H[0].real:  # about half the draws
            raise ValueError("modal fit near 700 Hz ran to the edge of its band")
        return {"re": float(d.receptances[0][0].real)}

    stats = monte_carlo(estimate, data, {"re": float(H[0].real)}, 0.05, n_samples=40, seed=1)
    assert 10 < stats.n_failed < 30
    assert stats.failures == {"ValueError: modal fit near 700 Hz ran to the edge of its band": stats.n_failed}
    assert stats.as_dict()["failures"] == stats.failures


def test_a_sample_that_divides_by_zero_is_counted_not_fatal():
    """A draw whose fit divides by zero (an element's parameters at the ends of their range)
    fails that sample, named; it used to end the whole identification."""
    data = FRFLevels("0", "0", np.array([1.0]), (F,), (H,))

    def estimate(d):
        if d.receptances[0][0].real > H[0].real:
            return {"re": 1.0 / 0.0}
        return {"re": float(d.receptances[0][0].real)}

    stats = monte_carlo(estimate, data, {"re": float(H[0].real)}, 0.05, n_samples=40, seed=1)
    assert 10 < stats.n_failed < 30
    assert stats.failures == {"ZeroDivisionError: float division by zero": stats.n_failed}


def _mean_power(data: FRFLevels):
    class Point:
        def parameters(self):
            return {"power": float(np.mean(np.abs(data.receptances[0]) ** 2))}
    return Point()


def test_an_estimate_that_moves_with_the_noise_has_an_interval_holding_it_and_the_noise_free_value():
    """mean |H|² over 400 unit lines: noise of std ε|H| moves it to 1 + ε² (E|1 + n|² = 1 + ε²)
    with a spread of about ε√2/20, so at ε = 0.3 measured data give about 1.09 ± 0.02 and
    their Monte-Carlo samples (noise added again) sit at 1.18. The basic bootstrap interval
    reflects the samples about the estimate: it is centred near the noise-free 1 and reaches
    up to the estimate. The percentile interval moved onto the estimate ([1.05, 1.13]) held
    neither the noise-free value nor, unmoved ([1.14, 1.22]), the estimate."""
    from nlupdate.core.identification.trust import shift_warnings
    from nlupdate.core.measurement.noise import add_frf_noise

    ones = np.ones(400, dtype=complex)
    noisy = FRFLevels("0", "0", np.array([1.0]), (np.arange(400.0),), (add_frf_noise(ones, 0.3, 11),))
    value = _mean_power(noisy).parameters()["power"]
    assert value == pytest.approx(1.09, abs=0.05)
    stats = monte_carlo(_mean_power, noisy, {"power": value}, 0.3, n_samples=200, seed=5).parameters
    power = stats["power"]
    assert power.shift == pytest.approx(0.09, abs=0.01)
    low, high = power.ci95
    assert low <= 1.0 <= high and low <= value <= high
    assert high == value  # the reflected band ends below the estimate; it is widened to hold it
    assert (value - power.shift) - low == pytest.approx(1.96 * 0.3 * np.sqrt(2 + 0.3**2) / 20, rel=0.3)
    [warning] = shift_warnings(stats)
    assert warning.subject == "power" and warning.kind == "moves_with_noise"
    unbiased = monte_carlo(_real_part, FRFLevels("0", "0", np.array([1.0]), (F,), (H,)), {"re": float(H[100].real)},
                           0.05, n_samples=200, seed=3).parameters
    assert shift_warnings(unbiased) == []
