"""The resonance peak of one noisy FRF curve (nlupdate.core.identification.frf_peak) against
a linear mode in closed form: H = φ²/(ω² − Ω² + 2iζωΩ) peaks at Ω = ω√(1 − 2ζ²) with
|H| = φ²/(2ζω²√(1 − ζ²))."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.optimize

from nlupdate.core.identification import frf_peak
from nlupdate.core.identification.frf_peak import MAX_EVALUATIONS, _three_point, resonance_peak
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


def _fits(monkeypatch) -> list:
    """Every least-squares result resonance_peak's fits return from now on."""
    results, fit = [], scipy.optimize.least_squares

    def recorded(*args, **kwargs):
        results.append(fit(*args, **kwargs))
        return results[-1]

    monkeypatch.setattr(scipy.optimize, "least_squares", recorded)
    return results


def test_a_fit_that_converges_needs_far_fewer_evaluations_than_the_cap(monkeypatch):
    """Linear modes whose top few lines sample (0.005, 0.01 and 0.0125 Hz apart: 15, 7–8 and 5–6
    lines above 0.8 of the peak), 0.5–2 % complex noise, 20 seeds each, the peak anywhere between
    lines: every peak within 1e-3 in frequency and 3 % in height of the closed form (measured
    4.2e-4, 2.1 %: the 2 % noise's scatter on six lines), and every tilted parabola whose vertex
    is taken (178 of 180) converged within a fifth of MAX_EVALUATIONS (measured ≤ 11 evaluations):
    the cap stops only fits that drift."""
    fits = _fits(monkeypatch)
    taken = []
    for step in (0.005, 0.01, 0.0125):
        for noise in (0.005, 0.01, 0.02):
            for seed in range(20):
                f = 9.6 + (np.arange(int(round(0.8 / step))) + (seed % 7) / 7) * step
                magnitude = np.abs(add_frf_noise(mode(f), noise, seed))
                fits.clear()
                at, height = resonance_peak(f, magnitude)
                assert at / PEAK_HZ - 1 == pytest.approx(0, abs=1e-3), (step, noise, seed)
                assert height / HEIGHT - 1 == pytest.approx(0, abs=0.03), (step, noise, seed)
                if fits and (at, height) != _three_point(f, magnitude, int(np.argmax(magnitude))):
                    taken.append(fits[0].nfev)
    assert len(taken) > 170 and max(taken) <= MAX_EVALUATIONS / 5, taken


#: the Brake–Reuss beam's 0.4886 N level cut to 80–80.6 Hz (tests/data/brb), |H| relative to its
#: largest line, four digits: the six lines above 0.8 zig-zag
BRB_TOP_HZ = 80.0 + 0.05 * np.arange(13)
BRB_TOP = np.array([0.9261, 1.0, 0.8719, 0.9114, 0.8824, 0.8159, 0.7187, 0.6801, 0.6376, 0.594, 0.555, 0.5219, 0.4918])


def test_a_top_no_parabola_holds_gives_up_at_the_cap_with_the_three_point_parabola(monkeypatch):
    """The BRB top above: the tilted parabola's fit runs down a valley towards K → 0 (a kink)
    without converging — stopped at MAX_EVALUATIONS, and with scipy's default 400 evaluations
    just the same — and the peak is the three-point parabola through the largest line, which
    lies between that line's neighbours."""
    fits = _fits(monkeypatch)
    three = _three_point(BRB_TOP_HZ, BRB_TOP, 1)
    assert resonance_peak(BRB_TOP_HZ, BRB_TOP) == three
    assert [(fit.status, fit.nfev) for fit in fits] == [(0, MAX_EVALUATIONS)]
    monkeypatch.setattr(frf_peak, "MAX_EVALUATIONS", None)  # scipy's default: 100 per coefficient
    assert resonance_peak(BRB_TOP_HZ, BRB_TOP) == three
    assert [(fit.status, fit.nfev) for fit in fits[1:]] == [(0, 400)]
    assert BRB_TOP_HZ[0] < three[0] < BRB_TOP_HZ[2] and three[1] >= 1.0
