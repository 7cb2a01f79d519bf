"""The plots of a study's updating runs: convergence, frequency errors against the
targets, and the candidates' linear FRFs against the reference (Figures, see
:mod:`nlupdate.reporting.figures`; each run styled by :mod:`nlupdate.reporting.styles`)."""
from __future__ import annotations

from typing import Any, Mapping, Sequence

import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter, MaxNLocator, NullLocator

from nlupdate.reporting.figures import (BAND_LABEL, MEASURED_STYLE, band_fill, grid_in_inches, label_thin_bands,
                                        prefixed_unit)
from nlupdate.reporting.styles import bar_style

#: Fill of a target's ±1σ and ±2σ interval.
TARGET_BAND = ({"color": "tab:green", "alpha": 0.22, "lw": 0}, {"color": "tab:green", "alpha": 0.1, "lw": 0})


#: Markers of the convergence plot, one per run (a run's own marker first, if it has one).
CONVERGENCE_MARKERS = ("o", "s", "^", "v", "D", "P", "X", "<", ">", "*", "h", "p")
#: Runs whose values coincide within this fraction of a panel's span are drawn side by side.
COINCIDE_FRACTION = 0.01
#: Largest horizontal shift (iterations) between neighbours of a group of coinciding runs.
SIDE_BY_SIDE_STEP = 0.12
#: Looks of the hidden truth and of each target's σ line (green, one line style each).
TRUTH_STYLE = {"color": "k", "lw": 0.9, "ls": (0, (6, 2, 1, 2))}
SIGMA_LINE_STYLES = (":", "--", "-.", (0, (1, 4)), (0, (5, 1)), (0, (3, 1, 1, 1, 1, 1)))


def side_by_side_offsets(curves: Mapping[str, tuple[np.ndarray, np.ndarray]], log: bool = False) -> dict[str, float]:
    """Run → horizontal shift (iterations) so that runs whose curves coincide stay
    visible. Two runs coincide when at every iteration both have (at least two, or
    their only one) their values differ by less than :data:`COINCIDE_FRACTION` of the
    panel's span (of log10 values when ``log``); runs linked that way form a group,
    spread symmetrically in run order by at most :data:`SIDE_BY_SIDE_STEP` (the whole
    group within ±0.3 iteration). A run that coincides with none keeps 0."""
    def scaled(v):
        v = np.asarray(v, float)
        return np.log10(np.maximum(v, 1e-300)) if log else v
    values = np.concatenate([scaled(v) for _, v in curves.values()]) if curves else np.zeros(0)
    values = values[np.isfinite(values)]
    tolerance = COINCIDE_FRACTION * (float(np.ptp(values)) if values.size else 0.0)
    runs = list(curves)

    def coincide(a: str, b: str) -> bool:
        (xa, va), (xb, vb) = curves[a], curves[b]
        shared, ia, ib = np.intersect1d(xa, xb, return_indices=True)
        if shared.size < min(2, len(xa), len(xb)) or not shared.size:
            return False
        gap = np.abs(scaled(va)[ia] - scaled(vb)[ib])
        return bool(np.all(np.nan_to_num(gap, nan=0.0) <= tolerance))

    group_of = {run: k for k, run in enumerate(runs)}
    for i, a in enumerate(runs):
        for b in runs[i + 1:]:
            if group_of[a] != group_of[b] and coincide(a, b):
                old, new = group_of[b], group_of[a]
                group_of.update({run: new for run, g in group_of.items() if g == old})
    offsets = {}
    for g in dict.fromkeys(group_of.values()):
        group = [run for run in runs if group_of[run] == g]
        step = min(SIDE_BY_SIDE_STEP, 0.6 / len(group))
        offsets.update({run: (j - (len(group) - 1) / 2) * step for j, run in enumerate(group)})
    return offsets


def convergence_figure(history: pd.DataFrame, styles: Mapping[str, dict], parameters: Sequence[Any],
                       truth: Mapping[str, float] | None = None,
                       target_sigma_pct: Mapping[str, float] | None = None) -> Figure:
    """Each updated parameter (in its unit, one panel each) and the largest |frequency
    error| over the target modes (%) per iteration of every run (``history``: the
    runs' histories with a ``run`` column); ``parameters``: the study's parameters
    (name, unit); ``truth``: hidden values drawn as lines; ``target_sigma_pct``: each
    target's standard deviation in % of its frequency, drawn on the error panel.

    Every run has its own marker; runs that coincide in a panel are drawn side by side
    (:func:`side_by_side_offsets`), so none hides another. No text sits on the axes: the
    truth values are in the panel titles, the σ values in the legend."""
    names = [p.name for p in parameters if f"p:{p.name}" in history.columns]
    units = {p.name: p.unit for p in parameters}
    count = len(names) + 1
    columns = min(count, 3)
    rows = -(-count // columns)
    runs = list(dict.fromkeys(history["run"]))
    entries = len(runs) + bool(truth) + len(target_sigma_pct or {})  # at most, in the legend's three columns
    figure = Figure(figsize=(4.4 * columns, 3.3 * rows + 1.6))
    # a fixed layout (inches; constrained layout would measure every tick label twice): a
    # two-line y label and tick labels left of each panel, the title above, the x label
    # and the legend (its title and a row per three entries) below
    axes = np.atleast_1d(figure.subplots(rows, columns, squeeze=False, gridspec_kw=grid_in_inches(
        figure, rows, columns, left=1.05, right=0.15, top=0.62, bottom=0.85 + 0.15 * -(-entries // 3),
        wspace=1.0, hspace=0.85))).ravel()
    looks = {}
    for k, run in enumerate(runs):
        marker = styles[run].get("marker") or CONVERGENCE_MARKERS[k % len(CONVERGENCE_MARKERS)]
        looks[run] = {"ms": 4.5, "lw": 1.4, **styles[run], "marker": marker, "mfc": "none" if k % 2 else None}
    panels = [(ax, f"p:{name}", name) for ax, name in zip(axes, names)]
    panels.append((axes[len(names)], "max_abs_error_pct", None))  # the frequency error: log scale
    truth_handle = None
    for ax, column, name in panels:
        log = name is None
        scale, unit = 1.0, ""
        if name is not None:
            known = [truth[name]] if truth and name in truth else []
            scale, unit = prefixed_unit(np.concatenate([history[column].to_numpy(dtype=float), known]),
                                        units.get(name, ""))
        curves = {}
        for run in runs:
            group = history[history["run"] == run]
            v = group[column].to_numpy(dtype=float)
            if np.isnan(v).all():
                continue
            curves[run] = (group["iteration"].to_numpy(dtype=float), np.maximum(v, 1e-12) if log else v / scale)
        offsets = side_by_side_offsets(curves, log)
        for run, (x, v) in curves.items():
            ax.plot(x + offsets[run], v, label=run, **looks[run])
        if log:
            ax.set_yscale("log")
            ax.set(xlabel="iteration", ylabel="max over target modes of\n|f_model − f_target| / f_target (%)",
                   title="frequency error")
            continue
        title = f"parameter {name}"
        if known:
            truth_handle = ax.axhline(known[0] / scale, **TRUTH_STYLE, label="hidden truth")
            title += f" (hidden truth {known[0] / scale:.4g})"
        ax.set(xlabel="iteration", ylabel=f"{name} ({unit})" if unit else name, title=title)
    error_ax = axes[len(names)]
    sigma_handles = []
    for k, (label, sigma) in enumerate((target_sigma_pct or {}).items()):
        if np.isfinite(sigma) and sigma > 0:
            sigma_handles.append(error_ax.axhline(sigma, color="tab:green", lw=1.0,
                                                  ls=SIGMA_LINE_STYLES[k % len(SIGMA_LINE_STYLES)],
                                                  label=f"σ of target {label}: {sigma:.2g} %"))
    for ax in axes[:count]:
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
        ax.grid(True, which="both", alpha=0.3)
    for ax in axes[count:]:
        ax.axis("off")
    drawn = {line.get_label(): line for ax in axes[:count][::-1] for line in ax.get_lines()}
    handles = [drawn[run] for run in runs if run in drawn]
    handles += ([truth_handle] if truth_handle is not None else []) + sigma_handles
    figure.legend(handles, [h.get_label() for h in handles], loc="lower center", ncol=min(3, len(handles)),
                  fontsize=7, title="run (colour: parameter set or candidate; line style: difference formula); runs "
                  "that coincide are drawn side by side, within ±0.3 iteration", title_fontsize=7)
    figure.suptitle("convergence of every updating run", fontsize=10, y=1 - 0.06 / figure.get_figheight(), va="top")
    return figure


def frequency_errors_figure(comparison: pd.DataFrame, styles: Mapping[str, dict],
                            target_sigma_pct: Mapping[str, float] | None = None) -> Figure:
    """Per target mode (one panel each) the frequency error (%) of every candidate, one
    labelled row each, against the target's ±1σ and ±2σ interval (``target_sigma_pct``:
    standard deviation in % of the target frequency)."""
    modes = list(dict.fromkeys(comparison["mode"]))
    candidates = list(dict.fromkeys(comparison["candidate"]))
    figure = Figure(figsize=(3.2 + 3.6 * len(modes), 1.2 + 0.3 * len(candidates)), layout="constrained")
    axes = np.atleast_1d(figure.subplots(1, len(modes), sharey=True, squeeze=False)).ravel()
    rows = np.arange(len(candidates))[::-1]
    for ax, mode in zip(axes, modes):
        table = comparison[comparison["mode"] == mode].set_index("candidate").loc[candidates]
        errors = table["error_pct"].to_numpy(dtype=float)
        sigma = (target_sigma_pct or {}).get(mode, float("nan"))
        if np.isfinite(sigma) and sigma > 0:
            ax.axvspan(-2 * sigma, 2 * sigma, **TARGET_BAND[1], label="target ±2σ")
            ax.axvspan(-sigma, sigma, **TARGET_BAND[0], label="target ±1σ")
        for row, name, error in zip(rows, candidates, errors):
            ax.barh(row, error, 0.7, label=name, **bar_style(styles[name]))
        sizes = np.abs(np.concatenate([errors, [2 * sigma if np.isfinite(sigma) else 0.0]]))
        reach = float(np.nanmax(sizes)) if np.isfinite(sizes).any() and np.nanmax(sizes) > 0 else 1.0
        threshold = sigma if np.isfinite(sigma) and sigma > 0 else 1e-2 * reach
        if reach > 30 * threshold:  # errors from ≪σ to ≫σ: linear within ±σ, logarithmic beyond
            ax.set_xscale("symlog", linthresh=threshold, linscale=0.6)
            ax.set_xlim(-reach * 8, reach * 8)
            decades = 10.0 ** np.arange(np.ceil(np.log10(3 * threshold)), np.floor(np.log10(reach * 8)) + 1)
            ax.set_xticks(np.concatenate([-decades[::-1], [0.0], decades]))
            ax.xaxis.set_major_formatter(FuncFormatter(lambda value, _: f"{value:g}"))
            ax.xaxis.set_minor_locator(NullLocator())
            ax.set_xlabel(f"frequency error (%), log scale beyond ±{threshold:.2g} %")
        else:
            ax.set_xlim(-1.45 * reach, 1.45 * reach)
            ax.set_xlabel("frequency error (%)")
        for row, error in zip(rows, errors):
            if np.isfinite(error):
                ax.annotate(f"{error:+.2g} %", (error, row), xytext=(3 if error >= 0 else -3, 0),
                            textcoords="offset points", ha="left" if error >= 0 else "right", va="center", fontsize=6.5)
        ax.axvline(0, color="k", lw=0.8)
        target = table["target_hz"].iloc[0]
        title = f"{mode}: target {target:.5g} Hz"
        if np.isfinite(sigma):
            title += f" (σ {sigma:.2g} %)"
        ax.set_title(title, fontsize=9)
        ax.grid(True, axis="x", alpha=0.3)
    axes[0].set_yticks(rows, candidates, fontsize=7)
    if any(np.isfinite((target_sigma_pct or {}).get(m, float("nan"))) for m in modes):
        handles, labels = axes[0].get_legend_handles_labels()
        keep = [i for i, label in enumerate(labels) if label.startswith("target")]
        axes[0].legend([handles[i] for i in keep], [labels[i] for i in keep], fontsize=7, loc="lower left")
    figure.suptitle("natural frequency of each candidate model against the targets", fontsize=10)
    return figure


def candidate_frfs_figure(frfs: Any, styles: Mapping[str, dict], title: str = "",
                          reference_label: str = "extracted linear FRF") -> Figure:
    """|H| (log, m/N) of the reference linear FRF (``reference_label``; with its 95 % band
    when it has one) and of every candidate model
    (:class:`~nlupdate.study.steps.updating.CandidateFRFs`), with what modal truncation does to the
    models' curves said on the plot."""
    f = np.asarray(frfs.frequency_hz, dtype=float)
    figure = Figure(figsize=(12, 5.4))
    # a fixed layout (inches; constrained layout would measure every tick label twice)
    ax, side = figure.subplots(1, 2, width_ratios=[2.6, 1], gridspec_kw=grid_in_inches(
        figure, 1, 2, left=0.95, right=0.1, top=0.4, bottom=0.6, wspace=0.3))
    side.axis("off")
    band = frfs.reference_band
    if band is not None:
        # over the candidates' curves (it veils them lightly), under the reference's points
        band_fill(ax, f, *band.magnitude, f"its {BAND_LABEL}", np.abs(np.asarray(frfs.reference)), covered_by=2.5,
                  color="0.3", alpha=0.2, zorder=2.5)
    ax.semilogy(f, np.abs(np.asarray(frfs.reference)), **{**MEASURED_STYLE, "ms": 2.5}, label=reference_label,
                zorder=3)
    for name, h in frfs.curves.items():
        ax.semilogy(f, np.abs(np.asarray(h)), label=name, **{"lw": 1.2, **styles[name], "marker": ""})
    ax.set(xlabel="frequency (Hz)", ylabel=f"|H| {frfs.response_dof}/{frfs.input_dof} (m/N)")
    ax.set_title(title, y=1.0)  # a log axis has no offset text to dodge: no second measuring of its ticks
    ax.grid(True, which="both", alpha=0.3)
    label_thin_bands(figure)
    side.legend(*ax.get_legend_handles_labels(), fontsize=7, loc="upper left", borderaxespad=0)
    side.text(0.0, 0.0, truncation_note(frfs), fontsize=7.5, ha="left", va="bottom", transform=side.transAxes,
              bbox={"boxstyle": "round", "facecolor": "lightyellow", "edgecolor": "0.6"})
    return figure


def truncation_note(frfs: Any) -> str:
    """What a reader must know about the candidates' FRFs: modal superposition of the
    computed modes, without residual terms."""
    note = (f"Model curves: modal superposition of the {frfs.modes}\nmodes each model computed, no residual terms.\n"
            f"Higher modes of the model are left out\n(modal truncation)")
    if frfs.response_dof == frfs.input_dof:
        note += (": at this driving point they\nwould add flexibility below their resonances,\nso without them "
                 "anti-resonances sit too high\nand |H| above the last computed mode\nis too large.")
    else:
        note += ":\nanti-resonances and the level away\nfrom the modes are off."
    return note + "\nNot an updating error: the updating\nmatches natural frequencies only."
