"""Measured FRF tables: what one is, its validation, building and selecting curves
(reading and writing files: :mod:`nlupdate.core.measurement.frf_files`).

A measured-FRF table is a long ("tidy") :class:`pandas.DataFrame` with one row per
(frequency, force level, response coordinate, input coordinate):

==============  =====  ==============================================================
column          type   meaning
==============  =====  ==============================================================
frequency_hz    float  excitation frequency, Hz (≥ 0)
force_level_n   float  amplitude of the harmonic force, N (≥ 0; 0 marks a linear FRF)
response_dof    str    name of the response coordinate ("0", "1", ... or "tip:uz")
input_dof       str    name of the forced coordinate
h_real, h_imag  float  receptance H = X/F, m/N, with x(t) = Re(X e^{iωt}) (docs/methods.md §1)
==============  =====  ==============================================================

Coordinates are identified by NAME (always str). Tables built or read here are sorted by
force level, input, response and frequency ("canonical order").

Errors in a table raise :class:`MeasurementTableError` naming the source, the 0-based
data row, the column and the offending value; for a ``.csv`` source the line number in
the file (row + 2: line 1 is the header) is given as well.

Optional columns (filled by readers when a file carries them; code works without them):

==================  =====  ========================================================
coherence           float  ordinary coherence of the (response, input) pair, 0…1
averages            int    number of averages behind an H1 estimate (≥ 1)
h_std               float  standard deviation of the complex estimate |δH| (unit of H, ≥ 0)
excitation          str    stepped_sine, sine_sweep, chirp, random, burst or unknown
sweep_direction     str    up, down or unknown
reference_unit      str    "N" (default) or "V": levels and H per volt (one for the table)
level_achieved      float  first-harmonic reference amplitude achieved at that line (> 0)
harmonic_distortion float  RMS of the response harmonics 2… over its first harmonic (≥ 0)
==================  =====  ========================================================
"""
from __future__ import annotations

from typing import Iterable

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from nlupdate.core.measurement.units import (
    REFERENCE_UNITS,
)

FRF_COLUMNS: tuple[str, ...] = (
    "frequency_hz", "force_level_n", "response_dof", "input_dof", "h_real", "h_imag",
)
_FLOAT_COLUMNS = ("frequency_hz", "force_level_n", "h_real", "h_imag")
_DOF_COLUMNS = ("response_dof", "input_dof")
_KEY_COLUMNS = ("frequency_hz", "force_level_n", "response_dof", "input_dof")
_SORT_COLUMNS = ["force_level_n", "input_dof", "response_dof", "frequency_hz"]
EXCITATIONS: tuple[str, ...] = ("stepped_sine", "sine_sweep", "chirp", "random", "burst", "unknown")
SWEEP_DIRECTIONS: tuple[str, ...] = ("up", "down", "unknown")
#: optional columns, in the order they are kept
OPTIONAL_COLUMNS: tuple[str, ...] = (
    "coherence", "averages", "h_std", "excitation", "sweep_direction", "reference_unit", "level_achieved",
    "harmonic_distortion",
)
#: largest |H| taken as a measurement (m/N or m/V): beyond it squares overflow and the value is no receptance
MAX_RECEPTANCE = 1e20


class MeasurementTableError(ValueError):
    """A measured-FRF table (or file) does not have the expected form."""


# --------------------------------------------------------------------------- validation
def _row(source: str, row: int) -> str:
    line = f" (line {row + 2})" if str(source).lower().endswith(".csv") else ""
    return f"row {row}{line}"


def _where(source: str, row: int) -> str:
    return f"{source}: {_row(source, row)}"


def _dof_name(value: object, source: str, row: int, column: str) -> str:
    if isinstance(value, str):
        if value == "":
            raise MeasurementTableError(f"{_where(source, row)}, column '{column}': empty coordinate name")
        return value
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        return str(int(value))
    raise MeasurementTableError(
        f"{_where(source, row)}, column '{column}': expected a coordinate name (str, or int for "
        f"lumped models), got {value!r}"
    )


def validate_frf_table(
    table: pd.DataFrame, source: str = "<table>", known_dofs: Iterable[str] | None = None
) -> pd.DataFrame:
    """Check a measured-FRF table and return a clean copy (row order kept).

    The copy has the columns :data:`FRF_COLUMNS` and those of :data:`OPTIONAL_COLUMNS`
    the table has (others are dropped), float columns as float64 and coordinate names as
    str (ints such as 0 become "0"). A column of booleans is refused (True/False is no
    number), and so is a receptance larger than :data:`MAX_RECEPTANCE`.
    ``source`` names the table in error messages (a file path ending in ``.csv`` adds the
    file line numbers). ``known_dofs``: if given, every coordinate name must be in it.
    Raises :class:`MeasurementTableError`.
    """
    if not isinstance(table, pd.DataFrame):
        raise MeasurementTableError(f"{source}: expected a pandas DataFrame, got {type(table).__name__}")
    missing = [c for c in FRF_COLUMNS if c not in table.columns]
    if missing:
        raise MeasurementTableError(
            f"{source}: missing column(s) {missing}; a measured-FRF table has columns {list(FRF_COLUMNS)}"
        )
    clean = pd.DataFrame(index=pd.RangeIndex(len(table)))
    for column in _FLOAT_COLUMNS:
        clean[column] = _finite_numbers(table, column, source)
    magnitude = np.hypot(clean["h_real"].to_numpy(), clean["h_imag"].to_numpy())
    bad = np.flatnonzero(magnitude > MAX_RECEPTANCE)
    if bad.size:
        raise MeasurementTableError(
            f"{_where(source, int(bad[0]))}, columns 'h_real', 'h_imag': |H| = {magnitude[bad[0]]:.3g} is no receptance "
            f"(expected |H| ≤ {MAX_RECEPTANCE:g} m/N; is the unit or scale of the file wrong?)"
        )
    for column, condition, expected in (
        ("frequency_hz", clean["frequency_hz"] < 0, "a frequency ≥ 0 Hz"),
        ("force_level_n", clean["force_level_n"] < 0, "a force amplitude ≥ 0 N (0 = linear FRF)"),
    ):
        bad = np.flatnonzero(condition.to_numpy())
        if bad.size:
            raise MeasurementTableError(
                f"{_where(source, int(bad[0]))}, column '{column}': {clean[column].iloc[bad[0]]!r}, "
                f"expected {expected}"
            )
    for column in _DOF_COLUMNS:
        values = table[column].tolist()
        clean[column] = pd.Series(
            [_dof_name(v, source, row, column) for row, v in enumerate(values)], dtype=object
        )
    if known_dofs is not None:
        known = [str(d) for d in known_dofs]
        for column in _DOF_COLUMNS:
            bad = np.flatnonzero(~clean[column].isin(known).to_numpy())
            if bad.size:
                raise MeasurementTableError(
                    f"{_where(source, int(bad[0]))}, column '{column}': unknown coordinate "
                    f"{clean[column].iloc[bad[0]]!r}; known coordinates: {known}"
                )
    duplicated = np.flatnonzero(clean.duplicated(list(_KEY_COLUMNS), keep=False).to_numpy())
    if duplicated.size:
        first = int(duplicated[0])
        key = clean.loc[first, list(_KEY_COLUMNS)]
        second = next(int(r) for r in duplicated[1:] if clean.loc[r, list(_KEY_COLUMNS)].equals(key))
        described = ", ".join(
            f"{c}={float(key[c]) if c in _FLOAT_COLUMNS else key[c]!r}" for c in _KEY_COLUMNS
        )
        raise MeasurementTableError(
            f"{_where(source, first)} and {_row(source, second)}: duplicate "
            f"measurement ({described}); each (frequency, force level, response, input) must "
            f"appear once"
        )
    for column in OPTIONAL_COLUMNS:
        if column in table.columns:
            clean[column] = _optional_column(table, column, source)
    return clean[list(FRF_COLUMNS) + [c for c in OPTIONAL_COLUMNS if c in clean.columns]]


def _finite_numbers(table: pd.DataFrame, column: str, source: str) -> NDArray[np.float64]:
    raw = table[column].reset_index(drop=True)
    if pd.api.types.is_bool_dtype(raw) or any(isinstance(v, (bool, np.bool_)) for v in raw.iloc[:1000]):
        row = next((i for i, v in enumerate(raw) if isinstance(v, (bool, np.bool_))), 0)
        raise MeasurementTableError(
            f"{_where(source, row)}, column '{column}': {bool(raw.iloc[row])} is a boolean (True/False); expected a "
            f"finite number"
        )
    values = pd.to_numeric(raw, errors="coerce").to_numpy(dtype=float, na_value=np.nan)
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        more = f" (and {bad.size - 1} more row(s))" if bad.size > 1 else ""
        raise MeasurementTableError(
            f"{_where(source, int(bad[0]))}, column '{column}': {raw.iloc[bad[0]]!r} is not a finite number{more}"
        )
    return values


def _optional_column(table: pd.DataFrame, column: str, source: str) -> pd.Series:
    """One optional column checked against its rule (module docstring)."""
    if column in ("excitation", "sweep_direction", "reference_unit"):
        allowed = {"excitation": EXCITATIONS, "sweep_direction": SWEEP_DIRECTIONS,
                   "reference_unit": REFERENCE_UNITS}[column]
        values = [str(v).strip() for v in table[column]]
        if column == "reference_unit":
            values = [v.upper() for v in values]
        else:
            values = [v.lower().replace("-", "_").replace(" ", "_") for v in values]
        bad = [row for row, v in enumerate(values) if v not in allowed]
        if bad:
            raise MeasurementTableError(f"{_where(source, bad[0])}, column '{column}': {table[column].iloc[bad[0]]!r}; "
                                        f"expected one of {list(allowed)}")
        if column == "reference_unit" and len(set(values)) > 1:
            raise MeasurementTableError(f"{source}: column 'reference_unit' mixes {sorted(set(values))}; one table "
                                        f"holds FRFs of one reference (N or V)")
        return pd.Series(values, dtype=object)
    values = _finite_numbers(table, column, source)
    rules = {
        "coherence": ((values >= 0) & (values <= 1), "a coherence between 0 and 1"),
        "averages": ((values >= 1) & (values == np.round(values)), "a whole number of averages ≥ 1"),
        "h_std": (values >= 0, "a standard deviation ≥ 0"),
        "level_achieved": (values > 0, "an achieved level > 0"),
        "harmonic_distortion": (values >= 0, "a distortion ratio ≥ 0"),
    }
    valid, expected = rules[column]
    bad = np.flatnonzero(~valid)
    if bad.size:
        raise MeasurementTableError(f"{_where(source, int(bad[0]))}, column '{column}': {values[bad[0]]!r}, "
                                    f"expected {expected}")
    return pd.Series(values.astype(int) if column == "averages" else values)


def _canonical(table: pd.DataFrame) -> pd.DataFrame:
    return table.sort_values(_SORT_COLUMNS, kind="mergesort").reset_index(drop=True)


# --------------------------------------------------------------------------- building, selecting
def frf_table(
    frequency_hz: ArrayLike,
    force_level_n: ArrayLike,
    response_dof: ArrayLike,
    input_dof: ArrayLike,
    h: ArrayLike,
) -> pd.DataFrame:
    """Build a validated measured-FRF table from broadcastable arrays or scalars.

    ``h`` is the complex receptance (m/N); frequencies in Hz, force amplitudes in N;
    coordinate names str (or int, converted to str). Returned in canonical order.
    """
    f, level, resp, inp, hh = np.broadcast_arrays(
        np.asarray(frequency_hz, dtype=float), np.asarray(force_level_n, dtype=float),
        np.asarray(response_dof, dtype=object), np.asarray(input_dof, dtype=object),
        np.asarray(h, dtype=complex),
    )
    table = pd.DataFrame({
        "frequency_hz": f.ravel(), "force_level_n": level.ravel(),
        "response_dof": resp.ravel(), "input_dof": inp.ravel(),
        "h_real": hh.real.ravel(), "h_imag": hh.imag.ravel(),
    })
    return _canonical(validate_frf_table(table, source="frf_table()"))


def force_levels(table: pd.DataFrame) -> NDArray[np.float64]:
    """Sorted unique force amplitudes (N) of a measured-FRF table."""
    return np.unique(table["force_level_n"].to_numpy(dtype=float))


def select_frf(
    table: pd.DataFrame, response_dof: str, input_dof: str, force_level_n: float
) -> tuple[NDArray[np.float64], NDArray[np.complex128]]:
    """One measured curve: (frequencies in Hz ascending, complex receptance in m/N).

    Force levels match within a relative 1e-9. Raises :class:`MeasurementTableError`
    listing the available (response, input, force level) curves if the curve is absent.
    """
    response, inp = str(response_dof), str(input_dof)
    levels = table["force_level_n"].to_numpy(dtype=float)
    mask = (
        (table["response_dof"].astype(str).to_numpy() == response)
        & (table["input_dof"].astype(str).to_numpy() == inp)
        & np.isclose(levels, float(force_level_n), rtol=1e-9, atol=0.0)
    )
    if not mask.any():
        curves = table[["response_dof", "input_dof", "force_level_n"]].drop_duplicates()
        available = [(str(r), str(i), float(F)) for r, i, F in curves.itertuples(index=False)]
        raise MeasurementTableError(
            f"no measured FRF for response_dof={response!r}, input_dof={inp!r}, "
            f"force_level_n={float(force_level_n)!r}; available (response, input, force level N): "
            f"{available}"
        )
    curve = table.loc[mask]
    order = np.argsort(curve["frequency_hz"].to_numpy(dtype=float), kind="mergesort")
    frequency = curve["frequency_hz"].to_numpy(dtype=float)[order]
    h = (curve["h_real"].to_numpy(dtype=float) + 1j * curve["h_imag"].to_numpy(dtype=float))[order]
    return frequency, h




def table_input(table: pd.DataFrame, input_dof: str | None = None, name: str = "input_dof") -> str:
    """The input a measured-FRF table is read at: ``input_dof``, one the table has, or its only
    one when None. Raises :class:`MeasurementTableError` naming the option (``name``, as the
    caller's user writes it) and the table's inputs."""
    inputs = sorted(set(table["input_dof"].astype(str)))
    if input_dof is None:
        if len(inputs) != 1:
            raise MeasurementTableError(f"the table has several input dofs {inputs}; choose one with {name}")
        return inputs[0]
    if str(input_dof) not in inputs:
        raise MeasurementTableError(f"{name} {input_dof}: the table has input_dof {', '.join(inputs)}")
    return str(input_dof)


def measured_pair(table: pd.DataFrame, input_dof: str | None = None, response_dof: str | None = None,
                  names: tuple[str, str] = ("input_dof", "response_dof")) -> tuple[str, str, dict[str, str]]:
    """The (response, input) curve of a measured-FRF table that one identification works
    on, and the defaults chosen for it: the table's only input when none is given; the
    driving point at that input, or the input's only response (a transfer FRF), when no
    response is given. Raises :class:`MeasurementTableError` naming the option (``names``:
    the input's and the response's, as the caller's user writes them) and what the table
    has."""
    input_name, response_name = names
    given, input_dof = input_dof, table_input(table, input_dof, input_name)
    defaults: dict[str, str] = {"input_dof": input_dof} if given is None else {}
    responses = sorted(set(table.loc[table["input_dof"].astype(str) == input_dof, "response_dof"].astype(str)))
    if response_dof is None:
        if input_dof in responses:
            response_dof = input_dof
        elif len(responses) == 1:
            response_dof = responses[0]
        else:
            raise MeasurementTableError(f"no driving-point FRF at {input_dof}; choose one of response_dof "
                                        f"{', '.join(responses)} with {response_name}")
        defaults["response_dof"] = response_dof
    elif str(response_dof) not in responses:
        raise MeasurementTableError(f"{response_name} {response_dof}: the table has response_dof "
                                    f"{', '.join(responses)} for input {input_dof}")
    return str(response_dof), input_dof, defaults
