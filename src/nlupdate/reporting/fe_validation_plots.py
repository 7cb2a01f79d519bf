"""The ``[fe_validation]`` figure: every forced run's measured resonance, damping
ratio and peak |H| beside the initial and the updated FE model's predictions, the test's own
repeatability drawn around the measured points. Renders the step's table; computes nothing."""
from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

_MODELS = {"initial": ("tab:orange", "s"), "updated": ("tab:blue", "o")}


def _run_label(control: str, level: float) -> str:
    return f"F {level:.3g} N" if control == "force" else f"R {1e6 * level:.0f} µm"


def fe_validation_figure(found) -> Figure:
    """Three panels over the runs (force-controlled by level in N, then response-controlled by
    held amplitude in µm): resonance (Hz), damping ratio (%) and peak |H| (m/N), measured in
    black with ±1σ of the test's repeatability, each model's prediction in its colour."""
    table = found.table
    runs = table.drop_duplicates("run")[["run", "control", "level", "resonance_hz_measured",
                                         "damping_ratio_measured", "peak_measured"]]
    x = np.arange(len(runs), dtype=float)
    position = dict(zip(runs.run, x))
    repeat = found.repeatability
    figure = Figure(figsize=(11, 4.2), layout="constrained")
    axes = figure.subplots(1, 3)
    panels = (("resonance_hz", "resonance (Hz)", 1.0, repeat.resonance_hz, False),
              ("damping_ratio", "damping ratio (%)", 100.0, repeat.damping_ratio, False),
              ("peak", "peak |H| (m/N)", 1.0, float("nan"), True))
    for ax, (name, label, scale, sigma, log) in zip(axes, panels):
        measured = scale * runs[f"{name}_measured"].to_numpy(float)
        if np.isfinite(sigma):
            ax.errorbar(x, measured, yerr=scale * sigma, fmt="none", ecolor="0.6", capsize=3,
                        label="test repeatability ±1σ")
        ax.plot(x, measured, "k*", ms=9, label="measured")
        for model, rows in table.groupby("model", sort=False):
            colour, marker = _MODELS.get(str(model), ("tab:green", "^"))
            ax.plot([position[r] for r in rows.run], scale * rows[f"{name}_predicted"].to_numpy(float), marker,
                    color=colour, mfc="none", ms=7, label=f"{model} model")
        split = (runs.control == "force").sum() - 0.5
        ax.axvline(split, color="0.8", lw=1)
        ax.set_xticks(x, [_run_label(c, v) for c, v in zip(runs.control, runs.level)], rotation=60, fontsize=7)
        ax.set_ylabel(label)
        if log:
            ax.set_yscale("log")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7)
    figure.suptitle("FE model against every forced run (F: force-controlled, R: response-controlled)", fontsize=10)
    return figure
