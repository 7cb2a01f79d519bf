"""The plots of an identification: the PRD/DDF points with the fitted curve and each
point's misfit in noise units, and the extracted linear FRF against the measured levels."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure
from numpy.typing import ArrayLike

from nlupdate.reporting.figures import level_colours, phase_deg, save_figure


def plot_fit(result: Any, path: Path, title: str, misfit: ArrayLike | None = None,
             poor_factor: float | None = None, reference_unit: str = "N") -> Path:
    """PRD/DDF points and the fitted curve: real and imaginary parts against amplitude (y in
    N/m, or V/m for a voltage reference), and (given ``misfit``, each point's misfit in
    units of its noise: :meth:`nlupdate.identification.pipeline.Identification.misfit_in_noise_units`)
    against amplitude, so a person sees where the model misses
    (``poor_factor`` draws the "poor fit" line)."""
    amplitude = np.asarray(result.amplitude)
    y = np.asarray(result.y)
    low, high = result.amplitude_range
    grid = np.linspace(0.0 if result.method == "prd" else 0.5 * low, 1.1 * high, 300)
    curve = result.fitted_y(grid)
    panels = 2 if misfit is None else 3
    fig = Figure(figsize=(5 * panels, 4))
    axes = fig.subplots(1, panels)
    for ax, part, label in ((axes[0], np.real, "Re"), (axes[1], np.imag, "Im")):
        ax.plot(amplitude * 1e3, part(y), ".", ms=4, alpha=0.6, label="data")
        ax.plot(grid * 1e3, part(curve), "-", lw=1.5, label="fit")
        ax.set_xlabel("response amplitude |X| (mm)")
        ax.set_ylabel(f"{label} y ({reference_unit}/m)")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    if misfit is not None:
        ax = axes[2]
        ax.loglog(amplitude * 1e3, np.asarray(misfit), ".", ms=4, label="points")
        ax.axhline(1.0, color="grey", lw=1, label="noise level")
        if poor_factor is not None:
            ax.axhline(poor_factor, color="crimson", lw=1, ls="--", label=f"{poor_factor:g}× noise: poor fit")
        ax.set_xlabel("response amplitude |X| (mm)")
        ax.set_ylabel("|y − fit| / noise of y")
        ax.set_title("residual against amplitude", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    what = "y = 1/H_i − 1/H_1" if result.method == "prd" else "Δ(x₂) implied by 1/H₂ − 1/H₁ + Δ(x₁)"
    fig.suptitle(f"{title}: {what}", fontsize=10)
    fig.tight_layout()
    return save_figure(fig, path)


def plot_linear_frf(
    frequency_hz: ArrayLike,
    h_linear: ArrayLike,
    measured: list[tuple[str, ArrayLike, ArrayLike]],
    path: Path,
    title: str,
    h_model: ArrayLike | None = None,
    reference_unit: str = "N",
) -> Path:
    """|H| (log) and phase of the extracted linear FRF with measured curves for comparison
    (and a fitted modal model of it, if given); |H| in m/N, or m/V for a voltage reference."""
    f = np.asarray(frequency_hz)
    h = np.asarray(h_linear)
    fig = Figure(figsize=(8, 6))
    ax_mag, ax_phase = fig.subplots(2, 1, sharex=True)
    colours = level_colours(len(measured), 0.1, 0.9)
    for (label, fm, hm), colour in zip(measured, colours):
        hm = np.asarray(hm)
        ax_mag.semilogy(fm, np.abs(hm), ".", ms=2, color=colour, label=label)
        ax_phase.plot(fm, phase_deg(hm), ".", ms=2, color=colour)
    ax_mag.semilogy(f, np.abs(h), "-", color="crimson", lw=1.5, label="extracted linear")
    ax_phase.plot(f, phase_deg(h), "-", color="crimson", lw=1.5)
    if h_model is not None:
        ax_mag.semilogy(f, np.abs(h_model), "--", color="black", lw=1.2, label="modal fit of the linear FRF")
        ax_phase.plot(f, phase_deg(np.asarray(h_model)), "--", color="black", lw=1.2)
    ax_mag.set_ylabel(f"|H| (m/{reference_unit})")
    ax_phase.set_ylabel("phase (deg)")
    ax_phase.set_xlabel("frequency (Hz)")
    for ax in (ax_mag, ax_phase):
        ax.grid(True, which="both", alpha=0.3)
    ax_mag.legend(fontsize=7, ncol=2)
    ax_mag.set_title(title, fontsize=10)
    fig.tight_layout()
    return save_figure(fig, path)
