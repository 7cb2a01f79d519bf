"""The figure of ``nlupdate validate --hold-out-type``: the held-out test type measured
against what the model fitted on the other types predicts."""
from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import NullFormatter

from nlupdate.reporting.figures import EXTRAPOLATION_FILL

from nlupdate.core.validation.held_type import HeldType


def held_type_figure(result: HeldType, unit: str = "N") -> Figure:
    """Two panels, natural frequency (or resonance) and damping ratio: for held-out samples
    against modal amplitude (measured marks, the model's curve, grey beyond the fitted sources'
    amplitudes, the prediction's bootstrap band where there is one); for held-out stepped-sine
    levels against force level (measured and predicted, the repeatability band about the
    prediction, a tick at each level). One legend below the panels, off the data."""
    fig = Figure(figsize=(10, 4.8), layout="constrained")
    axes = fig.subplots(1, 2)
    fitted = ", ".join(sorted({kind for _, kind, _ in result.fitted_on}))
    if len(result.levels):
        rows = result.levels
        for ax, name, scale, label in ((axes[0], "resonance_hz", 1.0, "resonance (Hz)"),
                                       (axes[1], "damping_ratio", 100.0, "damping ratio (%)")):
            x = rows["level"].to_numpy()
            if f"{name}_low" in rows:
                ax.fill_between(x, scale * rows[f"{name}_low"], scale * rows[f"{name}_high"], color="0.85",
                                label="95 % band of the prediction (the test's repeatability)")
            ax.semilogx(x, scale * rows[f"{name}_measured"], "o", mfc="none", label="measured (held out)")
            ax.semilogx(x, scale * rows[f"{name}_predicted"], "x-", label=f"predicted from {fitted}")
            ax.set_xticks(x, [f"{v:g}" for v in x])  # a log axis over one decade shows no labelled tick else
            ax.set_xlabel(f"force level ({unit})")
            ax.set_ylabel(label)
    else:
        rows = result.samples
        a = rows["modal_amplitude"].to_numpy()
        grid = np.geomspace(min(a.min(), result.fitted_range[0]) / 1.5, max(a.max(), result.fitted_range[1]) * 1.5,
                            200)  # no sample on the axis' edge
        for ax, measured, curve, scale, label in (
                (axes[0], "natural_frequency_hz", result.model.frequency_hz(grid), 1.0, "natural frequency (Hz)"),
                (axes[1], "damping_ratio", result.model.damping(grid), 100.0, "damping ratio (%)")):
            low, high = result.fitted_range  # grey where the model has no fitted sample (the figures' convention)
            outside = [span for span in ((grid[0], low), (high, grid[-1])) if span[1] > span[0]]
            for k, span in enumerate(outside):
                ax.axvspan(*span, **EXTRAPOLATION_FILL,
                           label="beyond the fitted types' amplitudes (extrapolated)" if k == 0 else None)
            ax.semilogx(a, scale * rows[measured], "o", ms=4, mfc="none", label=f"{result.test_type} (held out)")
            ax.semilogx(grid, scale * curve, "-", color="black", label=f"predicted from {fitted}")
            column = "predicted_frequency_hz" if measured == "natural_frequency_hz" else "predicted_damping_ratio"
            if result.test_type == "impact":  # one point each: bars, the measured pole's and the prediction's
                _impact_bars(ax, rows, measured, column, scale)
            elif f"{column}_low" in rows and np.isfinite(rows[f"{column}_low"]).any():  # no legend for an empty band
                order = np.argsort(a)
                ax.fill_between(a[order], scale * rows[f"{column}_low"].to_numpy()[order],
                                scale * rows[f"{column}_high"].to_numpy()[order], color="tab:orange", alpha=0.3,
                                label="95 % band (fit bootstrap ⊕ test scatter)")
            ax.set_xlim(grid[0], grid[-1])  # the grey spans reach the axis' edges: no white margin reads as fitted
            ax.set_xlabel("modal amplitude (m·√kg)")
            ax.set_ylabel(label)
    for ax in axes:
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.grid(True, which="both", alpha=0.3)
    fig.legend(*axes[0].get_legend_handles_labels(), loc="outside lower center", ncols=2, fontsize=8, frameon=False)
    fig.suptitle(f"{result.test_type} held out, predicted by the {result.model.backbone} model of {fitted}",
                 fontsize=10)
    return fig


def _impact_bars(ax, rows, measured: str, column: str, scale: float) -> None:
    """Held impacts at their modal amplitudes: the measured value's 95 % band (± 1.96 standard
    errors of the pole) and, just right of it, the prediction (the model's linear limit where
    it is read at a = 0) with its band, where there is one."""
    a = rows["modal_amplitude"].to_numpy()
    for name, shift, marker, colour, label in (
            (measured, 1.0, "_", "C0", "impact's own 95 % band"),
            (column, 1.1, "x", "C3", "predicted (below the fitted amplitudes: the linear limit, a = 0), 95 % band")):
        value = rows[name].to_numpy()
        low, high = ((rows[f"{name}_{side}"].to_numpy() if f"{name}_{side}" in rows else value)
                     for side in ("low", "high"))
        ax.errorbar(a * shift, scale * value, yerr=scale * np.nan_to_num(np.vstack([value - low, high - value])),
                    fmt=marker, color=colour, capsize=4, label=label)
