"""``[validation]`` of a study: the measured driving-point curve judged on held-out levels."""
from __future__ import annotations

import dataclasses

import pandas as pd

from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.validation.held_out import Validation, validate
from nlupdate.core.validation.held_response import held_runs_of, with_held_runs
from nlupdate.study.spec import Study, StudyError


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
