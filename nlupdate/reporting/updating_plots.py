"""PNG plots of updating runs (files written atomically).

Figures are built with :class:`matplotlib.figure.Figure` and rendered by the Agg
canvas, without pyplot, so importing this module never changes the global backend.
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Mapping

import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator
from numpy.typing import ArrayLike

from nlupdate.reporting.figures import save_figure


def plot_convergence(history: pd.DataFrame, path: str | os.PathLike, run_column: str = "run") -> Path:
    """Parameters (relative to their start) and the largest |frequency error| (%) per
    iteration (objective call for optimisation runs), one colour per run
    (``run_column``) and one line style per parameter."""
    figure = Figure(figsize=(11, 4.2))
    left, right = figure.subplots(1, 2)
    parameter_columns = [c for c in history.columns if c.startswith("p:")]
    styles = ["-", "--", ":", "-."]
    markers = ["o", "s", "^", "v", "D"]
    for k, (run, group) in enumerate(history.groupby(run_column, sort=False)):
        colour = f"C{k % 10}"
        for j, column in enumerate(parameter_columns):  # colour = run, line style = parameter
            values = group[column].to_numpy(dtype=float)
            if np.isnan(values).all():
                continue
            left.plot(group["iteration"], values / values[0], color=colour, ls=styles[j % 4], marker=markers[j % 5], ms=3,
                      label=f"{run}: {column[2:]}")
        right.semilogy(group["iteration"], np.maximum(group["max_abs_error_pct"].to_numpy(dtype=float), 1e-12),
                       color=colour, marker="o", ms=3, label=str(run))
    left.set(xlabel="iteration", ylabel="parameter / start value", title="parameters")
    right.set(xlabel="iteration", ylabel="max |frequency error| (%)", title="paired natural frequencies")
    for axis in (left, right):
        axis.xaxis.set_major_locator(MaxNLocator(integer=True))
        axis.grid(True, alpha=0.3)
        axis.legend(fontsize=7)
    figure.tight_layout()
    return save_figure(figure, path)


def plot_frequency_errors(comparison: pd.DataFrame, path: str | os.PathLike) -> Path:
    """Grouped bars of the frequency error (%) per mode, one bar per candidate."""
    modes = list(dict.fromkeys(comparison["mode"]))
    candidates = list(dict.fromkeys(comparison["candidate"]))
    width = 0.8 / len(candidates)
    figure = Figure(figsize=(max(6, 1.6 * len(modes) + 0.4 * len(candidates)), 4.2))
    axis = figure.subplots()
    for k, name in enumerate(candidates):
        rows = comparison[comparison["candidate"] == name].set_index("mode").loc[modes]
        axis.bar(np.arange(len(modes)) + (k - (len(candidates) - 1) / 2) * width, rows["error_pct"], width, label=name)
    axis.axhline(0, color="k", lw=0.8)
    axis.set_xticks(np.arange(len(modes)), modes)
    axis.set(ylabel="frequency error (%)", title="candidate models vs targets")
    axis.grid(True, axis="y", alpha=0.3)
    axis.legend(fontsize=7)
    figure.tight_layout()
    return save_figure(figure, path)


def plot_frf_comparison(
    frequency_hz: ArrayLike,
    reference: ArrayLike,
    curves: Mapping[str, ArrayLike],
    path: str | os.PathLike,
    title: str = "",
) -> Path:
    """|H| (log scale) of the reference (extracted linear FRF) and the model curves."""
    f = np.asarray(frequency_hz, dtype=float)
    figure = Figure(figsize=(8, 4.5))
    axis = figure.subplots()
    axis.semilogy(f, np.abs(np.asarray(reference)), "k.", ms=3, label="extracted linear FRF")
    for name, h in curves.items():
        axis.semilogy(f, np.abs(np.asarray(h)), lw=1.2, label=name)
    axis.set(xlabel="frequency (Hz)", ylabel="|receptance| (m/N)", title=title)
    axis.grid(True, which="both", alpha=0.3)
    axis.legend(fontsize=7)
    figure.tight_layout()
    return save_figure(figure, path)
