"""Response-controlled runs predicted from the force-controlled fit (docs/validation.md).

A response-controlled stepped-sine run holds the response amplitude X at the driving point
while the force varies (:mod:`nlupdate.core.identification.response_controlled` reads
them); it samples the mode at one amplitude. Each model is fitted on **every**
force-controlled level and predicts the run's receptance at the held X — on each line the
displacement the run achieved there (``HeldRun.held_on_lines``: a run holding acceleration
holds A/Ω², and on a simulated BRB-like mode its curve reads up to 3.4 % more damped than
one held at its median displacement, benchmarks/held_runs_truth.py) —
(:attr:`~nlupdate.core.validation.models.Fitted.at_response`); the run's resonance,
damping ratio and peak |H| — and the force needed at resonance, X/peak — are
compared with the measured ones (the estimator of :mod:`nlupdate.core.validation.resonance`
on both curves) and with the log-amplitude baseline at X
(:func:`~nlupdate.core.validation.baseline.baseline_at_response`). Bands as for a held-out
level (:func:`~nlupdate.core.validation.held_out.bands`): the jackknife over the
force-controlled levels and the test's repeatability, pooled over the force-controlled
levels and the runs (:func:`~nlupdate.core.validation.held_out.repeatability`: the two test
types differ by 0.08–0.14 Hz at equal amplitude on the BRB, part of the test's scatter).

A note states each run's modal constant against the one the single-mode models take from
every line of every force-controlled level at once (:func:`modal_constant_note`): a run's
damping ratio is read from its curve's width, which the modal constant does not set, while a
prediction's width scales with it — on the BRB the runs' were 1.25–1.36 × the lowest level's
one-mode fit's while that fit took a residual mass beside its constant, and run 2's damping
was predicted 18 % low with its peak within 2.3 %; with a constant residual alone 1.04–1.13 ×,
run 2 −6.6 % from the levels and the impact; with the constant of every level (issue 34)
1.02–1.11 ×, run 2 −4.1 % (docs/validation.md, "Run 2's damping").

**Extrapolation.** A run held outside the amplitudes the kept data cover — below the lowest
force-controlled level's response amplitude at resonance
(:func:`~nlupdate.core.validation.held_out.resonance_amplitudes`; down to 0 when a linear
limit, an impact, is kept) or above the highest — is an extrapolation, as a held-out level
outside the kept levels is (:func:`~nlupdate.core.validation.auto_choice.extrapolated`). The
jackknife measures only how the one model moves when a kept level is dropped; every refit
extrapolates the same form, so it does not see the form being wrong, and that is what an
extrapolation risks (on the BRB run 1, 19.7 µm below every level, went from −54.5 % in a band
[−83, +74] to −35.6 % in [−54, −9] when the lowest level's fit changed, docs/validation.md).
There the band is widened to the spread of the form itself: each quantity's band, and the
|H| band, take in the predictions at the run of every ``auto`` candidate
(:data:`~nlupdate.core.validation.models.AUTO_CANDIDATES`; with a linear limit those that
can keep it, as ``auto`` ranks them) fitted on the same levels — the
models the kept data cannot tell apart, whose disagreement outside them is the model-form
uncertainty the jackknife misses — and :attr:`HeldPrediction.extrapolation` states it (a
warning naming the run, its amplitude and the kept range, and the candidates taken). It widens,
never narrows, and moves no prediction. Where the candidates agree, the band stays narrow and
a miss stays a miss, stated beside the warning: on the BRB every candidate puts run 1's damping
16–36 % low, since the force-controlled levels read less damped than the runs at equal amplitude
(docs/validation.md).
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Sequence

import numpy as np

from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.level_residual import frf_residual
from nlupdate.core.identification.modal_fit import fit_mode_over_band
from nlupdate.core.identification.response_controlled import HeldRun, read_response_controlled
from nlupdate.core.measurement.frf_table import MeasurementTableError
from nlupdate.core.measurement.units import ReadOptions
from nlupdate.core.run_cache import one_run
from nlupdate.core.validation.baseline import baseline_at_response, baseline_fits
from nlupdate.core.validation.held_out import (
    CurveComparison, Repeatability, Validation, curve_comparison, kept_misfit, needs_misfit, refits,
    repeatability, resonance_amplitudes, validate,
)
from nlupdate.core.validation.auto_choice import choose_model
from nlupdate.core.validation.models import AUTO_CANDIDATES, WITH_RUNS, model_fitter
from nlupdate.core.validation.resonance import read_alike, resonance
from nlupdate.progress import ProgressCallback, no_progress


@dataclass(frozen=True, eq=False, kw_only=True)
class HeldPrediction(CurveComparison):
    """One response-controlled run (``run``, held amplitude ``held_m`` in m) under one model
    fitted on the force-controlled ``levels``."""

    run: str
    held_m: float
    levels: tuple[float, ...]

    def force_needed(self) -> dict[str, float]:
        """The force at resonance X/peak (measured, predicted and its band; N or V)."""
        peak = self.compared["peak_abs"]
        return {"measured": self.held_m / peak.measured, "predicted": self.held_m / peak.predicted,
                "low": self.held_m / peak.high if peak.high > 0 else float("nan"),
                "high": self.held_m / peak.low if peak.low > 0 else float("nan")}

    def as_dict(self) -> dict:
        return {"run": self.run, "held_amplitude_m": self.held_m, "model": self.model, "requested": self.requested,
                "fitted_levels": list(self.levels), **{name: c.as_dict() for name, c in self.compared.items()},
                "force_at_resonance": self.force_needed(), "residual_to_noise": self.residual_to_noise,
                "half_power_lines": self.half_power_lines,
                "baseline": {**{name: {"measured": c.measured, "predicted": c.predicted}
                                for name, c in self.baseline.items()},
                             "residual_to_noise": self.baseline_residual_to_noise},
                "note": self.note, **({"extrapolation": self.extrapolation} if self.extrapolation else {})}


def kept_amplitudes(data: FRFLevels) -> tuple[float, float]:
    """(lowest, highest) response amplitude (m) the force-controlled levels of ``data`` reached
    at resonance (:func:`~nlupdate.core.validation.held_out.resonance_amplitudes`); the lowest
    is 0 when ``data`` keeps a linear limit (an impact: the mode at vanishing amplitude)."""
    amplitudes = resonance_amplitudes(data)
    low = 0.0 if data.linear_limit is not None else float(np.nanmin(amplitudes))
    return low, float(np.nanmax(amplitudes))


def widened_for_extrapolation(data: FRFLevels, run: HeldRun, comparison: dict) -> tuple[dict, str]:
    """(``comparison`` — :func:`~nlupdate.core.validation.held_out.curve_comparison`'s fields
    for ``run`` — with each quantity's band and the |H| band widened to take in every ``auto``
    candidate's prediction at the run, fitted on all of ``data``'s levels; the warning stating
    the extrapolation) when the run's held amplitude lies outside :func:`kept_amplitudes`,
    else (``comparison``, '') (module docstring). A candidate that cannot be fitted or predict
    is left out of the spread and named; a quantity the model does not predict keeps no band."""
    low, high = kept_amplitudes(data)
    if low <= run.held_m <= high:
        return comparison, ""
    f, shown = run.frequency_hz, resonance(run.frequency_hz, run.h)
    taken, failed, values, sizes = [], [], {name: [] for name in comparison["compared"]}, []
    for name in [c for c in AUTO_CANDIDATES if data.linear_limit is None or c in WITH_RUNS]:
        try:
            curve = model_fitter(name)(data).at_response(f, run.held_on_lines)
        except (ValueError, ArithmeticError, np.linalg.LinAlgError):
            failed.append(name)
            continue
        r = read_alike(resonance(f, curve), shown)
        for key in values:
            values[key].append(float(getattr(r, key)))
        sizes.append(np.abs(curve))
        taken.append(name)
    compared = {}
    for key, c in comparison["compared"].items():
        spread = [v for v in values[key] if np.isfinite(v)]
        compared[key] = (replace(c, low=float(np.nanmin([c.low, *spread])), high=float(np.nanmax([c.high, *spread])))
                         if spread and np.isfinite(c.predicted) else c)
    widened = dict(comparison, compared=compared)
    if sizes:
        widened.update(abs_low=np.fmin(comparison["abs_low"], np.min(sizes, axis=0)),
                       abs_high=np.fmax(comparison["abs_high"], np.max(sizes, axis=0)))
    side = "below the lowest" if run.held_m < low else "above the highest"
    warning = (f"response-controlled run {run.name} held at {1e6 * run.held_m:.3g} µm, {side} amplitude the kept data "
               f"cover ({1e6 * low:.3g}–{1e6 * high:.3g} µm at resonance): an extrapolation; its bands widened to the "
               f"spread of the candidate models' predictions at it ({', '.join(taken) or 'none could predict it'})"
               + (f"; {', '.join(failed)} could not predict it" if failed else ""))
    return widened, warning


def predict_held_runs(data: FRFLevels, runs: Sequence[HeldRun], model: str, repeat: Repeatability, requested: str = ""
                      ) -> list[HeldPrediction]:
    """Every run of ``runs`` at ``data``'s driving point predicted by ``model`` fitted on all
    of ``data``'s levels (module docstring); ValueError when the model cannot predict a held
    response (PRD) or a run is at another coordinate."""
    fit = model_fitter(model)
    fitted = fit(data)
    if fitted.at_response is None:
        raise ValueError(f"model {model}: predicts force levels only, not a held response amplitude")
    levels = tuple(float(v) for v in data.levels)
    fits = baseline_fits(data, levels)
    out = []
    for run in runs:
        if (run.response_dof, run.input_dof) != (data.response_dof, data.input_dof):
            raise ValueError(f"response-controlled run {run.name}: at {run.response_dof}/{run.input_dof}, not the "
                             f"driving point {data.input_dof} of the force-controlled curve")
        f, h = run.frequency_hz, run.h
        held = run.held_on_lines  # a run holding acceleration holds A/Ω² on each line
        predicted = fitted.at_response(f, held)
        curves, note = refits(fit, levels, data, lambda inner: inner.at_response(f, held))
        misfit = kept_misfit(fitted, data, levels) if needs_misfit(f, curves) else None
        base = baseline_at_response(fits, run.held_m, f)
        comparison, warning = widened_for_extrapolation(
            data, run, curve_comparison(data, f, h, predicted, curves, base, repeat, misfit))
        out.append(HeldPrediction(run=run.name, held_m=run.held_m, levels=levels, model=model,
                                  requested=requested or model, **comparison,
                                  note=fitted.noted(note), extrapolation=warning))
    return out


def modal_constant_note(data: FRFLevels, runs: Sequence[HeldRun]) -> str:
    """Each run's modal constant (|A| of a one-mode fit of the run, a linear curve) over φ_f²
    (the modal constant P the single-mode models take from every line of every
    force-controlled level at once,
    :func:`~nlupdate.core.identification.level_residual.frf_residual`): one line for
    ``response_controlled_notes``; '' when no run can be fitted."""
    try:
        constant = frf_residual(data)[1].modal_constant
    except ValueError:
        return ""
    ratios = []
    for run in runs:
        try:
            own = fit_mode_over_band(run.frequency_hz, run.h)
        except ValueError:
            continue
        ratios.append(abs(complex(own.modal_constants[0])) / constant)
    if not ratios:
        return ""
    return (f"modal constants: each run's one-mode fit over the φ_f² the single-mode models take from every line of "
            f"the {data.levels.size} force-controlled levels at once: {', '.join(f'{r:.2f}' for r in ratios)}; a run's "
            f"damping ratio is read from its curve's width, which the modal constant does not set, a prediction's width "
            f"scales with φ_f²: where a run's peak is predicted well, a ratio r leaves its predicted damping about "
            f"r times too small")


def with_held_runs(validation: Validation, data: FRFLevels, runs: Sequence[HeldRun],
                   models: Sequence[str], progress: ProgressCallback = no_progress) -> Validation:
    """``validation`` with every run of ``runs`` predicted by every model of ``models``
    (``auto``: :func:`~nlupdate.core.validation.auto_choice.choose_model` on all force-controlled
    levels); a model that cannot predict them is named in ``response_controlled_notes``.
    ``progress("response-controlled runs: models", done, len(models))`` after each model."""
    results, notes = [], []
    repeat = repeatability(data, runs)  # the test's scatter over every curve it measured, both types
    notes += [note] if (note := modal_constant_note(data, runs)) else []
    for done, requested in enumerate(models, start=1):
        name = choose_model(data).name if requested == "auto" else requested
        try:
            results += predict_held_runs(data, runs, name, repeat, requested)
        except ValueError as error:
            notes.append(f"{requested}: {error}")
        progress("response-controlled runs: models", done, len(models))
    return replace(validation, response_controlled=tuple(results), response_controlled_notes=tuple(notes),
                   runs_repeatability=repeat)


def held_runs_of(paths: Sequence[str | Path], options: ReadOptions, data: FRFLevels) -> tuple[list[HeldRun], list[str]]:
    """(the response-controlled runs of the MATLAB files among ``paths`` at ``data``'s
    driving point, lowest held amplitude first; notes on the runs left out and why). A file
    without such runs adds nothing."""
    runs, notes = [], []
    for path in paths:
        if Path(path).suffix.lower() != ".mat":
            continue
        try:
            found = read_response_controlled(path, options)
        except MeasurementTableError as error:
            if "holds no response-controlled run" not in str(error):
                notes.append(f"response-controlled runs not read: {error}")
            continue
        for run in found:
            if (run.response_dof, run.input_dof) == (data.response_dof, data.input_dof):
                runs.append(run)
            else:
                notes.append(f"{path}: response-controlled run {run.name} at {run.response_dof}/{run.input_dof} left "
                             f"out: the force-controlled curve is at {data.response_dof}/{data.input_dof}")
    return sorted(runs, key=lambda run: run.held_m), notes


#: What is done with the response-controlled runs of the measured MATLAB files (``[validation]
#: response_controlled``, ``nlupdate validate --response-controlled``): predicted from all
#: force-controlled levels, left out, or kept beside the levels as backbone evidence.
RESPONSE_CONTROLLED = ("auto", "off", "kept")


@one_run()  # the held-out levels and the held runs share fits of the same levels (core/run_cache.py)
def validate_measured(data: FRFLevels, hold_out, models: Sequence[str], response_controlled: str,
                      paths: Sequence[str | Path], options: ReadOptions,
                      progress: ProgressCallback = no_progress) -> Validation:
    """:func:`~nlupdate.core.validation.held_out.validate` of ``data`` with the
    response-controlled runs of the MATLAB files among ``paths`` treated as
    ``response_controlled`` says (:data:`RESPONSE_CONTROLLED`): ``auto`` predicts them
    (:func:`with_held_runs`), ``kept`` keeps them in every fit (ValueError when there are
    none), ``off`` ignores them. The runs left out, and why, are in
    ``response_controlled_notes``."""
    if response_controlled not in RESPONSE_CONTROLLED:
        raise ValueError(f"response_controlled {response_controlled!r}: expected one of {', '.join(RESPONSE_CONTROLLED)}")
    runs, notes = held_runs_of(paths, options, data) if response_controlled != "off" else ([], [])
    if response_controlled == "kept" and not runs:
        raise ValueError(f"response_controlled kept: {', '.join(map(str, paths))} holds no response-controlled run at "
                         f"{data.input_dof}")
    validation = validate(data, hold_out, models, progress=progress, runs=runs if response_controlled == "kept" else ())
    if response_controlled == "auto" and runs:
        validation = with_held_runs(validation, data, runs, models, progress)
    return replace(validation, response_controlled_notes=validation.response_controlled_notes + tuple(notes))
