"""``[validation]`` of a study: the measured driving-point curve judged on held-out levels."""
from __future__ import annotations

import dataclasses

import pandas as pd

from nlupdate.core.identification.amplitude_inputs import SourceFiles, read_sources
from nlupdate.core.identification.amplitude_modal_fit import default_resamples
from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.measurement.frf_table import MeasurementTableError, table_input
from nlupdate.core.model.amplitude_modal import AmplitudeModelError
from nlupdate.core.validation.held_out import Validation
from nlupdate.core.validation.held_response import validate_measured
from nlupdate.core.validation.impact_limit import impact_linear_limit
from nlupdate.core.validation.held_type import (
    BACKBONE_OF_MODEL, HeldType, MissingShape, Source, TypedValidation, hold_out_type, stepped_sine_source,
)
from nlupdate.study.spec import Study, StudyError


def validation_step(study: Study, table: pd.DataFrame) -> Validation:
    """``[validation]``: the measured driving-point curve judged on held-out levels
    (:func:`nlupdate.core.validation.held_out.validate`), with ``impact``'s linear limit kept
    beside them as ``nlupdate validate --impact`` keeps it."""
    spec = study.validation
    try:
        input_dof = table_input(table, spec.input_dof or (study.identification.input_dof
                                                          if study.identification is not None else None),
                                "[validation] input_dof")
    except MeasurementTableError as error:
        raise StudyError(f"{study.path}: {error}") from None
    measured = study.measured
    paths = [measured.file] if measured.file is not None else [path for path, _ in measured.files]
    try:
        data = FRFLevels.from_table(table, input_dof, input_dof)
        if spec.impact is not None:
            data = dataclasses.replace(data, linear_limit=impact_linear_limit(spec.impact, spec.channel, None, data))
        validation = validate_measured(data, spec.hold_out, spec.models, spec.response_controlled, paths,
                                       measured.read_options())
        if spec.hold_out_type is not None:
            validation = TypedValidation(**{f.name: getattr(validation, f.name) for f in dataclasses.fields(validation)},
                                         held_type=held_type(study, data, paths))
        return validation
    except (AmplitudeModelError, ValueError) as error:
        raise StudyError(f"{study.path}: [validation]: {error}") from None


def held_type(study: Study, data: FRFLevels, paths: list[str]) -> HeldType:
    """``[validation] hold_out_type``: the sources ``nlupdate validate --hold-out-type`` reads
    — the measured stepped sine, the response-controlled runs of its MATLAB files (with
    ``response_controlled`` auto or kept), the ``ring_down`` records (displacement, m; band found from
    the record; :func:`~nlupdate.core.identification.amplitude_inputs.read_sources`, as the command
    reads them) — one held out by the amplitude-dependent modal model of the others
    (:func:`~nlupdate.core.validation.held_type.hold_out_type`)."""
    spec = study.validation
    shapes = dict(spec.shapes)
    try:
        sources: list[Source] = [stepped_sine_source(", ".join(paths) or "[measured]", data, shapes)]
    except MissingShape as error:
        raise StudyError(f"{study.path}: [validation] key 'shapes': {error}; got {sorted(shapes)}") from None
    runs = tuple(p for p in paths if p.lower().endswith(".mat")) if spec.response_controlled != "off" else ()
    read, _, _ = read_sources(SourceFiles(ring_down=tuple(spec.ring_down), response_controlled=runs,
                                          options=study.measured.read_options()), shapes)  # as the command reads them
    sources += [s for kind in ("response-controlled", "ring-down") for s in read if s[3] == kind]
    backbone = BACKBONE_OF_MODEL[spec.models[0]]
    return hold_out_type(sources, spec.hold_out_type, tuple(shapes.items()), data, backbone,
                         resamples=default_resamples(backbone))
