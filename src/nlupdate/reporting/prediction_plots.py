"""FRF plots people look at instead of reading tables: the measured levels, the predictions
against them level by level, and the correlation per level (Figures, see
:mod:`nlupdate.reporting.figures`)."""
from __future__ import annotations

from typing import Sequence

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from nlupdate.core.correlation.levels import SHAPE_POINTS
from nlupdate.core.measurement.units import table_reference_unit
from nlupdate.reporting.figures import (INITIAL_STYLE, MEASURED_STYLE, frf_curve, grid_in_inches, level_colours,
                                        unwrapped_phase_deg)

#: Styles of the predicted models after the initial one.
PREDICTION_COLOURS = ("C3", "C0", "C2", "C4", "C1", "C5")
#: Consecutive force levels further apart than this ratio are not joined by a line.
LEVEL_GAP_RATIO = 3.0


def measured_frfs_figure(table: pd.DataFrame, response_dof: str, input_dof: str, title: str = "") -> Figure:
    """|H| (m/N, or m/V per volt: the table's reference unit; log scale) against frequency for
    every level of a measured-FRF table."""
    unit = table_reference_unit(table)
    figure = Figure(figsize=(7, 4.5))
    # a fixed layout (inches; constrained layout would measure every tick label twice)
    ax = figure.subplots(gridspec_kw=grid_in_inches(figure, 1, 1, left=0.95, right=0.15, top=0.4, bottom=0.55))
    subset = table[(table["response_dof"] == response_dof) & (table["input_dof"] == input_dof)]
    levels = np.sort(subset["force_level_n"].unique())
    for level, colour in zip(levels, level_colours(levels.size)):
        curve = subset[subset["force_level_n"] == level].sort_values("frequency_hz")
        magnitude = np.hypot(curve["h_real"], curve["h_imag"])
        ax.semilogy(curve["frequency_hz"], magnitude, ".", ms=2, color=colour, label=f"{level:g} {unit}")
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel(f"|H| {response_dof}/{input_dof} (m/{unit})")
    ax.set_title(title or "measured receptance at each force level", y=1.0)  # log: no offset text to dodge
    ax.legend(fontsize=7, ncol=2, title="force level", title_fontsize=7)
    ax.grid(True, which="both", alpha=0.3)
    return figure


def prediction_labels(names: Sequence[str]) -> list[str]:
    """Short names for panel titles: ``initial`` stays, a single other model is
    ``updated``, several are ``updated 1``, ``updated 2``, …"""
    others = [n for n in names if n != "initial"]
    short = {n: "updated" if len(others) == 1 else f"updated {k + 1}" for k, n in enumerate(others)}
    return [short.get(n, n) for n in names]


def prediction_styles(names: Sequence[str]) -> list[dict]:
    """``initial`` grey and dashed, every other model its own colour, solid."""
    colours = iter(PREDICTION_COLOURS * (1 + len(names) // len(PREDICTION_COLOURS)))
    return [dict(INITIAL_STYLE) if n == "initial" else {"color": next(colours), "ls": "-", "lw": 1.3} for n in names]


def predictions_figure(
    measured: pd.DataFrame, predictions: Sequence, response_dof: str, input_dof: str, title: str = "",
    styles: Sequence[dict] | None = None, other_measured: tuple[str, pd.DataFrame] | None = None,
    short_names: Sequence[str] | None = None,
) -> Figure:
    """Per force level, |H| (log) and below it the unwrapped phase: measured points and
    each predicted model (``initial`` grey and dashed); each panel's title gives every
    model's FRAC at that level by its short name (default :func:`prediction_labels`).
    ``other_measured``: (label, table) of a second measurement drawn in grey."""
    names = [p.name for p in predictions]
    short_names = list(short_names or prediction_labels(names))
    styles = list(styles or prediction_styles(names))
    levels = sorted({float(level) for p in predictions for level in p.table["force_level_n"]})
    unit = table_reference_unit(measured)  # levels in N, or in V per volt
    level_rows = -(-len(levels) // 5)
    columns = -(-len(levels) // level_rows)
    separator = "; " if columns > 2 else "\n"  # two panels are too narrow for one line
    title = (f"{title or 'predicted vs measured at every force level'}\nresponse {response_dof}, input "
             f"{input_dof}{separator}FRAC = 1: the predicted FRF has the measured shape over the whole band")
    figure = Figure(figsize=(3.3 * columns, 4.4 * level_rows + 1.0))
    # a fixed layout (inches): the title's lines and a panel title above, tick labels as wide as
    # "6×10⁻⁵" and the y label left of each row, the x label and the legend below
    grid = figure.add_gridspec(level_rows, columns, **grid_in_inches(
        figure, level_rows, columns, left=0.78, right=0.12, top=0.44 + 0.18 * title.count("\n"), bottom=0.72,
        wspace=0.55, hspace=0.62))
    first = None
    for k, level in enumerate(levels):
        row, column = divmod(k, columns)
        cell = grid[row, column].subgridspec(2, 1, height_ratios=[1.5, 1], hspace=0.08)
        ax_mag = figure.add_subplot(cell[0], sharex=first)
        first = first or ax_mag
        ax_phase = figure.add_subplot(cell[1], sharex=first)
        f_m, h_m = frf_curve(measured, response_dof, input_dof, level)
        single = f_m.size < SHAPE_POINTS  # a single-frequency level: its points drawn large, on top
        marker = {**MEASURED_STYLE, "ms": 6 if single else 1.5, "zorder": 5 if single else None}
        ax_mag.semilogy(f_m, np.abs(h_m), **marker, label="measured")
        ax_phase.plot(f_m, unwrapped_phase_deg(h_m), **marker, label="measured")
        if other_measured is not None:
            f_o, h_o = frf_curve(other_measured[1], response_dof, input_dof, level)
            ax_mag.semilogy(f_o, np.abs(h_o), "x", ms=2, color="0.6", label=other_measured[0])
            ax_phase.plot(f_o, unwrapped_phase_deg(h_o), "x", ms=2, color="0.6", label=other_measured[0])
        fracs = []
        for prediction, style, short in zip(predictions, styles, short_names):
            f_p, h_p = frf_curve(prediction.table, response_dof, input_dof, level)
            ax_mag.semilogy(f_p, np.abs(h_p), label=f"{short}: {prediction.name}" if short != prediction.name
                            else prediction.name, **style)
            ax_phase.plot(f_p, unwrapped_phase_deg(h_p), label=prediction.name, **style)
            row_ = prediction.correlation[np.isclose(prediction.correlation["force_level_n"], level)]
            column_ = "normalised_error" if single else "frac"
            fracs.append(f"{short} {row_[column_].iloc[0]:.2f}" if len(row_) else f"{short} –")
        what = f"rel. error at {f_m.size} line{'s' if f_m.size > 1 else ''}: " if single else "FRAC "
        # y=1: a log axis has no offset text to dodge, so matplotlib need not measure its ticks once more
        ax_mag.set_title(f"{level:g} {unit} — {what}" + ", ".join(fracs), fontsize=7.5, y=1.0)
        for ax in (ax_mag, ax_phase):
            ax.grid(True, which="both", alpha=0.3)
            ax.tick_params(which="both", labelsize=7)
        ax_mag.tick_params(labelbottom=False)
        ax_phase.set_xlabel("frequency (Hz)", fontsize=8)
        if column == 0:
            ax_mag.set_ylabel(f"|H| (m/{unit})", fontsize=8)
            ax_phase.set_ylabel("phase (deg)", fontsize=8)
    handles, labels = first.get_legend_handles_labels()
    figure.legend(handles, labels, loc="lower center", ncol=len(labels), fontsize=8, markerscale=4)
    figure.suptitle(title, fontsize=10, y=1 - 0.06 / figure.get_figheight(), va="top")
    return figure


def _segments(levels: np.ndarray) -> list[np.ndarray]:
    """Indices of runs of force levels no further than :data:`LEVEL_GAP_RATIO` apart."""
    breaks = np.flatnonzero(levels[1:] / levels[:-1] > LEVEL_GAP_RATIO) + 1
    return np.split(np.arange(levels.size), breaks)


def correlation_figure(correlation: pd.DataFrame, unit: str = "N") -> Figure:
    """FRAC and the normalised FRF error per level (in ``unit``: N, or V per volt), one line per
    model (styled as in :func:`predictions_figure`). One column per measured level; levels more than
    :data:`LEVEL_GAP_RATIO` times apart are separated by a gap and not joined by a line."""
    levels = np.sort(correlation["force_level_n"].unique().astype(float))
    segments = _segments(levels)
    position = np.empty(levels.size)
    offset = 0.0
    for segment in segments:
        position[segment] = offset + np.arange(segment.size)
        offset += segment.size + 0.8
    where = dict(zip(levels, position))
    models = list(dict.fromkeys(correlation["model"]))
    figure = Figure(figsize=(11, 4.0))
    # a fixed layout (inches; constrained layout would measure every tick label twice)
    left, right = figure.subplots(1, 2, gridspec_kw=grid_in_inches(figure, 1, 2, left=0.75, right=0.15, top=0.4,
                                                                   bottom=0.62, wspace=1.0))
    for model, style, short in zip(models, prediction_styles(models), prediction_labels(models)):
        group = correlation[correlation["model"] == model].sort_values("force_level_n")
        x = np.array([where[float(v)] for v in group["force_level_n"]])
        label = f"{short}: {model}" if short != model else model
        for ax, column in ((left, "frac"), (right, "normalised_error")):
            y = group[column].to_numpy(dtype=float)
            xs = np.concatenate([np.append(x[np.isin(group["force_level_n"], levels[s])], np.nan) for s in segments])
            ys = np.concatenate([np.append(y[np.isin(group["force_level_n"], levels[s])], np.nan) for s in segments])
            ax.plot(xs, ys, marker="o", ms=4, label=label, **style)
    for ax in (left, right):
        ax.set_xticks(position, [f"{v:g}" for v in levels], fontsize=8)
        ax.set_xlabel(f"force level ({unit}); one column per level, a gap where levels are more than "
                      f"{LEVEL_GAP_RATIO:g}× apart", fontsize=8)
        ax.grid(True, alpha=0.3)
        for boundary in np.cumsum([s.size for s in segments])[:-1]:
            ax.axvline(position[boundary] - 0.9, color="0.6", lw=0.8, ls=(0, (2, 3)), label="_")
    left.set(ylabel="FRAC (1 = measured shape)", ylim=(0, 1.02), title="FRAC per force level")
    right.set(ylabel="‖H_model − H_measured‖ / ‖H_measured‖", title="normalised FRF error per force level")
    right.set_yscale("log")
    left.legend(fontsize=7, loc="lower right")
    return figure
