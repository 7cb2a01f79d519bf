"""Resonance frequency, damping ratio and peak of one FRF curve, the same estimator for a
measured and a predicted curve (docs/methods.md §10).

The peak: the largest |H|, refined by a parabola through the three lines around it
(:func:`nlupdate.core.correlation.metrics.peak`). The damping ratio: the modal circle fit of
the mobility over the lines with |H| ≥ 0.4 max|H| around the peak
(:func:`nlupdate.core.validation.circle_fit.circle_fit_damping`: NaN for fewer than 5 such
lines, a peak at that run's end — a jump or the band's edge — or a magnitude-only curve),
except where a step between two lines of that run is a jump no linear mode of the curve's
half-power width can make (:func:`~nlupdate.core.validation.circle_fit.jump_in_run`): then
the half-power value, as a circle fitted across a jump reads ζ up to 2× low. The two curves
of one comparison are read by one estimator (:func:`read_alike`): where one of them
jumps and the other not, both by the half-power value — the circle fit is not defined across
the jump, the half-power width is for both (the BRB's top level predicted from the three
below folds after its peak where the measured curve does not: read apart +26 %, alike
+2.2 %; docs/validation.md).
On simulated curves with the Brake–Reuss beam's lines and noise it is 2–3× less noisy than
the half-power bandwidth and needs no crossing inside the band (docs/validation.md, "How the
damping ratio is measured").

The half-power bandwidth is kept beside it: ``ζ_hp = (f₂ − f₁)/(2 f_r)`` with f₁, f₂ where
|H| crosses ``|H|_max/√2``, each crossing interpolated linearly between the two lines around
it, NaN unless both crossings lie within the band; ``half_power_lines`` counts the lines
between them (a bandwidth of fewer than ~5 lines is resolved poorly, and a comparison says so).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike

from nlupdate.core.correlation.metrics import peak
from nlupdate.core.run_cache import remembered_in_run
from nlupdate.core.validation.circle_fit import circle_fit_damping, jump_in_run

#: Fewer lines than this inside the half-power band: the damping ratio is poorly resolved.
MIN_HALF_POWER_LINES = 5


@dataclass(frozen=True)
class Resonance:
    """One curve's resonance_hz (Hz), damping_ratio (circle fit; NaN under its rules; the
    half-power value at a jump, ``jump``), peak_abs (|H| at the peak, the FRF's unit),
    half_power_lines and half_power_damping_ratio (NaN when a crossing lies outside the band)."""

    resonance_hz: float
    damping_ratio: float
    peak_abs: float
    half_power_lines: int
    half_power_damping_ratio: float = float("nan")
    #: whether a jump inside the circle's run made ``damping_ratio`` the half-power value
    jump: bool = False

    @property
    def damping_resolved(self) -> bool:
        return self.half_power_lines >= MIN_HALF_POWER_LINES


@remembered_in_run  # a measured curve enters every comparison, refit and repeatability of a validation
def resonance(frequency_hz: ArrayLike, h: ArrayLike) -> Resonance:
    """:class:`Resonance` of the curve ``h`` (complex or magnitude) over ``frequency_hz``
    (strictly increasing, Hz; ``h`` a receptance for the circle fit); NaN lines are ignored."""
    f = np.asarray(frequency_hz, dtype=float)
    h = np.asarray(h)
    magnitude = np.abs(h)
    finite = np.isfinite(magnitude)
    f, h, magnitude = f[finite], h[finite], magnitude[finite]
    if f.size < 3:
        return Resonance(float("nan"), float("nan"), float("nan"), 0)
    f_r, top = peak(f, magnitude)
    zeta_hp, lines = _half_power(f, magnitude, f_r, top)
    zeta = circle_fit_damping(f, h, start_zeta=zeta_hp)
    jump = bool(np.iscomplexobj(h) and jump_in_run(f, h, zeta_hp if np.isfinite(zeta_hp) else zeta))
    return Resonance(f_r, zeta_hp if jump else zeta, top, lines, zeta_hp, jump)


def read_alike(own: Resonance, other: Resonance | None) -> Resonance:
    """``own`` (one curve's :func:`resonance`) with its damping ratio read by the estimator
    that reads ``other`` (the curve it is compared with) too: the half-power value when one of
    the two jumps and the other not and both have one (module docstring); ``own`` otherwise."""
    if other is None or own.jump == other.jump or not (np.isfinite(own.half_power_damping_ratio)
                                                       and np.isfinite(other.half_power_damping_ratio)):
        return own
    return replace(own, damping_ratio=own.half_power_damping_ratio, jump=True)


def _half_power(f: np.ndarray, magnitude: np.ndarray, f_r: float, top: float) -> tuple[float, int]:
    """(half-power damping ratio, lines inside the half-power band); (NaN, 0) when a crossing
    lies outside the band."""
    half = top / np.sqrt(2.0)
    k = int(np.argmax(magnitude))
    below = np.flatnonzero(magnitude[:k] < half)
    above = np.flatnonzero(magnitude[k:] < half) + k
    if below.size == 0 or above.size == 0:
        return float("nan"), 0
    i, j = int(below[-1]), int(above[0])
    f1 = np.interp(half, magnitude[i:i + 2], f[i:i + 2])
    f2 = np.interp(half, magnitude[j - 1:j + 1][::-1], f[j - 1:j + 1][::-1])
    lines = int(np.count_nonzero((f > f1) & (f < f2)))
    return float((f2 - f1) / (2 * f_r)), lines
