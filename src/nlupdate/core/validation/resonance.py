"""Resonance frequency, damping ratio and peak of one FRF curve, the same estimator for a
measured and a predicted curve (docs/methods.md §10).

The peak: the largest |H|, refined by a parabola through the three lines around it
(:func:`nlupdate.core.correlation.metrics.peak`). The damping ratio: half-power bandwidth,
``ζ = (f₂ − f₁)/(2 f_r)`` with f₁, f₂ where |H| crosses ``|H|_max/√2``, each crossing
interpolated linearly between the two lines around it. It is defined only when both
crossings lie within the measured band; ``half_power_lines`` counts the lines between
them (a bandwidth of fewer than ~5 lines is resolved poorly, and a comparison says so).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from nlupdate.core.correlation.metrics import peak

#: Fewer lines than this inside the half-power band: the damping ratio is poorly resolved.
MIN_HALF_POWER_LINES = 5


@dataclass(frozen=True)
class Resonance:
    """One curve's resonance_hz (Hz), damping_ratio (half-power; NaN when a crossing lies
    outside the band), peak_abs (|H| at the peak, the FRF's unit) and half_power_lines."""

    resonance_hz: float
    damping_ratio: float
    peak_abs: float
    half_power_lines: int

    @property
    def damping_resolved(self) -> bool:
        return self.half_power_lines >= MIN_HALF_POWER_LINES


def resonance(frequency_hz: ArrayLike, h: ArrayLike) -> Resonance:
    """:class:`Resonance` of the curve ``h`` (complex or magnitude) over ``frequency_hz``
    (strictly increasing, Hz); NaN lines are ignored."""
    f = np.asarray(frequency_hz, dtype=float)
    magnitude = np.abs(np.asarray(h))
    finite = np.isfinite(magnitude)
    f, magnitude = f[finite], magnitude[finite]
    if f.size < 3:
        return Resonance(float("nan"), float("nan"), float("nan"), 0)
    f_r, top = peak(f, magnitude)
    half = top / np.sqrt(2.0)
    k = int(np.argmax(magnitude))
    below = np.flatnonzero(magnitude[:k] < half)
    above = np.flatnonzero(magnitude[k:] < half) + k
    if below.size == 0 or above.size == 0:
        return Resonance(f_r, float("nan"), top, 0)
    i, j = int(below[-1]), int(above[0])
    f1 = np.interp(half, magnitude[i:i + 2], f[i:i + 2])
    f2 = np.interp(half, magnitude[j - 1:j + 1][::-1], f[j - 1:j + 1][::-1])
    lines = int(np.count_nonzero((f > f1) & (f < f2)))
    return Resonance(f_r, float((f2 - f1) / (2 * f_r)), top, lines)
