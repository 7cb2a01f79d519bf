"""Per-force-level correlation of a predicted FRF table with a measured one (docs/methods.md §7).

For every force level of one (response, input) curve, on the frequencies both tables
hold: FRAC, the normalised FRF error ``‖H_p − H_m‖ / ‖H_m‖`` (0 = identical), and the
peak of |H|: predicted minus measured frequency (%) and the predicted/measured amplitude
ratio (a level of fewer than three lines: the normalised error alone). A linear model error shows up at every level alike; a missing or wrong
nonlinearity grows with force.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from nlupdate.core.correlation.metrics import frac, peak_errors
from nlupdate.core.measurement.frf_table import force_levels, select_frf

#: FRAC and the peak need a curve: a level measured at fewer lines (a single-frequency
#: PRD level, docs/measured-data.md) gets the normalised error alone, the others NaN.
SHAPE_POINTS = 3

COLUMNS = ["force_level_n", "frac", "normalised_error", "peak_frequency_error_pct", "peak_amplitude_ratio", "points"]


def correlate_levels(measured: pd.DataFrame, predicted: pd.DataFrame, response_dof: str, input_dof: str) -> pd.DataFrame:
    """One row per force level of the measured curve (columns :data:`COLUMNS`)."""
    rows = []
    for level in force_levels(measured[(measured["response_dof"] == response_dof) & (measured["input_dof"] == input_dof)]):
        f_m, h_m = select_frf(measured, response_dof, input_dof, level)
        f_p, h_p = select_frf(predicted, response_dof, input_dof, level)
        common, index_m, index_p = np.intersect1d(np.round(f_m, 9), np.round(f_p, 9), return_indices=True)
        if common.size == 0:
            raise ValueError(f"level {level:g} N: the prediction shares no frequency with the measurement")
        hm, hp = h_m[index_m], h_p[index_p]
        row = {"force_level_n": float(level), "frac": np.nan,
               "normalised_error": float(np.linalg.norm(hp - hm) / np.linalg.norm(hm)),
               "peak_frequency_error_pct": np.nan, "peak_amplitude_ratio": np.nan, "points": int(common.size)}
        if common.size >= SHAPE_POINTS:
            errors = peak_errors(common, hm, hp)
            row.update(frac=frac(hm, hp), peak_frequency_error_pct=errors.frequency_error_percent,
                       peak_amplitude_ratio=errors.model_amplitude / errors.reference_amplitude)
        rows.append(row)
    return pd.DataFrame(rows, columns=COLUMNS)


@dataclass(frozen=True)
class LevelSummary:
    """A correlation over the levels at a glance: FRAC's smallest and mean value over the
    ``frac_levels`` levels that have one, and the ``single_levels`` levels measured at too few
    lines for a FRAC (single-frequency) with their largest normalised FRF error (NaN without)."""

    frac_min: float
    frac_mean: float
    frac_levels: int
    single_levels: int
    single_error_max: float


def summarise_levels(correlation: pd.DataFrame) -> LevelSummary:
    """:class:`LevelSummary` of :func:`correlate_levels`' table."""
    single = correlation[correlation["frac"].isna()]
    return LevelSummary(float(correlation["frac"].min()), float(correlation["frac"].mean()),
                        int(correlation["frac"].notna().sum()), len(single),
                        float(single["normalised_error"].max()) if len(single) else float("nan"))
