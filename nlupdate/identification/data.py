"""Measured FRF curves of one (response, input) pair at several force levels.

:class:`FRFLevels` is the input of the PRD and DDF methods: one receptance curve
(frequencies in Hz ascending, complex H in m/N) per force amplitude (N), taken from a
measured-FRF table (:mod:`nlupdate.measurements`). Frequencies are matched exactly
(relative 1e-9), as a stepped-sine test repeats the same frequencies at every level.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from nlupdate.measurements import force_levels, select_frf
from nlupdate.noise import add_frf_noise

_RTOL = 1e-9


def _match(available: NDArray, wanted: NDArray) -> NDArray[np.int64]:
    """Index into ``available`` of each ``wanted`` frequency, −1 where absent."""
    position = np.clip(np.searchsorted(available, wanted), 0, max(available.size - 1, 0))
    out = np.full(wanted.shape, -1, dtype=np.int64)
    for offset in (0, -1):
        candidate = np.clip(position + offset, 0, available.size - 1)
        hit = np.isclose(available[candidate], wanted, rtol=_RTOL, atol=1e-12) & (out < 0)
        out[hit] = candidate[hit]
    return out


@dataclass(frozen=True, eq=False)
class FRFLevels:
    """Receptance curves of one coordinate pair, one per force level (ascending)."""

    response_dof: str
    input_dof: str
    levels: NDArray[np.float64]
    frequencies: tuple[NDArray[np.float64], ...]
    receptances: tuple[NDArray[np.complex128], ...]

    @classmethod
    def from_table(cls, table: pd.DataFrame, response_dof: str, input_dof: str) -> "FRFLevels":
        """All force levels of ``response_dof``/``input_dof``; unknown dofs raise ValueError."""
        response, inp = str(response_dof), str(input_dof)
        for column, name in (("response_dof", response), ("input_dof", inp)):
            names = sorted(set(table[column].astype(str)))
            if name not in names:
                raise ValueError(f"unknown {column} {name!r}: the measured table has {column} {names}")
        pair = table[(table["response_dof"].astype(str) == response) & (table["input_dof"].astype(str) == inp)]
        if pair.empty:
            raise ValueError(f"no measured FRF with response_dof={response!r} and input_dof={inp!r}")
        levels = force_levels(pair)
        curves = [select_frf(pair, response, inp, level) for level in levels]
        return cls(response, inp, levels, tuple(c[0] for c in curves), tuple(c[1] for c in curves))

    def level_index(self, force_n: float) -> int:
        hit = np.flatnonzero(np.isclose(self.levels, float(force_n), rtol=_RTOL, atol=0.0))
        if hit.size == 0:
            raise ValueError(
                f"force level {float(force_n):g} N not measured for response {self.response_dof!r} / input "
                f"{self.input_dof!r}; levels: {[float(f) for f in self.levels]} N"
            )
        return int(hit[0])

    def curve(self, force_n: float) -> tuple[NDArray[np.float64], NDArray[np.complex128]]:
        k = self.level_index(force_n)
        return self.frequencies[k], self.receptances[k]

    def common_frequencies(self, levels: ArrayLike) -> NDArray[np.float64]:
        """Frequencies (Hz) measured at every one of ``levels``."""
        indices = [self.level_index(level) for level in np.atleast_1d(levels)]
        common = self.frequencies[indices[0]]
        for k in indices[1:]:
            common = common[_match(self.frequencies[k], common) >= 0]
        return common

    def values(self, force_n: float, frequency_hz: ArrayLike) -> NDArray[np.complex128]:
        """H at given frequencies of one level; ValueError naming a missing frequency."""
        f, h = self.curve(force_n)
        wanted = np.atleast_1d(np.asarray(frequency_hz, dtype=float))
        index = _match(f, wanted)
        if np.any(index < 0):
            missing = wanted[index < 0][0]
            raise ValueError(
                f"frequency {missing:g} Hz not measured at {float(force_n):g} N (response "
                f"{self.response_dof!r}, input {self.input_dof!r}); measured {f.min():g}–{f.max():g} Hz, "
                f"{f.size} points"
            )
        return h[index]

    def has_frequency(self, force_n: float, frequency_hz: float) -> bool:
        f, _ = self.curve(force_n)
        return bool(_match(f, np.array([float(frequency_hz)]))[0] >= 0)

    def subset(self, levels: ArrayLike) -> "FRFLevels":
        indices = [self.level_index(level) for level in np.atleast_1d(levels)]
        return FRFLevels(
            self.response_dof, self.input_dof, self.levels[indices],
            tuple(self.frequencies[k] for k in indices), tuple(self.receptances[k] for k in indices),
        )

    def with_noise(self, fraction: float, rng: np.random.Generator) -> "FRFLevels":
        """A copy with METHODS §8 noise (std = fraction·|H|) added to every value."""
        return FRFLevels(
            self.response_dof, self.input_dof, self.levels, self.frequencies,
            tuple(add_frf_noise(h, fraction, rng) for h in self.receptances),
        )


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
