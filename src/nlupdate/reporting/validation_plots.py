"""Figures of a held-out validation: one per held-out level and one summary.

Per held-out level (:func:`held_out_figure`): |H| measured (points), the model's prediction
(line) with its 95 % band (shaded; the legend says when it is narrower than the line), and
the log-amplitude baseline (dashed); the y axis spans the curves (a band reaching far below
them is cut at the axis, and the legend says so), the legend sits below the axes. Summary
(:func:`summary_figure`): per held-out level and model, the resonance error (Hz) and the
damping and peak errors (%), each with the band as an error bar and the baseline's error
beside it (open markers), and the test's repeatability (±1σ, grey: in Hz, and the relative
scatter of the damping ratio and the peak) behind each panel, the legend below the panels;
the damping and peak panels on a log axis of predicted/measured, labelled in % error.
The response-controlled runs (:func:`response_controlled_figure`) the same, per run, with
the repeatability their bands use (levels and runs pooled).
"""
from __future__ import annotations

import textwrap

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter, LogLocator, MaxNLocator, NullFormatter

from nlupdate.core.validation.held_out import FLAT_BEYOND
from nlupdate.reporting.figures import MEASURED_STYLE

_MODEL_COLOURS = ("tab:red", "tab:blue", "tab:green", "tab:purple", "tab:orange", "tab:brown")


#: How far (a factor) the y axis of a held-out figure reaches beyond the curves it shows.
_Y_MARGIN = 3.0


def held_out_figure(result, unit: str = "N", evidence: str = "") -> Figure:
    """One held-out level (:class:`~nlupdate.core.validation.held_out.HeldOut`); ``evidence``
    names what the fit kept beside the levels (response-controlled runs, a linear limit), so
    the legend says everything the prediction was fitted on."""
    figure = Figure(figsize=(7.5, 5.2), layout="constrained")
    ax = figure.subplots()
    f = result.frequency_hz
    measured, predicted, base = np.abs(result.measured), np.abs(result.predicted), np.abs(result.baseline_frf)
    shown = np.concatenate([v[np.isfinite(v) & (v > 0)] for v in (measured, predicted, base)])
    bottom, top = shown.min() / _Y_MARGIN, shown.max() * _Y_MARGIN
    ax.semilogy(f, measured, **{**MEASURED_STYLE, "ms": 4}, label="measured (held out)", zorder=3)
    band = np.isfinite(result.abs_low) & np.isfinite(result.abs_high)
    if band.any():
        width = np.nanmax((result.abs_high - result.abs_low)[band] / predicted[band])
        cut = bool(np.any(result.abs_low[band] < bottom) or np.any(result.abs_high[band] > top))
        ax.fill_between(f, np.where(band, result.abs_low, np.nan), np.where(band, result.abs_high, np.nan),
                        color="tab:red", alpha=0.2, lw=0,
                        label="95 % band of the prediction" + (" (narrower than the line)" if width < 0.01 else "")
                        + (" (cut at the axis)" if cut else ""))
    fitted_on = _levels(result.kept, unit) + (f" + {evidence}" if evidence else "")
    ax.semilogy(f, predicted, color="tab:red", lw=1.5,
                label=textwrap.fill(f"predicted: {result.label} (fitted on {fitted_on})", 60,
                                    break_on_hyphens=False))
    ax.semilogy(f, base, color="0.35", ls="--", lw=1.2, label="log-amplitude baseline")
    ax.set_ylim(bottom, top)
    c = result.compared
    outside = bool(getattr(result, "extrapolation", ""))  # the terminal's warning, on the figure it qualifies
    ax.set_title(f"held-out level {result.level:g} {unit}: resonance {c['resonance_hz'].measured:.3f} Hz measured, "
                 f"{c['resonance_hz'].predicted:.3f} Hz predicted"
                 + ("\nEXTRAPOLATED: outside the kept levels (the band does not measure the form's error)"
                    if outside else "")
                 + ("\nthe polynomial backbone is held flat beyond the largest kept sample (the curve's kinks)"
                    if outside and FLAT_BEYOND in result.extrapolation else ""), fontsize=9, color="firebrick" if outside else "black")
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel(f"|H| (m/{unit})")
    ax.grid(True, which="both", alpha=0.3)
    figure.legend(loc="outside lower center", ncols=2, fontsize=7.5, frameon=False)
    return figure


def _levels(levels, unit: str) -> str:
    return ", ".join(f"{v:g}" for v in levels) + f" {unit}"


def summary_figure(validation) -> Figure:
    """Errors per held-out level and model (:class:`~nlupdate.core.validation.held_out.Validation`);
    a level outside the kept levels (an extrapolation, whose band does not measure the form's
    error) is starred on the axis, as :func:`response_controlled_figure` stars its runs."""
    unit = validation.reference_unit
    levels = sorted({r.level for r in validation.held_out})
    outside = {r.level for r in validation.held_out if r.extrapolation}  # outside the kept levels, as runs are starred
    figure = _error_panels(validation.held_out, lambda r: levels.index(r.level),
                           [f"{v:g}" + ("*" if v in outside else "") for v in levels],
                           f"held-out level ({unit}); *: extrapolated" if outside else f"held-out level ({unit})",
                           validation.repeatability)
    figure.suptitle("prediction errors at held-out levels (bars: 95 % bands; squares: log-amplitude baseline)",
                    fontsize=10)
    return figure


def response_controlled_figure(validation) -> Figure:
    """Errors per response-controlled run and model, predicted from every force-controlled
    level (:attr:`~nlupdate.core.validation.held_out.Validation.response_controlled`) and the
    linear limit when one was kept (the title says so), the repeatability behind them the one
    their bands use; a run held outside the kept amplitudes is starred on the axis."""
    held = sorted({r.held_m for r in validation.response_controlled})
    outside = {r.held_m for r in validation.response_controlled if r.extrapolation}
    repeat = validation.runs_repeatability or validation.repeatability
    figure = _error_panels(validation.response_controlled, lambda r: held.index(r.held_m),
                           [f"{1e6 * v:.0f}" + ("*" if v in outside else "") for v in held],
                           "held amplitude (µm); *: extrapolated" if outside else "held response amplitude (µm)",
                           repeat)  # * outside the amplitudes the kept data cover
    kept = " and the impact's linear limit" if getattr(validation, "linear_limit", None) is not None else ""
    figure.suptitle(f"response-controlled runs predicted from the force-controlled levels{kept} (bars: 95 % bands; "
                    "squares: log-amplitude baseline)", fontsize=10)
    return figure


def _model_label(rows) -> str:
    """The model as asked for, with auto's choice when it is one model for every row."""
    labels = set(r.label for r in rows)
    return labels.pop() if len(labels) == 1 else f"{rows[0].requested} (model per level)"


def _error_panels(results, position, ticks: list[str], xlabel: str, repeatability) -> Figure:
    """Resonance, damping and peak errors of ``results`` (each with ``compared``,
    ``baseline`` and ``requested``) at ``position(result)`` on the x axis, one colour per
    model, the test's repeatability (±1σ: Hz, and relative for the damping ratio and the
    peak) behind each panel, one legend below the panels. The damping and peak panels are
    drawn as the ratio predicted/measured on a log axis labelled in % error: a band of
    −90 … +1300 % then takes as much room as its factor 10 either way and leaves the other
    levels readable (on a linear axis it flattened them to a line)."""
    models = list(dict.fromkeys(r.requested for r in results))
    figure = Figure(figsize=(11, 4.3), layout="constrained")
    axes = figure.subplots(1, 3)
    panels = (("resonance_hz", "resonance error (Hz)", repeatability.resonance_hz, False),
              ("damping_ratio", "damping ratio error (%, log scale)", repeatability.damping_relative, True),
              ("peak_abs", "peak |H| error (%, log scale)", repeatability.peak_relative, True))
    x = np.arange(len(ticks), dtype=float)
    offsets = np.linspace(-0.2, 0.2, len(models)) if len(models) > 1 else np.zeros(1)
    for ax, (name, label, repeat, relative) in zip(axes, panels):
        drawn = []
        for k, model in enumerate(models):
            rows = [r for r in results if r.requested == model]
            xs = np.array([x[position(r)] for r in rows]) + offsets[k]
            c = [r.compared[name] for r in rows]
            b = [r.baseline[name] for r in rows]
            if relative:  # predicted / measured; a non-positive band edge has no place on the log axis
                err = np.array([v.predicted / v.measured for v in c])
                low = np.array([v.low / v.measured if v.low > 0 else np.nan for v in c])
                high = np.array([v.high / v.measured for v in c])
                base = np.array([v.predicted / v.measured for v in b])
            else:
                err = np.array([v.error for v in c])
                low = np.array([v.low - v.measured for v in c])
                high = np.array([v.high - v.measured for v in c])
                base = np.array([v.error for v in b])
            yerr = np.vstack([np.where(np.isfinite(low), err - low, 0), np.where(np.isfinite(high), high - err, 0)])
            colour = _MODEL_COLOURS[k % len(_MODEL_COLOURS)]
            ax.errorbar(xs, err, yerr=np.where(np.isfinite(yerr), yerr, 0), fmt="o", color=colour, ms=5, capsize=3,
                        label=f"{_model_label(rows)}, 95 % band" if name == "resonance_hz" else None)
            ax.plot(xs + 0.08, base, "s", mfc="none", color="0.3", ms=6,
                    label="log-amplitude baseline" if k == 0 and name == "resonance_hz" else None)
            drawn += [err, low, high, base]
        if np.isfinite(repeat):
            span = (np.exp(-repeat), np.exp(repeat)) if relative else (-repeat, repeat)
            ax.axhspan(*span, color="0.85", zorder=0,
                       label=f"test repeatability ±1σ ({repeatability.levels} curves)"
                       if name == "resonance_hz" else None)
        ax.axhline(1.0 if relative else 0.0, color="k", lw=0.8)
        if relative:
            _ratio_axis(ax, np.concatenate(drawn))
        ax.set_xticks(x, ticks)
        ax.set_xlim(-0.5, len(ticks) - 0.5)  # one slot per level, also for a single one
        ax.set_xlabel(xlabel)
        ax.set_ylabel(label)
        ax.grid(True, axis="y", alpha=0.3)
    figure.legend(loc="outside lower center", ncols=len(models) + 2, fontsize=8, frameon=False)
    return figure


def _ratio_axis(ax, ratios: np.ndarray) -> None:
    """A log axis of predicted/measured ratios, its ticks labelled as % errors."""
    ratios = ratios[np.isfinite(ratios) & (ratios > 0)]
    low, high = min(ratios.min(initial=1.0), 0.9), max(ratios.max(initial=1.0), 1.1)
    ax.set_yscale("log")
    ax.set_ylim(low / 1.1, high * 1.1)
    if high / low > 4:
        ax.yaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
    else:
        ax.yaxis.set_major_locator(MaxNLocator(7, steps=[1, 2, 2.5, 5, 10]))  # round % errors
    ax.yaxis.set_minor_formatter(NullFormatter())
    ax.yaxis.set_major_formatter(FuncFormatter(lambda y, _: "0" if abs(y - 1) < 1e-9 else f"{100 * (y - 1):+.3g}".replace("-", "−")))
