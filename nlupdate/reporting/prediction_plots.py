"""FRF plots people look at instead of reading tables (PNG, see :mod:`nlupdate.reporting.figures`)."""
from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from nlupdate.reporting.figures import frf_curve, level_colours, save_figure


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


def plot_predictions(
    measured: pd.DataFrame, predictions: Sequence, response_dof: str, input_dof: str, path: Path, title: str = "",
    styles: Sequence[dict] | None = None, other_measured: tuple[str, pd.DataFrame] | None = None,
) -> Path:
    """|H| per force level: measured points and each predicted model (by default the first,
    usually ``initial``, dashed grey); panel titles give each model's FRAC at that level.
    ``other_measured``: (label, table) of a second measurement drawn in grey."""
    levels = sorted({float(level) for p in predictions for level in p.table["force_level_n"]})
    columns = min(5, len(levels))
    rows = -(-len(levels) // columns)
    fig = Figure(figsize=(3.2 * columns, 2.7 * rows + 0.6))
    axes = np.atleast_1d(fig.subplots(rows, columns, sharex=True, squeeze=False)).ravel()
    if styles is None:
        styles = [dict(color="0.45", ls="--", lw=1.0)] + [dict(color=f"C{k + 3}", lw=1.3) for k in range(len(predictions))]
    for ax, level in zip(axes, levels):
        f_m, h_m = frf_curve(measured, response_dof, input_dof, level)
        ax.semilogy(f_m, np.abs(h_m), ".", ms=1.5, color="k", label="measured")
        if other_measured is not None:
            f_o, h_o = frf_curve(other_measured[1], response_dof, input_dof, level)
            ax.semilogy(f_o, np.abs(h_o), "x", ms=2, color="0.6", label=other_measured[0])
        fracs = []
        for prediction, style in zip(predictions, styles):
            f_p, h_p = frf_curve(prediction.table, response_dof, input_dof, level)
            ax.semilogy(f_p, np.abs(h_p), label=prediction.name, **style)
            row = prediction.correlation[np.isclose(prediction.correlation["force_level_n"], level)]
            fracs.append(f"{row['frac'].iloc[0]:.2f}" if len(row) else "–")
        ax.set_title(f"{level:g} N   FRAC " + " / ".join(fracs), fontsize=8)
        ax.grid(True, which="both", alpha=0.3)
        ax.tick_params(labelsize=7)
    for ax in axes[len(levels):]:
        ax.axis("off")
    axes[0].legend(fontsize=6)
    fig.supxlabel("frequency (Hz)", fontsize=9)
    fig.supylabel(f"|H| {response_dof}/{input_dof} (m/N)", fontsize=9)
    fig.suptitle(title or "predicted vs measured at every force level", fontsize=10)
    fig.tight_layout()
    return save_figure(fig, path, dpi=110)


def plot_correlation_levels(correlation: pd.DataFrame, path: Path) -> Path:
    """FRAC and the normalised FRF error against force level, one line per model."""
    fig = Figure(figsize=(10, 3.8))
    left, right = fig.subplots(1, 2)
    for model, group in correlation.groupby("model", sort=False):
        group = group.sort_values("force_level_n")
        left.semilogx(group["force_level_n"], group["frac"], "o-", ms=3, label=model)
        right.loglog(group["force_level_n"], group["normalised_error"], "o-", ms=3, label=model)
    left.set(xlabel="force level (N)", ylabel="FRAC", ylim=(0, 1.02), title="FRAC per force level")
    right.set(xlabel="force level (N)", ylabel="‖H_model − H_measured‖ / ‖H_measured‖", title="normalised FRF error")
    for ax in (left, right):
        ax.grid(True, which="both", alpha=0.3)
    left.legend(fontsize=7)
    fig.tight_layout()
    return save_figure(fig, path)
