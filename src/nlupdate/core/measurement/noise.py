"""Measurement noise: the docs/methods.md §8 model on simulated FRFs, and estimates of it from data.

The source pollutes harmonic-balance responses with normal noise whose standard
deviation is a fraction (5 %) of the response amplitude. Here each complex value H gets

    H_noisy = H + e,   e = σ (n₁ + i n₂) / √2,   σ = fraction·|H|,   n₁, n₂ ~ N(0, 1) i.i.d.,

i.e. circular complex normal noise with E[e] = 0 and E|e|² = σ²: the real and the
imaginary parts each have standard deviation fraction·|H|/√2. Since the force is exact,
noise on the receptance equals noise on the response amplitude relative to |X| = |H|·F.

Estimates of that level from measured data (:func:`estimate_table_noise`): from the
uncertainty the data state (an ``h_std`` column; ``coherence`` with ``averages``), from
repeated runs, or model-free from the smoothness of ``1/H`` within contiguous stretches of
the frequency grid (:func:`estimate_noise_fraction`, never across the gaps between bands).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd
import scipy.special
from numpy.typing import ArrayLike, NDArray

from nlupdate.core.measurement.frf_table import validate_frf_table

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


def contiguous_stretches(frequency_hz: ArrayLike, jump: float = 3.0) -> list[NDArray[np.int64]]:
    """Index arrays (into ``frequency_hz``) of the contiguous stretches of a frequency grid.

    The grid is sorted; a gap separates two stretches where a step exceeds ``jump`` times the
    typical step on both sides of it (the median of up to four steps before it and of up to
    four after it). So separate bands and holes in a sweep are split, while an evenly,
    logarithmically or smoothly graded grid stays one stretch, and so does a fine stretch
    that continues with a coarser one. Repeated frequencies stay in their stretch.
    """
    f = np.asarray(frequency_hz, dtype=float).ravel()
    order = np.argsort(f, kind="stable")
    steps = np.diff(f[order])
    positive = steps > 0
    if f.size < 3 or not positive.any():
        return [order] if f.size else []
    distinct = np.flatnonzero(positive)
    d = steps[distinct]  # the steps between distinct frequencies, each with its four before and after
    padded = np.concatenate([np.full(4, np.nan), d, np.full(4, np.nan)])
    at = np.arange(d.size)[:, None]
    typical = np.fmax(_row_medians(padded[at + np.arange(4)]), _row_medians(padded[at + 5 + np.arange(4)]))
    cuts = distinct[d > jump * np.where(np.isnan(typical), np.inf, typical)] + 1
    return [piece for piece in np.split(order, cuts) if piece.size]


def _row_medians(rows: NDArray) -> NDArray:
    """``np.median`` of each row's values (NaN marks an absent one; NaN for a row of none):
    the middle value, or the mean of the middle two as ``np.median`` takes it (equal bits)."""
    ordered = np.sort(rows, axis=1)  # NaN last
    count = np.sum(~np.isnan(ordered), axis=1)
    index = np.arange(ordered.shape[0])
    out = np.full(ordered.shape[0], np.nan)
    odd, even = count % 2 == 1, (count % 2 == 0) & (count > 0)
    out[odd] = ordered[index[odd], count[odd] // 2]
    out[even] = (ordered[index[even], count[even] // 2 - 1] + ordered[index[even], count[even] // 2]) / 2
    return out


_DEGREE = 3  # polynomial fitted to 1/H̃ over a window
_TRIM_PROBABILITY = 0.99  # windows above this quantile of the noise distribution are spoilt by model error


def _window_mean_squares(f: NDArray, z: NDArray, window: int) -> list[float]:
    """Per-window mean squares of the relative residuals of a weighted cubic fit to 1/H̃."""
    out = []
    for start in range(0, f.size - window + 1, max(window // 2, 1)):
        x = f[start : start + window]
        x = (x - x.mean()) / max(np.ptp(x), 1e-300)
        v = np.vander(x, _DEGREE + 1)
        target = z[start : start + window]
        weight = 1.0 / np.abs(target)
        coefficients = np.linalg.lstsq(v * weight[:, None], target * weight, rcond=None)[0]
        relative = (target - v @ coefficients) * weight
        out.append(float(np.sum(np.abs(relative) ** 2) / (window - _DEGREE - 1)))
    return out


def _robust_variance(mean_squares: NDArray, dof: int) -> float:
    """σ² from per-window mean squares, each ``σ²·χ²_dof/dof`` unless spoilt by model error
    (then larger): start from the median, drop windows above the 99 % quantile and take the
    mean of the rest, corrected for the truncation (``E[χ²_d | χ²_d < c] = d·F_{d+2}(c)/F_d(c)``)."""
    variance = float(np.median(mean_squares)) / (scipy.special.chdtri(dof, 0.5) / dof)
    if variance <= 0:
        return 0.0
    for _ in range(3):
        limit = scipy.special.chdtri(dof, 1.0 - _TRIM_PROBABILITY) * variance / dof
        kept = mean_squares[mean_squares <= limit]
        cut = limit * dof / variance
        variance = float(kept.mean()) / (scipy.special.chdtr(dof + 2, cut) / scipy.special.chdtr(dof, cut))
    return variance


def _curve_mean_squares(frequency_hz: ArrayLike, h: ArrayLike, window: int) -> list[float]:
    """The window mean squares of one curve, windows within contiguous stretches."""
    f = np.asarray(frequency_hz, dtype=float)
    z = 1.0 / np.asarray(h, dtype=complex)
    mean_squares: list[float] = []
    for stretch in contiguous_stretches(f):
        if stretch.size >= window:
            mean_squares += _window_mean_squares(f[stretch], z[stretch], window)
    return mean_squares


def estimate_noise_fraction(frequency_hz: ArrayLike, h: ArrayLike, window: int = 9) -> float:
    """Relative noise level of a measured FRF (std of the noise / |H|), model-free.

    Measurement noise ``H(1 + ε)`` gives ``1/H̃ ≈ (1/H)(1 − ε)``, and ``1/H`` (dynamic
    stiffness) is smooth in ω near a resonance. So a cubic in ω is fitted to ``1/H̃`` over
    sliding windows of ``window`` points, weighted by ``|H̃|`` (so that the relative
    residuals ``(1/H̃ − fit)·|H̃|`` all carry the same noise), and those residuals estimate ε.
    Windows lie within contiguous stretches of the grid (:func:`contiguous_stretches`),
    never across a gap between bands, where ``1/H`` is not a cubic over the window.
    Returns ``sqrt(E|ε|²)``: a robust mean of the per-window mean squares (windows spoilt by
    a sharp feature — an antiresonance, where 1/H has a pole — are dropped, see
    :func:`_robust_variance`), corrected for the fitted degrees of freedom. Needs a stretch
    of at least ``window`` points (``window`` ≥ 6).
    """
    if window < _DEGREE + 3:
        raise ValueError(f"noise estimate window: expected at least {_DEGREE + 3} points, got {window}")
    mean_squares = _curve_mean_squares(frequency_hz, h, window)
    if not mean_squares:
        f = np.asarray(frequency_hz, dtype=float)
        raise ValueError(
            f"noise estimate needs at least {window} contiguous frequencies, got {f.size} frequencies in stretches of "
            f"{[len(s) for s in contiguous_stretches(f)]} points"
        )
    return float(np.sqrt(_robust_variance(np.array(mean_squares), 2 * (window - _DEGREE - 1))))


def coherence_noise_fraction(coherence: ArrayLike, averages: ArrayLike) -> NDArray[np.float64]:
    """Relative standard deviation of an H1 estimate from its ordinary coherence γ² and the
    number of averages n_d (Bendat & Piersol, random errors of frequency-response estimates).

    The normalised random errors of the magnitude and of the phase (rad) are each
    ``√(1 − γ²) / (|γ|·√(2 n_d))``, so the complex error ``δH`` of docs/methods.md §8 form has
    ``E|δH|²/|H|² = (1 − γ²)/(γ² n_d)``; returned is its square root per point. A coherence
    of 0 gives ``inf`` (the point carries no information).
    """
    gamma2 = np.clip(np.asarray(coherence, dtype=float), 0.0, 1.0)
    n = np.asarray(averages, dtype=float)
    with np.errstate(divide="ignore"):
        return np.sqrt(np.where(gamma2 > 0, (1.0 - gamma2) / (gamma2 * n), np.inf))


def repeat_noise_fraction(h_repeats: ArrayLike) -> float:
    """Relative noise std of one measurement from repeats: ``h_repeats`` (n_repeats ≥ 2, n_points)
    holds the same points measured several times. Pooled over points:
    ``σ² = Σ_points Σ_repeats |H_k − H̄|² / |H̄|² / (n_points (n_repeats − 1))``."""
    h = np.asarray(h_repeats, dtype=complex)
    if h.ndim != 2 or h.shape[0] < 2:
        raise ValueError(f"repeats: expected an array (n_repeats ≥ 2, n_points), got shape {h.shape}")
    mean = h.mean(axis=0)
    relative = np.abs(h - mean) ** 2 / np.abs(mean) ** 2
    return float(np.sqrt(np.sum(relative) / (h.shape[1] * (h.shape[0] - 1))))


@dataclass(frozen=True, eq=False)
class NoiseEstimate:
    """The noise level of a measured-FRF table and where it came from.

    fraction: relative std of the complex FRF error, ``sqrt(mean σ_k²)/|H|`` over the points
    (docs/methods.md §8 form; σ² is what a perfect model's FRAC gap approaches); source: ``"h_std"``,
    ``"coherence"``, ``"repeats"`` or ``"smoothness"`` (the model-free estimate of
    :func:`estimate_noise_fraction`, windows of every measured curve pooled); per_point: relative std
    per table row when the data state it (h_std, coherence), else None; detail: one line
    saying how it was obtained.
    """

    fraction: float
    source: str
    detail: str
    per_point: NDArray[np.float64] | None = None


def estimate_table_noise(table: pd.DataFrame, window: int = 9) -> NoiseEstimate:
    """Noise level of a measured-FRF table, from what the data carry, in this order:

    1. an ``h_std`` column (std of the complex FRF, same unit as H): ``σ_k = h_std/|H|``;
    2. ``coherence`` and ``averages`` columns: :func:`coherence_noise_fraction`;
    3. a ``repeat`` column (run number; the same frequency, level and coordinates measured in
       several runs): :func:`repeat_noise_fraction` of one run;
    4. otherwise the smoothness of ``1/H`` within contiguous stretches of every measured curve
       (one force level, response and input): the windows of all curves pooled into one
       robust estimate (:func:`estimate_noise_fraction`), so the windows a nonlinearity or an
       antiresonance spoils are trimmed wherever they are.

    A ``coherence`` column without ``averages`` cannot give a noise level (the number of
    averages is unknown); the smoothness estimate is used and the detail says so.
    """
    columns = set(table.columns)
    h = table["h_real"].to_numpy(dtype=float) + 1j * table["h_imag"].to_numpy(dtype=float)
    if "h_std" in columns:
        per_point = table["h_std"].to_numpy(dtype=float) / np.abs(h)
        return NoiseEstimate(float(np.sqrt(np.mean(per_point**2))), "h_std", "from the h_std column", per_point)
    if {"coherence", "averages"} <= columns:
        per_point = coherence_noise_fraction(table["coherence"].to_numpy(dtype=float),
                                             table["averages"].to_numpy(dtype=float))
        finite = per_point[np.isfinite(per_point)]
        fraction = float(np.sqrt(np.mean(finite**2))) if finite.size else float("inf")
        return NoiseEstimate(fraction, "coherence", "from the coherence and averages columns (H1 random error)",
                             per_point)
    keys = ["force_level_n", "response_dof", "input_dof"]
    if "repeat" in columns:
        runs = table.groupby("repeat", sort=True)
        if runs.ngroups >= 2:
            by_point = table.assign(h=h).sort_values("repeat", kind="stable").groupby(keys + ["frequency_hz"], sort=False)
            complete = [group["h"].to_numpy() for _, group in by_point if len(group) == runs.ngroups]
            if complete:
                return NoiseEstimate(repeat_noise_fraction(np.array(complete).T), "repeats",
                                     f"from {runs.ngroups} repeated runs at {len(complete)} points")
    mean_squares: list[float] = []
    curves = 0
    for _, curve in table.assign(h=h).groupby(keys, sort=True):
        if "repeat" in columns:
            curve = curve[curve["repeat"] == curve["repeat"].iloc[0]]
        found = _curve_mean_squares(curve["frequency_hz"].to_numpy(), curve["h"].to_numpy(), window)
        curves += bool(found)
        mean_squares += found
    if not mean_squares:
        return NoiseEstimate(0.0, "smoothness", f"no curve has {window} contiguous frequencies; noise unknown")
    why = " (a coherence column without averages gives no noise level)" if "coherence" in columns else ""
    fraction = float(np.sqrt(_robust_variance(np.array(mean_squares), 2 * (window - _DEGREE - 1))))
    return NoiseEstimate(fraction, "smoothness",
                         f"model-free, from the smoothness of 1/H within contiguous stretches of {curves} curve(s), "
                         f"{len(mean_squares)} windows pooled{why}")


def smooth_inverse_receptance(frequency_hz: ArrayLike, h: ArrayLike, window: int) -> NDArray[np.complex128]:
    """Noise-reduced ``1/H``: a weighted least-squares quadratic in ω over ``window``
    neighbouring points (odd, ≥ 5) evaluated at each frequency (a Savitzky–Golay filter
    on the dynamic stiffness, which is smooth even at resonances). Weights ``|H̃|``
    match the relative noise of docs/methods.md §8. Windows are shifted inwards at the ends."""
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
