"""The study's measured data and their identification, and the coordinates of the measured
curve — as measured and in the FE model — that the later steps compare with."""
from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd

from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.pipeline import Identification, identify
from nlupdate.core.measurement.frf_files import read_frf_table, read_frf_tables
from nlupdate.core.measurement.time_history import estimate_frf, read_time_record
from nlupdate.core.measurement.units import calibrated, validate_reads_runs_apart
from nlupdate.core.model.model_file import element_from_table, load_system
from nlupdate.core.prediction.predict import model_dofs
from nlupdate.core.model.system import NonlinearSystem
from nlupdate.core.response.simulate import simulate_frf_table
from nlupdate.fe.adapters.registry import build_adapter
from nlupdate.study.spec import SimulationSpec, Study, StudyError


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
    paths = [spec.file] if spec.file is not None else [path for path, _ in spec.files]
    options = spec.read_options()
    # response-controlled runs read by [validation] or [amplitude] are not lost
    apart = () if study.validation is None else validate_reads_runs_apart(paths, study.validation.response_controlled)
    if study.amplitude is not None:
        apart = (*apart, *(str(study.resolve(path)) for path in study.amplitude.response_controlled))
    if apart:
        options = dataclasses.replace(options, runs_read_apart=tuple(apart))
    if spec.file is not None:
        return read_frf_table(spec.file, options=options)
    if spec.files:
        return read_frf_tables(paths, options=options)
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


def identification_step(study: Study, table: pd.DataFrame) -> Identification:
    """:func:`nlupdate.core.identification.pipeline.identify` on the study's measured curve."""
    settings = study.identification
    data = FRFLevels.from_table(table, settings.response_dof, settings.input_dof)
    return identify(data, settings)


def measured_pair(study: Study) -> tuple[str, str]:
    """(response, input) names of the measured curve the study compares with."""
    t = study.targets
    if t is not None and t.response_dof is not None and t.input_dof is not None:
        return t.response_dof, t.input_dof
    if study.identification is not None:
        return study.identification.response_dof, study.identification.input_dof
    raise StudyError(f"{study.path}: comparing with an FRF needs [targets] response_dof and input_dof")


def model_pair(study: Study) -> tuple[str, str]:
    """(response, input) names of the measured curve's coordinates in the FE model
    (:func:`~nlupdate.core.prediction.predict.model_dofs`: a driving point renamed by
    ``[targets] model_response_dof`` alone names its input too)."""
    t = study.targets
    return model_dofs(*measured_pair(study), *((t.model_response_dof, t.model_input_dof) if t is not None else ()))
