"""``report.md``: a run archive's report, written to be read top to bottom.

It opens with a line saying so when no updating run converged (and why each stopped),
then the warnings about results that should not be trusted as they stand
(:func:`nlupdate.study.steps.trust.study_warnings`, a best model that predicts worse than the
initial one first; the CLI prints the summary, so they reach the terminal too) and the
answer (identified nonlinearity, updated parameters with their
uncertainty, how well the updated nonlinear model predicts every force level), then
shows how each step got there, with the plots linked beside the numbers. For a
simulated study the hidden truth is printed beside every estimate.
"""
from __future__ import annotations

import re
from typing import Any, Mapping

import numpy as np
import pandas as pd

from nlupdate.reporting.amplitude_report import amplitude_section, amplitude_summary, amplitude_warnings
from nlupdate.reporting.fe_validation_report import fe_validation_section, fe_validation_summary
from nlupdate.reporting.identification_report import identification_section
from nlupdate.reporting.markdown import markdown_table, number, run_line
from nlupdate.reporting.validation_text import (error_cells, held_type_section, held_type_summary, in_band_cell,
                                                repeatability_line, said_markdown, summary_headline)
from nlupdate.core.measurement.units import table_reference_unit
from nlupdate.core.correlation.metrics import FRAC_MEANING
from nlupdate.core.identification.methods import METHODS
from nlupdate.core.identification.trust import warning_texts
from nlupdate.core.response.method import describe
from nlupdate.core.updating.sensitivity import FORMULA_LABELS, ORDER_MEANING, order_labels
from nlupdate.core.updating.runs import best_ranked

UNCERTAINTY_NOTE = ("± is one standard deviation (Monte Carlo over the measurement-noise model for identified values; "
                    "propagated through the updating sensitivities for updated parameters); the identified values' "
                    "95 % intervals, which also carry model-form error, are in the identification section")


def _plot_files(plots: Mapping[str, str]) -> list[str]:
    """The report's line listing ``plots/*.png``, none when the folder holds none."""
    names = sorted(name for name in plots.values() if name.startswith("plots/"))
    return ["* `plots/*.png` — " + ", ".join(f"`{name}`" for name in names)] if names else []


#: why an updated parameter has no ± (the table's note and the summary say it)
NO_TARGET_STD = "no uncertainty: the targets state no std_hz"
#: what the "Nσ off" beside a value and its truth says (:func:`_with_truth`)
SIGMA_OFF_MEANING = "the truth lies N standard deviations (N times the ±) from the value"


def formula_orders(names) -> list[str]:
    """The O(·) of the difference formulas the run ``names`` mention, lowest order first."""
    return order_labels([f for f, label in FORMULA_LABELS.items() if any(label in name for name in names)])


def terms_line(result, text: str) -> str:
    """``Terms: …``: what the words of ``text`` (the summary) that a new reader cannot know
    stand for, each from its owner: the identification method's name
    (:data:`~nlupdate.core.identification.methods.METHODS`), an identified element parameter's
    meaning (its element's declaration: ``Identification.parameter_meanings``; the numbered copies
    of a repeated element, ``kf_1, kf_2``, in one term), an updating parameter's
    ``description`` (``[[parameters]]``), a difference formula's O(·)
    (:data:`~nlupdate.core.updating.sensitivity.ORDER_MEANING`), "σ off" and FRAC; '' when
    it uses none of them."""
    terms = []
    ident = result.identification
    if ident is not None and ident.settings.method.upper() in text:
        terms.append(f"{ident.settings.method.upper()} = {METHODS[ident.settings.method].long_name} "
                     "(the identification method)")
    if ident is not None:
        for names, meaning in ident.parameter_meanings():
            used = [name for name in names if re.search(rf"(?<!\w){re.escape(name)}(?!\w)", text)]
            if used:
                terms.append(f"{', '.join(used)} = {meaning}")
    terms += [f"{p.name} = {p.description}" for p in result.study.parameters
              if p.description and f"{p.name} = " in text]
    orders = formula_orders([text])
    if orders:
        terms.append(f"{', '.join(orders)} = {ORDER_MEANING}")
    if "σ off" in text:
        terms.append(f"Nσ off = {SIGMA_OFF_MEANING}")
    if "FRAC" in text:
        terms.append(f"FRAC = {FRAC_MEANING}")
    return "Terms: " + "; ".join(terms) + "." if terms else ""


def _with_truth(value: float, std: float | None, truth: float | None, scale: float = 1.0, unit: str = "",
                missing: str = "no uncertainty") -> str:
    """``value ± std unit`` with the truth and how many σ off it; without a std (None or NaN)
    the value alone and ``missing`` (why there is none) — never "± –"."""
    known = std is not None and bool(np.isfinite(std))
    text = (f"{number(value / scale)} ± {number(std / scale, 2)} {unit}" if known
            else f"{number(value / scale)} {unit}").rstrip()
    notes = [] if known else [missing]
    if truth is not None:
        truth_text = f"truth {number(truth / scale)}{' ' + unit if unit else ''}"
        notes.insert(0, f"{truth_text}; {number(abs(value - truth) / std, 2)}σ off" if known and std > 0 else truth_text)
    notes = [note for note in notes if note]
    return text + (f" ({'; '.join(notes)})" if notes else "")


def report_markdown(result, manifest: Mapping[str, Any], plots: Mapping[str, str]) -> str:
    """The report of a :class:`~nlupdate.study.sequential.StudyResult` with its manifest; ``plots``
    maps plot keys to their paths relative to the archive."""
    study = result.study
    truth = study.hidden_truth
    lines = [f"# Study `{study.name}`", ""]
    if study.description:
        lines += [study.description, ""]
    lines += [run_line(manifest), ""]

    lines += ["## Summary", ""]
    headline = none_converged_line(result.runs)
    lines += [f"**{headline[0]}**{headline[1]}", ""] if headline else []
    warned = _warning_lines(result)
    lines += warned
    summary = _summary_lines(result, truth)
    lines += summary or ["(nothing was computed)"]
    terms = terms_line(result, "\n".join(warned + summary))
    lines += ["", terms] if terms else []
    lines += [""] + ([f"_{UNCERTAINTY_NOTE}._", ""] if result.identification is not None or result.runs else [])
    if result.failures:
        lines += ["**Failed updating runs** (the others finished):", ""]
        lines += [f"* `{f.name}`: {f.error}" for f in result.failures] + [""]

    if result.measured is not None:
        lines += ["## Measured data", ""]
        sim = study.measured.simulate
        if sim is not None:
            lines += [f"Simulated stepped-sine test (sweep {sim.sweep}) of the hidden truth at "
                      f"{', '.join(f'{f:g}' for f in sim.forces_n)} N, {len(sim.frequencies_hz)} frequencies "
                      f"{min(sim.frequencies_hz):g}–{max(sim.frequencies_hz):g} Hz, noise {100 * sim.noise:g} % "
                      f"(docs/methods.md §8), seed {sim.seed}.", ""]
        else:
            spec = study.measured
            sources = [spec.file] if spec.file else [p for p, _ in spec.files] or list(spec.time_histories)
            how = "FRFs estimated by `nlupdate frf` from the time histories " if spec.time_histories else "Read from "
            unit = table_reference_unit(result.measured)
            per_volt = " The reference is the excitation voltage: levels in V, FRFs in m/V, parameters per volt." \
                if unit == "V" else ""
            lines += [f"{how}{', '.join(f'`{s}`' for s in sources)} (SHA-256 of the table "
                      f"`{manifest['inputs']['measured']['sha256'][:16]}…`).{per_volt}", ""]
        if "measured" in plots:
            lines += [f"![measured FRFs]({plots['measured']})", ""]

    if result.identification is not None:
        lines += identification_section(result.identification, truth, plots)
    if result.targets is not None:
        lines += _targets_section(result)
    if result.runs:
        lines += _updating_section(result, truth, plots)
    if result.predictions:
        lines += _prediction_section(result, plots)
    if result.validation is not None:
        lines += _validation_section(result.validation, plots)
    if result.fe_validation is not None:
        lines += fe_validation_section(result.fe_validation)
    if result.amplitude is not None:
        lines += amplitude_section(result.amplitude, plots)

    lines += ["## Files", "",
              "* `manifest.json` — inputs and their hashes, versions, seeds, timing, tasks computed vs cached",
              "* `study.toml` — the study file as run",
              "* `tables/*.parquet` — " + ", ".join(f"`{name}`" for name in manifest.get("tables", [])),
              *_plot_files(plots), ""]
    if result.amplitude is not None:
        lines[-1:-1] = ["* `amplitude/` — the files `nlupdate amplitude` writes for the `[amplitude]` sources"]
    return "\n".join(lines)


def none_converged_line(runs) -> tuple[str, str] | None:
    """(headline, detail) when there are updating runs and none converged: how each stopped."""
    if not runs or any(run.converged for run in runs):
        return None
    how = "; ".join(f"{run.name}: {run.reason}" for run in runs)
    what = "The updating run did not converge" if len(runs) == 1 else f"None of the {len(runs)} updating runs converged"
    return what, (f" ({how}). The values below are where {'it' if len(runs) == 1 else 'each'} stopped, not updated "
                  f"parameters.")


def _not_converged(value: float, truth: float | None, unit: str = "") -> str:
    """A value where a run stopped (in ``unit``): no ±, since it is no result."""
    return f"{number(value)}{' ' + unit if unit else ''} (not converged{f'; truth {number(truth)}' if truth is not None else ''})"


def study_warning_lines(result) -> list[str]:
    """Every warning the archive's manifest carries, one line each, for a terminal: the
    study's (``result.warnings``), then the validation's and the amplitude model's
    (:func:`step_warnings`: every one — the validation's first alone, with how many more, hid an
    extrapolation behind the line saying which bands test nothing)."""
    return warning_texts(result.warnings) + [f"{w['source']}: {w['message']}" for w in step_warnings(result)]



def step_warnings(result) -> list[dict[str, str]]:
    """The validation's and the amplitude model's warnings, each as the manifest keeps a
    warning ({subject, kind, message, source}): every warning the validation says
    (:meth:`~nlupdate.core.validation.held_out.Validation.said`, the held-out type's too) and
    :func:`amplitude_warnings`."""
    out = []
    if result.validation is not None:
        out += [{"subject": "validation", "kind": "validation", "message": line.text, "source": "validation"}
                for line in result.validation.warnings()]
    if result.amplitude is not None:
        out += [{"subject": "amplitude", "kind": "amplitude", "message": text, "source": "amplitude model"}
                for text in amplitude_warnings(result.amplitude)]
    return out


def _warning_lines(result) -> list[str]:
    """The **Warnings** block that opens the summary (nothing when there are none)."""
    warnings = result.warnings
    if not warnings:
        return []
    texts = warning_texts(warnings)
    lines = [f"**Warnings** ({len(texts)}: results not to be trusted as they stand):", ""]
    lines += [f"* {text}" for text in texts]
    return lines + [""]


def declared_unit(study, name: str) -> str:
    """The unit an updating parameter's ``[[parameters]]`` entry declares ('' when none does)."""
    declared = {p.name: p.unit for p in study.parameters}
    return "" if declared.get(name, "") in ("", "1", "-") else declared[name]


def _with_unit(name: str, unit: str) -> str:
    """A table column's name with its unit: ``k1 (N/m)``."""
    return f"{name} ({unit})" if unit else name


def _identified(ident, name: str, truth: float | None) -> str:
    """One identified parameter as the summary states it: ``value ± std unit`` (the unit its
    element declares, per volt with a V reference: ``Identification.unit_of``), or, when the fit
    ran off with it, what that means instead of the number (``Identification.diverged``)."""
    s = ident.uncertainty.parameters[name]
    if name in ident.diverged:
        return ident.diverged[name]
    return f"{name} = " + _with_truth(s.value, s.std, truth, unit=ident.unit_of(name), missing="no Monte-Carlo uncertainty")


def _summary_lines(result, truth: Mapping[str, float]) -> list[str]:
    out = [] if result.amplitude is None else amplitude_summary(result.amplitude)
    ident = result.identification
    if ident is not None:
        parts = [_identified(ident, name, truth.get(name)) for name in ident.uncertainty.parameters
                 if name in ident.parameters()]
        out.append(f"* **Identified** ({ident.model_description}, {ident.settings.method.upper()}): " + "; ".join(parts)
                   + ("" if ident.trustworthy else " — **not trustworthy**: the linear FRF differs between the "
                      "levels beyond their noise (Identification below)"))
    if result.runs and result.ranking is not None:
        best = best_ranked(result.ranking)
        run = next(r for r in result.runs if r.name == best)
        u = result.uncertainties.get(best)
        if run.converged:
            values = "; ".join(
                f"{name} = " + _with_truth(value, u.std[name] if u else None, truth.get(name),
                                           unit=declared_unit(result.study, name), missing=NO_TARGET_STD)
                for name, value in run.parameters.items())
            untrusted = ident is not None and not ident.trustworthy and result.study.targets is not None \
                and result.study.targets.from_identification
            out.append(f"* **Best updated model** for the user weights: `{best}`: {values}" + (
                " — **its targets are the modes of an identification that is not trustworthy** (Identification "
                "below)" if untrusted else ""))
        else:
            values = "; ".join(f"{name} = {_not_converged(value, truth.get(name), declared_unit(result.study, name))}"
                               for name, value in run.parameters.items())
            out.append(f"* **No converged updated model**; the best-ranked run `{best}` did not converge "
                       f"({run.stop}): {values}")
        if u is not None and u.note:
            out.append(f"  ({u.note})")
    for prediction in result.predictions:
        c = prediction.summary
        out.append(f"* **Prediction** `{prediction.name}` (loss factor {number(prediction.loss_factor, 3)}, "
                   f"{prediction.loss_factor_source}): FRAC per level min {number(c.frac_min, 3)}, "
                   f"mean {number(c.frac_mean, 3)} over {_count(c.frac_levels, 'level')}"
                   + _single_frequency_levels(c))
    if result.validation is not None:
        headline = summary_headline(result.validation.said())
        if headline is not None:  # a miss, an extrapolation or a note opens the summary
            out.insert(0, f"* **Validation: {headline}**")
        out += held_type_summary(result.validation) + _validation_summary(result.validation)
    if result.fe_validation is not None:
        out += fe_validation_summary(result.fe_validation)
    return out


def _validation_summary(validation) -> list[str]:
    """One line per model: its largest held-out errors beside the baseline's
    (:meth:`~nlupdate.core.validation.held_out.Validation.worst_by_model`)."""
    out = []
    for w in validation.worst_by_model():
        model, base, (banded, inside, idle) = w.model, w.baseline, w.resonance
        out.append(f"* **Held-out levels** `{w.requested}` ({w.levels} level{'s' if w.levels > 1 else ''}): resonance "
                   f"within {number(model['resonance_hz'], 3)} Hz (baseline {number(base['resonance_hz'], 3)}), "
                   f"damping within {number(100 * model['damping_ratio'], 3)} % (baseline "
                   f"{number(100 * base['damping_ratio'], 3)} %), peak within {number(100 * model['peak_abs'], 3)} % "
                   f"(baseline {number(100 * base['peak_abs'], 3)} %); measured resonance in its "
                   f"95 % band at {inside} of {banded}"
                   + (f" ({idle} of them in uninformative bands: they test nothing)" if idle else "")
                   + f"; test repeatability {number(validation.repeatability.resonance_hz, 3)} Hz")
    return out


def _count(n: int, noun: str) -> str:
    return f"{n} {noun}" + ("" if n == 1 else "s")


def _single_frequency_levels(summary) -> str:
    """The levels measured at single frequencies (no FRAC): their largest relative error."""
    if not summary.single_levels:
        return ""
    return (f"; {_count(summary.single_levels, 'single-frequency level')} (no FRAC): relative FRF error up to "
            f"{number(summary.single_error_max, 3)}")


def _targets_section(result) -> list[str]:
    t = result.targets.targets
    std = result.targets.std_hz
    frame = pd.DataFrame({"mode": list(t.labels), "target (Hz)": t.frequencies_hz,
                          "std (Hz)": std if std is not None else float("nan"), "weight": t.weights})
    return ["## Updating targets", "", markdown_table(frame, 6), ""]


def _updating_section(result, truth: Mapping[str, float], plots: Mapping[str, str]) -> list[str]:
    lines = ["## Updating", ""]
    updated = [p for p in result.study.parameters if any(p.name in run.parameters for run in result.runs)]
    orders = formula_orders([run.name for run in result.runs if run.method == "eigensensitivity"])
    lines += [("An eigensensitivity run is named by its difference formula — " + ", ".join(orders)
               + f" = {ORDER_MEANING} — and the parameters it updates, in braces. " if orders else "")
              + "Parameters: " + ", ".join(p.described() for p in updated) + ".", ""]
    rows, without_std = [], False
    for run in result.runs:
        u = result.uncertainties.get(run.name)
        stds = {name: u.std[name] if u else None for name in run.parameters}
        without_std |= run.converged and not all(s is not None and np.isfinite(s) for s in stds.values())
        on_bound = [w.subject for w in result.warnings if w.source == run.name and w.kind == "at_bound"]
        converged = "yes" if run.converged else f"no ({run.stop if on_bound else run.reason})"
        if on_bound:
            converged += f", on the bound of {', '.join(on_bound)}"
        kinds = {w.kind for w in result.warnings if w.source == run.name}
        converged += ", misses its targets (Warnings)" if "targets_missed" in kinds else ""
        converged += ", stopped short of its targets (Warnings)" if "stopped_short" in kinds else ""
        rows.append({
            "run": run.name, "converged": converged, "iterations": run.iterations,
            "FE runs new/cached": f"{run.counts['new']}/{run.counts['cached']}",
            **{_with_unit(name, declared_unit(result.study, name)): (
                _with_truth(v, stds[name], None, missing="") if run.converged else _not_converged(v, None))
               for name, v in run.parameters.items()},
        })
    frame = pd.DataFrame(rows).fillna("–")
    lines += [markdown_table(frame), ""]
    if without_std:
        lines += ["No ± on the updated values: the targets state no std_hz (`[targets] std_hz`, "
                  "docs/study-files.md), so there is no uncertainty to propagate."
                  if result.targets is not None and result.targets.std_hz is None
                  else "No ± on some updated values: their propagated uncertainty could not be determined.", ""]
    if truth:
        known = {k: v for k, v in truth.items() if any(k in r.parameters for r in result.runs)}
        if known:
            lines += ["Hidden truth: " + ", ".join(f"{k} = {number(v)}" for k, v in known.items()), ""]
    notes = {u.note for u in result.uncertainties.values() if u.note}
    lines += [f"* {note}" for note in sorted(notes)] + ([""] if notes else [])
    if "convergence" in plots:
        lines += [f"![convergence]({plots['convergence']})", ""]
    comparison = result.comparison
    has_frac = bool(comparison["frac"].notna().any())
    lines += ["Comparison with the targets, mode by mode: the frequency error of each candidate model"
              + (" and the FRAC of its linear FRF against the extracted one (explained below the table):" if has_frac
                 else ":"), ""]
    errors = comparison.pivot_table(index="candidate", columns="mode", values="error_pct", sort=False)
    errors.columns = [f"error {c} (%)" for c in errors.columns]
    table = errors
    if has_frac:
        fracs = comparison.pivot_table(index="candidate", columns="mode", values="frac", sort=False, dropna=False)
        fracs.columns = [f"FRAC {c}" for c in fracs.columns]
        table = errors.join(fracs)
    lines += [markdown_table(table.reset_index()), ""]
    if has_frac:
        lines += [_frac_explanation(result), ""]
    if "frequency_errors" in plots:
        sigma = (" The green bands are each target's ±1σ and ±2σ — the uncertainty the updating propagates into "
                 "the updated parameters." if result.targets is not None and result.targets.std_hz is not None else "")
        lines += [f"![frequency errors]({plots['frequency_errors']})", "",
                  f"Each bar is a candidate's error for one target mode, its value beside it.{sigma}", ""]
    if "frf_comparison" in plots:
        lines += [f"![candidate FRFs]({plots['frf_comparison']})", "",
                  f"The candidates' linear FRFs are modal superpositions of the {result.candidate_frfs.modes} modes "
                  f"each model computed, without residual terms: if the model has higher modes, the curves miss them "
                  f"(modal truncation) — anti-resonances and the level above the last computed mode are off for that "
                  f"reason, not because of the updating.", ""]
    columns = {"rank": "rank", "candidate": "candidate", "weighted_abs_error_pct": "weighted mean abs. frequency error (%)"}
    if has_frac:
        columns["weighted_frac"] = "weighted FRAC"
    ranking = result.ranking[list(columns)].rename(columns=columns)
    if "converged" in result.ranking:
        ranking.insert(2, "converged", ["–" if v is pd.NA else ("yes" if v else "no") for v in result.ranking["converged"]])
    lines += ["Ranking for the user weights, by the weighted mean |frequency error| (Σ w·|error| / Σ w over the target "
              "modes; lower is better), the runs that converged before those that did not, whatever their errors "
              "where they stopped: the first is the best updated model"
              + (". Weighted FRAC (Σ w·FRAC / Σ w, higher is better) is shown beside it; read it against what the "
                 "extracted FRF's own fits reach (above)." if has_frac else "."), "",
              markdown_table(ranking), ""]
    return lines


def _frac_explanation(result) -> str:
    """What the candidates' per-mode FRAC measures and what it can reach here."""
    band = result.study.comparison.band_fraction
    text = (f"FRAC (0–1, 1 = same shape) compares a candidate's linear FRF — its computed modes with the "
            f"identified loss factors — with the extracted linear FRF within ±{100 * band:g} % of each target. It "
            f"is limited by the noise of that reference and by modal truncation, not only by the model")
    reachable = result.targets.reference_fit_frac if result.targets is not None else None
    if reachable is None:
        return text + "."
    values = ", ".join(f"{number(v, 3)} ({label})" for label, v in zip(result.targets.targets.labels, reachable))
    return (text + f": the extracted FRF's own one-mode fits — curves fitted to these very data — reach {values} in "
            f"the same bands. A candidate near those values agrees with the reference as well as its noise lets "
            f"any curve agree, however low the number; a low value there says the reference is noisy, not that the "
            f"model is poor. How well the model predicts is the prediction's FRAC against the measurements, below.")


def _prediction_section(result, plots: Mapping[str, str]) -> list[str]:
    lines = ["## Prediction at every force level", "",
             "The updated linear FE model (its modes at the measured coordinates) plus the identified elements, "
             "simulated at every measured force level and frequency, against the measurements; `initial` is the "
             "model before updating with the same elements. Response method ([prediction] `method`): "
             f"{describe(result.study.prediction.harmonic_balance)}.", ""]
    if "predictions" in plots:
        lines += [f"![predictions]({plots['predictions']})", "",
                  "Magnitude and phase at each force level; each panel's title gives the FRAC of the initial and of "
                  "the updated model at that level.", ""]
    unit = table_reference_unit(result.measured)
    columns = {"model": "model", "force_level_n": f"force level ({unit})", "frac": "FRAC",
               "normalised_error": "‖H_model − H_measured‖ / ‖H_measured‖",
               "peak_frequency_error_pct": "peak frequency error (%)",
               "peak_amplitude_ratio": "peak amplitude model / measured"}
    table = pd.concat([p.correlation.assign(model=p.name) for p in result.predictions], ignore_index=True)
    table = table[list(columns)].rename(columns=columns)
    lines += ["Per level, against the measurement itself over the whole measured band: FRAC (0–1, 1 = the "
              "measured shape), the relative FRF error, and the error of the highest peak's frequency and "
              "amplitude.", "", markdown_table(table, 3), ""]
    if "correlation" in plots:
        lines += [f"![correlation per level]({plots['correlation']})", ""]
    return lines


def summary_section(markdown: str) -> str:
    """The ``## Summary`` section of a report as plain text (for a terminal)."""
    text = markdown.split("## Summary", 1)[-1].split("\n## ", 1)[0]
    lines = [line for line in text.splitlines() if not (line.startswith("_") and line.endswith("_"))]
    return "\n".join(lines).replace("**", "").replace("`", "").strip()


def _validation_section(validation, plots: Mapping[str, str]) -> list[str]:
    """Held-out levels (``[validation]``): each level's errors beside the baseline's and the
    test's own repeatability."""
    unit = validation.reference_unit
    repeat = validation.repeatability
    lines = ["## Held-out levels", "",
             "Each held-out level predicted by a model fitted on the other levels of the measured curve "
             "(docs/methods.md §10), beside the log-amplitude baseline (interpolation between the kept levels). "
             "Resonance, damping ratio (circle fit) and peak come from one estimator for the measured and predicted "
             "curves; bands are 95 %: jackknife over the kept levels plus the test's repeatability — no model can be "
             "expected to do better than the test repeats to:", "",
             f"* {repeatability_line(repeat, 'held-out levels')}"]
    if validation.response_controlled and validation.runs_repeatability is not None:
        lines.append(f"* {repeatability_line(validation.runs_repeatability, 'response-controlled runs')}")
    lines.append("")
    # the verdict and what qualifies the numbers (extrapolations, each comparison's notes, auto's
    # refusals) before the tables, as the terminal prints them
    lines += [said_markdown(line) for line in validation.said(unit)] + [""]
    rows = [{f"level ({unit})": number(r.level), **_errors(r)} for r in validation.held_out]
    lines += [markdown_table(pd.DataFrame(rows)), ""]
    if "validation" in plots:
        lines += [f"![held-out levels]({plots['validation']})", ""]
    if validation.response_controlled:
        rows = [{"run": r.run, "held amplitude (µm)": number(1e6 * r.held_m, 3), **_errors(r)}
                for r in validation.response_controlled]
        lines += ["Response-controlled runs predicted from all force-controlled levels at their held amplitude:", "",
                  markdown_table(pd.DataFrame(rows)), ""]
        lines += [f"![response-controlled runs]({plots['response_controlled']})", ""] if "response_controlled" in plots \
            else []
    return lines + held_type_section(validation)


def _errors(r) -> dict[str, str]:
    """One prediction's errors with their 95 % bands (a held-out level or a response-controlled
    run) beside the baseline's."""
    res, zeta, peak = error_cells(r.compared, True)
    base = error_cells(r.baseline, False)
    return {"model": r.label, "resonance error (Hz) [95 % band]": res, "damping error (%) [band]": zeta,
            "peak error (%) [band]": peak, "measured in its 95 % band (f, ζ, peak)": in_band_cell(r.compared),
            "baseline: resonance (Hz), damping (%), peak (%)": ", ".join(base),
            "residual / noise (model, baseline)": f"{number(r.residual_to_noise, 3)}, {number(r.baseline_residual_to_noise, 3)}"}
