"""The warnings on a study's results not to be trusted as they stand: a best model that
predicts worse than the initial one, the identification's and each updating run's."""
from __future__ import annotations

from typing import Sequence

import pandas as pd

from nlupdate.core.identification.pipeline import Identification
from nlupdate.core.identification.trust import TrustWarning
from nlupdate.core.prediction.predict import LOSS_FACTOR_BOUNDS, loss_factor_bound
from nlupdate.core.updating.eigensensitivity import UpdatingResult
from nlupdate.core.updating.parameter_warnings import updating_warnings
from nlupdate.core.updating.runs import best_ranked
from nlupdate.study.spec import Study
from nlupdate.study.steps.prediction import Prediction
from nlupdate.study.steps.updating import Comparison, TargetSet, UpdatingOutcome


def best_run(updating: UpdatingOutcome | None, comparison: Comparison | None) -> UpdatingResult | None:
    """The best-ranked updating run (converged ones rank first), None without runs."""
    if updating is None or not updating.runs or comparison is None:
        return None
    return {run.name: run for run in updating.runs}.get(best_ranked(comparison.ranking))


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


def loss_factor_warning(study: Study, predictions: Sequence[Prediction]) -> TrustWarning | None:
    """``loss_factor_at_bound`` when ``[prediction] loss_factor = "low_force_fit"`` ended on a
    bound of its search for some updated models (:func:`~nlupdate.core.prediction.predict.loss_factor_bound`):
    their predictions' damping is the search's end, not the structure's. The ``initial``
    model, a baseline whose resonance may lie far from the curve's, says so in its summary
    line only."""
    if study.prediction is None or study.prediction.loss_factor != "low_force_fit":
        return None
    stuck = [p for p in predictions if p.name != "initial" and loss_factor_bound(p.loss_factor) is not None]
    if not stuck:
        return None
    low, high = LOSS_FACTOR_BOUNDS
    return TrustWarning("prediction", "loss_factor_at_bound",
                        f"the loss factor fitted to the lowest level's measurement is {stuck[0].loss_factor:.3g} for "
                        f"{', '.join(f'`{p.name}`' for p in stuck)}, on the {loss_factor_bound(stuck[0].loss_factor)} "
                        f"bound of its search ({low:g}–{high:g}): no loss factor in that range reproduces that "
                        "curve, so the predictions' damping is the search's end, not the structure's; check the "
                        "measured curve's sign and units, or give [prediction] loss_factor", "prediction")


def _spread(values: pd.Series) -> str:
    low, high = float(values.min()), float(values.max())
    return f"{low:.2g}" if f"{low:.2g}" == f"{high:.2g}" else f"{low:.2g}–{high:.2g}"


def study_warnings(study: Study, identification: Identification | None, updating: UpdatingOutcome | None,
                   comparison: Comparison | None, predictions: Sequence[Prediction] | None = None,
                   targets: TargetSet | None = None) -> tuple[TrustWarning, ...]:
    """The warning that the best model predicts worse than the initial one
    (:func:`prediction_warning`) first, then the identification's warnings
    (:mod:`nlupdate.core.identification.trust`), then each updating run's
    (:mod:`nlupdate.core.updating.parameter_warnings`: not converged, parameters that ended on
    a bound of the study, propagated uncertainty above the value, targets missed beyond
    their standard deviations ``targets.std_hz``), in run order."""
    out: list[TrustWarning] = []
    best = best_run(updating, comparison)
    worse = prediction_warning(predictions or (), best.name) if best is not None else None
    if worse is not None:
        out.append(worse)
    on_bound = loss_factor_warning(study, predictions or ())
    if on_bound is not None:
        out.append(on_bound)
    if identification is not None:
        out += identification.warnings
    bounds = {p.name: (p.lower, p.upper) for p in study.parameters}
    uncertainties = {} if comparison is None else comparison.uncertainties
    for run in (updating.runs if updating is not None else ()):
        out += updating_warnings(run, {**(run.bounds or {}), **bounds}, uncertainties.get(run.name),
                                 target_std_hz=None if targets is None else targets.std_hz)
    return tuple(out)

