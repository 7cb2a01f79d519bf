"""The resonance peak of one noisy FRF curve (nlupdate.core.identification.frf_peak) against
a linear mode in closed form: H = φ²/(ω² − Ω² + 2iζωΩ) peaks at Ω = ω√(1 − 2ζ²) with
|H| = φ²/(2ζω²√(1 − ζ²))."""
from __future__ import annotations

import numpy as np
import pytest

from nlupdate.core.identification.frf_peak import _three_point, resonance_peak
from nlupdate.core.measurement.noise import add_frf_noise

W, ZETA, PHI = 2 * np.pi * 10.0, 0.005, 0.7


def mode(f_hz: np.ndarray) -> np.ndarray:
    omega = 2 * np.pi * f_hz
    return PHI**2 / (W**2 - omega**2 + 2j * ZETA * W * omega)


PEAK_HZ = W * np.sqrt(1 - 2 * ZETA**2) / (2 * np.pi)
HEIGHT = PHI**2 / (2 * ZETA * W**2 * np.sqrt(1 - ZETA**2))


@pytest.mark.parametrize("offset", [0.0, 0.3, 0.5])
def test_noise_free_linear_mode_gives_its_peak_exactly(offset):
    """Lines 0.005 Hz apart (the half-power band 20 lines), the peak anywhere between two:
    the tilted parabola is exact for a linear mode (1/|H|² a quadratic in Ω²): within 1e-8
    (measured 4e-15)."""
    f = 9.0 + (np.arange(301) + offset) * 0.005
    at, height = resonance_peak(f, np.abs(mode(f)))
    assert at / PEAK_HZ - 1 == pytest.approx(0, abs=1e-8)
    assert height / HEIGHT - 1 == pytest.approx(0, abs=1e-8)


def test_noisy_linear_mode_peak_is_unbiased_where_the_largest_line_is_not():
    """2 % complex noise per line (add_frf_noise), 40 seeds: the largest line and its
    neighbours' parabola put the peak high (the maximum of noisy values; measured mean +1.1 %,
    spread 1.0 %), which is ζ as much low; the fit through every line near the top is unbiased
    within its scatter (measured mean −0.02 %, spread 0.65 %) and within 0.05 % in frequency
    (measured 2.9e-4)."""
    f = 9.5 + np.arange(201) * 0.005
    clean = mode(f)
    new, old, where = [], [], []
    for seed in range(40):
        magnitude = np.abs(add_frf_noise(clean, 0.02, seed))
        at, height = resonance_peak(f, magnitude)
        new.append(height / HEIGHT - 1)
        where.append(at / PEAK_HZ - 1)
        old.append(_three_point(f, magnitude, int(np.argmax(magnitude)))[1] / HEIGHT - 1)
    new, old = np.array(new), np.array(old)
    assert 0.005 < old.mean() < 0.03
    assert abs(new.mean()) < 3 * new.std() / np.sqrt(new.size) + 1e-3 and new.std() < 0.01
    assert np.abs(where).max() < 5e-4


def test_too_few_lines_near_the_top_fall_back_to_the_three_point_parabola():
    """A peak sampled by fewer than six lines within 0.8 of its height (0.05 Hz apart, the
    half-power band two lines): the three-point parabola, as before."""
    f = 9.5 + np.arange(21) * 0.05
    magnitude = np.abs(mode(f))
    assert resonance_peak(f, magnitude) == _three_point(f, magnitude, int(np.argmax(magnitude)))
