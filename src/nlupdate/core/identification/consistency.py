"""Is the extracted linear FRF the same at every force level? The placement check.

The linear receptance does not depend on the force. Every level j gives its own estimate
of the linear dynamic stiffness once the describing function ν is known
(docs/methods.md §4, :func:`~nlupdate.core.identification.linear_frf.level_terms`):

    t_j(ω) = 1/H_j(ω) − ν(|H_j(ω)| F_j, ω),

with noise variance σ_j² (the noise of 1/H_j and the noise ν picks up through the
measured amplitude). When the identified elements describe the structure *at the
measured coordinate* the t_j agree within σ_j at every line. They do not when the
nonlinearity acts elsewhere (between two unmeasured coordinates, or between the measured
one and another: the measured 1/H_j is then not 1/H^L + ν at any ν) or the element set
is wrong (the wrong amplitude law): then the levels' estimates differ by far more than
their noise wherever the nonlinearity is active — and their weighted mean, the extracted
linear FRF, is a blend that can show resonances the structure does not have.

The statistic, per line with m ≥ 2 levels: with weights w_j = 1/σ_j² and the weighted
mean t̄,

    χ²(ω) = Σ_j w_j |t_j − t̄|²,   E χ² = m − 1 under circular complex noise

(2χ² follows χ² with 2(m − 1) degrees of freedom). :attr:`LevelConsistency.spread_ratio`
is √(Σ_ω χ² / Σ_ω (m − 1)): the RMS level-to-level spread in units of the noise, 1 when
the levels agree. A line is *inconsistent* when its 2χ² exceeds the 99.9 % point of its
χ² distribution (0.1 % of lines under pure noise).

The check fails when ``spread_ratio > SPREAD_LIMIT`` (2: the spread has four times the
noise variance). Calibration (``tests/test_linear_frf_consistency.py``: 3-DOF chain,
cubic spring, five levels, time-integration data, 1 % noise, seeds 1–5): correctly placed
0.85–1.0; between two unmeasured coordinates 6.3–8.4; between the measured coordinate and
another (the outer masses) 6.4–8.5; a Jenkins element fitted where the truth is a cubic
spring 34–44. The noise level itself is estimated to ~10 %, which moves the ratio by as
much; 2 leaves room for that and for the first-harmonic approximation of ν on
time-integration data.

What it cannot see: a misplaced nonlinearity that acts in one mode only. Near an isolated
mode the measured point looks like a single-degree-of-freedom system whose modal
coordinate carries the nonlinearity, ν_eff(|X_m|) = r² ν(r |X_m|) with r = φ_e/φ_m (the
mode's relative displacement across the element over its displacement at the measured
coordinate; a cubic spring: k3 scaled by r⁴) — an element at the measured coordinate with
scaled parameters describes it exactly, at every level. The misplacement shows once the
nonlinearity acts in two modes (a different r in each), or between them.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.stats import chi2

from nlupdate.core.identification.linear_frf import LevelTerms

#: The RMS level-to-level spread of the extracted linear FRF, in noise units, above which
#: the check fails (module docstring).
SPREAD_LIMIT = 2.0

#: A line is inconsistent when its statistic exceeds this quantile of its distribution.
LINE_QUANTILE = 0.999


@dataclass(frozen=True, eq=False)
class LevelConsistency:
    """The level-to-level spread of the extracted linear FRF (module docstring).

    frequency_hz (Hz): the lines; line_ratio: √(χ²/(m − 1)) per line (NaN where fewer than
    two levels give a value); inconsistent: lines beyond the 99.9 % point;
    spread_ratio: the RMS over all lines; levels_n: the levels compared.
    """

    levels_n: tuple[float, ...]
    frequency_hz: NDArray[np.float64]
    line_ratio: NDArray[np.float64]
    inconsistent: NDArray[np.bool_]
    spread_ratio: float

    @property
    def passed(self) -> bool:
        """The levels agree within ``SPREAD_LIMIT`` times the noise."""
        return bool(self.spread_ratio <= SPREAD_LIMIT)

    def worst_band_hz(self) -> tuple[float, float] | None:
        """The span (Hz) of the inconsistent lines, None when there are none."""
        f = self.frequency_hz[self.inconsistent]
        return None if f.size == 0 else (float(f.min()), float(f.max()))

    def as_dict(self) -> dict:
        band = self.worst_band_hz()
        return {
            "passed": self.passed,
            "spread_ratio_to_noise": self.spread_ratio,
            "limit": SPREAD_LIMIT,
            "levels_n": list(self.levels_n),
            "lines": int(np.sum(np.isfinite(self.line_ratio))),
            "inconsistent_lines": int(np.sum(self.inconsistent)),
            "inconsistent_span_hz": None if band is None else list(band),
            "definition": "each level's 1/H_j - nu(|H_j| F_j) is an estimate of the linear dynamic stiffness; "
                          "spread_ratio_to_noise = sqrt(sum over lines of sum_j |t_j - weighted mean|^2 / sigma_j^2 "
                          "over sum of (levels - 1)), 1 when the levels agree within their noise; a line is "
                          f"inconsistent beyond the {100 * LINE_QUANTILE:g} % point of its chi-square; the check fails "
                          f"above {SPREAD_LIMIT:g}",
        }


def level_consistency(terms: LevelTerms, noise_fraction: float) -> LevelConsistency | None:
    """The check on ``terms`` (:func:`~nlupdate.core.identification.linear_frf.level_terms`)
    with relative noise ``noise_fraction`` (std / |H|; used when the terms' variances are
    relative). None when no line has two measured levels or the noise level is 0. Lines two
    levels measured where the fitted elements leave no finite term (a degenerate fit of a
    wrong element set: a stiffness of 1e-305) fail the check with an infinite spread: no
    linear FRF at all is no evidence that the levels agree."""
    scale = 1.0 if terms.absolute else float(noise_fraction) ** 2
    good = np.isfinite(terms.terms) & np.isfinite(terms.variance) & (terms.variance > 0)
    count = np.sum(good, axis=0)
    if not scale > 0:
        return None
    if not np.any(count >= 2):
        measured = np.sum(terms.measured, axis=0) if terms.measured is not None else count
        if not np.any(measured >= 2):
            return None
        none = np.full(terms.frequency_hz.shape, np.nan)
        return LevelConsistency(terms.levels_n, terms.frequency_hz, none, np.zeros(none.shape, bool), float("inf"))
    weight = np.where(good, 1.0 / (scale * np.where(good, terms.variance, 1.0)), 0.0)
    value = np.where(good, terms.terms, 0.0)
    total = np.sum(weight, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        mean = np.sum(weight * value, axis=0) / total
    statistic = np.sum(weight * np.abs(value - mean[None, :]) ** 2, axis=0)
    compared = count >= 2
    dof = np.where(compared, count - 1, 1)
    with np.errstate(invalid="ignore"):
        line_ratio = np.where(compared, np.sqrt(statistic / dof), np.nan)
    inconsistent = compared & (2 * statistic > chi2.ppf(LINE_QUANTILE, 2 * dof))
    spread = float(np.sqrt(np.sum(statistic[compared]) / np.sum(count[compared] - 1)))
    return LevelConsistency(terms.levels_n, terms.frequency_hz, line_ratio, inconsistent, spread)
