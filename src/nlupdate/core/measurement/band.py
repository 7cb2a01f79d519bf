"""The excited band of a measured FRF: where the test put energy in.

A broadband export covers the analyser's whole range (0–512 Hz for 1024 Hz sampling)
while the excitation covered a part of it (a 70–110 Hz chirp); outside, the "FRF" is
the ratio of two noises. :func:`excited_band` finds the excited range:

* **with coherence**: the longest run of lines whose coherence is at least
  ``threshold`` (default :data:`COHERENCE_THRESHOLD`), gaps of up to two lines bridged;
* **without**: where the FRF is smooth. The dynamic stiffness ``Z = 1/H`` of a structure
  is smooth in frequency even at a resonance; its relative second difference
  ``|Z_{k−1} − 2Z_k + Z_{k+1}| / mean|Z|`` is small where H is measured (about
  ``2(Δω/ω_r)²/η`` at a resonance of loss factor η, about √6 × the relative noise
  elsewhere) and of order 1 where H is noise. Its running median over 9 lines below
  :data:`ROUGHNESS_LIMIT` (0.5) marks the excited lines; the longest run of them is the
  band. When that run covers nearly all lines (≥ 80 % of the range), the whole range is
  returned: the curve shows no unexcited part.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike

from nlupdate.core.measurement.units import table_reference_unit

COHERENCE_THRESHOLD = 0.8
ROUGHNESS_LIMIT = 0.5
_WINDOW = 9
#: relative tolerance of a band's ends: a stepped-sine test repeats its frequencies at every
#: level, and a logger may round them differently in the last digits (42.70540998163596 and
#: …597 Hz); a band found at one level keeps the same lines of the others
BAND_RTOL = 1e-9


def in_band(frequency_hz: ArrayLike, band_hz: tuple[float, float]) -> np.ndarray:
    """Boolean mask of the frequencies (Hz) within ``band_hz`` = (low, high) Hz, ends
    included up to :data:`BAND_RTOL`."""
    f = np.asarray(frequency_hz, dtype=float)
    low, high = band_hz
    return (f >= low * (1 - BAND_RTOL)) & (f <= high * (1 + BAND_RTOL))


@dataclass(frozen=True)
class Band:
    """An excited band (Hz, ends included) and how it was found."""

    low_hz: float
    high_hz: float
    reason: str

    @property
    def hz(self) -> tuple[float, float]:
        return (self.low_hz, self.high_hz)


def _longest_run(mask: np.ndarray, bridge: int = 2) -> tuple[int, int] | None:
    """(first, last) index of the longest run of True, gaps up to ``bridge`` bridged."""
    best, start, gap, last_true = None, None, 0, None
    for k, value in enumerate(mask):
        if value:
            if start is None:
                start = k
            last_true, gap = k, 0
        elif start is not None:
            gap += 1
            if gap > bridge:
                if best is None or last_true - start > best[1] - best[0]:
                    best = (start, last_true)
                start, gap = None, 0
    if start is not None and (best is None or last_true - start > best[1] - best[0]):
        best = (start, last_true)
    return best


def roughness(frequency_hz: ArrayLike, h: ArrayLike) -> np.ndarray:
    """Running median (9 lines) of the relative second difference of ``1/H`` (module docstring)."""
    z = 1.0 / np.asarray(h, dtype=complex)
    second = np.abs(z[:-2] - 2 * z[1:-1] + z[2:]) / ((np.abs(z[:-2]) + np.abs(z[1:-1]) + np.abs(z[2:])) / 3)
    second = np.concatenate([[second[0]], second, [second[-1]]])
    half = _WINDOW // 2
    padded = np.pad(second, half, mode="edge")
    return np.median(np.lib.stride_tricks.sliding_window_view(padded, _WINDOW), axis=1)


def excited_band(frequency_hz: ArrayLike, h: ArrayLike, coherence: ArrayLike | None = None,
                 threshold: float = COHERENCE_THRESHOLD) -> Band:
    """The excited band of one measured curve (module docstring); the whole range when
    nothing marks a smaller one."""
    f = np.asarray(frequency_hz, dtype=float)
    whole = Band(float(f[0]), float(f[-1]), "all measured frequencies")
    if f.size < 2 * _WINDOW:
        return whole
    if coherence is not None:
        run = _longest_run(np.asarray(coherence, dtype=float) >= threshold)
        if run is None:
            raise ValueError(f"no line has a coherence of {threshold:g} or more: nothing was measured (give the band "
                             f"with --band LOW:HIGH)")
        return Band(float(f[run[0]]), float(f[run[1]]), f"coherence ≥ {threshold:g}")
    rough = roughness(f, h)
    run = _longest_run(rough < ROUGHNESS_LIMIT)
    if run is None or (f[run[1]] - f[run[0]]) >= 0.8 * (f[-1] - f[0]):
        return whole
    return Band(float(f[run[0]]), float(f[run[1]]),
                f"where the FRF is smooth (relative 2nd difference of 1/H < {ROUGHNESS_LIMIT:g}; no coherence given)")


def excited_band_of_table(table: pd.DataFrame) -> tuple[tuple[float, float], str]:
    """((low, high) Hz, how it was found): the excited band
    (:func:`excited_band`) of each response/input pair's lowest level with at least 20 lines, joined over the pairs; the whole range when no level has."""
    lows, highs, reasons = [], [], []
    for (response, inp), pair in table.groupby(["response_dof", "input_dof"], sort=True):
        for level, curve in pair.groupby("force_level_n", sort=True):
            if len(curve) < 20:
                continue
            curve = curve.sort_values("frequency_hz")
            h = curve["h_real"].to_numpy(float) + 1j * curve["h_imag"].to_numpy(float)
            coherence = curve["coherence"].to_numpy(float) if "coherence" in curve.columns \
                and curve["coherence"].notna().all() else None
            try:
                band = excited_band(curve["frequency_hz"].to_numpy(float), h, coherence, COHERENCE_THRESHOLD)
            except ValueError as error:
                raise ValueError(f"response {response}, input {inp}, level {level:g}: {error}") from None
            lows.append(band.low_hz)
            highs.append(band.high_hz)
            reasons.append(f"{band.reason}, level {level:g} {table_reference_unit(table)} of {response}/{inp}")
            break
    if not lows:
        return (float(table["frequency_hz"].min()), float(table["frequency_hz"].max())), "all measured frequencies"
    return (min(lows), max(highs)), "; ".join(sorted(set(reasons)))


def table_within(table: pd.DataFrame, band_hz: tuple[float, float]) -> tuple[pd.DataFrame, int]:
    """(the rows of an FRF table whose frequency lies in ``band_hz`` (Hz, closed), how many
    rows were left out)."""
    inside = in_band(table["frequency_hz"], band_hz)
    return table[inside].reset_index(drop=True), int((~inside).sum())
