"""What ``nlupdate validate`` prints of a held-out validation
(:class:`~nlupdate.core.validation.held_out.Validation`), the bad news first.

:func:`verdict_lines` opens the output: what the validation says before its numbers
(:func:`nlupdate.core.validation.verdict.said`: whether every held-out level, and every
response-controlled run predicted, lies within its 95 % bands, else each quantity that does
not, and how many of the values in band lie in bands that test nothing — a warning then; the
extrapolations, each comparison's notes and auto's warnings), everything that qualifies a
number before it. :func:`validation_lines` is the rest: the test's repeatability, one aligned
table per held-out level and model (each error with its band, which quantities the
measurement lies inside the band of, the residual over the noise) with the baseline's errors
in the row below, the same for the response-controlled runs, and auto's choices. Renders
only: every number, flag, count and warning comes from the validation.
"""
from __future__ import annotations

import numpy as np

from nlupdate.core.model.amplitude_modal import AmplitudeModalModel
from nlupdate.core.validation.verdict import HELD_NAMES, Said
from nlupdate.reporting.model_numbers import damping_text, linear_limit_text


def said_line(line: Said) -> str:
    """One :class:`~nlupdate.core.validation.verdict.Said` line for a terminal: ``warning:`` before a warning."""
    return f"warning: {line.text}" if line.warns else line.text


def said_markdown(line: Said) -> str:
    """One :class:`~nlupdate.core.validation.verdict.Said` line for the report: ``Warning:`` before a warning."""
    return f"Warning: {line.text}" if line.warns else line.text


def verdict_lines(validation, unit: str) -> list[str]:
    """The first lines, as a terminal prints them (:meth:`~nlupdate.core.validation.held_out.Validation.said`:
    the verdict, then every warning that qualifies the numbers below it)."""
    return [said_line(line) for line in validation.said(unit)]


def summary_headline(said: list[Said]) -> str | None:
    """The line a validation that warns opens the study report's summary with, from what it
    says (:meth:`~nlupdate.core.validation.held_out.Validation.said`): its first warning (a
    miss, an extrapolation, a note) and how many more open the validation section; None when
    nothing warns."""
    warned = [line.text for line in said if line.warns]
    if not warned:
        return None
    more = len(warned) - 1
    return warned[0] + (f" ({more} more warning{' opens' if more == 1 else 's open'} the validation section)" if more else "")


def repeatability_line(repeat, what: str) -> str:
    """The test's scatter (1σ) in the units the tables use."""
    trend = "a line" if repeat.degree == 1 else "a parabola" if repeat.degree == 2 else f"degree {repeat.degree}"
    return (f"test repeatability ({what}; 1σ about {trend} in log amplitude, {repeat.levels} curves): resonance "
            f"{repeat.resonance_hz:.3g} Hz, damping ratio {_percent(100 * repeat.damping_relative, sign=False)} % of "
            f"itself, peak |H| {_percent(100 * repeat.peak_relative, sign=False)} % of itself")


def _percent(value: float, sign: bool = True) -> str:
    if not np.isfinite(value):
        return "—"
    return f"{value:+.0f}" if sign and abs(value) >= 100 else f"{value:+.1f}" if sign else f"{value:.2g}"


def _bounds(c, relative: bool) -> str:
    if not (np.isfinite(c.low) and np.isfinite(c.high)):
        return ""
    if relative:
        return f" [{100 * (c.low / c.measured - 1):+.0f}, {100 * (c.high / c.measured - 1):+.0f}]"
    return f" [{c.low - c.measured:+.2f}, {c.high - c.measured:+.2f}]"


def error_cells(compared: dict, bands: bool) -> list[str]:
    """The resonance error (Hz) and the damping and peak errors (%), with their bands."""
    res, zeta, peak = compared["resonance_hz"], compared["damping_ratio"], compared["peak_abs"]
    frequency = f"{res.error:+.3f}" if np.isfinite(res.error) else "—"
    return [frequency + (_bounds(res, False) if bands else ""),
            _percent(100 * zeta.relative_error) + (_bounds(zeta, True) if bands else ""),
            _percent(100 * peak.relative_error) + (_bounds(peak, True) if bands else "")]


def in_band_cell(compared: dict) -> str:
    """Per quantity whether the measured value lies in the prediction's band (— without one),
    "yes (band uninformative)" where that band tests nothing (:mod:`nlupdate.core.validation.compared`)."""
    return ", ".join(in_band_word(c.inside, c.informative) for c in compared.values())


def in_band_word(inside: bool | None, informative: bool | None) -> str:
    """One quantity's "in band" cell: — (no band), NO, yes, or "yes (band uninformative)"."""
    return ("—" if inside is None else "NO" if not inside
            else "yes (band uninformative)" if informative is False else "yes")


#: The columns: each error with its 95 % band, whether the measured value lies in each band,
#: the prediction's residual over the measurement noise.
_HEADER = ("f error (Hz) [95 % band]", "ζ error (%) [band]", "peak error (%) [band]", "in band f, ζ, peak",
           "residual/noise")


def _table(first: str, second: str, rows) -> list[str]:
    """Rows of (first column, second column, model, comparison, baseline comparison,
    residual, baseline residual) as aligned text; the baseline's row below each."""
    cells = [(first, second, "model", *_HEADER)]
    for a, b, label, compared, baseline, residual, base_residual in rows:
        cells.append((a, b, label, *error_cells(compared, True), in_band_cell(compared), f"{residual:.3g}"))
        cells.append(("", "", "baseline (log-amplitude)", *error_cells(baseline, False), "", f"{base_residual:.3g}"))
    return _aligned(cells)


def _aligned(cells: list[tuple[str, ...]]) -> list[str]:
    """Rows of cells as text, each column as wide as its widest cell; a column empty throughout is left out."""
    widths = [max(len(row[k]) for row in cells) for k in range(len(cells[0]))]
    return ["  ".join(cell.ljust(w) for cell, w in zip(row, widths) if w).rstrip() for row in cells]


def validation_lines(validation, unit: str) -> list[str]:
    """Everything after the verdict: repeatability, the held-out levels' table, the
    response-controlled runs' table, auto's choices."""
    lines = [repeatability_line(validation.repeatability, "held-out levels")]
    lines += _table(f"level ({unit})", "", [(f"{r.level:g}", "", r.label, r.compared, r.baseline, r.residual_to_noise,
                                             r.baseline_residual_to_noise) for r in validation.held_out])
    runs = validation.response_controlled
    if runs:
        lines.append("")
        lines.append(repeatability_line(validation.runs_repeatability or validation.repeatability,
                                        "response-controlled runs"))
        lines += _table("response-controlled run", "held X (µm)",
                        [(r.run, f"{1e6 * r.held_m:.3g}", r.label, r.compared, r.baseline, r.residual_to_noise,
                          r.baseline_residual_to_noise) for r in runs])
    lines.append(RESIDUAL_LEGEND)
    for level, choice in validation.choices.items():
        lines.append(f"auto at {level:g} {unit}: {choice.name} — {choice.reason}")
    return lines


#: What the tables' last column is (validation.json's ``residual_to_noise``): printed bare, a
#: 728 or 4.94e+03 beside errors of a few per cent said nothing a user could act on.
RESIDUAL_LEGEND = ("residual/noise: the RMS over the curve's lines of |H predicted − H measured| over the measurement "
                   "noise there (the curve's estimated relative noise × |H|): about 1 is a prediction within the noise "
                   "of every line; compare a model's with the baseline's below it")


def held_type_worst_line(worst: dict) -> str:
    """The largest |relative error| of each quantity within the fitted amplitudes (validation.json's
    ``held_out_type.worst_within_fit``), as ``validate --hold-out-type`` and a study's report say it."""
    names = {**HELD_NAMES, "modal_amplitude_held": "held amplitude"}
    return "largest relative error within the fitted amplitudes: " + (
        ", ".join(f"{names.get(key, key)} {100 * value:.3g} %" for key, value in worst.items()) or "none within")


def held_type_rows(summary: dict, unit: str) -> list[str]:
    """The held-out type's table: for a held stepped sine one aligned row per level (measured,
    predicted with its band, in band or not: :func:`in_band_word`), for held impacts one row per
    impact and quantity (measured and predicted, each with its band, the error, in band or not),
    for other held samples one row each (:func:`_sample_rows`)."""
    if summary["test_type"] == "impact":
        return _impact_rows(summary["samples"])
    if not summary["levels"]:
        return _sample_rows(summary["samples"])
    cells = [(f"level ({unit})", "resonance (Hz): measured", "predicted [95 % band]", "damping (%): measured",
              "predicted [95 % band]", "peak error (%)", "in band f, ζ, peak")]
    for entry in summary["levels"]:
        res, zeta, peak = entry["resonance_hz"], entry["damping_ratio"], entry["peak_abs"]
        flags = ", ".join(in_band_word(c.get("inside"), c.get("informative")) for c in (res, zeta, peak))
        cells.append((f"{entry['level']:g}", f"{res['measured']:.3f}", f"{res['predicted']:.3f}" + _band(res, 1.0, 2),
                      f"{100 * zeta['measured']:.3g}", f"{100 * zeta['predicted']:.3g}" + _band(zeta, 100.0, None),
                      _percent(100 * peak["relative_error"]),
                      flags + ("" if entry["within_fit"] else " (outside the fitted amplitudes)")))
    return _aligned(cells)


def _impact_rows(samples: list[dict]) -> list[str]:
    """One aligned row per held impact and quantity: measured [its band], predicted [band],
    where the prediction is read (the impact's amplitude, or 0: the linear limit), error."""
    cells = [("impact", "quantity", "measured [95 % band]", "predicted [95 % band]", "predicted at (m·√kg)", "error",
              "in band")]
    for entry in samples:
        at = entry["predicted_at_modal_amplitude"]
        where = "0 (linear limit)" if at == 0 else f"{at:.3g}"
        for key, label, scale, unit, digits in (("natural_frequency_hz", "natural frequency", 1.0, "Hz", 4),
                                                ("damping_ratio", "damping ratio", 100.0, "%", 4)):
            c = entry[key]
            measured = f"{scale * c['measured']:.{digits}f} {unit}" + (
                f" [{scale * c['measured_low']:.{digits}f}, {scale * c['measured_high']:.{digits}f}]"
                if "measured_low" in c else "")
            predicted = f"{scale * c['predicted']:.{digits}f} {unit}" + (
                f" [{scale * c['low']:.{digits}f}, {scale * c['high']:.{digits}f}]" if "low" in c else "")
            error = (f"{c['error']:+.4f} Hz ({100 * c['relative_error']:+.3f} %)" if key == "natural_frequency_hz"
                     else f"{_percent(100 * c['relative_error'])} %")
            flag = in_band_word(c.get("inside"), c.get("informative"))
            cells.append((entry["source"], label, measured, predicted, where, error, flag))
    return _aligned(cells)


def _sample_rows(samples: list[dict]) -> list[str]:
    """One aligned row per held sample (a ring-down's, a response-controlled run's, a
    phase-resonance point's): its modal amplitude, measured and predicted frequency and damping
    ratio with the prediction's band, the errors, in band or not — validation.json's
    ``samples``, which the terminal summarised in one line of the largest errors."""
    cells = [("modal amplitude (m·√kg)", "frequency (Hz): measured", "predicted [95 % band]", "error (%)",
              "damping (%): measured", "predicted [95 % band]", "error (%)", "in band f, ζ")]
    for entry in samples:
        f, zeta = entry["natural_frequency_hz"], entry["damping_ratio"]
        flags = ", ".join(in_band_word(c.get("inside"), c.get("informative")) for c in (f, zeta))
        cells.append((f"{entry['modal_amplitude']:.3g}", f"{f['measured']:.3f}", f"{f['predicted']:.3f}" + _band(f, 1.0, 2),
                      f"{100 * f['relative_error']:+.3f}", f"{100 * zeta['measured']:.3g}",
                      f"{100 * zeta['predicted']:.3g}" + _band(zeta, 100.0, None), _percent(100 * zeta["relative_error"]),
                      flags if entry["within_fit"] else "— (outside the fitted amplitudes: extrapolated)"))
    return _aligned(cells) if samples else []


def _band(compared: dict, scale: float, decimals: int | None) -> str:
    if "low" not in compared:
        return ""
    low, high = scale * compared["low"], scale * compared["high"]
    return f" [{low:.{decimals}f}, {high:.{decimals}f}]" if decimals is not None else f" [{low:.3g}, {high:.3g}]"


def _held_type(validation) -> tuple[dict, list[Said], list[str]] | None:
    """``[validation] hold_out_type``'s summary (validation.json's ``held_out_type``), what it
    says before its numbers and its table rows (:func:`held_type_rows`); None without one."""
    held = getattr(validation, "held_type", None)
    if held is None:
        return None
    return held.summary(), held.said(validation.reference_unit), held_type_rows(held.summary(),
                                                                               validation.reference_unit)


def held_type_summary(validation) -> list[str]:
    """The summary's line on the held-out test type: its verdict (bold when it warns), what
    the model was fitted on and the largest errors within the fitted amplitudes."""
    found = _held_type(validation)
    if found is None:
        return []
    summary, said, _ = found
    verdict = said[0].text
    kinds = ", ".join(dict.fromkeys(entry["test_type"] for entry in summary["fitted_on"]))
    text = f"{verdict} (model fitted on {kinds}); {held_type_worst_line(summary['worst_within_fit'])}"
    more = len(said) - 1
    text += f" ({more} more warning{'s' if more > 1 else ''} in the validation section)" if more else ""
    return [f"* **Held-out test type**: **{text}**" if said[0].warns
            else f"* **Held-out test type**: {text}"]


def held_type_section(validation) -> list[str]:
    found = _held_type(validation)
    if found is None:
        return []
    summary, said, rows = found
    model = summary["model"]
    kinds = ", ".join(f"{entry['source']} ({entry['test_type']}, {entry['samples']})" for entry in summary["fitted_on"])
    fitted = AmplitudeModalModel.from_dict(model)
    lines = [f"### A whole test type held out: {summary['test_type']}", "",
             f"The amplitude-dependent modal model ({model['backbone']} backbone) fitted on {kinds} — "
             f"{linear_limit_text(fitted)}, {damping_text(fitted)} — predicts "
             f"the held-out {summary['test_type']} (validation.json's `held_out_type`, as `nlupdate validate "
             f"--hold-out-type` writes it):", ""]
    lines += [said_markdown(line) for line in said]
    lines += [""] + (["```", *rows, "```", ""] if rows else [])
    return lines + [held_type_worst_line(summary["worst_within_fit"]) + ".", ""]
