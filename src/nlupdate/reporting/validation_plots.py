"""Figures of a held-out validation: one per held-out level and one summary.

Per held-out level (:func:`held_out_figure`): |H| measured (points), the model's prediction
(line) with its 95 % band (shaded; the legend says when it is narrower than the line), and
the log-amplitude baseline (dashed). Summary (:func:`summary_figure`): per held-out level
and model, the resonance error (Hz) and the damping and peak errors (%), each with the
band as an error bar and the baseline's error beside it (open markers), and the test's
repeatability (±1σ, grey) behind the resonance and damping panels. The response-controlled
runs (:func:`response_controlled_figure`) the same, per run.
"""
from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from nlupdate.reporting.figures import MEASURED_STYLE

_MODEL_COLOURS = ("tab:red", "tab:blue", "tab:green", "tab:purple", "tab:orange", "tab:brown")


def held_out_figure(result, unit: str = "N") -> Figure:
    """One held-out level (:class:`~nlupdate.core.validation.held_out.HeldOut`)."""
    figure = Figure(figsize=(7.5, 4.6), layout="constrained")
    ax = figure.subplots()
    f = result.frequency_hz
    ax.semilogy(f, np.abs(result.measured), **{**MEASURED_STYLE, "ms": 4}, label="measured (held out)")
    predicted = np.abs(result.predicted)
    band = np.isfinite(result.abs_low) & np.isfinite(result.abs_high)
    if band.any():
        width = np.nanmax((result.abs_high - result.abs_low)[band] / predicted[band])
        ax.fill_between(f, np.where(band, result.abs_low, np.nan), np.where(band, result.abs_high, np.nan),
                        color="tab:red", alpha=0.2, lw=0,
                        label="95 % band" + (" (narrower than the line)" if width < 0.01 else ""))
    ax.semilogy(f, predicted, color="tab:red", lw=1.5, label=f"{result.label} (fitted on {_levels(result.kept, unit)})")
    ax.semilogy(f, np.abs(result.baseline_frf), color="0.35", ls="--", lw=1.2, label="log-amplitude baseline")
    c = result.compared
    ax.set_title(f"held-out level {result.level:g} {unit}: resonance {c['resonance_hz'].measured:.3f} Hz measured, "
                 f"{c['resonance_hz'].predicted:.3f} predicted", fontsize=9)
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel(f"|H| (m/{unit})")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7.5)
    return figure


def _levels(levels, unit: str) -> str:
    return ", ".join(f"{v:g}" for v in levels) + f" {unit}"


def summary_figure(validation) -> Figure:
    """Errors per held-out level and model (:class:`~nlupdate.core.validation.held_out.Validation`)."""
    unit = validation.reference_unit
    levels = sorted({r.level for r in validation.held_out})
    figure = _error_panels(validation.held_out, lambda r: levels.index(r.level), [f"{v:g}" for v in levels],
                           f"held-out level ({unit})", validation.repeatability)
    figure.suptitle("prediction errors at held-out levels (bars: 95 % bands; squares: log-amplitude baseline)",
                    fontsize=10)
    return figure


def response_controlled_figure(validation) -> Figure:
    """Errors per response-controlled run and model, predicted from every force-controlled
    level (:attr:`~nlupdate.core.validation.held_out.Validation.response_controlled`)."""
    held = sorted({r.held_m for r in validation.response_controlled})
    figure = _error_panels(validation.response_controlled, lambda r: held.index(r.held_m),
                           [f"{1e6 * v:.0f}" for v in held], "held response amplitude (µm)", validation.repeatability)
    figure.suptitle("response-controlled runs predicted from the force-controlled levels (bars: 95 % bands; "
                    "squares: log-amplitude baseline)", fontsize=10)
    return figure


def _error_panels(results, position, ticks: list[str], xlabel: str, repeatability) -> Figure:
    """Resonance, damping and peak errors of ``results`` (each with ``compared``,
    ``baseline`` and ``requested``) at ``position(result)`` on the x axis, one colour per
    model, the test's repeatability behind."""
    models = list(dict.fromkeys(r.requested for r in results))
    figure = Figure(figsize=(11, 3.8), layout="constrained")
    axes = figure.subplots(1, 3)
    panels = (("resonance_hz", "resonance error (Hz)", 1.0, repeatability.resonance_hz, False),
              ("damping_ratio", "damping ratio error (%)", 100.0, repeatability.damping_ratio, True),
              ("peak_abs", "peak |H| error (%)", 100.0, float("nan"), True))
    x = np.arange(len(ticks), dtype=float)
    offsets = np.linspace(-0.2, 0.2, len(models)) if len(models) > 1 else np.zeros(1)
    for ax, (name, label, scale, repeat, relative) in zip(axes, panels):
        for k, model in enumerate(models):
            rows = [r for r in results if r.requested == model]
            xs = np.array([x[position(r)] for r in rows]) + offsets[k]
            c = [r.compared[name] for r in rows]
            b = [r.baseline[name] for r in rows]
            if relative:
                err = np.array([scale * v.relative_error for v in c])
                low = np.array([scale * (v.low / v.measured - 1) for v in c])
                high = np.array([scale * (v.high / v.measured - 1) for v in c])
                base = np.array([scale * v.relative_error for v in b])
            else:
                err = np.array([v.error for v in c])
                low = np.array([v.low - v.measured for v in c])
                high = np.array([v.high - v.measured for v in c])
                base = np.array([v.error for v in b])
            yerr = np.vstack([np.where(np.isfinite(low), err - low, 0), np.where(np.isfinite(high), high - err, 0)])
            colour = _MODEL_COLOURS[k % len(_MODEL_COLOURS)]
            ax.errorbar(xs, err, yerr=yerr, fmt="o", color=colour, ms=5, capsize=3, label=model)
            ax.plot(xs + 0.08, base, "s", mfc="none", color="0.3", ms=6,
                    label="log-amplitude baseline" if k == 0 else None)
        if np.isfinite(repeat):
            span = scale * repeat
            if relative:
                mean_measured = np.mean([r.compared[name].measured for r in results])
                span = 100 * repeat / mean_measured
            ax.axhspan(-span, span, color="0.85", zorder=0, label="test repeatability ±1σ")
        ax.axhline(0.0, color="k", lw=0.8)
        ax.set_xticks(x, ticks)
        ax.set_xlim(-0.5, len(ticks) - 0.5)  # one slot per level, also for a single one
        ax.set_xlabel(xlabel)
        ax.set_ylabel(label)
        ax.grid(True, axis="y", alpha=0.3)
    axes[0].legend(fontsize=7)
    return figure
