"""One quantity of a held-out prediction against its measurement (:class:`Compared`), and
whether its 95 % band tests anything (:func:`widest_band`).

An uninformative band. "Measured inside the 95 % band" is evidence only if a wrong
prediction could have landed outside it. A band is *uninformative* — its "in band" tests
nothing — when it is wider than the larger of two widths the test itself fixes:

* twice the spread of the quantity over every curve the test measured (the levels, and the
  response-controlled runs where they are pooled: the curves of ``repeatability``) —
  max − min of the resonance (Hz), ln(max/min) of the damping ratio and of the peak |H|
  (they scatter by a fraction of themselves, their bands are taken in the logarithm). A
  band that wide, centred anywhere within the measured range, holds every value the test
  measured of the quantity: predicting any level's value, or none changing with amplitude,
  passes as well as following the amplitude dependence the model is meant to predict. The
  factor 2 makes that hold wherever the band lies, so the rule never needs its centre; a
  narrower band may still happen to hold them all, and is not flagged (the rule errs
  towards "informative");
* the test's resolution: the narrowest 95 % band the test's own repeatability allows,
  ``2 · 1.96 · σ_R`` (σ_R of ``Repeatability``, 1σ; ln units for the damping ratio and
  the peak) — the width a prediction with no model error at all would have if the test's
  scatter were known exactly. A band no wider is as narrow as the test can tell, so a
  quantity that barely changes with amplitude (a nearly linear mode) keeps informative
  bands: this clause keeps the rule from firing on a band the data could not narrow.

A resonance band is moreover uninformative whenever it is wider than the lines of the
held-out curve (their span, Hz): any resonance the test could measure lies within it. A
damping or peak band reaching 0 (low ≤ 0) spans an unbounded factor: uninformative.

The rule judges the band's width only: an uninformative band the measured value falls
*outside* is still a miss. Measured (docs/validation.md, "Bands"): on a Jenkins SDOF from
stuck to gross slip predicted by the model of the right form every band is informative
(width 0.26–0.81 of the limit); on the simulated BRB-like tests of
benchmarks/validate_band_coverage.py at the BRB's scatter (σ_f = 0.1 Hz, whose resonance
moves over the four levels by little more than that) about half of the in-band resonances
are flagged, at σ_f = 0.02 Hz 6 of 80; on the BRB's four levels every resonance band.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
from numpy.typing import NDArray

#: The quantities compared, in table order; the last two are judged in their logarithm.
QUANTITIES = ("resonance_hz", "damping_ratio", "peak_abs")
#: A band this many times the test's spread of a quantity, centred anywhere within that spread, holds
#: every value the test measured of it (module docstring).
SPREAD_FACTOR = 2.0
#: The two-sided 95 % normal factor of the test's resolution (σ_R known exactly).
Z95 = 1.96


@dataclass(frozen=True)
class Compared:
    """One quantity of a held-out level: measured, predicted and its 95 % band (low, high);
    ``widest``: the widest band that still tests something (:func:`widest_band`: Hz for the
    resonance, ln(high/low) for the damping ratio and the peak, ``log`` True), NaN when not judged."""

    measured: float
    predicted: float
    low: float = float("nan")
    high: float = float("nan")
    widest: float = float("nan")
    log: bool = False

    @property
    def error(self) -> float:
        return self.predicted - self.measured

    @property
    def relative_error(self) -> float:
        return self.predicted / self.measured - 1

    @property
    def inside(self) -> bool | None:
        """Whether the measured value lies in the band (None without a band)."""
        if not (np.isfinite(self.low) and np.isfinite(self.high)):
            return None
        return bool(self.low <= self.measured <= self.high)

    @property
    def predicted_inside(self) -> bool | None:
        """Whether the predicted value lies in its own band (None without a band); a
        prediction without a value (NaN) is not in it."""
        if not (np.isfinite(self.low) and np.isfinite(self.high)):
            return None
        return bool(self.low <= self.predicted <= self.high)

    @property
    def width(self) -> float:
        """The band's width: high − low (Hz), or ln(high/low) (``log``; inf when low ≤ 0)."""
        if not self.log:
            return self.high - self.low
        return float(np.log(self.high / self.low)) if self.low > 0 else float("inf")

    @property
    def informative(self) -> bool | None:
        """Whether the band is no wider than :attr:`widest` (module docstring); None
        without a band or without a judgement."""
        if self.inside is None or not np.isfinite(self.widest):
            return None
        return bool(self.width <= self.widest)

    def as_dict(self) -> dict[str, float]:
        out = {"measured": self.measured, "predicted": self.predicted, "low": self.low, "high": self.high}
        if self.informative is not None:
            out.update(informative=self.informative, widest_informative_band=self.widest,
                       band_width_scale="ln(high/low)" if self.log else "high - low")
        return out


def measured_spread(values: dict[str, Sequence[float]]) -> dict[str, float]:
    """Per quantity of ``values`` (each curve's measured value) its spread over the curves:
    max − min for the resonance, ln(max/min) for the damping ratio and the peak (positive
    values only); NaN with fewer than two."""
    out = {}
    for name in QUANTITIES:
        v = np.asarray(values.get(name, ()), dtype=float)
        v = v[np.isfinite(v) & ((v > 0) | (name == "resonance_hz"))]
        if v.size < 2:
            out[name] = float("nan")
        else:
            out[name] = float(v.max() - v.min()) if name == "resonance_hz" else float(np.log(v.max() / v.min()))
    return out


def widest_band(name: str, spread: float, test_std: float, frequency_hz: NDArray) -> float:
    """The widest band of quantity ``name`` that still tests something (module docstring):
    the larger of the test's ``spread`` of it and its resolution 2·1.96·``test_std`` (either
    NaN is left out), the resonance's capped at the span of the lines ``frequency_hz`` (Hz);
    NaN when neither is known."""
    parts = [x for x in (SPREAD_FACTOR * spread, 2 * Z95 * test_std) if np.isfinite(x)]
    widest = max(parts) if parts else float("nan")
    if name == "resonance_hz":
        span = float(np.ptp(frequency_hz)) if np.size(frequency_hz) else float("nan")
        widest = min(widest, span) if np.isfinite(widest) else span
    return widest
