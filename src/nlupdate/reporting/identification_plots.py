"""The plots of an identification (:class:`~nlupdate.core.identification.pipeline.Identification`):
the PRD/DDF points with the fitted curve, its 95 % Monte-Carlo band and each point's
misfit in noise units; the extracted linear FRF with its band and modal fit."""
from __future__ import annotations

from typing import Any

import numpy as np
from matplotlib.colors import BoundaryNorm, ListedColormap
from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter, NullFormatter
from numpy.typing import ArrayLike

from nlupdate.core.identification.methods import METHODS
from nlupdate.reporting.coverage import AMPLITUDE_GAP_RATIO, covered_intervals, describe_intervals
from nlupdate.reporting.figures import (
    BAND_LABEL, EXTRACTED_COLOUR, EXTRAPOLATION_FILL, FIT_COLOUR, FIT_WIDTH, THIN_BAND_NOTE, band_fill, grid_in_inches,
    label_thin_bands, level_colours, unwrapped_phase_deg,
)


def _level_colouring(result: Any, unit: str):
    """(colour values, colour map, norm, levels) for the points: one viridis colour per
    high force level (PRD); None when the points carry no level (DDF: one level)."""
    levels_of_points = getattr(result, "point_force_n", None)
    if levels_of_points is None or len(levels_of_points) != len(result.amplitude):
        return None
    levels = np.unique(levels_of_points)
    colours = ListedColormap(level_colours(levels.size, 0.05, 0.9))
    edges = np.concatenate([[levels[0] - 1], (levels[1:] + levels[:-1]) / 2, [levels[-1] + 1]]) if levels.size > 1 \
        else np.array([levels[0] - 1, levels[0] + 1])
    return np.asarray(levels_of_points), colours, BoundaryNorm(edges, colours.N), levels


def _minor_label(value: float, _position=None) -> str:
    """A minor tick's label on a log axis spanning a factor 3 to 10: only 2, 3 and 5 × 10ⁿ,
    so neighbouring labels (0.8, 0.9) never run into each other."""
    mantissa = value / 10 ** np.floor(np.log10(value)) if value > 0 else 0.0
    return f"{value:g}" if np.any(np.isclose(mantissa, (2.0, 3.0, 5.0))) else ""


def fit_figure(identification: Any, title: str, poor_factor: float | None = None) -> Figure:
    """The PRD/DDF points (coloured by force level), the fitted curve with its 95 %
    Monte-Carlo band — solid over the stretches of amplitude the data cover, dashed across
    the gaps between them (consecutive points more than
    :data:`~nlupdate.reporting.coverage.AMPLITUDE_GAP_RATIO` times apart), dotted in the
    extrapolation beyond them; gaps and extrapolation shaded grey — real and imaginary
    parts against amplitude (y in N/m, or
    V/m for a voltage reference), and each point's misfit in units of its noise
    (:meth:`~nlupdate.core.identification.pipeline.Identification.misfit_in_noise_units`;
    ``poor_factor`` draws the "poor fit" line)."""
    result = identification.result
    unit = identification.reference_unit
    amplitude = np.asarray(result.amplitude)
    y = np.asarray(result.y)
    low, high = result.amplitude_range
    band = identification.fit_band
    covered = covered_intervals(amplitude)
    edges = [x for interval in covered for x in interval]
    grid = np.union1d(band.x if band is not None else np.linspace(low, high, 200), edges)
    curve = result.fitted_y(grid)
    gaps = list(zip([b for _, b in covered[:-1]], [a for a, _ in covered[1:]]))
    solid = np.any([(grid >= a) & (grid <= b) for a, b in covered], axis=0)
    dashed = np.any([(grid >= a) & (grid <= b) for a, b in gaps], axis=0) if gaps else np.zeros(grid.shape, bool)
    dotted = (grid <= low) | (grid >= high)
    colouring = _level_colouring(result, unit)
    point_style = dict(s=7, alpha=0.75, lw=0)
    if colouring is not None:
        point_style.update(c=colouring[0], cmap=colouring[1], norm=colouring[2])
    else:
        point_style.update(color="C0")
    figure = Figure(figsize=(15, 4.6))
    # a fixed layout (inches; constrained layout would measure every tick label twice): tick
    # labels as wide as "−300000" and the y label left of each panel, the two title lines
    # above, the x label and the legend (one row: at most six entries) below, the colour bar's labels right
    axes = figure.subplots(1, 3, gridspec_kw=grid_in_inches(figure, 1, 3, left=1.0, right=0.75 if colouring else 0.15,
                                                             top=0.62, bottom=0.88, wspace=1.05))
    for ax, part, band_part, name in ((axes[0], np.real, "real", "Re"), (axes[1], np.imag, "imag", "Im")):
        empty = [(grid[0], low)] if grid[0] < low else []
        empty += gaps + ([(high, grid[-1])] if grid[-1] > high else [])
        for k, (a, b) in enumerate(empty):
            ax.axvspan(a * 1e3, b * 1e3, **EXTRAPOLATION_FILL, label="_" if k else "no data")
        if band is not None:
            band_fill(ax, band.x * 1e3, *getattr(band, band_part), f"{BAND_LABEL} ({band.n_samples} fits)",
                      part(result.fitted_y(band.x)), judged_over=[(a * 1e3, b * 1e3) for a, b in covered],
                      color=FIT_COLOUR, alpha=0.25)
        ax.scatter(amplitude * 1e3, part(y), **point_style, label="data (colour: force level)" if colouring else "data")
        ax.plot(grid * 1e3, np.where(solid, part(curve), np.nan), "-", color=FIT_COLOUR, lw=FIT_WIDTH,
                label="fit where the data lie")
        if gaps:
            ax.plot(grid * 1e3, np.where(dashed, part(curve), np.nan), "--", color=FIT_COLOUR, lw=FIT_WIDTH,
                    label="fit across a gap in the data")
        if dotted.any() and (grid[0] < low or grid[-1] > high):
            ax.plot(grid * 1e3, np.where(dotted, part(curve), np.nan), ":", color=FIT_COLOUR, lw=FIT_WIDTH,
                    label="fit, extrapolated")
        ax.set_xlabel("response amplitude |X| (mm)")
        ax.set_ylabel(f"{name} y ({unit}/m)")
        if high > 30 * low:  # data over decades of amplitude: a log axis shows each decade
            ax.set_xscale("log")
            ax.set_xlim(grid[grid > 0][0] * 1e3, grid[-1] * 1e3)
            ax.set_xlabel("response amplitude |X| (mm, log scale)")
        else:
            ax.set_xlim(grid[0] * 1e3, grid[-1] * 1e3)
        ax.grid(True, alpha=0.3)
    ax = axes[2]
    ax.scatter(amplitude * 1e3, np.asarray(identification.misfit_in_noise_units()), **point_style, label="points")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.xaxis.set_major_formatter(FuncFormatter(lambda value, _: f"{value:g}"))  # mm, not 2×10⁰
    if high < 10 * low:  # less than a decade: label minor ticks too, there may be no major one
        ax.xaxis.set_minor_formatter(FuncFormatter(_minor_label if high > 3 * low else lambda value, _: f"{value:g}"))
    else:
        ax.xaxis.set_minor_formatter(NullFormatter())
    ax.axhline(1.0, color="grey", lw=1, label="noise level")
    if poor_factor is not None:
        ax.axhline(poor_factor, color="crimson", lw=1, ls="--", label=f"{poor_factor:g}× noise: poor fit")
    ax.set_xlabel("response amplitude |X| (mm)")
    ax.set_ylabel("|y − fit| / noise of y")
    ax.set_title("misfit of each point in units of its noise", fontsize=9, y=1.0)  # log: no offset text to dodge
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    if colouring is not None:
        bar = figure.colorbar(axes[2].collections[0], ax=axes[2], ticks=colouring[3], pad=0.01)
        bar.set_label(f"force level ({unit})", fontsize=8)
        bar.ax.tick_params(labelsize=7)
    label_thin_bands(figure)
    if band is not None:  # one legend for both panels: say which one a thin band is in
        fills = [[c for c in ax.collections if BAND_LABEL in c.get_label()][0] for ax in axes[:2]]
        thin = [THIN_BAND_NOTE in c.get_label() for c in fills]
        if thin[0] != thin[1]:
            part = "Re y" if thin[0] else "Im y"
            for c in fills:
                c.set_label(f"{BAND_LABEL} ({band.n_samples} fits): {THIN_BAND_NOTE} over the data in {part}")
    handles, labels = axes[0].get_legend_handles_labels()  # beside the panels: inside it would hide points
    figure.legend(handles, labels, loc="lower center", ncol=min(len(labels), 6), fontsize=7)
    method = METHODS[result.method]
    where = f"the fit is solid where the data lie ({describe_intervals(covered)})"
    if gaps:
        where += (f", dashed across the gap{'s' if len(gaps) > 1 else ''} between them (no point within a factor "
                  f"{AMPLITUDE_GAP_RATIO:g})")
    figure.suptitle(f"{title}: {method.fitted_quantity}\n{method.describe_points(result, unit)}; {where}", fontsize=9,
                    y=1 - 0.05 / figure.get_figheight(), va="top")
    return figure


def linear_frf_figure(identification: Any, measured: tuple[str, ArrayLike, ArrayLike] | None, title: str,
                      max_zooms: int = 3) -> Figure:
    """The extracted linear FRF with its 95 % Monte-Carlo band, the one-mode fits of its
    modes, and the (lowest-level) measured curve it was extracted from (``measured``: label, Hz, H):
    |H| (log; m/N, or m/V for a voltage reference) and unwrapped phase over the whole band
    (left), and around each of the first ``max_zooms`` modes (right, over :func:`zoom_window`).
    A band no wider than its curve says so in the legend (:func:`~nlupdate.reporting.figures.label_thin_bands`)."""
    f = np.asarray(identification.linear_frequency_hz)
    h = np.asarray(identification.linear_frf)
    band = identification.linear_frf_band
    model = identification.modal_receptance(f)
    unit = identification.reference_unit
    modes = list(identification.modes)[:max_zooms]
    figure = Figure(figsize=(6.5 + 3.0 * len(modes), 6.4))
    # a fixed layout (inches; constrained layout would measure every tick label twice): tick
    # labels as wide as "6 × 10⁻⁵" left of each panel, two-line titles above the zooms
    grid = figure.add_gridspec(2, 1 + len(modes), width_ratios=[2.2] + [1] * len(modes), **grid_in_inches(
        figure, 2, 1 + len(modes), left=0.95, right=0.15, top=0.5, bottom=0.55, wspace=0.78, hspace=0.4))
    phase = unwrapped_phase_deg(h)
    model_phase = unwrapped_phase_deg(model)
    panels = []
    for column in range(1 + len(modes)):
        ax_mag = figure.add_subplot(grid[0, column])
        ax_phase = figure.add_subplot(grid[1, column], sharex=ax_mag)
        panels.append((ax_mag, ax_phase))
        if measured is not None:
            label, f_m, h_m = measured
            label = (f"measured at {label} (lowest of the {len(identification.linear_from_levels_n)} levels "
                     f"it is extracted from)" if len(identification.linear_from_levels_n) > 1 else
                     f"measured at {label} (extracted from it)")
            ax_mag.semilogy(f_m, np.abs(h_m), ".", ms=2, color="0.55", label=label)
            ax_phase.plot(f_m, unwrapped_phase_deg(h_m), ".", ms=2, color="0.55", label=label)
        if band is not None:
            label = f"{BAND_LABEL} ({band.n_samples} extractions)"
            band_fill(ax_mag, f, *band.magnitude, label, np.abs(h), covered_by=1.2, color=EXTRACTED_COLOUR,
                      alpha=0.22)
            band_fill(ax_phase, f, phase + band.phase_offset_deg[0], phase + band.phase_offset_deg[1], label,
                      phase, covered_by=1.2, color=EXTRACTED_COLOUR, alpha=0.22)
        ax_mag.semilogy(f, np.abs(h), "-", color=EXTRACTED_COLOUR, lw=1.0, label="extracted linear FRF")
        ax_phase.plot(f, phase, "-", color=EXTRACTED_COLOUR, lw=1.0, label="extracted linear FRF")
        ax_mag.semilogy(f, np.abs(model), "--", color="black", lw=1.2, label="one-mode fit of each mode")
        ax_phase.plot(f, model_phase, "--", color="black", lw=1.2, label="one-mode fit of each mode")
        for ax in (ax_mag, ax_phase):
            ax.grid(True, which="both", alpha=0.3)
        ax_phase.set_xlabel("frequency (Hz)")
    panels[0][0].set_ylabel(f"|H| (m/{unit})")
    panels[0][1].set_ylabel("phase (deg, unwrapped)")
    panels[0][0].set_title(title, fontsize=9, y=1.0)  # y=1: a log axis has no offset text to dodge
    fraction = identification.settings.modal_band_fraction
    stats = identification.uncertainty.parameters
    for i, (mode, (ax_mag, ax_phase)) in enumerate(zip(modes, panels[1:])):
        natural = float(mode.natural_frequencies_hz[0])
        window = zoom_window(f, natural, float(mode.loss_factors[0]), fraction)
        ax_mag.set_xlim(*window)
        near = (f >= window[0]) & (f <= window[1])
        shown = [np.abs(h[near])] + ([band.magnitude[0][near], band.magnitude[1][near]] if band is not None else [])
        values = np.concatenate([v[np.isfinite(v) & (v > 0)] for v in shown])
        if values.size:
            ax_mag.set_ylim(values.min() / 1.5, values.max() * 1.5)
        phases = np.concatenate([phase[near], model_phase[near]])
        phases = phases[np.isfinite(phases)]
        if phases.size:
            ax_phase.set_ylim(phases.min() - 30, phases.max() + 30)
        f_stats, eta_stats = stats.get(f"linear_f{i + 1}_hz"), stats.get(f"linear_eta{i + 1}")
        detail = f"mode {i + 1}: {natural:.4g}"
        if f_stats is not None and np.isfinite(f_stats.std):
            detail += f" ± {f_stats.std:.2g}"
        detail += f" Hz\nloss factor η = {float(mode.loss_factors[0]):.3g}"
        if eta_stats is not None and np.isfinite(eta_stats.std):
            detail += f" ± {eta_stats.std:.2g}"
        ax_mag.set_title(detail, fontsize=8, y=1.0)
    label_thin_bands(figure)
    if band is not None:
        bands = [[c for c in ax.collections if BAND_LABEL in c.get_label()][0] for ax in figure.axes]
        wide = [k for k in range(1, len(panels)) if any(THIN_BAND_NOTE not in c.get_label()
                                                         for c in bands[2 * k:2 * k + 2])]
        if THIN_BAND_NOTE in bands[0].get_label() and wide:  # the legend speaks for the left panel only
            bands[0].set_label(f"{bands[0].get_label()} here; wider around mode "
                               + ", ".join(str(k) for k in wide))
    panels[0][0].legend(fontsize=7)
    return figure


#: A mode's zoom spans this many half-power bandwidths (η·f) either side of its resonance.
ZOOM_BANDWIDTHS = 4.0


def zoom_window(frequency_hz: ArrayLike, natural_hz: float, loss_factor: float, fraction: float) -> tuple[float, float]:
    """(low, high) Hz of the panel around a mode at ``natural_hz``: :data:`ZOOM_BANDWIDTHS`
    half-power bandwidths (``loss_factor``·f) either side, at most ``fraction`` of f (the
    modal fit's band; all of it when the loss factor is unknown), never narrower than
    five frequency steps either side, and clipped to the frequencies the data cover."""
    f = np.sort(np.asarray(frequency_hz, dtype=float))
    f = f[np.isfinite(f)]
    half = fraction * natural_hz
    if np.isfinite(loss_factor) and loss_factor > 0:
        half = min(half, ZOOM_BANDWIDTHS * loss_factor * natural_hz)
    if f.size > 1:
        half = max(half, 5 * float(np.median(np.diff(f))))
        return max(natural_hz - half, float(f[0])), min(natural_hz + half, float(f[-1]))
    return natural_hz - half, natural_hz + half

