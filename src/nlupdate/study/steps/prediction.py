"""The predictions of a study: the initial model and the chosen updating runs, each an
updated nonlinear model predicting the measured curve at every force level, correlated."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import pandas as pd

from nlupdate.core.correlation.levels import LevelSummary, summarise_levels
from nlupdate.core.identification.pipeline import Identification
from nlupdate.core.measurement.frf_table import force_levels
from nlupdate.core.prediction.predict import chosen_loss_factor, predict_measured
from nlupdate.core.updating.evaluation import PointEvaluator
from nlupdate.core.updating.runs import best_ranked
from nlupdate.fe.adapters.base import ModalResult
from nlupdate.fe.adapters.registry import AdapterSpec
from nlupdate.study.spec import Study, StudyError
from nlupdate.study.steps.measured import measured_pair, model_pair
from nlupdate.study.steps.updating import Comparison, UpdatingOutcome, held_at_start


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

    @property
    def summary(self) -> LevelSummary:
        """The correlation at a glance (:func:`~nlupdate.core.correlation.levels.summarise_levels`)."""
        return summarise_levels(self.correlation)


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
        names = [name for name in [best_ranked(ranking)] if name in by_name]
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
    response, inp = measured_pair(study)
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
    response, inp = measured_pair(study)
    model_response, model_input = model_pair(study)
    coordinates = list(modes.coordinates)
    for what, dof in (("response", model_response), ("input", model_input)):
        if dof not in coordinates:
            raise StudyError(f"{study.path}: [prediction]: the {what} coordinate {dof!r} is not a coordinate of the "
                             f"prediction model {coordinates}; set [adapter.options] or [prediction.adapter_options] "
                             f"coordinates")
    elements = identification.elements((coordinates.index(model_response),))
    found = predict_measured(modes, elements, table, response, inp, model_response_dof=model_response,
                             model_input_dof=model_input,
                             loss_factor=chosen_loss_factor(study.prediction.loss_factor, identification),
                             force_levels_n=prediction_levels(study, table), sweep=study.prediction.sweep,
                             harmonic_balance=study.prediction.harmonic_balance)
    source = ("the extracted linear FRF's modes (identification)" if study.prediction.loss_factor == "identified"
              else found.loss_factor_source)
    return Prediction(name, dict(point), found.loss_factor, source, found.table, found.correlation)

