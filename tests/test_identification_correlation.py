"""Correlation metrics against hand-computed values and analytical receptances."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from nlupdate.core.correlation.metrics import (
    frac, mac_matrix, natural_frequencies, natural_frequency_error, peak, peak_errors,
)
from nlupdate.core.model.linear import LumpedModel


def test_frac_values():
    h = np.array([1 + 1j, 2 - 1j, -0.5j])
    assert frac(h, h) == pytest.approx(1.0)
    assert frac(h, (3 - 2j) * h) == pytest.approx(1.0)  # insensitive to a complex scale
    assert frac([1, 0], [1, 1]) == pytest.approx(0.5)   # |1|² / (1 · 2)
    assert frac([1, 0], [0, 1]) == 0.0
    assert frac([1, np.nan, 0], [1, 5, 1]) == pytest.approx(0.5)  # NaN points are left out
    with pytest.raises(ValueError, match="share one grid"):
        frac([1, 2], [1, 2, 3])


def test_mac_matrix_values():
    phi = np.array([[1.0, 1.0], [1.0, -1.0]])
    assert np.allclose(mac_matrix(phi, phi), np.eye(2))
    assert mac_matrix([1.0, 0.0], [1.0, 1.0])[0, 0] == pytest.approx(0.5)
    assert mac_matrix([1.0, 2.0], [-2.0, -4.0])[0, 0] == pytest.approx(1.0)
    with pytest.raises(ValueError, match="coordinates"):
        mac_matrix(np.ones((3, 1)), np.ones((2, 1)))


def test_natural_frequency_error():
    assert natural_frequency_error([100.0, 200.0], [101.0, 198.0]) == pytest.approx([1.0, -1.0])


def test_line_fit_natural_frequencies_of_analytical_receptance():
    mass = np.diag([0.1, 0.5])
    stiffness = np.array([[2e6, -1e6], [-1e6, 2e6]])
    model = LumpedModel.with_loss_factor(mass, stiffness, 0.005)
    exact = np.sqrt(scipy.linalg.eigh(stiffness, mass, eigvals_only=True)) / (2 * np.pi)
    f = np.arange(200.0, 900.0, 1.0)
    h = model.receptance(2 * np.pi * f, [0], [0])[:, 0, 0]
    found = natural_frequencies(f, h)
    assert found == pytest.approx(exact, rel=2e-4)
    assert natural_frequencies(f, h, n_modes=1) == pytest.approx([exact[1]], rel=2e-4)  # the larger peak
    # SDOF with structural damping: Re(1/H) = k − mω² exactly, so the line fit is exact
    sdof = 1.0 / (2e6 - 0.1 * (2 * np.pi * f) ** 2 + 0.01j * 2e6)
    assert natural_frequencies(f, sdof) == pytest.approx([np.sqrt(2e7) / (2 * np.pi)], rel=1e-10)


def test_peak_interpolation_and_errors():
    f = np.arange(600.0, 800.0, 1.0)
    omega_n = np.sqrt(2e7)
    h = 1.0 / (2e6 - 0.1 * (2 * np.pi * f) ** 2 + 0.01j * 2e6)   # |H| is largest at ω_n exactly
    f_peak, amplitude = peak(f, h)
    assert f_peak == pytest.approx(omega_n / (2 * np.pi), abs=0.02)
    assert amplitude == pytest.approx(1.0 / (0.01 * 2e6), rel=1e-3)
    errors = peak_errors(f, h, 1.1 * h)
    assert errors.frequency_error_hz == pytest.approx(0.0, abs=1e-9)
    assert errors.amplitude_error_percent == pytest.approx(10.0, rel=1e-9)
