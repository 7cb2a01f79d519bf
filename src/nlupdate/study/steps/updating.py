"""The updating part of a study: targets, one updating run per eigensensitivity formula ×
parameter set and per optimisation candidate, the runs' comparison, ranking and parameter
uncertainty, and the candidates' linear FRFs against the reference."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from nlupdate.core.correlation.metrics import frac
from nlupdate.core.identification.pipeline import Identification
from nlupdate.core.identification.uncertainty import CurveBand
from nlupdate.core.model.amplitude_modal import read_amplitude_model
from nlupdate.core.updating.eigensensitivity import UpdatingResult
from nlupdate.core.updating.evaluation import PointEvaluator
from nlupdate.core.updating.runs import UpdatingRun, candidate_frf, compare_candidates, rank_candidates, update
from nlupdate.core.updating.sensitivity import FORMULA_LABELS, ORDER_MEANING, order_labels
from nlupdate.core.updating.target_uncertainty import ParameterUncertainty, propagate_target_uncertainty
from nlupdate.core.updating.targets import UpdatingTargets, frf_natural_frequencies, read_linear_frf
from nlupdate.fe.adapters.base import Parameter
from nlupdate.fe.adapters.registry import AdapterSpec
from nlupdate.study.spec import Study, StudyError
from nlupdate.study.steps.measured import measured_pair, model_pair


@dataclass(frozen=True, eq=False)
class TargetSet:
    """Updating targets, their standard deviations (Hz; None when unknown), the reference
    linear FRF (frequencies Hz, receptance m/N) when there is one, and the loss factors of
    the target modes when the identification measured them.

    When the reference is this study's extracted linear FRF: ``reference_band``, its 95 %
    Monte-Carlo band, and ``reference_fit_frac``, per target the FRAC that the
    identification's own one-mode fit of that mode reaches against the reference in the
    comparison's band around the target — what a model can reach against a reference this
    noisy (the candidates' per-mode FRAC is read against it)."""

    targets: UpdatingTargets
    std_hz: NDArray[np.float64] | None
    reference: tuple[NDArray[np.float64], NDArray[np.complex128]] | None
    loss_factors: NDArray[np.float64] | None = None
    reference_band: CurveBand | None = None
    reference_fit_frac: NDArray[np.float64] | None = None


@dataclass(frozen=True)
class RunFailure:
    """An updating run (sweep branch) that failed: its name and the error."""

    name: str
    error: str


@dataclass(frozen=True, eq=False)
class UpdatingOutcome:
    """The updating runs that finished and those that failed, in the order of the runs."""

    runs: tuple[UpdatingResult, ...]
    failures: tuple[RunFailure, ...]

    @classmethod
    def of(cls, outcomes: Sequence[UpdatingResult | RunFailure]) -> "UpdatingOutcome":
        return cls(tuple(o for o in outcomes if isinstance(o, UpdatingResult)),
                   tuple(o for o in outcomes if isinstance(o, RunFailure)))


@dataclass(frozen=True, eq=False)
class Comparison:
    """The runs compared mode by mode (``table``), ranked for the user's weights, and each
    run's parameter uncertainty propagated from the targets'."""

    table: pd.DataFrame
    ranking: pd.DataFrame
    uncertainties: Mapping[str, ParameterUncertainty]


@dataclass(frozen=True, eq=False)
class CandidateFRFs:
    """The reference linear FRF of the targets and every run's (and the initial model's)
    linear receptance at the measured pair of the model (m/N), over ``frequency_hz`` (Hz):
    modal superposition of the ``modes`` modes each model computed, with the comparison's
    damping; no residual terms, so the modes left out are missing (modal truncation).
    ``reference_band``: the reference's 95 % Monte-Carlo band, when it has one."""

    frequency_hz: NDArray[np.float64]
    reference: NDArray[np.complex128]
    curves: Mapping[str, NDArray[np.complex128]]
    response_dof: str
    input_dof: str
    modes: int
    reference_band: CurveBand | None = None


def study_targets(study: Study, identification: Identification | None) -> TargetSet:
    """Targets from the study: a list, the modes of this study's extracted linear FRF, or
    the linear FRF of an earlier ``nlupdate identify`` output."""
    t = study.targets
    reference, std, loss_factors, band, fit_frac = None, None, None, None, None
    model_modes = t.model_modes
    if t.from_identification:
        modes = list(t.modes or range(1, len(identification.modes) + 1))
        if not identification.modes:
            raise StudyError(f"{study.path}: [targets] from_identification: the extracted linear FRF has no resonance "
                             f"in the measured band")
        if max(modes) > len(identification.modes):
            found = ", ".join(f"{f:.2f}" for f in identification.natural_frequencies_hz)
            raise StudyError(f"{study.path}: [targets] modes {modes}: the extracted linear FRF has "
                             f"{len(identification.modes)} mode(s) ({found} Hz)")
        index = [m - 1 for m in modes]
        frequencies = identification.natural_frequencies_hz[index]
        std = identification.natural_frequency_std_hz[index]
        loss_factors = identification.loss_factors[index]
        reference = (identification.linear_frequency_hz, identification.linear_frf)
        band = identification.linear_frf_band
        fit_frac = reference_fit_frac(identification, index, frequencies, study.comparison.band_fraction)
    elif t.identification is not None:
        frequency, h = read_linear_frf(study.resolve(t.identification), t.response_dof, t.input_dof, t.force_level_n)
        reference = (frequency, h)
        try:
            frequencies = frf_natural_frequencies(frequency, h, t.n_modes, t.band_hz, t.frf_method)
        except ValueError as error:
            raise StudyError(f"{study.path}: [targets] identification {t.identification!r}: {error}") from None
    elif t.amplitude_models:  # the linear limits (joint stuck) of amplitude-dependent modal models
        try:
            models = [read_amplitude_model(study.resolve(written)) for written in t.amplitude_models]
        except (ValueError, OSError) as error:  # AmplitudeModelError, InputFileError: the file named
            raise StudyError(f"{study.path}: [targets] amplitude_models: {error}") from None
        frequencies = np.array([m.natural_frequency_hz for m in models])
        model_modes = model_modes or tuple(m.mode for m in models)
    else:
        frequencies = np.asarray(t.frequencies_hz, dtype=float)
        std = np.asarray(t.std_hz, dtype=float) if t.std_hz is not None else None
    if study.comparison.frf is not None:
        response, inp = measured_pair(study)
        reference = read_linear_frf(study.comparison.frf, response, inp, t.force_level_n)
        band, fit_frac = None, None
    shapes = np.asarray(t.mode_shapes, dtype=float).T if t.mode_shapes is not None else None
    try:
        targets = UpdatingTargets(frequencies, t.weights, shapes, t.coordinates, t.labels, model_modes)
    except ValueError as error:
        raise StudyError(f"{study.path}: [targets]: {error}") from None
    return TargetSet(targets, std, reference, loss_factors, band, fit_frac)


def reference_fit_frac(identification: Identification, modes: Sequence[int], frequencies_hz: NDArray,
                       band_fraction: float) -> NDArray[np.float64]:
    """Per target: FRAC of the identification's one-mode fit of mode ``modes[i]`` (0-based)
    against the extracted linear FRF within ±``band_fraction`` of ``frequencies_hz[i]``
    (as :func:`nlupdate.core.updating.runs.compare_candidates` scores the candidates; NaN with
    fewer than 3 points in the band)."""
    f, h = identification.linear_frequency_hz, identification.linear_frf
    out = np.full(len(modes), np.nan)
    for i, (mode, target) in enumerate(zip(modes, frequencies_hz)):
        band = np.abs(f - target) <= band_fraction * target
        if band.sum() >= 3:
            out[i] = frac(h[band], identification.modes[mode].receptance(f[band]))
    return out


def run_name(method: str, formula: str, parameter_set: Sequence[str]) -> str:
    """Name of an eigensensitivity run: method, formula and parameter set."""
    return f"{method} {FORMULA_LABELS[formula]} {{{', '.join(parameter_set)}}}"


def run_names_explained(parameters: Sequence[Parameter], formulas: Sequence[str]) -> str:
    """What the runs' names say, for a reader who meets them first: each parameter they
    update (:meth:`~nlupdate.fe.adapters.base.Parameter.described`) and the O(·) of the
    eigensensitivity ``formulas`` (:data:`~nlupdate.core.updating.sensitivity.ORDER_MEANING`)."""
    orders = order_labels(formulas)
    return "; ".join(part for part in (
        "parameters " + ", ".join(p.described() for p in parameters) if parameters else "",
        f"{', '.join(orders)}: {ORDER_MEANING}" if orders else "") if part)


def updating_intro(study: Study, runs: Sequence[UpdatingRun]) -> str:
    """The line before the updating runs: how many, and what their names say
    (:func:`run_names_explained`)."""
    updated = {p.name: p for run in runs for p in run.parameters}
    formulas = [run.options.formula for run in runs if run.method == "eigensensitivity"]
    explained = run_names_explained(list(updated.values()), formulas)
    return f"{len(runs)} run{'' if len(runs) == 1 else 's'}" + (f"; {explained}" if explained else "")


def held_at_start(study: Study, updated: Sequence[str]) -> dict[str, float]:
    """The model values a run does not update: ``[adapter]`` fixed values and every other
    ``[[parameters]]`` entry at its start — the same model the prediction of that run uses."""
    return {**study.fixed, **{p.name: p.start for p in study.parameters if p.name not in updated}}


def updating_model(study: Study) -> AdapterSpec:
    """The FE model the updating runs evaluate."""
    return study.adapter


def updating_runs(study: Study, targets: TargetSet) -> list[UpdatingRun]:
    """One task per eigensensitivity formula × parameter set and per optimisation candidate."""
    by_name = {p.name: p for p in study.parameters}
    tasks = []
    if study.eigensensitivity is not None:
        for parameter_set in study.eigensensitivity.parameter_sets:
            for formula in study.eigensensitivity.formulas:
                options = dataclasses.replace(study.eigensensitivity.options, formula=formula)
                tasks.append(UpdatingRun(run_name("eigensensitivity", formula, parameter_set), study.adapter,
                                          tuple(by_name[n] for n in parameter_set), targets.targets, "eigensensitivity",
                                          options, held_at_start(study, parameter_set)))
    if study.optimisation is not None:
        options = study.optimisation
        for entry in study.candidates:
            parameters = tuple(
                dataclasses.replace(by_name[n], start=entry.start[n]) if n in entry.start else by_name[n]
                for n in entry.parameters
            )
            try:
                weighted = targets.targets.with_weights(entry.weights)
            except ValueError as error:
                raise StudyError(f"{study.path}: [[optimisation.candidates]] {entry.name!r}: {error}") from None
            tasks.append(UpdatingRun(entry.name, study.adapter, parameters, weighted, "optimisation", options,
                                      held_at_start(study, entry.parameters)))
    return tasks


def comparison_damping(study: Study, targets: TargetSet) -> tuple[float | list[float], float | list[float]]:
    """(damping ratios, loss factors) of the candidates' modal FRFs: the study's, else the
    loss factors the identification measured for the target modes, else none."""
    ratios = study.comparison.damping_ratios
    losses = study.comparison.loss_factors
    if losses is None:
        losses = list(targets.loss_factors) if targets.loss_factors is not None and ratios is None else 0.0
    return (0.0 if ratios is None else ratios), losses


def run_update(study: Study, run: UpdatingRun, evaluator: PointEvaluator, targets: TargetSet) -> UpdatingResult:
    """One updating run, its FE points evaluated by ``evaluator``."""
    return update(run, evaluator)


def run_verdict(run: UpdatingRun, outcome: UpdatingResult | RunFailure) -> str:
    """A computed run's progress detail (the line names the run): converged or not, and
    the FE evaluations it made new and found already made."""
    if isinstance(outcome, RunFailure):
        return f"FAILED: {outcome.error}"
    verdict = "converged" if outcome.converged else f"not converged ({outcome.reason})"
    return f"{verdict}, {outcome.counts['new']} new / {outcome.counts['cached']} cached FE runs"


def compare_runs(study: Study, targets: TargetSet, updating: UpdatingOutcome) -> Comparison:
    """Mode-by-mode comparison (with FRAC against the reference FRF when there is one), the
    ranking for the study's user weights (default: the target weights; runs that converged
    first) and each converged run's parameter uncertainty."""
    runs = updating.runs
    response, inp = model_pair(study) if targets.reference is not None else (None, None)
    comparison = compare_candidates(runs, targets.reference, response, inp, *comparison_damping(study, targets),
                                    study.comparison.band_fraction)
    weights = study.comparison.user_weights
    ranking = rank_candidates(comparison, weights if weights is not None else list(targets.targets.weights),
                              {run.name: run.converged for run in runs})
    return Comparison(comparison, ranking, parameter_uncertainties(study, targets, runs))


def candidate_frfs(study: Study, targets: TargetSet, updating: UpdatingOutcome) -> CandidateFRFs:
    """Every run's (and the initial model's) linear FRF against the targets' reference."""
    frequency, h = targets.reference
    response, inp = model_pair(study)
    damping = comparison_damping(study, targets)
    runs = updating.runs
    curves = {"initial": candidate_frf(runs[0], frequency, response, inp, *damping, "initial")}
    curves.update({run.name: candidate_frf(run, frequency, response, inp, *damping) for run in runs})
    return CandidateFRFs(np.asarray(frequency, dtype=float), np.asarray(h), curves, response, inp,
                         len(runs[0].final.natural_frequencies_hz), targets.reference_band)


def parameter_uncertainties(study: Study, targets: TargetSet, runs: Sequence[UpdatingResult]) -> dict[str, ParameterUncertainty]:
    """Each converged run's parameter standard deviations from the target uncertainty (none
    when the targets carry none): where a run stopped without converging, the linearised
    spread describes no result."""
    if targets.std_hz is None:
        return {}
    lower = {p.name: p.lower for p in study.parameters}
    upper = {p.name: p.upper for p in study.parameters}
    return {run.name: propagate_target_uncertainty(run, targets.std_hz, lower, upper) for run in runs if run.converged}
