"""How an amplitude-dependent modal model fitted to several test types is told and drawn
(:class:`~nlupdate.core.identification.amplitude_joint.AmplitudeFit`): the lines
``nlupdate amplitude`` prints (:func:`amplitude_lines`), its two figures
(:func:`plot_amplitude_fit`) and a study's ``[amplitude]`` section and summary lines. Renders
only: every number comes from the fit.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from nlupdate.core.identification.amplitude_joint import POOR_FIT, AmplitudeFit
from nlupdate.core.identification.amplitude_modal_fit import KINKED_BACKBONES
from nlupdate.core.identification.backbone_samples import DISAGREEMENT, MIN_SCATTER_SAMPLES
from nlupdate.reporting.backbone_plots import modal_amplitude_unit, plot_sources
from nlupdate.reporting.markdown import markdown_table
from nlupdate.reporting.model_numbers import damping_text, joint_text, linear_limit_text


def plot_amplitude_fit(fit: AmplitudeFit, folder: Path) -> tuple[Path, Path]:
    """``folder/backbone.png`` and ``folder/damping.png``: every fitted source on the model,
    with the band of its backbone table, the sources the consistency check names marked, the
    sources held out beside them."""
    odd = frozenset() if fit.agreement is None else frozenset(
        f"{row.source} ({row.test_type})" for row in fit.agreement.itertuples() if not row.consistent)
    return plot_sources(fit.model, [(f"{name} ({kind})", s) for name, s, _, kind in fit.points], fit.curve, folder,
                        odd, [(f"{name} ({kind})", s) for name, s, _, kind in fit.held])


def _disagreement_line(fit: AmplitudeFit) -> str | None:
    odd = fit.disagreeing()
    if not odd:
        return None
    return (f"{', '.join(odd)} {'disagrees' if len(odd) == 1 else 'disagree'} with the joint fit by more than {DISAGREEMENT:g} standard errors "
            f"(consistency.csv): a test-type effect (e.g. shaker–structure interaction, a drift between tests) or a "
            f"wrong shape or unit")


def _unchecked_line(fit: AmplitudeFit) -> str | None:
    """The sources no other agreeing source reaches (consistency.csv ``compared_with`` none)."""
    if fit.agreement is None:
        return None
    alone = [f"{row.source} ({row.test_type})" for row in fit.agreement.itertuples()
             if row.consistent and row.compared_with == "none"]
    if not alone:
        return None
    one = len(alone) == 1
    return (f"{', '.join(alone)}: no other agreeing source has samples within {'its' if one else 'their'} amplitude "
            f"range, so the consistency check cannot test {'it' if one else 'them'} (consistency.csv: compared_with "
            f"none); the joint fit follows {'it' if one else 'them'} there")


def _poor_line(fit: AmplitudeFit) -> str | None:
    if not fit.poor():
        return None
    f, z = fit.misfit()
    return (f"the model misses its samples by {100 * f:.3g} % in frequency and {100 * z:.3g} % in damping (rms; "
            f"a good fit is within {100 * POOR_FIT[0]:g} % and {100 * POOR_FIT[1]:g} %): another backbone or a band "
            f"that holds the mode alone")


def _held_lines(fit: AmplitudeFit) -> list[str]:
    """What the model predicts for each held-out source (:meth:`AmplitudeFit.held_worst`)."""
    return [f"held out {w.source} ({w.test_type}): predicted within {100 * w.frequency_error:.3g} % in frequency and "
            f"{100 * w.damping_error:.3g} % in damping ratio"
            + (f", {100 * w.amplitude_error:.3g} % in amplitude at its forces" if np.isfinite(w.amplitude_error) else "")
            + f" ({w.samples} samples {'within' if w.within_fit else 'outside'} the fitted amplitudes)"
            + (": an impact below them, against the model's linear limit (a = 0), an extrapolation"
               if w.at_linear_limit else "")
            for w in fit.held_worst()]


def _amplitudes(samples, unit: str = "N") -> str:
    """The amplitudes the samples cover, in their unit: modal (m·√kg; per volt, ``unit`` "V",
    m·√(kg·V/N): :func:`modal_amplitude_unit`), or a record's own (m) when it was read without
    a shape (:attr:`ModalSamples.modal`)."""
    span = f"{samples.amplitude.min():.3g}–{samples.amplitude.max():.3g}"
    return f"modal amplitudes {span} {modal_amplitude_unit(unit)}" if samples.modal else \
        f"amplitudes {span} m at the record's channel (no shape given: not modal)"


def amplitude_lines(fit: AmplitudeFit) -> list[str]:
    """What ``nlupdate amplitude`` prints after the fit, the bad news first (sources that
    disagree, a poor fit, the model's warnings); then the linear limit and backbone, the
    modal joint, notes, the bands, each source's agreement and the held-out predictions."""
    model, samples = fit.model, fit.samples
    lines = [f"warning: {text}" for text in (_disagreement_line(fit), _unchecked_line(fit), _poor_line(fit)) if text]
    lines += [f"warning: {warning}" for warning in model.warnings]
    lines.append(f"mode {model.mode}: {linear_limit_text(model)}, damping ratio {damping_text(model)} "
                 f"({model.backbone} backbone, {samples.amplitude.size} samples, "
                 f"{_amplitudes(samples, fit.unit)})")
    if model.joint is not None:
        lines.append(f"modal joint: {joint_text(model, fit.unit)}")
    if model.note:
        lines.append(f"note: {model.note}")
    if fit.options.backbone in KINKED_BACKBONES and fit.samples.amplitude.size > 1:
        lines.append("note: backbone.csv's *_low/*_high bands: 95 % from the fit's linearised covariance (the "
                     "phase-resonance points' amplitude noise included; the kink moves with the slip amplitude)")
    elif fit.resamples and fit.samples.amplitude.size < MIN_SCATTER_SAMPLES:
        lines.append(f"note: backbone.csv's *_low/*_high bands: 95 % of {fit.resamples} refits with misfits drawn from "
                     f"the noise the fit assumed ({fit.samples.amplitude.size} samples cannot show their own scatter; wider than "
                     f"it where the fit's chi² lies far below its degrees of freedom: docs/ring-down.md, 'The bands')")
    elif fit.resamples:
        lines.append(f"note: backbone.csv's *_low/*_high bands: 95 % of {fit.resamples} refits of a residual bootstrap")
    else:
        lines.append("note: backbone.csv's *_low/*_high band columns are NaN (the backbone fits give no covariance); "
                     "--bootstrap N refits N resamples for them ([amplitude] bootstrap in a study)")
    if fit.agreement is not None:
        for row in fit.agreement.itertuples():
            if row.compared_with == "none":
                lines.append(f"{row.source} ({row.test_type}): {row.samples} sample(s), not checked (no other agreeing "
                             f"source has samples within its amplitude range; the joint fit follows it there)")
                continue
            lines.append(f"{row.source} ({row.test_type}): {row.samples} sample(s), mean misfit "
                         f"{100 * row.frequency_offset:+.2g} % in frequency ({row.frequency_score:+.2g} standard "
                         f"errors), {100 * row.damping_offset:+.2g} % in damping ({row.damping_score:+.2g})"
                         + ("" if row.consistent else " — DISAGREES with the other sources beyond its uncertainty"))
    return lines + _held_lines(fit)


def amplitude_warnings(fit: AmplitudeFit) -> list[str]:
    """The bad news on the fit, as the study's summary and terminal open with it: sources that
    disagree, a poor fit, the model's own warnings (its linear limit extrapolated or on a bound)."""
    return [text for text in (_disagreement_line(fit), _poor_line(fit)) if text] + list(fit.model.warnings)


def amplitude_summary(fit: AmplitudeFit) -> list[str]:
    """The study summary's lines, the bad news first (:func:`amplitude_warnings`); then the
    linear limit and the amplitudes covered, and the sources the consistency check could not
    test."""
    lines = [f"* **Amplitude model: {text}**" for text in amplitude_warnings(fit)]
    model, samples = fit.model, fit.samples
    kinds = ", ".join(dict.fromkeys(kind for _, _, _, kind in fit.points))
    lines.append(f"* **Amplitude model** (mode {model.mode}, {model.backbone} backbone, {kinds}): "
                 f"{linear_limit_text(model)}, damping ratio {damping_text(model)}; "
                 f"{_amplitudes(samples, fit.unit)}")
    unchecked = _unchecked_line(fit)  # not bad news in itself: what the check could not test
    return lines + ([f"* Amplitude model: {unchecked}"] if unchecked else [])


def _agreement_table(agreement: pd.DataFrame) -> pd.DataFrame:
    """consistency.csv as the report shows it: offsets in % and scores in standard errors,
    two significant figures, whether each source agrees with the joint fit."""
    return pd.DataFrame({
        "source": agreement["source"], "test type": agreement["test_type"], "samples": agreement["samples"],
        "frequency misfit (%)": [f"{100 * v:+.2g}" if v == v else "—" for v in agreement["frequency_offset"]],
        "frequency misfit (standard errors)": [f"{v:+.2g}" if v == v else "—" for v in agreement["frequency_score"]],
        "damping misfit (%)": [f"{100 * v:+.2g}" if v == v else "—" for v in agreement["damping_offset"]],
        "damping misfit (standard errors)": [f"{v:+.2g}" if v == v else "—" for v in agreement["damping_score"]],
        "agrees with the fit": ["not checked" if alone == "none" else "yes" if ok else "**NO**"
                                for ok, alone in zip(agreement["consistent"], agreement["compared_with"])]})


def amplitude_section(fit: AmplitudeFit, plots: dict[str, str]) -> list[str]:
    """The report's ``[amplitude]`` section: what each source gave, the model, the
    agreement of the sources and the figures (``plots``: name → path in the archive)."""
    lines = ["## Amplitude-dependent modal model", "",
             "One mode's natural frequency and damping ratio against modal amplitude, fitted jointly to every test "
             "type the `[amplitude]` table names (each source weighted by its own noise), with a consistency check "
             "across the sources (docs/ring-down.md).", ""]
    lines += [f"* {note}" for note in fit.notes] + [""]
    lines += [f"* {line}" for line in amplitude_lines(fit)] + [""]
    f, z = fit.misfit()
    lines += [f"Misfit of the samples about the model (rms): {100 * f:.3g} % in frequency, {100 * z:.3g} % in "
              f"damping.", ""]
    if fit.agreement is not None:
        lines += [markdown_table(_agreement_table(fit.agreement)), ""]
    for name in ("amplitude_backbone", "amplitude_damping"):
        if name in plots:
            lines += [f"![{name.replace('_', ' ')}]({plots[name]})", ""]
    lines += ["Files `amplitude/amplitude_model.json`, `backbone.csv`, `backbone_points.csv`"
              + (", `consistency.csv`" if fit.agreement is not None else "")
              + (", `held_out.csv`" if fit.held_errors is not None else "") + " (as `nlupdate amplitude` writes them).",
              ""]
    return lines
