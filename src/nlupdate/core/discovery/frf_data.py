"""Measured stepped-sine FRFs at several force levels, matched to the model's coordinates.

A discovery compares the model with the measurement point by point: a point is one
(force level, frequency) at which every measured response coordinate has a value. The
measured-FRF table (:mod:`nlupdate.core.measurement.frf_table`) must have one input coordinate
and at least two force levels > 0; its coordinate names must be coordinates of the model.

Optional columns the table may carry (docs/measured-data.md):

* ``h_std``, or ``coherence`` with ``averages`` — the noise of every value; then the misfit
  weighs each value by its own noise (:func:`nlupdate.core.measurement.noise.estimate_table_noise`);
* ``repeat`` — a run number: the same points measured in several runs are averaged, and
  the noise is taken from their spread;
* ``sweep_direction`` — ``up``, ``down`` or ``unknown`` per row (one value per force level):
  how the test reached each frequency.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from nlupdate.core.discovery.errors import MeasuredDataError
from nlupdate.core.measurement.frf_table import SWEEP_DIRECTIONS, MeasurementTableError, validate_frf_table
from nlupdate.core.measurement.noise import NoiseEstimate, estimate_table_noise
from nlupdate.core.model.linear import LinearModel

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


class ForceLevels:
    """The force levels of measured points with a force (N) each (:class:`FRFData`,
    :class:`~nlupdate.core.discovery.modal_data.ModalData`)."""

    force: NDArray[np.float64]

    @property
    def levels(self) -> NDArray[np.float64]:
        """The distinct forces (N), ascending."""
        return np.unique(self.force)

    @property
    def level_index(self) -> NDArray[np.int64]:
        """Index into :attr:`levels` of every point."""
        return np.searchsorted(self.levels, self.force)


@dataclass(frozen=True, eq=False)
class FRFData(ForceLevels):
    """Measured receptances at points (force level, frequency), all response coordinates.

    force: force amplitude (N) per point; omega: excitation frequency (rad/s) per point;
    h: receptance (m/N), shape (n_points, n_responses); points sorted by force, frequency.
    Coordinates are model indices (``input_dof``, ``response_dofs``) with their names.
    noise: the table's noise estimate (:func:`~nlupdate.core.measurement.noise.estimate_table_noise`);
    point_noise: relative noise std of every value (n_points, n_responses) when the data state
    it, else None; sweep_by_level: the stated sweep direction per force level.
    """

    input_dof: int
    response_dofs: tuple[int, ...]
    input_name: str
    response_names: tuple[str, ...]
    force: NDArray[np.float64]
    omega: NDArray[np.float64]
    h: NDArray[np.complex128]
    noise: NoiseEstimate | None = None
    point_noise: NDArray[np.float64] | None = None
    sweep_by_level: tuple[str, ...] = ()

    @property
    def frequency_hz(self) -> NDArray[np.float64]:
        return self.omega / (2 * np.pi)

    @property
    def x(self) -> NDArray[np.complex128]:
        """Measured complex response amplitudes (m), ``H·F``."""
        return self.h * self.force[:, None]

    def noise_fraction(self) -> float:
        """Relative noise std of the measured values (docs/methods.md §8 form): the table's noise
        estimate (stated uncertainty, repeats, or the model-free smoothness estimate within
        contiguous stretches of every curve)."""
        return self.noise.fraction if self.noise is not None else 0.0

    @property
    def sweep(self) -> str:
        """The stated sweep direction: one for all levels, else ``"unknown"``."""
        stated = set(self.sweep_by_level)
        return stated.pop() if len(stated) == 1 else "unknown"

    @classmethod
    def from_table(cls, table: pd.DataFrame, model: LinearModel, source: str = "measured") -> "FRFData":
        """Validate a measured-FRF table against the model (raises :class:`MeasuredDataError`)."""
        table, noise = _averaged_repeats(table, source)
        try:
            clean = validate_frf_table(table, source)
        except MeasurementTableError as error:
            raise MeasuredDataError(str(error)) from None
        clean = clean.assign(**{name: table[name].to_numpy() for name in _OPTIONAL if name in table.columns})
        noise = noise or estimate_table_noise(clean, _NOISE_WINDOW)
        clean["_noise"] = noise.per_point if noise.per_point is not None else np.nan
        sweeps = _sweep_directions(clean, source)
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
        force, frequency, h, point_noise = [], [], [], []
        for level in levels:
            rows = clean[clean["force_level_n"] == level]
            curves = {
                name: group.set_index("frequency_hz")[["h_real", "h_imag", "_noise"]]
                for name, group in rows.groupby("response_dof")
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
            point_noise.append(np.column_stack([curves[name].loc[common, "_noise"].to_numpy() for name in responses]))
        stated = np.vstack(point_noise)
        return cls(
            input_dof, response_dofs, inputs[0], tuple(responses),
            np.concatenate(force), 2 * np.pi * np.concatenate(frequency), np.vstack(h), noise,
            stated if noise.per_point is not None else None, tuple(sweeps[level] for level in levels),
        )


_OPTIONAL = ("h_std", "coherence", "averages", "sweep_direction", "excitation")


def _averaged_repeats(table: pd.DataFrame, source: str) -> tuple[pd.DataFrame, NoiseEstimate | None]:
    """A table with a ``repeat`` column → the mean over the runs per point, and the noise of
    that mean (the spread of the runs over √runs); other tables unchanged, noise None."""
    if not isinstance(table, pd.DataFrame) or "repeat" not in table.columns:
        return table, None
    keys = ["frequency_hz", "force_level_n", "response_dof", "input_dof"]
    runs = int(table["repeat"].nunique())
    single = estimate_table_noise(table, _NOISE_WINDOW)
    grouped = table.groupby(keys, sort=False, as_index=False)
    mean = grouped[["h_real", "h_imag"]].mean()
    counts = grouped.size()["size"].to_numpy()
    if runs < 2 or single.source != "repeats":
        return mean, None
    if np.any(counts != runs):
        raise MeasuredDataError(
            f"{source}: column 'repeat' has {runs} runs but some points are measured in fewer runs; "
            "every run must cover the same frequencies, levels and coordinates"
        )
    for name in ("sweep_direction", "excitation"):
        if name in table.columns:
            mean[name] = grouped[name].first()[name].to_numpy()
    fraction = single.fraction / np.sqrt(runs)
    return mean, NoiseEstimate(fraction, "repeats", f"{single.detail}; the mean of {runs} runs has 1/√{runs} of it")


def _sweep_directions(clean: pd.DataFrame, source: str) -> dict[float, str]:
    """The stated sweep direction per force level (``unknown`` without the column)."""
    levels = np.unique(clean["force_level_n"].to_numpy())
    if "sweep_direction" not in clean.columns:
        return {float(level): "unknown" for level in levels}
    out = {}
    for level in levels:
        stated = set(str(v).strip().lower() for v in clean.loc[clean["force_level_n"] == level, "sweep_direction"])
        bad = sorted(stated - set(SWEEP_DIRECTIONS))
        if bad:
            raise MeasuredDataError(f"{source}: column 'sweep_direction' has {bad[0]!r}; expected one of "
                                    f"{', '.join(SWEEP_DIRECTIONS)}")
        if len(stated) > 1:
            raise MeasuredDataError(f"{source}: column 'sweep_direction' has {sorted(stated)} at {level:g} N; "
                                    "expected one direction per force level")
        out[float(level)] = stated.pop()
    return out
