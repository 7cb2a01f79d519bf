"""FRF noise model (docs/methods.md §8): statistics checked against the stated distribution."""
from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from nlupdate.core.measurement.frf_table import frf_table
from nlupdate.core.measurement.noise import add_frf_noise, add_table_noise

H = np.array([2e-6 + 1e-6j, -3e-4j, 1e-9, -5.0 + 0.0j])
N_SAMPLES = 100_000
FRACTION = 0.05


def noise_samples(seed=1) -> np.ndarray:
    """Errors e = noisy − H, shape (N_SAMPLES, len(H)), one call on a tiled array."""
    h = np.tile(H, (N_SAMPLES, 1))
    return add_frf_noise(h, FRACTION, seed) - h


def test_noise_statistics_match_fraction_of_amplitude():
    e = noise_samples()
    sigma = FRACTION * np.abs(H)
    # E|e|^2 = sigma^2; the real and imaginary parts each carry sigma^2/2
    np.testing.assert_allclose(np.sqrt(np.mean(np.abs(e) ** 2, axis=0)), sigma, rtol=0.02)
    np.testing.assert_allclose(e.real.std(axis=0), sigma / np.sqrt(2), rtol=0.02)
    np.testing.assert_allclose(e.imag.std(axis=0), sigma / np.sqrt(2), rtol=0.02)
    # zero mean: within 5 standard errors
    standard_error = sigma / np.sqrt(2 * N_SAMPLES)
    assert np.all(np.abs(e.real.mean(axis=0)) < 5 * standard_error)
    assert np.all(np.abs(e.imag.mean(axis=0)) < 5 * standard_error)
    # real and imaginary parts uncorrelated, and independent between entries of h
    for k in range(H.size):
        assert abs(np.corrcoef(e.real[:, k], e.imag[:, k])[0, 1]) < 0.02
    assert abs(np.corrcoef(e.real[:, 0], e.real[:, 1])[0, 1]) < 0.02


def test_noise_is_normal():
    e = noise_samples(seed=2)
    z = np.concatenate([e.real / (FRACTION * np.abs(H) / np.sqrt(2)), e.imag / (FRACTION * np.abs(H) / np.sqrt(2))])
    assert stats.kstest(z.ravel()[:50_000], "norm").pvalue > 1e-3


def test_seed_reproducibility_and_generator():
    assert np.array_equal(add_frf_noise(H, 0.05, seed=3), add_frf_noise(H, 0.05, seed=3))
    assert not np.array_equal(add_frf_noise(H, 0.05, seed=3), add_frf_noise(H, 0.05, seed=4))
    rng_a, rng_b = np.random.default_rng(9), np.random.default_rng(9)
    first, second = add_frf_noise(H, 0.05, rng_a), add_frf_noise(H, 0.05, rng_a)
    assert not np.array_equal(first, second)  # the generator advances
    assert np.array_equal(first, add_frf_noise(H, 0.05, rng_b))
    assert np.array_equal(first, add_frf_noise(H, 0.05, 9))  # int seed == fresh generator with that seed


def test_zero_fraction_and_zero_response_are_noise_free():
    np.testing.assert_array_equal(add_frf_noise(H, 0.0, seed=1), H)
    np.testing.assert_array_equal(add_frf_noise(np.zeros(3), 0.5, seed=1), np.zeros(3))
    assert add_frf_noise(1e-6, 0.05, seed=1).shape == ()


@pytest.mark.parametrize("fraction", [-0.01, np.nan, np.inf])
def test_bad_fraction_is_rejected(fraction):
    with pytest.raises(ValueError, match="noise fraction must be a finite number >= 0"):
        add_frf_noise(H, fraction)


def test_table_noise_changes_only_receptance():
    f = np.linspace(600.0, 850.0, 2001)
    h = 1.0 / (2e6 - 0.1 * (2 * np.pi * f) ** 2 + 2e4j)  # SDOF, γ = 0.01
    table = frf_table(f, 100.0, "0", "0", h)
    noisy = add_table_noise(table, FRACTION, seed=5)
    assert noisy[["frequency_hz", "force_level_n", "response_dof", "input_dof"]].equals(
        table[["frequency_hz", "force_level_n", "response_dof", "input_dof"]]
    )
    relative = (noisy["h_real"] + 1j * noisy["h_imag"] - h).to_numpy() / np.abs(h)
    assert np.sqrt(np.mean(np.abs(relative) ** 2)) == pytest.approx(FRACTION, rel=0.05)
    assert noisy.equals(add_table_noise(table, FRACTION, seed=5))
    assert np.array_equal(table["h_real"] + 1j * table["h_imag"], h)  # input untouched
