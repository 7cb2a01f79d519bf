"""Measured data in MATLAB files: v5 (scipy.io) and v7.3 (HDF5, h5py).

The variables are read from the top level of the file, or from the fields of its only
struct when that is all it holds. Names are the project's column names; MATLAB vectors
may be rows or columns; text is a char array (one name) or a cell array of char arrays.

FRFs (``nlupdate identify/discover --measured FILE.mat``, a study's ``[measured] file``),
either form:

* **long**, one value per (frequency, level, response, input), as the table columns:
  ``frequency_hz``, ``force_level_n``, ``response_dof``, ``input_dof``, ``h_real``,
  ``h_imag`` (and any optional column such as ``coherence``), all of length n;
* **wide**, one column per curve: ``frequency_hz`` (n), ``H`` (n × m complex receptance,
  or a vector for one curve), ``force_level_n`` (one level, or m), ``response_dof`` and
  ``input_dof`` (one name, or m), optional ``coherence`` (n × m), ``reference_unit``
  (``'N'`` or ``'V'``) and ``excitation``.

Time histories (``nlupdate frf FILE.mat``, :mod:`nlupdate.measurement.time_history`):
``time_s`` (n), the reference ``force`` (N) or ``voltage`` (V), optional ``frequency_hz``
and ``level`` (n, logged by a stepped-sine controller), and every other numeric vector of
length n is a response coordinate named by its variable.
"""
from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from nlupdate.measurement.frf_table import FRF_COLUMNS, OPTIONAL_COLUMNS, MeasurementTableError


def mat_variables(data: bytes, path: Path, kind: str) -> dict[str, Any]:
    """The variables of a MATLAB file's bytes: numpy arrays (MATLAB orientation kept:
    rows × columns) and str / list[str] for text. ``kind``: ``"mat5"`` or ``"hdf5"``."""
    try:
        variables = _v73_variables(data) if kind == "hdf5" else _v5_variables(data)
    except MeasurementTableError:
        raise
    except Exception as error:  # scipy / h5py raise many kinds on a corrupt file
        raise MeasurementTableError(f"{path}: not a readable MATLAB file ({type(error).__name__}: {error})") from None
    structs = [name for name, value in variables.items() if isinstance(value, dict)]
    if len(variables) == 1 and structs:
        variables = variables[structs[0]]
    return {name: value for name, value in variables.items() if not isinstance(value, dict)}


def _v5_variables(data: bytes) -> dict[str, Any]:
    import scipy.io

    raw = scipy.io.loadmat(io.BytesIO(data), simplify_cells=True, chars_as_strings=True)
    return {name: _plain(value) for name, value in raw.items() if not name.startswith("__")}


def _plain(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, str):
        return value
    if isinstance(value, np.ndarray) and value.dtype == object:
        items = [_plain(v) for v in value.ravel()]
        return [str(v) for v in items] if all(isinstance(v, str) for v in items) else np.asarray(items)
    if isinstance(value, (list, tuple)):
        return [str(v) for v in value] if all(isinstance(v, str) for v in value) else np.asarray(value)
    return np.asarray(value)


def _v73_variables(data: bytes) -> dict[str, Any]:
    import h5py

    with h5py.File(io.BytesIO(data), "r") as handle:
        return {name: _v73_value(handle, item) for name, item in handle.items() if not name.startswith("#")}


def _v73_value(handle, item) -> Any:
    import h5py

    if isinstance(item, h5py.Group):
        return {name: _v73_value(handle, child) for name, child in item.items()}
    matlab_class = item.attrs.get("MATLAB_class", b"")
    matlab_class = matlab_class.decode() if isinstance(matlab_class, bytes) else str(matlab_class)
    value = item[()]
    if matlab_class == "char":
        codes = np.asarray(value, dtype=np.uint16)
        return "".join(map(chr, codes.T.ravel())) if codes.ndim < 2 or min(codes.shape) == 1 else \
            ["".join(map(chr, row)).rstrip() for row in codes.T]
    if matlab_class == "cell":
        items = [_v73_value(handle, handle[ref]) for ref in np.asarray(value).T.ravel()]
        return [str(v) for v in items] if all(isinstance(v, str) for v in items) else np.asarray(items)
    array = np.asarray(value)
    if array.dtype.names and {"real", "imag"} <= set(array.dtype.names):
        array = array["real"] + 1j * array["imag"]
    return array.T  # HDF5 holds MATLAB's column-major arrays transposed


def _vector(value: Any, name: str, path: Path) -> np.ndarray:
    array = np.asarray(value)
    if array.ndim > 2 or (array.ndim == 2 and min(array.shape) > 1):
        raise MeasurementTableError(f"{path}: variable '{name}' has shape {array.shape}; expected a vector")
    return array.ravel()


def _names(value: Any, count: int, name: str, path: Path) -> list[str]:
    if isinstance(value, str):
        return [value] * count
    if isinstance(value, list) and len(value) in (1, count):
        return [str(v) for v in value] * (count if len(value) == 1 else 1)
    array = np.asarray(value).ravel()
    if array.size in (1, count) and np.issubdtype(array.dtype, np.number):  # lumped-model numbers
        return [str(int(v)) if float(v).is_integer() else str(v) for v in array] * (count if array.size == 1 else 1)
    raise MeasurementTableError(f"{path}: variable '{name}' holds {np.size(value)} name(s); expected one, or one per "
                                f"curve ({count})")


def read_mat_frf(data: bytes, path: Path, kind: str) -> pd.DataFrame:
    """A raw measured-FRF table from a MATLAB file's bytes (module docstring)."""
    variables = mat_variables(data, path, kind)
    if all(column in variables for column in FRF_COLUMNS):
        columns = {c: (_names(variables[c], np.size(variables["frequency_hz"]), c, path) if c.endswith("_dof")
                       else _vector(variables[c], c, path)) for c in FRF_COLUMNS}
        for column in OPTIONAL_COLUMNS:
            if column in variables:
                value = variables[column]
                columns[column] = value if isinstance(value, str) else (
                    value if isinstance(value, list) else _vector(value, column, path))
        try:
            return pd.DataFrame(columns)
        except ValueError:
            lengths = {c: np.size(v) for c, v in columns.items()}
            raise MeasurementTableError(f"{path}: the column variables differ in length {lengths}") from None
    required = ("frequency_hz", "H", "force_level_n", "response_dof", "input_dof")
    missing = [name for name in required if name not in variables]
    if missing:
        raise MeasurementTableError(
            f"{path}: missing variable(s) {missing}; a MATLAB FRF file holds either the table columns "
            f"{list(FRF_COLUMNS)} or frequency_hz, H (frequencies × curves), force_level_n, response_dof and input_dof "
            f"(found {sorted(variables)})")
    frequency = _vector(variables["frequency_hz"], "frequency_hz", path).astype(float)
    h = np.asarray(variables["H"])
    if h.ndim == 1 or h.ndim == 2 and h.shape[0] != frequency.size and h.shape[1] == frequency.size:
        h = h.reshape(frequency.size, -1) if h.ndim == 1 else h.T
    if h.ndim != 2 or h.shape[0] != frequency.size:
        raise MeasurementTableError(f"{path}: variable 'H' has shape {np.shape(variables['H'])}; expected "
                                    f"({frequency.size} frequencies × curves)")
    if not np.iscomplexobj(h):
        raise MeasurementTableError(f"{path}: variable 'H' is real; an FRF is complex (m/N)")
    n_curves = h.shape[1]
    levels = np.broadcast_to(_vector(variables["force_level_n"], "force_level_n", path).astype(float), (n_curves,)) \
        if np.size(variables["force_level_n"]) in (1, n_curves) else None
    if levels is None:
        raise MeasurementTableError(f"{path}: variable 'force_level_n' holds {np.size(variables['force_level_n'])} "
                                    f"values; expected one, or one per curve ({n_curves})")
    responses = _names(variables["response_dof"], n_curves, "response_dof", path)
    inputs = _names(variables["input_dof"], n_curves, "input_dof", path)
    columns: dict[str, Any] = {
        "frequency_hz": np.tile(frequency, n_curves), "force_level_n": np.repeat(levels, frequency.size),
        "response_dof": np.repeat(responses, frequency.size), "input_dof": np.repeat(inputs, frequency.size),
        "h_real": h.T.real.ravel(), "h_imag": h.T.imag.ravel(),
    }
    if "coherence" in variables:
        coherence = np.asarray(variables["coherence"], dtype=float).reshape(frequency.size, -1) \
            if np.ndim(variables["coherence"]) == 1 else np.asarray(variables["coherence"], dtype=float)
        if coherence.shape != h.shape:
            raise MeasurementTableError(f"{path}: variable 'coherence' has shape {coherence.shape}; expected that of "
                                        f"H {h.shape}")
        columns["coherence"] = coherence.T.ravel()
    for name in ("reference_unit", "excitation"):
        if name in variables:
            columns[name] = str(variables[name])
    return pd.DataFrame(columns)
