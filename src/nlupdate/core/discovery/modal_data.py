"""A modal table (:mod:`nlupdate.core.measurement.modal_table`) matched to the model's modes and coordinates."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from nlupdate.core.discovery.errors import MeasuredDataError
from nlupdate.core.discovery.frf_data import ONE_LEVEL_REASON, ForceLevels
from nlupdate.core.measurement.modal_table import ModalTableError, validate_modal_table
from nlupdate.core.model.linear import LinearModel, LumpedModel, ModalModel


def as_modal(model: LinearModel) -> ModalModel:
    """The model as a modal model (a lumped one through its modes)."""
    if isinstance(model, ModalModel):
        return model
    if isinstance(model, LumpedModel):
        return model.to_modal(None if not model.is_sparse else min(model.n_dof - 1, 20))
    raise MeasuredDataError(f"model: a modal table needs a lumped or modal model, got {type(model).__name__}")


@dataclass(frozen=True, eq=False)
class ModalData(ForceLevels):
    """Natural frequency (Hz) and damping ratio per point (force level, mode).

    mode: 0-based index of the model's mode (the table's mode number − 1); force in N;
    input_dof: model index of the excited coordinate.
    """

    input_dof: int
    input_name: str
    force: NDArray[np.float64]
    mode: NDArray[np.int64]
    frequency_hz: NDArray[np.float64]
    damping_ratio: NDArray[np.float64]

    @property
    def n_points(self) -> int:
        return self.force.size

    @classmethod
    def from_table(cls, table: pd.DataFrame, model: LinearModel, source: str = "measured") -> "ModalData":
        try:
            clean = validate_modal_table(table, source)
        except ModalTableError as error:
            raise MeasuredDataError(str(error)) from None
        levels = np.unique(clean["force_level_n"])
        if levels.size < 2:
            raise MeasuredDataError(f"{source}: only one force level ({levels[0]:g} N); {ONE_LEVEL_REASON}")
        names = list(model.dof_names)
        if "input_dof" in clean:
            inputs = sorted(set(clean["input_dof"]))
            if len(inputs) != 1:
                raise MeasuredDataError(f"{source}: column 'input_dof' has {len(inputs)} coordinates {inputs}; expected one")
            if inputs[0] not in names:
                raise MeasuredDataError(
                    f"{source}: column 'input_dof' names coordinate {inputs[0]!r}, which the model lacks "
                    f"(model coordinates: {names[:20]})"
                )
            input_name = inputs[0]
        elif len(names) == 1:
            input_name = names[0]
        else:
            raise MeasuredDataError(
                f"{source}: no column 'input_dof' and the model has {len(names)} coordinates; name the excited one"
            )
        n_modes = as_modal(model).natural_frequencies_hz.size
        too_high = clean["mode"].to_numpy() > n_modes
        if np.any(too_high):
            row = int(np.flatnonzero(too_high)[0])
            raise MeasuredDataError(
                f"{source}: row {row}, column 'mode': mode {clean['mode'].iloc[row]} but the model has {n_modes} mode(s)"
            )
        return cls(
            names.index(input_name), input_name, clean["force_level_n"].to_numpy(float),
            clean["mode"].to_numpy(int) - 1, clean["natural_frequency_hz"].to_numpy(float),
            clean["damping_ratio"].to_numpy(float),
        )
