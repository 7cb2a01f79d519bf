"""Measurement noise on simulated FRFs (METHODS §8).

The source pollutes harmonic-balance responses with normal noise whose standard
deviation is a fraction (5 %) of the response amplitude. Here each complex value H gets

    H_noisy = H + e,   e = σ (n₁ + i n₂) / √2,   σ = fraction·|H|,   n₁, n₂ ~ N(0, 1) i.i.d.,

i.e. circular complex normal noise with E[e] = 0 and E|e|² = σ²: the real and the
imaginary parts each have standard deviation fraction·|H|/√2. Since the force is exact,
noise on the receptance equals noise on the response amplitude relative to |X| = |H|·F.
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from nlupdate.measurement.frf_table import validate_frf_table

Seed = int | np.random.Generator | None


def add_frf_noise(h: ArrayLike, fraction: float, seed: Seed = None) -> NDArray[np.complex128]:
    """Return ``h`` (complex receptance, any shape) plus noise of RMS ``fraction·|h|``.

    ``seed``: an int (reproducible), a :class:`numpy.random.Generator` (drawn from, so
    successive calls differ) or None (fresh entropy). Real parts are drawn before the
    imaginary parts, in C order of ``h``. ``fraction`` must be a finite number ≥ 0.
    """
    fraction = float(fraction)
    if not math.isfinite(fraction) or fraction < 0:
        raise ValueError(f"noise fraction must be a finite number >= 0 (e.g. 0.05 for 5 %), got {fraction!r}")
    h = np.asarray(h, dtype=complex)
    normal = np.random.default_rng(seed).standard_normal((2,) + h.shape)
    sigma = fraction * np.abs(h) / math.sqrt(2.0)
    return h + sigma * (normal[0] + 1j * normal[1])


def add_table_noise(table: pd.DataFrame, fraction: float, seed: Seed = None) -> pd.DataFrame:
    """A validated copy of a measured-FRF table with :func:`add_frf_noise` applied to
    ``h_real + i·h_imag`` (noise drawn in the table's row order)."""
    noisy = validate_frf_table(table)
    h = add_frf_noise(noisy["h_real"].to_numpy() + 1j * noisy["h_imag"].to_numpy(), fraction, seed)
    noisy["h_real"], noisy["h_imag"] = h.real, h.imag
    return noisy


def estimate_noise_fraction(frequency_hz: ArrayLike, h: ArrayLike, window: int = 9) -> float:
    """Relative noise level of a measured FRF (std of the noise / |H|), model-free.

    Measurement noise ``H(1 + ε)`` gives ``1/H̃ ≈ (1/H)(1 − ε)``, and ``1/H`` (dynamic
    stiffness) is smooth in ω even at a resonance. So a quadratic in ω is fitted to
    ``1/H̃`` over sliding windows of ``window`` points, and the relative residuals
    ``(1/H̃ − fit)/|fit|`` estimate ε. Returns ``sqrt(E|ε|²)`` from the median of the
    per-window mean squares (robust to windows spoilt by a sharp feature), corrected
    for the fitted degrees of freedom. Needs at least ``window`` points.
    """
    f = np.asarray(frequency_hz, dtype=float)
    z = 1.0 / np.asarray(h, dtype=complex)
    if f.size < window:
        raise ValueError(f"noise estimate needs at least {window} frequencies, got {f.size}")
    mean_squares = []
    for start in range(0, f.size - window + 1, max(window // 2, 1)):
        x = f[start : start + window]
        x = (x - x.mean()) / max(np.ptp(x), 1e-300)
        v = np.vander(x, 3)
        target = z[start : start + window]
        coefficients = np.linalg.lstsq(v, target, rcond=None)[0]
        fit = v @ coefficients
        relative = (target - fit) / np.abs(fit)
        mean_squares.append(np.sum(np.abs(relative) ** 2) / (window - 3))
    # the median of a scaled chi-square with 2(window−3) degrees of freedom sits below its mean
    dof = 2 * (window - 3)
    median_to_mean = (1 - 2 / (9 * dof)) ** 3
    return float(np.sqrt(np.median(mean_squares) / median_to_mean))


def smooth_inverse_receptance(frequency_hz: ArrayLike, h: ArrayLike, window: int) -> NDArray[np.complex128]:
    """Noise-reduced ``1/H``: a weighted least-squares quadratic in ω over ``window``
    neighbouring points (odd, ≥ 5) evaluated at each frequency (a Savitzky–Golay filter
    on the dynamic stiffness, which is smooth even at resonances). Weights ``|H̃|``
    match the relative noise of METHODS §8. Windows are shifted inwards at the ends."""
    f = np.asarray(frequency_hz, dtype=float)
    z = 1.0 / np.asarray(h, dtype=complex)
    window = int(window)
    if window < 5 or window % 2 == 0:
        raise ValueError(f"smoothing window must be an odd number of points ≥ 5, got {window}")
    if f.size < window:
        raise ValueError(f"smoothing window of {window} points is longer than the sweep ({f.size} points)")
    half = window // 2
    out = np.empty(f.size, dtype=complex)
    weights = 1.0 / np.abs(z)
    for k in range(f.size):
        start = min(max(k - half, 0), f.size - window)
        span = slice(start, start + window)
        x = (f[span] - f[k]) / max(np.ptp(f[span]), 1e-300)
        design = np.vander(x, 3) * weights[span, None]
        coefficients = np.linalg.lstsq(design, z[span] * weights[span], rcond=None)[0]
        out[k] = coefficients[-1]
    return out
