"""Figures of a discovery (PNG), built on :class:`matplotlib.figure.Figure` without pyplot.

* :func:`plot_frfs` — measured vs model before vs model after, per force level (FRF data:
  |H| of every measured coordinate; modal data: natural frequency and damping vs force);
* :func:`plot_describing_function` — the apparent describing function at the place of the
  first effect against the best candidates' DFs there;
* :func:`plot_gap` — the gap (1 − FRAC) per force level before and after;
* :func:`plot_residuals` — the residual left after against the measured amplitude, per
  force level, with the noise level and the poor-fit limit: what the model still misses.

On the FRF plots, points where the measurement follows another branch than a stepped sweep
in the stated direction would reach are ringed, and points the model cannot solve are
marked at the bottom of the axis.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import NullFormatter

from nlupdate.core.discovery.effects import DFSamples
from nlupdate.core.discovery.workflow import DiscoveryResult
from nlupdate.files import atomic_file

_MAX_COLUMNS = 3
_CANDIDATES_SHOWN = 3
_GAP_FLOOR = 1e-6  # gaps below are drawn at this height (log axis)
_SAME_FREQUENCY = 0.35  # relative spread of ω below which DFs are drawn on a dense amplitude grid


def _save(figure: Figure, path: str | os.PathLike, rect: tuple[float, float, float, float] = (0, 0, 1, 1)) -> Path:
    """Lay ``figure`` out inside ``rect`` (figure fraction) and write it as PNG, atomically."""
    figure.tight_layout(rect=rect)
    with atomic_file(path) as temporary:
        figure.savefig(temporary, dpi=110)
    return Path(path)


def _broken(frequency: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Insert NaN between separate bands so a line does not bridge them."""
    spacing = np.diff(frequency)
    cut = np.flatnonzero(spacing > 3 * np.median(spacing)) + 1
    return np.insert(frequency, cut, np.nan), np.insert(values.astype(float), cut, np.nan)


def _plot_frf_levels(result: DiscoveryResult, figure: Figure) -> None:
    data = result.data
    columns = min(len(data.response_dofs), _MAX_COLUMNS)
    axes = np.atleast_2d(figure.subplots(data.levels.size, columns, squeeze=False))
    before = np.column_stack([result.prediction_before.at(d) for d in data.response_dofs]) / data.force[:, None]
    after = np.column_stack([result.prediction_after.at(d) for d in data.response_dofs]) / data.force[:, None]
    other = result.other_branch_after if result.other_branch_after is not None else np.zeros(data.force.size, bool)
    for row, level in enumerate(data.levels):
        mask = data.force == level
        f = data.frequency_hz[mask]
        for column in range(columns):
            axis = axes[row, column]
            axis.semilogy(f, np.abs(data.h[mask, column]), "k.", ms=3, label="measured")
            axis.semilogy(*_broken(f, np.abs(before[mask, column])), "C3--", lw=1, label="model before")
            axis.semilogy(*_broken(f, np.abs(after[mask, column])), "C0-", lw=1, label="model after")
            ringed = other[mask]
            if ringed.any():
                axis.semilogy(f[ringed], np.abs(data.h[mask, column])[ringed], "o", mfc="none", mec="C1", ms=6,
                              label=f"other branch than a sweep {result.sweep}")
            unsolved = ~np.isfinite(after[mask, column])
            if unsolved.any():
                bottom = np.nanmin(np.abs(data.h[mask, column]))
                axis.semilogy(f[unsolved], np.full(unsolved.sum(), bottom), "x", color="C3", ms=5,
                              label="no stable solution (counts as misfit)")
            axis.set_title(f"{level:g} N, response {data.response_names[column]}", fontsize=8)
            axis.tick_params(labelsize=7)
            if row == data.levels.size - 1:
                axis.set_xlabel("frequency (Hz)", fontsize=8)
            if column == 0:
                axis.set_ylabel("|H| (m/N)", fontsize=8)
    labelled = {}
    for axis in axes.ravel():  # one legend with every kind of mark used anywhere
        for handle, label in zip(*axis.get_legend_handles_labels()):
            labelled.setdefault(label, handle)
    axes[0, 0].legend(list(labelled.values()), list(labelled), fontsize=7)


def _plot_modal_levels(result: DiscoveryResult, figure: Figure) -> None:
    data = result.data
    left, right = figure.subplots(1, 2)
    for mode in np.unique(data.mode):
        mask = data.mode == mode
        force = data.force[mask]
        for axis, measured, before, after, scale in (
            (left, data.frequency_hz, result.prediction_before.frequency_hz, result.prediction_after.frequency_hz, 1.0),
            (right, data.damping_ratio, result.prediction_before.damping_ratio, result.prediction_after.damping_ratio, 100.0),
        ):
            axis.semilogx(force, scale * measured[mask], "ko", ms=4, label=f"measured, mode {mode + 1}")
            axis.semilogx(force, scale * before[mask], "C3s--", ms=3, lw=1, label="model before")
            axis.semilogx(force, scale * after[mask], "C0^-", ms=3, lw=1, label="model after")
    left.set(xlabel="force level (N)", ylabel="natural frequency (Hz)")
    right.set(xlabel="force level (N)", ylabel="damping ratio (%)")
    for axis in (left, right):
        axis.grid(True, alpha=0.3)
        axis.legend(fontsize=7)


def _curve_points(samples: DFSamples) -> tuple[np.ndarray, np.ndarray]:
    """Where to draw candidate DFs: a dense amplitude grid at the median ω when the samples
    share about one frequency, else the samples themselves (sorted by amplitude)."""
    if np.ptp(samples.omega) < _SAME_FREQUENCY * np.median(samples.omega):
        amplitude = np.geomspace(samples.amplitude.min(), samples.amplitude.max(), 200)
        return amplitude, np.full(amplitude.size, np.median(samples.omega))
    order = np.argsort(samples.amplitude)
    return samples.amplitude[order], samples.omega[order]


def plot_frfs(result: DiscoveryResult, path: str | os.PathLike) -> Path:
    """Measured vs model before vs model after at every force level."""
    if result.kind == "modal":
        figure = Figure(figsize=(10, 4))
        _plot_modal_levels(result, figure)
    else:
        rows = result.data.levels.size
        figure = Figure(figsize=(4 * min(len(result.data.response_dofs), _MAX_COLUMNS), 2.3 * rows + 0.6))
        _plot_frf_levels(result, figure)
    return _save(figure, path)


def plot_describing_function(result: DiscoveryResult, path: str | os.PathLike) -> Path:
    """Apparent DF samples (real and imaginary part vs amplitude) at the place of the first
    iteration's best candidate, the DFs of the best candidates fitted there in that round
    (with the effects found earlier at that place), and the final model's: the sum of every
    effect found at that place, with its jointly refitted values. A candidate's score is its
    change of the information criterion (χ² change + parameter penalty; negative is better)."""
    figure = Figure(figsize=(10, 4))
    left, right = figure.subplots(1, 2)
    step_number, step = next(((i, s) for i, s in enumerate(result.steps, 1) if s.samples is not None), (0, None))
    if step is None:
        left.text(0.5, 0.5, "no candidate was fitted:\nthe model is at the noise level", ha="center", va="center")
        right.set_axis_off()
        return _save(figure, path)
    samples = step.samples
    place = step.candidates[0].dofs
    for axis, part in ((left, np.real), (right, np.imag)):
        axis.semilogx(samples.amplitude, part(samples.nu), ".", color="0.5", ms=3, label="apparent DF (measured)")
    amplitude, omega = _curve_points(samples)
    shown = [c for c in step.candidates if c.dofs == place][:_CANDIDATES_SHOWN]
    for k, candidate in enumerate(shown):
        nu = candidate.effect.nu(np.array(candidate.values), amplitude, omega)
        for companion in candidate.companions:
            nu = nu + companion.effect.nu(np.array(companion.values), amplitude, omega)
        variant = f" ({candidate.effect.variant})" if candidate.effect.variant else ""
        label = f"round {step_number}: {candidate.name}{variant}, score {candidate.score:+.3g}"
        for axis, part in ((left, np.real), (right, np.imag)):
            axis.semilogx(amplitude, part(nu), "-", color=f"C{k}", lw=1.2, label=label)
    final = [found for found in result.effects if tuple(found.dofs) == tuple(place)]
    if final:
        nu = sum(found.effect.nu(np.array(found.values), amplitude, omega) for found in final)
        label = "final model: " + " + ".join(found.name for found in final) + " (refitted together)"
        for axis, part in ((left, np.real), (right, np.imag)):
            axis.semilogx(amplitude, part(nu), "-", color="k", lw=2.2, alpha=0.8, label=label)
    left.set(xlabel="amplitude at the place (m)", ylabel="Re ν (N/m)", title=f"{result.place(place)}: stiffness")
    right.set(xlabel="amplitude at the place (m)", ylabel="Im ν (N/m)", title="damping (Im ν > 0 dissipates)")
    for axis in (left, right):
        axis.grid(True, alpha=0.3)
        axis.legend(fontsize=7)
        axis.tick_params(labelsize=7)
        axis.xaxis.set_minor_formatter(NullFormatter())
    figure.text(0.5, 0.005, f"score: change of the {result.options.criterion.upper()} when the candidate is added "
                "(χ² change + a penalty per parameter); negative is better, the most negative is chosen",
                ha="center", va="bottom", fontsize=7, color="0.3")
    return _save(figure, path, rect=(0, 0.05, 1, 1))  # room for the note


def plot_gap(result: DiscoveryResult, path: str | os.PathLike) -> Path:
    """Gap (1 − FRAC) per force level before and after, with the noise level σ² (FRF data)."""
    figure = Figure(figsize=(6.5, 4))
    axis = figure.subplots()
    levels = [level.force_n for level in result.gap_before.levels]
    x = np.arange(len(levels))
    before = [max(level.gap, _GAP_FLOOR) for level in result.gap_before.levels]
    after = [max(level.gap, _GAP_FLOOR) for level in result.gap_after.levels]
    axis.bar(x - 0.2, before, 0.4, color="C3", label=f"before (mean {result.gap_before.gap:.3g})")
    axis.bar(x + 0.2, after, 0.4, color="C0", label=f"after (mean {result.gap_after.gap:.3g})")
    if result.kind == "frf":
        axis.axhline(result.noise_fraction**2, color="k", ls=":", label=f"noise level σ² = {result.noise_fraction**2:.2g}")
    axis.set_yscale("log")
    axis.set_xticks(x, [f"{level:g}" for level in levels])
    axis.set(xlabel="force level (N)", ylabel="gap = 1 − FRAC")
    axis.legend(fontsize=8)
    axis.grid(True, axis="y", alpha=0.3)
    return _save(figure, path)


def plot_residuals(result: DiscoveryResult, path: str | os.PathLike) -> Path:
    """The residual left by the model after, against amplitude (FRF data) or force (modal data).

    FRFs: per point the RMS over the measured coordinates of ``|H_model − H̃|/|H̃|`` against
    the measured amplitude at the place of the first effect found (the driven or first
    measured coordinate when none), one colour per force level, with the noise level σ and
    the poor-fit limit (``poor_fit_ratio``·σ). A residual that grows with amplitude is a
    nonlinearity still missing; one flat in amplitude but above σ, a linear error.
    Modal tables: frequency and damping errors relative to their uncertainties against force.
    """
    figure = Figure(figsize=(7.5, 4.5))
    axis = figure.subplots()
    limit = result.options.poor_fit_ratio
    if result.kind == "modal":
        data, after = result.data, result.prediction_after
        axis.semilogx(data.force, np.abs(after.frequency_hz / data.frequency_hz - 1) / result.options.frequency_uncertainty,
                      "o", label="natural frequency error / its uncertainty")
        axis.semilogx(data.force, np.abs(after.damping_ratio / data.damping_ratio - 1) / result.options.damping_uncertainty,
                      "s", label="damping error / its uncertainty")
        axis.axhline(1.0, color="k", ls=":", label="noise level")
        axis.axhline(limit, color="C3", ls="--", label=f"poor fit ({limit:g}× noise)")
        axis.set(xlabel="force level (N)", ylabel="error / uncertainty")
    else:
        data = result.data
        place = result.effects[0].dofs if result.effects else (
            (data.input_dof,) if data.input_dof in data.response_dofs else (data.response_dofs[0],))
        measured = {d: data.x[:, k] for k, d in enumerate(data.response_dofs)}
        u = measured[place[0]] - (measured[place[1]] if len(place) == 2 else 0.0)
        residual = np.sqrt(np.mean(np.abs(result.residuals_after) ** 2, axis=1))
        for k, level in enumerate(data.levels):
            mask = data.force == level
            axis.loglog(np.abs(u[mask]), residual[mask], ".", ms=4, label=f"{level:g} N")
        sigma = result.noise_fraction
        axis.axhline(sigma, color="k", ls=":", label=f"noise level σ = {sigma:.2g}")
        axis.axhline(limit * sigma, color="C3", ls="--", label=f"poor fit ({limit:g}σ)")
        axis.set(xlabel=f"measured amplitude at {result.place(place)} (m)", ylabel="relative residual |H_model − H̃|/|H̃|")
    axis.set_title(f"residual after ({result.summary().split(' — ')[0]}, {result.misfit_ratio:.3g}× noise)", fontsize=9)
    axis.grid(True, which="both", alpha=0.3)
    axis.legend(fontsize=7)
    return _save(figure, path)
