"""The linear receptance extracted from the measured curves and the identified nonlinearity.

At every force level L the first-harmonic balance at the response coordinate reads
(docs/methods.md §4)

    1/H^L(ω) = 1/H_L(ω) − ν(A_L(ω), ω),     A_L = |H_L|·F_L,

so each level gives the linear receptance H^L once the describing function ν is known.
The source extracts it from the lowest level alone, with the constant Δ_f1 found at the
excitation frequency (its eq. 2.55; :func:`from_low_force`). That level is often the
worst one: a stuck joint adds its full stiffness there, 1/H_1 ≈ 1/H^L + k_f, and near a
linear resonance the noise of 1/H_1 (a fraction of |1/H_1| ≈ k_f) swamps the small
1/H^L. On the demo's T-beam the 0.01 N level carries 12× the noise of the 1 N level at
the first linear mode, which the extraction then misplaces by up to 1 Hz.

:func:`from_all_levels` combines every level line by line, each weighted by the inverse
variance of its 1/H_L − ν: the noise of 1/H_L (relative noise of H: a fraction of
|1/H_L|, or the stated h_std/|H_L|²) and the noise ν picks up through the measured
amplitude (A·|∂ν/∂A| times the same fraction). It needs ν at every amplitude and
frequency, so it serves physical elements; a polynomial DF is only known over the
amplitudes it was fitted to and keeps the low-force route.

:func:`locate_linear_modes` fits the modes of either extraction, weighted by its noise.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.identification.data import FRFLevels, match_frequencies
from nlupdate.core.identification.modal_fit import ModalFit, fit_mode_near, resonance_crossings
from nlupdate.core.measurement.noise import smooth_inverse_receptance

#: Relative amplitude step (central difference) for ∂ν/∂A in the noise of each level.
AMPLITUDE_STEP = 1e-4

#: Finite lines a mode's band needs for its one-mode fit (``fit_mode_near``'s minimum).
MIN_MODE_LINES = 8

#: The linear-FRF routes by name (study files: ``[identification] linear_from``).
LINEAR_FROM = ("all levels", "low force")

DescribingFunctionAt = Callable[[float], Callable[[NDArray, NDArray], NDArray]]


@dataclass(frozen=True, eq=False)
class LinearExtraction:
    """An extracted linear receptance on the reference level's frequencies.

    levels_n: the force levels it was taken from; frequency_hz (Hz), receptance (m/N);
    inverse_noise: the standard deviation of 1/H^L at each frequency, up to one common
    factor (N/m; the weights of a modal fit); reference_level_n, reference_receptance:
    the measured curve it is drawn beside (the lowest level used).
    """

    levels_n: tuple[float, ...]
    frequency_hz: NDArray[np.float64]
    receptance: NDArray[np.complex128]
    inverse_noise: NDArray[np.float64]
    reference_level_n: float
    reference_receptance: NDArray[np.complex128]


def from_low_force(data: FRFLevels, level: float, receptance: NDArray) -> LinearExtraction:
    """The source's route: ``receptance`` extracted from the ``level`` curve alone; its
    noise scale is |1/H_1| smoothed over 9 points (weights taken from the noisy values
    themselves would favour the points whose noise happens to shrink |1/H_1|: a bias)."""
    f, h = data.curve(level)
    noise = np.abs(smooth_inverse_receptance(f, h, 9)) if f.size >= 9 else np.abs(1.0 / h)
    return LinearExtraction((float(level),), f, np.asarray(receptance, dtype=complex), noise, float(level), h)


@dataclass(frozen=True, eq=False)
class LevelTerms:
    """Each level's own estimate of the linear dynamic stiffness, 1/H_j − ν(|H_j|F_j, ω)
    (N/m), on the reference level's frequencies: ``terms`` (n_levels, n_lines), NaN where
    a level gives no finite value; ``variance`` the variance of each term ((N/m)²) —
    absolute when ``absolute`` (the data state h_std), else for a relative noise of 1
    (multiply by the noise fraction squared)."""

    levels_n: tuple[float, ...]
    frequency_hz: NDArray[np.float64]
    terms: NDArray[np.complex128]
    variance: NDArray[np.float64]
    absolute: bool
    reference_receptance: NDArray[np.complex128]
    measured: NDArray[np.bool_] | None = None  # (n_levels, n_lines): the level was measured at the line


def level_terms(data: FRFLevels, describing_function_at: DescribingFunctionAt) -> LevelTerms:
    """Every level's term 1/H_j − ν and its noise variance (module docstring), on the
    lowest level's frequencies. ``describing_function_at(level)`` is ν(A [m], ω [rad/s])
    → N/m for that level."""
    reference = float(data.levels[0])
    f, h_reference = data.curve(reference)
    omega = 2 * np.pi * f
    terms = np.full((data.levels.size, f.size), np.nan, dtype=complex)
    variances = np.full((data.levels.size, f.size), np.nan)
    measured = np.zeros((data.levels.size, f.size), dtype=bool)
    for index, level in enumerate(data.levels):
        f_level, h_level = data.curve(float(level))
        at = match_frequencies(f_level, f)
        present = measured[index] = at >= 0
        h = np.full(f.size, np.nan, dtype=complex)
        h[present] = h_level[at[present]]
        force = np.full(f.size, np.nan)
        force[present] = data.force_at(float(level), f_level)[at[present]]
        relative = np.ones(f.size)
        if data.h_stds is not None:
            stds = np.full(f.size, np.nan)
            stds[present] = data.h_stds[index][at[present]]
            relative = stds / np.abs(h)
        with np.errstate(divide="ignore", invalid="ignore"):
            amplitude = np.abs(h) * force
            nu_of = describing_function_at(float(level))
            usable = present & np.isfinite(amplitude) & (amplitude > 0)
            nu = np.full(f.size, np.nan, dtype=complex)
            slope = np.full(f.size, np.nan)
            a, w = amplitude[usable], omega[usable]
            nu[usable] = nu_of(a, w)
            slope[usable] = np.abs(nu_of(a * (1 + AMPLITUDE_STEP), w) - nu_of(a * (1 - AMPLITUDE_STEP), w)) \
                / (2 * AMPLITUDE_STEP)
            variance = relative ** 2 * (np.abs(1.0 / h) ** 2 + slope ** 2)
            term = 1.0 / h - nu
        good = usable & np.isfinite(term) & np.isfinite(variance) & (variance > 0)
        terms[index, good] = term[good]
        variances[index, good] = variance[good]
    return LevelTerms(tuple(float(level) for level in data.levels), f, terms, variances, data.h_stds is not None,
                      h_reference, measured)


def from_all_levels(data: FRFLevels, describing_function_at: DescribingFunctionAt) -> LinearExtraction:
    """The linear receptance from every level (module docstring), on the lowest level's
    frequencies. ``describing_function_at(level)`` is ν(A [m], ω [rad/s]) → N/m for that
    level. A line no level gives a finite value for is NaN."""
    return combined(level_terms(data, describing_function_at))


def combined(terms: LevelTerms) -> LinearExtraction:
    """The inverse-variance weighted mean of the levels' terms, line by line."""
    good = np.isfinite(terms.terms) & np.isfinite(terms.variance)
    weight = np.where(good, 1.0 / np.where(good, terms.variance, 1.0), 0.0)
    weighted = np.sum(np.where(good, terms.terms, 0.0) * weight, axis=0)
    total_weight = np.sum(weight, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        inverse = np.where(total_weight > 0, weighted / total_weight, np.nan)
        return LinearExtraction(terms.levels_n, terms.frequency_hz, 1.0 / inverse, np.sqrt(1.0 / total_weight),
                                terms.levels_n[0], terms.reference_receptance)


def locate_linear_modes(
    frequency_hz: NDArray, h_linear: NDArray, inverse_noise: NDArray, near_hz: tuple[float, ...] | None,
    band_fraction: float,
) -> tuple[ModalFit, ...]:
    """One-mode fits of an extracted linear FRF near ``near_hz`` (default: at each of its
    resonance crossings; none when it has no resonance in the band), weighted by
    ``inverse_noise``, the noise of its ``1/H`` at each frequency (up to a common factor);
    fits that land on an already found mode (within 1 %) are dropped. Ascending. A mode
    asked for where the extraction has no finite line (elements that leave no linear FRF
    there: a wrong element set, which the level check flags) is left out, not an error."""
    finite = np.isfinite(h_linear) & np.isfinite(inverse_noise)  # lines no level gave
    frequency_hz, h_linear, noise_scale = frequency_hz[finite], h_linear[finite], inverse_noise[finite]
    starts = resonance_crossings(frequency_hz, h_linear) if near_hz is None else np.asarray(near_hz, dtype=float)
    modes: list[ModalFit] = []
    for start in starts:
        try:
            fit = fit_mode_near(frequency_hz, h_linear, float(start), inverse_noise=noise_scale,
                                band_fraction=band_fraction, residual_slope=True)
        except (ValueError, np.linalg.LinAlgError):
            near = np.abs(frequency_hz - float(start)) <= band_fraction * float(start)
            if near_hz is not None and near.sum() >= MIN_MODE_LINES:
                raise
            continue  # no crossing there, or the elements leave no linear FRF there (said by the level check)
        found = float(fit.natural_frequencies_hz[0])
        if all(abs(found / float(m.natural_frequencies_hz[0]) - 1) > 0.01 for m in modes):
            modes.append(fit)
    return tuple(sorted(modes, key=lambda m: float(m.natural_frequencies_hz[0])))
