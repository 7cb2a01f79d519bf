"""The steps of a study, each a function of plain inputs (a :class:`~nlupdate.study.spec.Study`
and what earlier steps returned); :mod:`nlupdate.study.chain` declares their order.

Both interpreters of the chain — :func:`nlupdate.study.sequential.run_study` in one process and
the Prefect flows (:mod:`nlupdate.orchestration.flows`) as cached tasks — call these very functions;
nothing here knows which of the two is calling, nor where FE points are evaluated (the
fan-out steps get an evaluator).

measured data → identification → targets → updating runs (one per formula × parameter
set and per optimisation candidate) → comparison, ranking and parameter uncertainty →
the candidates' linear FRFs → predictions of the updated nonlinear models at every force
level, correlated → the warnings on results not to be trusted as they stand.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from nlupdate.fe.adapters.base import ModalResult
from nlupdate.core.correlation.metrics import frac
from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.pipeline import Identification, identify
from nlupdate.core.identification.trust import TrustWarning
from nlupdate.core.identification.uncertainty import CurveBand
from nlupdate.core.measurement.frf_table import force_levels
from nlupdate.core.measurement.frf_files import read_frf_table, read_frf_tables
from nlupdate.core.measurement.time_history import estimate_frf, read_time_record
from nlupdate.core.measurement.units import calibrated
from nlupdate.core.model.amplitude_modal import read_amplitude_model
from nlupdate.core.model.model_file import element_from_table, load_system
from nlupdate.core.model.system import NonlinearSystem
from nlupdate.core.prediction.predict import predict_measured
from nlupdate.core.response.simulate import simulate_frf_table
from nlupdate.study.spec import SimulationSpec, Study, StudyError
from nlupdate.fe.adapters.registry import AdapterSpec, build_adapter
from nlupdate.core.updating.runs import UpdatingRun, candidate_frf, compare_candidates, rank_candidates, update
from nlupdate.core.updating.evaluation import PointEvaluator
from nlupdate.core.updating.parameter_warnings import updating_warnings
from nlupdate.core.updating.eigensensitivity import UpdatingResult
from nlupdate.core.updating.sensitivity import FORMULA_LABELS
from nlupdate.core.updating.targets import UpdatingTargets, frf_natural_frequencies, read_linear_frf
from nlupdate.core.updating.target_uncertainty import ParameterUncertainty, propagate_target_uncertainty
from nlupdate.core.validation.held_out import Validation, validate
from nlupdate.core.validation.held_response import held_runs_of, with_held_runs


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


@dataclass(frozen=True)
class PredictionJob:
    """One model to predict with: its name (``initial`` or a run) and its FE point."""

    name: str
    point: Mapping[str, float]


@dataclass(frozen=True, eq=False)
class Prediction:
    """The updated nonlinear model of one run (or ``initial``) at every force level.

    parameters: the model point (fixed values included); loss_factor: modal η used and
    its source; table: predicted FRFs of the measured curve (measured coordinate names);
    correlation: per-level metrics (:func:`nlupdate.core.correlation.levels.correlate_levels`).
    """

    name: str
    parameters: Mapping[str, float]
    loss_factor: float
    loss_factor_source: str
    table: pd.DataFrame
    correlation: pd.DataFrame


# --------------------------------------------------------------------------- measured data
def truth_system(study: Study, simulation: SimulationSpec) -> NonlinearSystem:
    """The hidden truth of a simulated test: a model file, or an FE model (adapter at the
    truth parameters, modal loss factor) with the listed elements."""
    if simulation.model_file is not None:
        return load_system(simulation.model_file)
    modes = build_adapter(simulation.adapter).evaluate(simulation.parameters)
    model = modes.to_modal_model(loss_factors=simulation.loss_factor)
    elements = tuple(
        element_from_table(table, model, f"{study.path} [[measured.simulate.nonlinear]] #{i + 1}")
        for i, table in enumerate(simulation.elements)
    )
    return NonlinearSystem(model, elements)


def measured_description(study: Study) -> str:
    """Where the measured data come from, in a few words."""
    spec = study.measured
    if spec.simulate is not None:
        return "simulated test"
    return str(spec.file) if spec.file is not None else f"{len(spec.files or spec.time_histories)} files"


def measured_table(study: Study) -> pd.DataFrame:
    """The study's measured-FRF table: read from its file, or simulated (stepped sine read
    off the continuation, docs/methods.md §8 noise)."""
    if study.measured is None:
        raise StudyError(f"{study.path}: the study has no [measured] data")
    spec = study.measured
    if spec.file is not None:
        return read_frf_table(spec.file, options=spec.read_options())
    if spec.files:
        return read_frf_tables([path for path, _ in spec.files], options=spec.read_options())
    if spec.time_histories:
        records = [read_time_record(path) for path in spec.time_histories]
        input_dof = spec.input_dof or ("force" if records[0].reference_unit == "N" else "voltage")
        table = estimate_frf(records, input_dof, spec.excitation, spec.response_quantity).table
        if spec.reference_calibration is not None:
            table = calibrated(table, spec.reference_calibration, str(study.path))
        return table
    sim = study.measured.simulate
    table, _ = simulate_frf_table(truth_system(study, sim), sim.input_dof, np.asarray(sim.frequencies_hz), sim.forces_n,
                                  sweep=sim.sweep, noise=sim.noise, seed=sim.seed)
    return table


# --------------------------------------------------------------------------- identification
def identification_step(study: Study, table: pd.DataFrame) -> Identification:
    """:func:`nlupdate.core.identification.pipeline.identify` on the study's measured curve."""
    settings = study.identification
    data = FRFLevels.from_table(table, settings.response_dof, settings.input_dof)
    return identify(data, settings)


# --------------------------------------------------------------------------- targets and runs
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
        response, inp = _measured_pair(study)
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


def _measured_pair(study: Study) -> tuple[str, str]:
    """(response, input) names of the measured curve the study compares with."""
    t = study.targets
    if t is not None and t.response_dof is not None and t.input_dof is not None:
        return t.response_dof, t.input_dof
    if study.identification is not None:
        return study.identification.response_dof, study.identification.input_dof
    raise StudyError(f"{study.path}: comparing with an FRF needs [targets] response_dof and input_dof")


def model_pair(study: Study) -> tuple[str, str]:
    """(response, input) names of the measured curve's coordinates in the FE model."""
    response, inp = _measured_pair(study)
    t = study.targets
    if t is None:
        return response, inp
    return t.model_response_dof or response, t.model_input_dof or inp


def run_name(method: str, formula: str, parameter_set: Sequence[str]) -> str:
    """Name of an eigensensitivity run: method, formula and parameter set."""
    return f"{method} {FORMULA_LABELS[formula]} {{{', '.join(parameter_set)}}}"


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


# --------------------------------------------------------------------------- prediction
def prediction_adapter(study: Study) -> AdapterSpec:
    """The FE model used for predictions: the study's adapter with the prediction's option
    overrides (typically more modes, local ones included)."""
    options = {**study.adapter.options, **study.prediction.adapter_options}
    return AdapterSpec(study.adapter.kind, study.adapter.model, options)


def prediction_jobs(study: Study, updating: UpdatingOutcome, comparison: Comparison, *_: object) -> list[PredictionJob]:
    """Every model to predict with: ``initial`` and the runs the ``[prediction] candidates``
    choice names (default: the best-ranked run)."""
    runs, ranking = updating.runs, comparison.ranking
    start = held_at_start(study, ())
    by_name = {run.name: run for run in runs}
    choice = study.prediction.candidates
    if choice == "best":
        names = [name for name in ranking["candidate"] if name in by_name][:1]
    elif choice == "all":
        names = list(by_name)
    else:
        unknown = [name for name in choice if name not in by_name]
        if unknown:
            raise StudyError(f"{study.path}: [prediction] candidates {unknown} are not runs of this study; runs: "
                             f"{list(by_name)}")
        names = list(choice)
    return [PredictionJob("initial", start)] + [PredictionJob(name, {**start, **by_name[name].parameters})
                                                for name in names]


def prediction_levels(study: Study, table: pd.DataFrame) -> tuple[float, ...]:
    """Force levels (N) to predict: the study's list, or every level of the measured curve."""
    if study.prediction.force_levels_n is not None:
        return study.prediction.force_levels_n
    response, inp = _measured_pair(study)
    curve = table[(table["response_dof"].astype(str) == response) & (table["input_dof"].astype(str) == inp)]
    return tuple(float(level) for level in force_levels(curve))


def predict_job(study: Study, job: PredictionJob, evaluator: PointEvaluator, updating: UpdatingOutcome,
                comparison: Comparison, identification: Identification, table: pd.DataFrame) -> Prediction:
    """The prediction of one model: its FE modes at its point (through ``evaluator``), then
    :func:`predict_model`."""
    modes = evaluator([job.point])[0]
    return predict_model(study, job.name, job.point, modes, identification, table)


def predict_model(
    study: Study, name: str, point: Mapping[str, float], modes: ModalResult, identification: Identification,
    table: pd.DataFrame,
) -> Prediction:
    """Predict the measured curve at every prediction level with the FE ``modes`` (at
    ``point``) and the identified elements, by the response method of ``[prediction]``
    (describing function or harmonic balance), and correlate it with the measurement."""
    response, inp = _measured_pair(study)
    model_response, model_input = model_pair(study)
    coordinates = list(modes.coordinates)
    for what, dof in (("response", model_response), ("input", model_input)):
        if dof not in coordinates:
            raise StudyError(f"{study.path}: [prediction]: the {what} coordinate {dof!r} is not a coordinate of the "
                             f"prediction model {coordinates}; set [adapter.options] or [prediction.adapter_options] "
                             f"coordinates")
    elements = identification.elements((coordinates.index(model_response),))
    setting = study.prediction.loss_factor
    if setting == "identified":
        setting = float(np.mean(identification.loss_factors))
    found = predict_measured(modes, elements, table, response, inp, model_response_dof=model_response,
                             model_input_dof=model_input, loss_factor=setting,
                             force_levels_n=prediction_levels(study, table), sweep=study.prediction.sweep,
                             harmonic_balance=study.prediction.harmonic_balance)
    source = ("the extracted linear FRF's modes (identification)" if study.prediction.loss_factor == "identified"
              else found.loss_factor_source)
    return Prediction(name, dict(point), found.loss_factor, source, found.table, found.correlation)


# --------------------------------------------------------------------------- record
def _model_record(spec: AdapterSpec | None) -> dict | None:
    if spec is None:
        return None
    try:
        version = build_adapter(spec).solver_version()
    except (ValueError, RuntimeError) as error:
        version = f"unknown ({error})"
    return {"kind": spec.kind, "model": spec.model, "options": dict(spec.options), "solver": version}


def models_used(study: Study) -> dict[str, dict | None]:
    """The FE models the study used — for updating, as the simulated truth, for
    predictions — and the version of the program that solved each."""
    models = {"updating": _model_record(study.adapter)}
    simulation = study.measured.simulate if study.measured is not None else None
    if simulation is not None and simulation.adapter is not None:
        models["simulated_truth"] = _model_record(simulation.adapter)
    if study.prediction is not None and study.adapter is not None:
        models["prediction"] = _model_record(prediction_adapter(study))
    return models


# --------------------------------------------------------------------------- trust
def best_run(updating: UpdatingOutcome | None, comparison: Comparison | None) -> UpdatingResult | None:
    """The best-ranked updating run (converged ones rank first), None without runs."""
    if updating is None or not updating.runs or comparison is None:
        return None
    by_name = {run.name: run for run in updating.runs}
    name = next((n for n in comparison.ranking["candidate"] if n in by_name), None)
    return by_name.get(name)


def prediction_warning(predictions: Sequence[Prediction], best: str) -> TrustWarning | None:
    """``prediction_worse`` when the prediction of the run ``best`` matches the measurements
    worse than the initial model's: a lower mean FRAC over the force levels, or a larger
    mean relative FRF error ‖H_model − H_measured‖ / ‖H_measured‖. None when either
    prediction is missing or the best is no worse by both."""
    by_name = {p.name: p for p in predictions}
    if "initial" not in by_name or best not in by_name:
        return None
    initial, updated = by_name["initial"].correlation, by_name[best].correlation
    worse = []
    if updated["frac"].mean() < initial["frac"].mean():
        worse.append(f"FRAC per level {_spread(updated['frac'])} against {_spread(initial['frac'])}")
    if updated["normalised_error"].mean() > initial["normalised_error"].mean():
        worse.append(f"relative FRF error per level {_spread(updated['normalised_error'])} against "
                     f"{_spread(initial['normalised_error'])}")
    if not worse:
        return None
    return TrustWarning("prediction", "prediction_worse",
                        f"the best updated model `{best}` predicts the measurements worse than the initial model: "
                        + "; ".join(worse) + " (initial): the updating made the model worse where it matters",
                        "prediction")


def _spread(values: pd.Series) -> str:
    low, high = float(values.min()), float(values.max())
    return f"{low:.2g}" if f"{low:.2g}" == f"{high:.2g}" else f"{low:.2g}–{high:.2g}"


def study_warnings(study: Study, identification: Identification | None, updating: UpdatingOutcome | None,
                   comparison: Comparison | None, predictions: Sequence[Prediction] | None = None,
                   ) -> tuple[TrustWarning, ...]:
    """The warning that the best model predicts worse than the initial one
    (:func:`prediction_warning`) first, then the identification's warnings
    (:mod:`nlupdate.core.identification.trust`), then each updating run's
    (:mod:`nlupdate.core.updating.parameter_warnings`: not converged, parameters that ended on
    a bound of the study, propagated uncertainty above the value), in run order."""
    out: list[TrustWarning] = []
    best = best_run(updating, comparison)
    worse = prediction_warning(predictions or (), best.name) if best is not None else None
    if worse is not None:
        out.append(worse)
    if identification is not None:
        out += identification.warnings
    bounds = {p.name: (p.lower, p.upper) for p in study.parameters}
    uncertainties = {} if comparison is None else comparison.uncertainties
    for run in (updating.runs if updating is not None else ()):
        out += updating_warnings(run, {**(run.bounds or {}), **bounds}, uncertainties.get(run.name))
    return tuple(out)


def validation_step(study: Study, table: pd.DataFrame) -> Validation:
    """``[validation]``: the measured driving-point curve judged on held-out levels
    (:func:`nlupdate.core.validation.held_out.validate`)."""
    spec = study.validation
    inputs = sorted(set(table["input_dof"].astype(str)))
    input_dof = spec.input_dof or (study.identification.input_dof if study.identification is not None else None) \
        or (inputs[0] if len(inputs) == 1 else None)
    if input_dof is None:
        raise StudyError(f"{study.path}: [validation] input_dof: the measured table has input dofs {inputs}; name one")
    measured = study.measured
    paths = [measured.file] if measured.file is not None else [path for path, _ in measured.files]
    try:
        data = FRFLevels.from_table(table, input_dof, input_dof)
        validation = validate(data, spec.hold_out, spec.models)
        if spec.response_controlled and paths:
            runs, notes = held_runs_of(paths, measured.read_options(), data)
            if runs:
                validation = with_held_runs(validation, data, runs, spec.models)
            if notes:
                validation = dataclasses.replace(
                    validation, response_controlled_notes=validation.response_controlled_notes + tuple(notes))
        return validation
    except ValueError as error:
        raise StudyError(f"{study.path}: [validation]: {error}") from None
