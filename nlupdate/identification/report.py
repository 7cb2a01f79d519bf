"""Identification outputs: JSON summary, linear-FRF table, PNG plots, atomic output folder.

``identification.json`` keys (SI units, polynomial coefficients highest order first):

* ``method`` ("prd"/"ddf"), ``estimator``, ``model``, ``response_dof``, ``input_dof``;
* ``warnings``: results not to be trusted as they stand, each ``{"subject", "kind",
  "message", "source"}`` (:mod:`nlupdate.identification.trust`; empty when none);
* ``excitation_frequency_hz`` (PRD; null for DDF), ``low_force_n`` and ``high_forces_n``
  (PRD) or ``force_pair_n`` and ``band_hz`` (DDF);
* ``describing_function``: ``{"real", "imag", "definition", "amplitude_range_m"}`` — the DF
  ν(A) (N/m) that, added to the extracted linear dynamic stiffness, reproduces the
  high-force data (PRD: ``y + Δ_f1``; DDF: ``Δ``);
* ``prd_fit`` (PRD): the fitted PRD curve ``y(A) = 1/H_i − 1/H_1`` (the source's
  "identified DF", constant term ``−Δ_f1``) and ``delta_f1`` (real, imag);
* ``elements`` (physical models): type, dofs and parameters, ready for
  :data:`nlupdate.model.elements.ELEMENT_TYPES`;
* ``parameters``: per parameter ``{"value", "mean", "std", "ci95"}`` and ``uncertainty``
  (how the statistics were made); ``noise_fraction`` (the noise level used) and
  ``fit_residual`` (the noise level the fit's residuals imply, and its ratio to it);
* ``fit``: ``"poor"`` when that ratio exceeds 5 (the model does not describe the data; the
  fit plot shows the residual against amplitude), ``"consistent"``, or ``"unknown"`` (no
  spare degrees of freedom), with ``fit_ratio_to_noise``;
* ``linear_frf``: the table file and the natural frequencies of the extracted linear FRF;
* ``defaults_used``: every option that was not given and the value chosen.
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Callable

import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from numpy.typing import ArrayLike

from nlupdate.identification.dfmodels import PhysicalModel
from nlupdate.files import atomic_directory
from nlupdate.reporting.jsonfile import write_json
from nlupdate.reporting.figures import level_colours, phase_deg, save_figure

JSON_NAME = "identification.json"


def linear_frf_table(frequency_hz: ArrayLike, h: ArrayLike, response_dof: str, input_dof: str) -> pd.DataFrame:
    """Tidy table of the extracted linear FRF; ``force_level_n = 0`` means "linear"."""
    f = np.asarray(frequency_hz, dtype=float)
    hh = np.asarray(h, dtype=complex)
    return pd.DataFrame({
        "frequency_hz": f, "force_level_n": np.zeros(f.size), "response_dof": str(response_dof),
        "input_dof": str(input_dof), "h_real": hh.real, "h_imag": hh.imag,
    })


def elements_summary(result: Any, dof_name: str) -> list[dict] | None:
    """Physical elements as ``{"type", "dofs", <parameters>}`` dictionaries, else None."""
    model = getattr(result, "physical", None) or getattr(result, "model", None)
    if not isinstance(model, PhysicalModel):
        return None
    p = result.p
    out = []
    for name, element in zip(model.element_names, model.elements(p)):
        entry = {"type": name, "dofs": [dof_name]}
        entry.update({k: float(v) for k, v in vars(element).items() if k != "dofs"})
        out.append(entry)
    return out


def residual_in_noise_units(result: Any, noise_fraction: float) -> np.ndarray:
    """The misfit of each PRD/DDF point, ``|y_i − ŷ(A_i)|``, over the noise it carries,
    about ``σ·√2·F_i/A_i`` (σ: relative noise; ``F_i/A_i = |1/H_i|``, and the reference
    level's ``|1/H|`` taken as the same size) — about 1 where the model fits."""
    amplitude = np.asarray(result.amplitude, dtype=float)
    if result.method == "prd":
        forces = np.asarray(result.setup.high_forces, dtype=float)
        force = np.tile(forces, max(amplitude.size // forces.size, 1))[: amplitude.size]
    else:
        force = np.full(amplitude.size, float(result.setup.force_pair[1]))
    misfit = np.abs(np.asarray(result.y) - result.fitted_y(amplitude))
    return misfit / (max(float(noise_fraction), 1e-12) * np.sqrt(2) * force / amplitude)


def plot_fit(result: Any, path: Path, title: str, noise_fraction: float | None = None,
             poor_factor: float | None = None, reference_unit: str = "N") -> Path:
    """PRD/DDF points and the fitted curve: real and imaginary parts against amplitude (y in
    N/m, or V/m for a voltage reference), and (given the noise level) each point's misfit in
    units of its noise against amplitude, so a person sees where the model misses
    (``poor_factor`` draws the "poor fit" line)."""
    amplitude = np.asarray(result.amplitude)
    y = np.asarray(result.y)
    low, high = result.amplitude_range
    grid = np.linspace(0.0 if result.method == "prd" else 0.5 * low, 1.1 * high, 300)
    curve = result.fitted_y(grid)
    panels = 2 if noise_fraction is None else 3
    fig = Figure(figsize=(5 * panels, 4))
    axes = fig.subplots(1, panels)
    for ax, part, label in ((axes[0], np.real, "Re"), (axes[1], np.imag, "Im")):
        ax.plot(amplitude * 1e3, part(y), ".", ms=4, alpha=0.6, label="data")
        ax.plot(grid * 1e3, part(curve), "-", lw=1.5, label="fit")
        ax.set_xlabel("response amplitude |X| (mm)")
        ax.set_ylabel(f"{label} y ({reference_unit}/m)")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    if noise_fraction is not None:
        ax = axes[2]
        ax.loglog(amplitude * 1e3, residual_in_noise_units(result, noise_fraction), ".", ms=4, label="points")
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


def write_directory_atomically(final: str | os.PathLike, write: Callable[[Path], None], replace: bool = False) -> Path:
    """Call ``write(tmp)`` on a temporary folder beside ``final`` and rename it to ``final``;
    returns the folder written.

    With ``replace``, an existing ``final`` is replaced only if it is empty or an
    identification output nlupdate wrote (:func:`nlupdate.files.check_replaceable`), and
    only once the new one is complete; a failure leaves it untouched.
    """
    with atomic_directory(final, on_exists="replace" if replace else "error", kind="identification") as archive:
        write(archive.path)
    return archive.final
