"""The gap between model and measurement, per force level, and how it changes with force.

Per level, over the measured band and all measured coordinates stacked into one vector:

* ``frac`` — FRAC (docs/methods.md §7) of measured and modelled receptances; ``gap = 1 − FRAC``;
* ``frf_error`` — normalised FRF error ``‖H_model − H_measured‖ / ‖H_measured‖``;
* resonance shift — peak frequency of the model minus that of the measurement (%), on the
  reference coordinate (the driving point if it is measured);
* ``peak_ratio`` — peak |H| of the model over the measured one.

Every measured point counts: where the model has no solution (no stable branch reaches the
frequency, or the solver fails there) its receptance counts as zero, so FRAC and FRF error
include the whole measured energy there; ``unsolved_points`` says how many points of the
level that is and ``unsolved_hz`` their frequency range. ``other_branch_points`` counts
the points where the model's solution nearest the measurement is not the one a stepped
sweep in the stated direction would reach (see :mod:`nlupdate.core.discovery.simulation`).

The discovery's headline figure is the mean gap over the force levels. With measurement
noise of relative std σ (docs/methods.md §8) a perfect model has ``gap ≈ σ²``. A linear model
error gives a gap that does not depend on the force level; a missing nonlinearity gives a
gap, a resonance shift or a peak ratio that changes with it: :attr:`GapReport.trends` are
the least-squares slopes of each figure per decade of force.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from numpy.typing import ArrayLike

from nlupdate.core.correlation.metrics import frac, peak


@dataclass(frozen=True)
class LevelGap:
    """Gap figures at one force level (see module docstring); frequencies in Hz."""

    force_n: float
    frac: float
    gap: float
    frf_error: float
    resonance_measured_hz: float
    resonance_model_hz: float
    resonance_shift_percent: float
    peak_ratio: float
    unsolved_points: int = 0
    unsolved_hz: tuple[float, float] | None = None
    other_branch_points: int = 0
    points: int = 0


@dataclass(frozen=True)
class GapReport:
    """Gap figures of every force level (ascending force)."""

    levels: tuple[LevelGap, ...]

    @property
    def gap(self) -> float:
        """Mean over force levels of ``1 − FRAC``."""
        return float(np.mean([level.gap for level in self.levels]))

    @property
    def trends(self) -> dict[str, float]:
        """Slopes per decade of force of the gap, the resonance shift (%) and log10 peak ratio."""
        log_force = np.log10([level.force_n for level in self.levels])
        figures = {
            "gap": [level.gap for level in self.levels],
            "resonance_shift_percent": [level.resonance_shift_percent for level in self.levels],
            "log10_peak_ratio": [np.log10(max(level.peak_ratio, 1e-300)) for level in self.levels],
        }
        if np.ptp(log_force) == 0:
            return {f"{name}_per_decade": 0.0 for name in figures}
        return {f"{name}_per_decade": float(np.polyfit(log_force, values, 1)[0]) for name, values in figures.items()}

    def to_dict(self) -> dict:
        return {"gap": self.gap, "levels": [asdict(level) for level in self.levels], "trends": self.trends}


def level_gap(
    force_n: float, frequency_hz: ArrayLike, h_measured: ArrayLike, h_model: ArrayLike, reference: int,
    other_branch: ArrayLike | None = None,
) -> LevelGap:
    """Gap figures of one level: frequencies (n,) ascending in Hz, receptances (n, m) in m/N
    (NaN where the model has no solution: counted as zero); ``reference`` is the column used
    for the resonance and peak figures; ``other_branch`` (n,) marks points on another branch
    than the stated sweep."""
    f = np.asarray(frequency_hz, dtype=float)
    measured = np.asarray(h_measured, dtype=complex)
    model = np.asarray(h_model, dtype=complex)
    unsolved = ~np.all(np.isfinite(model), axis=1)
    filled = np.where(np.isfinite(model), model, 0.0)
    value = frac(measured, filled)
    error = np.linalg.norm(filled - measured) / np.linalg.norm(measured)
    f_measured, a_measured = peak(f, measured[:, reference])
    if unsolved.all():
        f_model, a_model = float("nan"), 0.0
    else:
        f_model, a_model = peak(f, model[:, reference])
    return LevelGap(
        force_n=float(force_n),
        frac=value,
        gap=1.0 - value,
        frf_error=float(error),
        resonance_measured_hz=f_measured,
        resonance_model_hz=f_model,
        resonance_shift_percent=100.0 * (f_model - f_measured) / f_measured,
        peak_ratio=a_model / a_measured,
        unsolved_points=int(unsolved.sum()),
        unsolved_hz=(float(f[unsolved].min()), float(f[unsolved].max())) if unsolved.any() else None,
        other_branch_points=int(np.sum(other_branch)) if other_branch is not None else 0,
        points=int(f.size),
    )
