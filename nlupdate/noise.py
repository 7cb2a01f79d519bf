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

from nlupdate.measurements import validate_frf_table

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
