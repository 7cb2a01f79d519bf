"""What ``nlupdate validate`` prints of a held-out validation
(:class:`~nlupdate.core.validation.held_out.Validation`), the bad news first.

:func:`verdict_lines` opens the output: whether every held-out level (and every
response-controlled run predicted) lies within its 95 % bands, else each quantity that does
not, naming level and model, and how many of the values in band lie in bands that test
nothing (:func:`uninformative_clause`; a warning then); then the extrapolations, each comparison's notes and auto's
warnings — everything that qualifies a number comes before it. :func:`validation_lines` is
the rest: the test's repeatability, one aligned table per held-out level and model (each
error with its band, which quantities the measurement lies inside the band of, the residual
over the noise) with the baseline's errors in the row below, the same for the
response-controlled runs, and auto's choices. Renders only: every number and flag comes from the validation.
"""
from __future__ import annotations

import numpy as np

from nlupdate.core.model.amplitude_modal import AmplitudeModalModel
from nlupdate.reporting.markdown import number
from nlupdate.reporting.model_numbers import damping_text, linear_limit_text

QUANTITY_NAMES = {"resonance_hz": "resonance", "damping_ratio": "damping ratio", "peak_abs": "peak |H|"}
#: the quantities a held-out test type is judged on: a held stepped sine's, and a held sample's frequency
HELD_NAMES = {**QUANTITY_NAMES, "natural_frequency_hz": "natural frequency"}


def _outside(result) -> list[str]:
    """The quantities of one comparison whose measured value lies outside the band, or
    that have no predicted value."""
    return [QUANTITY_NAMES[key] for key, c in result.compared.items()
            if c.inside is False or not np.isfinite(c.predicted)]


def verdict_lines(validation, unit: str) -> list[str]:
    """The first lines: every held-out level (and predicted run) inside its bands, or each
    one that is not (the first line then starts with ``warning:``); each held-out level outside
    the kept levels and each response-controlled run outside the kept amplitudes (an
    extrapolation, once each); what the table cannot show of each comparison
    (:func:`comparison_notes`: a measured damping ratio the lines do not resolve, a band from
    the in-sample misfit, ...) and the response-controlled runs' notes (a model that cannot
    predict them, their modal constants against the one the models take), before the numbers
    they qualify; auto's warnings."""
    misses = [f"{r.level:g} {unit} {', '.join(_outside(r))} ({r.label})" for r in validation.held_out if _outside(r)]
    misses += [f"{r.run} {', '.join(_outside(r))} ({r.label})" for r in validation.response_controlled
               if _outside(r)]
    what = "held-out level" + (" and response-controlled run" if validation.response_controlled else "")
    idle = uninformative_clause([*validation.held_out, *validation.response_controlled])
    outside = _extrapolated_clause(validation, unit)
    if misses:
        lines = [f"warning: measured OUTSIDE the prediction's 95 % band: {'; '.join(misses)}"
                 + (f"; {idle}" if idle else "")]
    elif idle or outside:
        lines = [f"warning: every {what}'s resonance, damping ratio and peak |H| lies within its prediction's 95 % "
                 f"band, but {'; '.join(text for text in (idle, outside) if text)}"]
    else:
        lines = [f"every {what}'s resonance, damping ratio and peak |H| lies within its prediction's 95 % band"]
    lines += [f"warning: {w}" for w in dict.fromkeys(r.extrapolation for r in (*validation.held_out,
                                                                                *validation.response_controlled)
                                                       if r.extrapolation)]
    lines += [f"warning: at {r.level:g} {unit} ({r.label}): {note}" for r in validation.held_out
              for note in comparison_notes(r)]
    lines += [f"warning: at {r.run} ({r.label}): {note}" for r in validation.response_controlled
              for note in comparison_notes(r)]
    lines += [f"warning: response-controlled runs: {note}" for note in validation.response_controlled_notes]
    return lines + [f"warning: {choice.warning}" for choice in validation.choices.values() if choice.warning]


def _extrapolated_clause(validation, unit: str) -> str:
    """The held-out levels and runs outside what the fit kept ('' when none is): an all-in-band
    verdict on them alone read as a confident pass (the transmitter beam's ``--hold-out top``:
    "every held-out level … lies within its prediction's 95 % band", the warning that 0.45 V
    is an extrapolation after it)."""
    names = list(dict.fromkeys([f"{r.level:g} {unit}" for r in validation.held_out if r.extrapolation]
                               + [r.run for r in validation.response_controlled if r.extrapolation]))
    if not names:
        return ""
    return (f"{', '.join(names)} {'lies' if len(names) == 1 else 'lie'} outside what the fit kept, where a band does "
            f"not measure the form's error")


def in_band_counts(results, keys: tuple[str, ...] | None = None) -> tuple[int, int, int]:
    """(values with a band, values inside it, of those the ones whose band is uninformative:
    :attr:`~nlupdate.core.validation.compared.Compared.informative` False) over ``results``'
    quantities ``keys`` (every one compared when None)."""
    compared = [c for r in results for key, c in r.compared.items()
                if (keys is None or key in keys) and c.inside is not None]
    inside = [c for c in compared if c.inside]
    return len(compared), len(inside), sum(c.informative is False for c in inside)


def uninformative_clause(results) -> str:
    """How many in-band values of ``results`` lie in uninformative bands, they test nothing
    ('' when none does)."""
    return counted_clause(*in_band_counts(results))


def counted_clause(banded: int, inside: int, idle: int, single: bool = False) -> str:
    """:func:`uninformative_clause` of counts (values with a band, inside it, of those in
    uninformative bands): '' when none is. ``single``: the held test is one value, judged against
    the kept sources' spread (:mod:`nlupdate.core.validation.held_type`)."""
    if not idle:
        return ""
    spread = ("the kept sources' spread of the quantity (one held value has none of its own) and than its own "
              "resolution" if single else "the test's own spread of the quantity over its curves and than its "
              "resolution (a resonance band: or than the measured lines)")
    return f"{inside} of {banded} values in band, {idle} of them in bands wider than twice {spread}: they test nothing"


def summary_headline(validation, unit: str) -> str | None:
    """The line a validation that warns opens the study report's summary with: its first
    warning (a miss, an extrapolation, a note; :func:`verdict_lines`) and how many more open
    the validation section; None when nothing warns."""
    warned = [line.removeprefix("warning: ") for line in verdict_lines(validation, unit) if line.startswith("warning: ")]
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


def comparison_notes(result) -> list[str]:
    """What the table cannot show of one comparison: no predicted value, the prediction
    outside its own band, a half-power band of few lines, the model's own note."""
    notes = []
    for key, c in result.compared.items():
        name = QUANTITY_NAMES.get(key, key)
        if not np.isfinite(c.predicted):
            notes.append(f"no predicted {name} (the predicted curve gives none)")
        elif c.predicted_inside is False:
            notes.append(f"the predicted {name} {c.predicted:.6g} lies OUTSIDE its own 95 % band [{c.low:.6g}, "
                         f"{c.high:.6g}]")
    if result.half_power_lines < 5:
        notes.append(f"the measured half-power band spans {result.half_power_lines} lines: its damping ratio is "
                     f"poorly resolved")
    if result.note:
        notes.append(result.note)
    return notes


def held_type_worst_line(worst: dict) -> str:
    """The largest |relative error| of each quantity within the fitted amplitudes (validation.json's
    ``held_out_type.worst_within_fit``), as ``validate --hold-out-type`` and a study's report say it."""
    names = {**HELD_NAMES, "modal_amplitude_held": "held amplitude"}
    return "largest relative error within the fitted amplitudes: " + (
        ", ".join(f"{names.get(key, key)} {100 * value:.3g} %" for key, value in worst.items()) or "none within")


def held_type_lines(summary: dict, unit: str) -> list[str]:
    """What ``nlupdate validate --hold-out-type`` prints of validation.json's
    ``held_out_type`` entry (:meth:`~nlupdate.core.validation.held_type.HeldType.summary`),
    the bad news first: an impact compared with the model's linear limit extrapolated to zero
    amplitude (said before anything else); each held-out level or sample whose measured value
    lies outside the prediction's 95 % band; the fitted model's own warnings (its linear limit
    extrapolated or on a bound, a poor fit: ``warning:`` lines, in validation.json only
    before); the verdict counts the in-band values whose band tests nothing
    (:func:`held_type_in_band`, validation.json's ``informative``: the rule of the held-out
    levels) and warns then; then, for a held stepped sine, one aligned row per level (measured,
    predicted with its band, in band or not: :func:`in_band_word`), for held impacts one row per
    impact and quantity (measured and predicted, each with its band, the error, in band or not)."""
    names = HELD_NAMES
    misses = [f"{entry['level']:g} {unit} {names[key]}" for entry in summary["levels"]
              for key in ("resonance_hz", "damping_ratio", "peak_abs") if entry[key].get("inside") is False]
    sampled = [entry for entry in summary["samples"] if entry["within_fit"]]
    extrapolated = [entry for entry in summary["samples"] if "extrapolation" in entry]
    for key in ("natural_frequency_hz", "damping_ratio"):
        count = sum(entry[key].get("inside") is False for entry in sampled)
        if count:
            misses.append(f"{names[key]} of {count} of the {len(sampled)} held-out samples within the fitted amplitudes")
        misses += [f"{names[key]} of {entry['source']} (its linear limit)" for entry in extrapolated
                   if entry[key].get("inside") is False]
    what = f"{summary['test_type']} held out"
    idle = counted_clause(*held_type_in_band(summary), single=len(summary["samples"]) == 1 and not summary["levels"])
    if extrapolated:  # first: every number below it qualifies
        banded = all("inside" in entry[key] for entry in extrapolated for key in ("natural_frequency_hz",
                                                                                   "damping_ratio"))
        verdict = (f"measured OUTSIDE the prediction's 95 % band: {'; '.join(misses)}" if misses
                   else "measured within the prediction's 95 % band" if banded
                   else "without a band (no bootstrap refits: --bootstrap N)")
        lines = [f"warning: {what}: {'; '.join(entry['extrapolation'] for entry in extrapolated)}; {verdict}"
                 + (f"; {idle}" if idle else "")]
    elif misses:
        lines = [f"warning: {what}: measured OUTSIDE the prediction's 95 % band: {'; '.join(misses)}"
                 + (f"; {idle}" if idle else "")]
    elif not summary["levels"] and not sampled:
        lines = [f"warning: {what}: no held-out sample lies within the fitted amplitudes: each prediction is an "
                 f"extrapolation, without a band"]
    elif idle:
        lines = [f"warning: {what}: every measured value within the fitted amplitudes lies within the prediction's "
                 f"95 % band, but {idle}"]
    else:
        lines = [f"{what}: every measured value within the fitted amplitudes lies within the prediction's 95 % band"]
    lines += [f"warning: the model fitted without {summary['test_type']}: {warning}"
              for warning in summary["model"].get("warnings", [])]
    if summary["test_type"] == "impact":
        return lines + _impact_rows(summary["samples"])
    if not summary["levels"]:
        return lines + _sample_rows(summary["samples"])
    cells = [(f"level ({unit})", "resonance (Hz): measured", "predicted [95 % band]", "damping (%): measured",
              "predicted [95 % band]", "peak error (%)", "in band f, ζ, peak")]
    for entry in summary["levels"]:
        res, zeta, peak = entry["resonance_hz"], entry["damping_ratio"], entry["peak_abs"]
        flags = ", ".join(in_band_word(c.get("inside"), c.get("informative")) for c in (res, zeta, peak))
        cells.append((f"{entry['level']:g}", f"{res['measured']:.3f}", f"{res['predicted']:.3f}" + _band(res, 1.0, 2),
                      f"{100 * zeta['measured']:.3g}", f"{100 * zeta['predicted']:.3g}" + _band(zeta, 100.0, None),
                      _percent(100 * peak["relative_error"]),
                      flags + ("" if entry["within_fit"] else " (outside the fitted amplitudes)")))
    return lines + _aligned(cells)


def held_type_in_band(summary: dict) -> tuple[int, int, int]:
    """:func:`in_band_counts` of validation.json's ``held_out_type`` entry: over every level's
    quantities, the samples within the fitted amplitudes and the impacts compared at the
    linear limit (those the verdict judges) — values with a band, inside it, of those in
    uninformative bands (``informative`` false)."""
    entries = [*summary["levels"], *(entry for entry in summary["samples"]
                                     if entry["within_fit"] or "extrapolation" in entry)]
    compared = [c for entry in entries for key, c in entry.items()
                if key in HELD_NAMES and isinstance(c, dict) and "inside" in c]
    inside = [c for c in compared if c["inside"]]
    return len(compared), len(inside), sum(c.get("informative") is False for c in inside)


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


def held_type_said(validation) -> tuple[dict, list[str], list[str]] | None:
    """``[validation] hold_out_type``'s summary (validation.json's ``held_out_type``), its
    verdict and warning lines and its table rows (:func:`held_type_lines`); None without one."""
    held = getattr(validation, "held_type", None)
    if held is None:
        return None
    summary = held.summary()
    lines = held_type_lines(summary, validation.reference_unit)
    said = [lines[0]] + [line for line in lines[1:] if line.startswith("warning: ")]
    return summary, said, [line for line in lines[1:] if not line.startswith("warning: ")]


def held_type_summary(validation) -> list[str]:
    """The summary's line on the held-out test type: its verdict (bold when it warns), what
    the model was fitted on and the largest errors within the fitted amplitudes."""
    found = held_type_said(validation)
    if found is None:
        return []
    summary, said, _ = found
    verdict = said[0].removeprefix("warning: ")
    kinds = ", ".join(dict.fromkeys(entry["test_type"] for entry in summary["fitted_on"]))
    text = f"{verdict} (model fitted on {kinds}); {held_type_worst_line(summary['worst_within_fit'])}"
    more = len(said) - 1
    text += f" ({more} more warning{'s' if more > 1 else ''} in the validation section)" if more else ""
    return [f"* **Held-out test type**: **{text}**" if said[0].startswith("warning: ")
            else f"* **Held-out test type**: {text}"]


def held_type_section(validation) -> list[str]:
    found = held_type_said(validation)
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
    lines += [f"Warning: {line.removeprefix('warning: ')}" if line.startswith("warning: ") else line for line in said]
    lines += [""] + (["```", *rows, "```", ""] if rows else [])
    return lines + [held_type_worst_line(summary["worst_within_fit"]) + ".", ""]
