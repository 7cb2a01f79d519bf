"""Noise of an H1 FRF estimate from its coherence, averages or stated standard deviation.

For an H1 estimate from n_d independent averages with ordinary coherence γ², the
normalised random errors of |H| and of its phase are both
``ε = √(1 − γ²) / (|γ| √(2 n_d))`` (Bendat & Piersol, *Random Data*, §9.2.4), so the
complex error has ``E|δH|² = 2ε²|H|²``: a relative noise level (std / |H|, the
convention of docs/methods.md §8 and of :mod:`nlupdate.core.measurement.noise`)
``σ = √((1 − γ²)/(γ² n_d))``.

This small function stands here until the project's noise estimator
(:mod:`nlupdate.core.measurement.noise`, issue 22) takes coherence, averages and ``h_std``
itself; the identification calls it when a table carries those columns.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike


def noise_fraction_from_coherence(coherence: ArrayLike, averages: ArrayLike) -> float:
    """Median relative noise level (std / |H|) of an H1 estimate over its lines (module docstring)."""
    g2 = np.clip(np.asarray(coherence, dtype=float), 1e-12, 1.0)
    n = np.broadcast_to(np.asarray(averages, dtype=float), g2.shape)
    return float(np.median(np.sqrt((1.0 - g2) / (g2 * n))))


def noise_fraction_from_std(h: ArrayLike, h_std: ArrayLike) -> float:
    """Median of ``h_std / |H|``: the relative noise level of FRFs that state their standard deviation."""
    return float(np.median(np.asarray(h_std, dtype=float) / np.abs(np.asarray(h, dtype=complex))))
