"""FRF plots people look at instead of reading tables (PNG, see :mod:`nlupdate.reporting.figures`)."""
from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from nlupdate.reporting.figures import level_colours, save_figure
from nlupdate.response.continuation import FrequencyResponse


def plot_frf_levels(table: pd.DataFrame, response_dof: str, input_dof: str, path: Path, title: str = "") -> Path:
    """|H| (m/N, log scale) against frequency for every force level of a measured-FRF table."""
    fig = Figure(figsize=(7, 4.5))
    ax = fig.subplots()
    subset = table[(table["response_dof"] == response_dof) & (table["input_dof"] == input_dof)]
    levels = np.sort(subset["force_level_n"].unique())
    colours = level_colours(levels.size)
    for level, colour in zip(levels, colours):
        curve = subset[subset["force_level_n"] == level].sort_values("frequency_hz")
        magnitude = np.hypot(curve["h_real"], curve["h_imag"])
        ax.semilogy(curve["frequency_hz"], magnitude, ".", ms=2, color=colour, label=f"{level:g} N")
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel(f"|H| {response_dof}/{input_dof} (m/N)")
    ax.set_title(title or "measured receptance at each force level")
    ax.legend(fontsize=7, ncol=2)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    return save_figure(fig, path)


def plot_continuation(curves: Sequence[tuple[str, FrequencyResponse]], dof_position: int, path: Path) -> Path:
    """Traced amplitude curves: stable solid, unstable dashed, folds marked."""
    fig = Figure(figsize=(7, 4.5))
    ax = fig.subplots()
    for label, curve in curves:
        amplitude = np.abs(curve.x_nonlinear[:, dof_position])
        frequency = curve.frequency_hz
        stable = curve.stable.copy()
        (line,) = ax.semilogy(frequency, np.where(stable, amplitude, np.nan), "-", lw=1.2, label=label)
        ax.plot(frequency, np.where(~stable | curve.turning_point, amplitude, np.nan), "--", lw=1.0, color=line.get_color())
        ax.plot(frequency[curve.turning_point], amplitude[curve.turning_point], "o", ms=4, color=line.get_color())
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("amplitude (m)")
    ax.set_title("continuation: stable (solid), unstable (dashed), folds (dots)")
    ax.legend(fontsize=7)
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    return save_figure(fig, path)
