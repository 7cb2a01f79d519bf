"""The FE models a study used, and the program version that solved each (for the archive)."""
from __future__ import annotations

from nlupdate.fe.adapters.registry import AdapterSpec, build_adapter
from nlupdate.study.spec import Study
from nlupdate.study.steps.prediction import prediction_adapter


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

