"""Measured stepped-sine FRFs at several force levels, matched to the model's coordinates.

A discovery compares the model with the measurement point by point: a point is one
(force level, frequency) at which every measured response coordinate has a value. The
measured-FRF table (:mod:`nlupdate.measurement.frf_table`) must have one input coordinate
and at least two force levels > 0; its coordinate names must be coordinates of the model.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from nlupdate.discovery.errors import MeasuredDataError
from nlupdate.measurement.frf_table import MeasurementTableError, validate_frf_table
from nlupdate.measurement.noise import estimate_noise_fraction
from nlupdate.model.linear import LinearModel

_MIN_POINTS_PER_LEVEL = 5
_NOISE_WINDOW = 9

ONE_LEVEL_REASON = (
    "discovery needs FRFs at two or more force levels: a missing nonlinearity shows only as a change of "
    "the FRF with the force level, and at a single level it cannot be told apart from a linear model error"
)


def _model_index(model: LinearModel, name: str, column: str, source: str) -> int:
    names = list(model.dof_names)
    if name in names:
        return names.index(name)
    raise MeasuredDataError(
        f"{source}: column '{column}' names coordinate {name!r}, which the model lacks "
        f"(model coordinates: {names[:20]}{' …' if len(names) > 20 else ''})"
    )


@dataclass(frozen=True, eq=False)
class FRFData:
    """Measured receptances at points (force level, frequency), all response coordinates.

    force: force amplitude (N) per point; omega: excitation frequency (rad/s) per point;
    h: receptance (m/N), shape (n_points, n_responses); points sorted by force, frequency.
    Coordinates are model indices (``input_dof``, ``response_dofs``) with their names.
    """

    input_dof: int
    response_dofs: tuple[int, ...]
    input_name: str
    response_names: tuple[str, ...]
    force: NDArray[np.float64]
    omega: NDArray[np.float64]
    h: NDArray[np.complex128]

    @property
    def frequency_hz(self) -> NDArray[np.float64]:
        return self.omega / (2 * np.pi)

    @property
    def x(self) -> NDArray[np.complex128]:
        """Measured complex response amplitudes (m), ``H·F``."""
        return self.h * self.force[:, None]

    @property
    def levels(self) -> NDArray[np.float64]:
        return np.unique(self.force)

    @property
    def level_index(self) -> NDArray[np.int64]:
        """Index into :attr:`levels` of every point."""
        return np.searchsorted(self.levels, self.force)

    def noise_fraction(self) -> float:
        """Model-free noise estimate (std / |H|, METHODS §8 noise model): the median over the
        measured curves of :func:`nlupdate.measurement.noise.estimate_noise_fraction`."""
        estimates = [
            estimate_noise_fraction(self.frequency_hz[mask], self.h[mask, k], window=_NOISE_WINDOW)
            for mask in (self.level_index == i for i in range(self.levels.size))
            for k in range(len(self.response_dofs))
            if mask.sum() >= _NOISE_WINDOW
        ]
        return float(np.median(estimates)) if estimates else 0.0

    @classmethod
    def from_table(cls, table: pd.DataFrame, model: LinearModel, source: str = "measured") -> "FRFData":
        """Validate a measured-FRF table against the model (raises :class:`MeasuredDataError`)."""
        try:
            clean = validate_frf_table(table, source)
        except MeasurementTableError as error:
            raise MeasuredDataError(str(error)) from None
        inputs = sorted(set(clean["input_dof"]))
        if len(inputs) != 1:
            raise MeasuredDataError(
                f"{source}: column 'input_dof' has {len(inputs)} coordinates {inputs}; discovery uses one "
                "excitation coordinate per table"
            )
        levels = np.unique(clean["force_level_n"].to_numpy())
        if np.any(levels <= 0):
            raise MeasuredDataError(
                f"{source}: column 'force_level_n' has 0 N (the marker of an extracted linear FRF); discovery "
                "needs measured force levels > 0 N"
            )
        if levels.size < 2:
            raise MeasuredDataError(f"{source}: only one force level ({levels[0]:g} N); {ONE_LEVEL_REASON}")
        input_dof = _model_index(model, inputs[0], "input_dof", source)
        responses = sorted(set(clean["response_dof"]), key=lambda name: _model_index(model, name, "response_dof", source))
        response_dofs = tuple(_model_index(model, name, "response_dof", source) for name in responses)
        force, frequency, h = [], [], []
        for level in levels:
            rows = clean[clean["force_level_n"] == level]
            curves = {
                name: group.set_index("frequency_hz")[["h_real", "h_imag"]] for name, group in rows.groupby("response_dof")
            }
            if len(curves) != len(responses):
                missing = sorted(set(responses) - set(curves))
                raise MeasuredDataError(f"{source}: no FRF of response coordinate(s) {missing} at {level:g} N")
            common = sorted(set.intersection(*(set(c.index) for c in curves.values())))
            if len(common) < _MIN_POINTS_PER_LEVEL:
                raise MeasuredDataError(
                    f"{source}: at {level:g} N only {len(common)} frequencies are measured at every response "
                    f"coordinate; need at least {_MIN_POINTS_PER_LEVEL}"
                )
            values = np.column_stack([
                curves[name].loc[common, "h_real"].to_numpy() + 1j * curves[name].loc[common, "h_imag"].to_numpy()
                for name in responses
            ])
            force.append(np.full(len(common), level))
            frequency.append(np.asarray(common, dtype=float))
            h.append(values)
        return cls(
            input_dof, response_dofs, inputs[0], tuple(responses),
            np.concatenate(force), 2 * np.pi * np.concatenate(frequency), np.vstack(h),
        )
