"""The plots of an identification (:class:`~nlupdate.identification.pipeline.Identification`):
the PRD/DDF points with the fitted curve, its 95 % Monte-Carlo band and each point's
misfit in noise units; the extracted linear FRF with its band and modal fit."""
from __future__ import annotations

from typing import Any

import numpy as np
from matplotlib.colors import BoundaryNorm, ListedColormap
from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter, NullFormatter
from numpy.typing import ArrayLike

from nlupdate.reporting.figures import (
    BAND_LABEL, EXTRACTED_COLOUR, EXTRAPOLATION_FILL, FIT_COLOUR, level_colours, unwrapped_phase_deg,
)


def _points_caption(result: Any, unit: str) -> str:
    """Where the points come from: how many, from which force levels, at which frequencies."""
    n = len(result.amplitude)
    if result.method == "prd":
        setup = result.setup
        levels = sorted(setup.high_forces)
        span = f"{levels[0]:g}–{levels[-1]:g} {unit}" if len(levels) > 1 else f"{levels[0]:g} {unit}"
        window = result.extras.get("half_window") if result.estimator == "improved" else None
        where = f"within ±{100 * window:g} % of {setup.frequency_hz:g} Hz" if window else f"at {setup.frequency_hz:g} Hz"
        return (f"{n} points: {len(levels)} force level{'s' if len(levels) > 1 else ''} ({span}) against "
                f"{setup.low_force:g} {unit}, {where}")
    low, high = result.setup.force_pair
    band = result.setup.band_hz
    return f"{n} points: {high:g} {unit} against {low:g} {unit}, {band[0]:g}–{band[1]:g} Hz"


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


def fit_figure(identification: Any, title: str, poor_factor: float | None = None) -> Figure:
    """The PRD/DDF points (coloured by force level), the fitted curve with its 95 %
    Monte-Carlo band — solid over the amplitudes the data cover, dotted in the shaded
    extrapolation beyond them — real and imaginary parts against amplitude (y in N/m, or
    V/m for a voltage reference), and each point's misfit in units of its noise
    (:meth:`~nlupdate.identification.pipeline.Identification.misfit_in_noise_units`;
    ``poor_factor`` draws the "poor fit" line)."""
    result = identification.result
    unit = identification.reference_unit
    amplitude = np.asarray(result.amplitude)
    y = np.asarray(result.y)
    low, high = result.amplitude_range
    band = identification.fit_band
    grid = band.x if band is not None else np.linspace(low, high, 200)
    curve = result.fitted_y(grid)
    inside = (grid >= low) & (grid <= high)
    colouring = _level_colouring(result, unit)
    point_style = dict(s=7, alpha=0.75, lw=0)
    if colouring is not None:
        point_style.update(c=colouring[0], cmap=colouring[1], norm=colouring[2])
    else:
        point_style.update(color="C0")
    figure = Figure(figsize=(15, 4.6), layout="constrained")
    axes = figure.subplots(1, 3)
    for ax, part, band_part, name in ((axes[0], np.real, "real", "Re"), (axes[1], np.imag, "imag", "Im")):
        if grid[0] < low:
            ax.axvspan(grid[0] * 1e3, low * 1e3, **EXTRAPOLATION_FILL, label="extrapolation: no data")
        if grid[-1] > high:
            ax.axvspan(high * 1e3, grid[-1] * 1e3, **EXTRAPOLATION_FILL,
                       label="_" if grid[0] < low else "extrapolation: no data")
        if band is not None:
            ax.fill_between(grid * 1e3, *getattr(band, band_part), color=FIT_COLOUR, alpha=0.25, lw=0,
                            label=f"{BAND_LABEL} ({band.n_samples} fits)")
        ax.scatter(amplitude * 1e3, part(y), **point_style, label="data (colour: force level)" if colouring else "data")
        ax.plot(grid[inside] * 1e3, part(curve[inside]), "-", color=FIT_COLOUR, lw=1.6, label="fit over the data")
        if not inside.all():
            ax.plot(grid * 1e3, np.where(inside, np.nan, part(curve)), ":", color=FIT_COLOUR, lw=1.6,
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
    axes[0].legend(fontsize=7, loc="best")
    ax = axes[2]
    ax.scatter(amplitude * 1e3, np.asarray(identification.misfit_in_noise_units()), **point_style, label="points")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.xaxis.set_major_formatter(FuncFormatter(lambda value, _: f"{value:g}"))  # mm, not 2×10⁰
    if high < 10 * low:  # less than a decade: label the minor ticks too, there may be no major one
        ax.xaxis.set_minor_formatter(FuncFormatter(lambda value, _: f"{value:g}"))
    else:
        ax.xaxis.set_minor_formatter(NullFormatter())
    ax.axhline(1.0, color="grey", lw=1, label="noise level")
    if poor_factor is not None:
        ax.axhline(poor_factor, color="crimson", lw=1, ls="--", label=f"{poor_factor:g}× noise: poor fit")
    ax.set_xlabel("response amplitude |X| (mm)")
    ax.set_ylabel("|y − fit| / noise of y")
    ax.set_title("misfit of each point in units of its noise", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    if colouring is not None:
        bar = figure.colorbar(axes[2].collections[0], ax=axes[2], ticks=colouring[3], pad=0.01)
        bar.set_label(f"force level ({unit})", fontsize=8)
        bar.ax.tick_params(labelsize=7)
    what = "y = 1/H_i − 1/H_1" if result.method == "prd" else "Δ(x₂) implied by 1/H₂ − 1/H₁ + Δ(x₁)"
    figure.suptitle(f"{title}: {what}\n{_points_caption(result, unit)}; the fit is drawn solid over the amplitudes "
                    f"the data cover ({low * 1e3:.3g}–{high * 1e3:.3g} mm)", fontsize=9)
    return figure


def linear_frf_figure(identification: Any, measured: tuple[str, ArrayLike, ArrayLike] | None, title: str,
                      max_zooms: int = 3) -> Figure:
    """The extracted linear FRF with its 95 % Monte-Carlo band, the one-mode fits of its
    modes, and the (lowest-level) measured curve it was extracted from (``measured``: label, Hz, H):
    |H| (log; m/N, or m/V for a voltage reference) and unwrapped phase over the whole band
    (left), and around each of the first ``max_zooms`` modes (right)."""
    f = np.asarray(identification.linear_frequency_hz)
    h = np.asarray(identification.linear_frf)
    band = identification.linear_frf_band
    model = identification.modal_receptance(f)
    unit = identification.reference_unit
    modes = list(identification.modes)[:max_zooms]
    figure = Figure(figsize=(6.5 + 3.0 * len(modes), 6.4), layout="constrained")
    grid = figure.add_gridspec(2, 1 + len(modes), width_ratios=[2.2] + [1] * len(modes))
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
            ax_mag.fill_between(f, *band.magnitude, color=EXTRACTED_COLOUR, alpha=0.22, lw=0, label=label)
            ax_phase.fill_between(f, phase + band.phase_offset_deg[0], phase + band.phase_offset_deg[1],
                                  color=EXTRACTED_COLOUR, alpha=0.22, lw=0, label=label)
        ax_mag.semilogy(f, np.abs(h), "-", color=EXTRACTED_COLOUR, lw=1.0, label="extracted linear FRF")
        ax_phase.plot(f, phase, "-", color=EXTRACTED_COLOUR, lw=1.0, label="extracted linear FRF")
        ax_mag.semilogy(f, np.abs(model), "--", color="black", lw=1.2, label="one-mode fit of each mode")
        ax_phase.plot(f, model_phase, "--", color="black", lw=1.2, label="one-mode fit of each mode")
        for ax in (ax_mag, ax_phase):
            ax.grid(True, which="both", alpha=0.3)
        ax_phase.set_xlabel("frequency (Hz)")
    panels[0][0].set_ylabel(f"|H| (m/{unit})")
    panels[0][1].set_ylabel("phase (deg, unwrapped)")
    panels[0][0].legend(fontsize=7)
    panels[0][0].set_title(title, fontsize=9)
    fraction = identification.settings.modal_band_fraction
    stats = identification.uncertainty.parameters
    for i, (mode, (ax_mag, ax_phase)) in enumerate(zip(modes, panels[1:])):
        natural = float(mode.natural_frequencies_hz[0])
        ax_mag.set_xlim(natural * (1 - fraction), natural * (1 + fraction))
        near = np.abs(f - natural) <= fraction * natural
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
        ax_mag.set_title(detail, fontsize=8)
    return figure

