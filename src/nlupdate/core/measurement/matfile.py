"""Measured data in MATLAB files: v5 (scipy.io) and v7.3 (HDF5, h5py).

The variables are read from the top level of the file, or from the fields of its only
struct when that is all it holds. Names are the project's column names; MATLAB vectors
may be rows or columns; text is a char array (one name) or a cell array of char arrays.

FRFs (``nlupdate identify/discover --measured FILE.mat``, a study's ``[measured] file``),
in one of three forms:

* **long**, one value per (frequency, level, response, input), as the table columns:
  ``frequency_hz``, ``force_level_n``, ``response_dof``, ``input_dof``, ``h_real``,
  ``h_imag`` (and any optional column such as ``coherence``), all of length n;
* **wide**, one column per curve: ``frequency_hz`` (n), ``H`` (n × m complex receptance,
  or a vector for one curve), ``force_level_n`` (one level, or m), ``response_dof`` and
  ``input_dof`` (one name, or m), optional ``coherence`` (n × m), ``reference_unit``
  (``'N'`` or ``'V'``) and ``excitation``;
* **stepped-sine runs** (MATLAB v5 files), what a stepped-sine controller reports: a struct array (at the
  top level or a field of a struct, e.g. ``FRdata.ForceControl``), one element per run,
  with fields ``frequency`` (n, Hz), ``force`` (n, or one value: the reference's
  first-harmonic amplitude achieved at each line), ``amplitude`` (n, the response's
  first-harmonic amplitude), ``phase`` (n, the response's phase relative to the
  reference) and ``units`` (text naming the four units in that order, e.g.
  ``'Hz, N, m/s^2, rad'``: the force in N/kN, or V/mV for a voltage reference; the
  response in m, mm, m/s, mm/s, m/s^2, mm/s^2 or g; the phase in rad or deg), optional
  ``response_dof`` and ``input_dof``. H = amplitude·e^{i·phase}/force at each line,
  converted to receptance. A run is one level: its mean achieved force (4 significant
  digits), each line keeping its own force as ``level_achieved``; ``excitation`` is
  ``stepped_sine``. A run that held the response amplitude instead of the force (its
  response varies less along the run than its force: response-controlled testing) is
  not an FRF at a force level and is left out with a warning. Coordinates the file does
  not name are stated with ``--coordinates FILE=RESPONSE,INPUT``; ``NODE:-DIR`` (a sensor
  or force along the negative direction) negates the FRF and names ``NODE:DIR``.

Time histories (``nlupdate frf FILE.mat``, :mod:`nlupdate.core.measurement.time_history`):
``time_s`` (n), the reference ``force`` (N) or ``voltage`` (V), optional ``frequency_hz``
and ``level`` (n, logged by a stepped-sine controller), and every other numeric vector of
length n is a response coordinate named by its variable.
"""
from __future__ import annotations

import io
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from nlupdate.input_files import InputFileError, check_decoded_size, max_input_bytes, megabytes
from nlupdate.core.measurement.frf_table import FRF_COLUMNS, OPTIONAL_COLUMNS, MeasurementTableError
from nlupdate.core.measurement.units import (
    REFERENCE_UNIT_LABELS, RESPONSE_UNIT_LABELS, ReadOptions, checked_reference_unit,
)
from nlupdate.notices import NlupdateWarning

_RUN_FIELDS = ("frequency", "force", "amplitude", "phase")
_PHASE_UNITS = {"rad": 1.0, "deg": np.pi / 180, "°": np.pi / 180, "degree": np.pi / 180, "degrees": np.pi / 180}
_HELD_FORCE_SPREAD = 0.10  # a run whose force strays more than this from its mean is warned about


def _raw_variables(data: bytes, path: Path, kind: str, what: str = "measured-FRF file") -> dict[str, Any]:
    """The variables of the file; what they declare is held to the input limit before any
    is decoded (:func:`nlupdate.input_files.check_decoded_size`; ``what``: the file's role)."""
    try:
        if kind == "hdf5":
            return _v73_variables(data, path, what)
        _check_v5_sizes(data, path, what)
        return _v5_variables(data)
    except (MeasurementTableError, InputFileError):
        raise
    except Exception as error:  # scipy / h5py raise many kinds on a corrupt file
        raise MeasurementTableError(f"{path}: not a readable MATLAB file ({type(error).__name__}: {error})") from None


def mat_variables(data: bytes, path: Path, kind: str, what: str = "measured-FRF file") -> dict[str, Any]:
    """The variables of a MATLAB file's bytes: numpy arrays (MATLAB orientation kept:
    rows × columns) and str / list[str] for text. ``kind``: ``"mat5"`` or ``"hdf5"``;
    ``what``: the file's role, for messages."""
    variables = _raw_variables(data, path, kind, what)
    structs = [name for name, value in variables.items() if isinstance(value, dict)]
    if len(variables) == 1 and structs:
        variables = variables[structs[0]]
    elif len(structs) > 1 and len(structs) == len(variables):
        raise MeasurementTableError(
            f"{path}: holds {len(structs)} structs ({', '.join(structs)}) and no variable outside them; nlupdate reads "
            f"the variables at the top level of the file or the fields of its only struct: save the one struct's "
            f"fields, e.g. save('{path.name}', '-struct', '{structs[0]}')")
    return {name: value for name, value in variables.items() if not isinstance(value, dict)}


#: Bytes per element of MATLAB's numeric classes once loaded (char: numpy's 4-byte code points).
_V5_WIDTHS = {"double": 8, "single": 4, "int8": 1, "uint8": 1, "int16": 2, "uint16": 2, "int32": 4, "uint32": 4,
              "int64": 8, "uint64": 8, "logical": 1, "char": 4}


def _declared(name: str, elements: int, width: int, total: int) -> str:
    own = elements * width
    limit = max_input_bytes()
    with_others = "" if total == own or (limit is not None and own > limit) else \
        f", {megabytes(total)} MB with the variables before it"
    return f"variable '{name}' declares {elements} elements of {width} bytes, {megabytes(own)} MB once decoded" \
           f"{with_others}"


def _check_v5_sizes(data: bytes, path: Path, what: str) -> None:
    """Hold the sizes a v5 file declares (its variable headers, read without decompressing
    the data) to the input limit; cells and structs are counted when they are loaded."""
    import scipy.io

    try:
        declared = scipy.io.whosmat(io.BytesIO(data))
    except Exception:  # noqa: BLE001 - a damaged file: loadmat reports it
        return
    total = 0
    for name, shape, matlab_class in declared:
        width = _V5_WIDTHS.get(matlab_class)
        if width is None:
            continue
        elements = int(np.prod(shape, dtype=object))
        total += elements * width
        check_decoded_size(total, path, _declared(name, elements, width, total), what)


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


def _v73_variables(data: bytes, path: Path, what: str) -> dict[str, Any]:
    import h5py

    decoded = [0]  # bytes the datasets read so far declare
    with h5py.File(io.BytesIO(data), "r") as handle:
        return {name: _v73_value(handle, _v73_member(handle, name, path), decoded, path, what) for name in handle
                if not name.startswith("#")}


def _v73_member(group, name: str, path: Path):
    """The object ``name`` of an HDF5 group, refusing links: an external link would read
    another file than the one given, and MATLAB writes none."""
    import h5py

    link = group.get(name, getlink=True)
    if isinstance(link, h5py.ExternalLink):
        raise MeasurementTableError(f"{path}: variable '{f'{group.name}/{name}'.strip('/')}' is an HDF5 external link to "
                                    f"{link.filename}:{link.path}; nlupdate reads only what the file itself holds "
                                    f"(save the data in the file, as MATLAB's save -v7.3 does)")
    if isinstance(link, h5py.SoftLink):
        raise MeasurementTableError(f"{path}: variable '{f'{group.name}/{name}'.strip('/')}' is an HDF5 soft link to "
                                    f"{link.path}; expected the variable's data (as MATLAB's save -v7.3 writes it)")
    return group[name]


def _v73_value(handle, item, decoded: list[int], path: Path, what: str) -> Any:
    import h5py

    if isinstance(item, h5py.Group):
        return {name: _v73_value(handle, _v73_member(item, name, path), decoded, path, what) for name in item}
    matlab_class = item.attrs.get("MATLAB_class", b"")
    matlab_class = matlab_class.decode() if isinstance(matlab_class, bytes) else str(matlab_class)
    if item.attrs.get("MATLAB_empty", 0):  # MATLAB stores an empty array as its dimensions, [0 0]
        return "" if matlab_class == "char" else [] if matlab_class == "cell" else np.zeros(0)
    elements, width = int(np.prod(item.shape, dtype=object)) if item.shape else 1, item.dtype.itemsize
    decoded[0] += elements * width  # checked from the declared shape, before it is read
    check_decoded_size(decoded[0], path, _declared(item.name.lstrip("/"), elements, width, decoded[0]), what)
    value = item[()]
    if matlab_class == "char":
        codes = np.asarray(value, dtype=np.uint16)
        return "".join(map(chr, codes.T.ravel())) if codes.ndim < 2 or min(codes.shape) == 1 else \
            ["".join(map(chr, row)).rstrip() for row in codes.T]
    if matlab_class == "cell":
        items = [_v73_value(handle, handle[ref], decoded, path, what) for ref in np.asarray(value).T.ravel()]
        return [str(v) for v in items] if all(isinstance(v, str) for v in items) else np.asarray(items)
    array = np.asarray(value)
    if array.dtype.names and {"real", "imag"} <= set(array.dtype.names):
        array = array["real"] + 1j * array["imag"]
    return array.T  # HDF5 holds MATLAB's column-major arrays transposed


def _vector(value: Any, name: str, path: Path) -> np.ndarray:
    array = np.asarray(value)
    if array.size == 0:
        raise MeasurementTableError(f"{path}: variable '{name}' is empty; expected a vector of values")
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


def read_mat_frf(data: bytes, path: Path, kind: str, options: ReadOptions | None = None) -> pd.DataFrame:
    """A raw measured-FRF table from a MATLAB file's bytes (module docstring)."""
    options = options or ReadOptions()
    groups = _run_groups(_raw_variables(data, path, kind))
    if groups:
        return _read_runs(groups, path, options)
    if options.coordinates_of(str(path)) is not None:
        raise MeasurementTableError(f"{path}: names its coordinates itself (variables response_dof, input_dof); "
                                    f"--coordinates is for stepped-sine runs that name none")
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


# ------------------------------------------------------------------------------ stepped-sine runs
def _is_run(value: Any) -> bool:
    return isinstance(value, dict) and all(name in value for name in _RUN_FIELDS)


def _run_groups(tree: dict[str, Any], prefix: str = "") -> list[tuple[str, list[dict[str, Any]]]]:
    """Every struct (array) of stepped-sine runs in the variables, by its MATLAB name."""
    groups = []
    for name, value in tree.items():
        where = f"{prefix}{name}"
        if _is_run(value):
            groups.append((where, [value]))
        elif isinstance(value, np.ndarray) and value.dtype == object and value.size and all(map(_is_run, value.ravel())):
            groups.append((where, list(value.ravel())))
        elif isinstance(value, dict):
            groups.extend(_run_groups(value, f"{where}."))
    return groups


def _run_units(run: dict[str, Any], where: str, stated: str | None) -> tuple[int, float, str, float, float]:
    """(power of iω to receptance, response factor to SI, reference unit, reference factor,
    phase factor to rad) from a run's ``units`` text."""
    expected = "the units of frequency, force, amplitude and phase, e.g. 'Hz, N, m/s^2, rad'"
    text = run.get("units")
    if not isinstance(text, str):
        raise MeasurementTableError(f"{where}: field 'units' {'missing' if text is None else repr(text)}; expected "
                                    f"{expected}")
    parts = [part.strip() for part in text.split(",")]
    if len(parts) != 4:
        raise MeasurementTableError(f"{where}: field 'units' {text!r}; expected {expected}")
    frequency, force, response, phase = parts
    if frequency.lower() != "hz":
        raise MeasurementTableError(f"{where}: field 'units' gives the frequency in {frequency!r}; expected Hz")
    if force.lower() not in REFERENCE_UNIT_LABELS:
        raise MeasurementTableError(f"{where}: field 'units' gives the force in {force!r}; expected N, kN, or V, mV "
                                    f"for a voltage reference")
    unit, reference_factor = REFERENCE_UNIT_LABELS[force.lower()]
    if unit == "V" and stated is None:
        raise MeasurementTableError(f"{where}: the reference is a voltage ({force}): FRFs per volt are read only when "
                                    f"stated: --reference-unit V (study: [measured] reference_unit = \"V\")")
    if stated is not None and unit != checked_reference_unit(stated, "reference unit"):
        raise MeasurementTableError(f"{where}: the reference is in {force}, not in {stated} as stated")
    if response not in RESPONSE_UNIT_LABELS:
        raise MeasurementTableError(f"{where}: field 'units' gives the response in {response!r}; expected one of "
                                    f"{', '.join(RESPONSE_UNIT_LABELS)}")
    power, response_factor = RESPONSE_UNIT_LABELS[response]
    if phase.lower() not in _PHASE_UNITS:
        raise MeasurementTableError(f"{where}: field 'units' gives the phase in {phase!r}; expected rad or deg")
    return power, response_factor, unit, reference_factor, _PHASE_UNITS[phase.lower()]


def _signed(name: str) -> tuple[str, float]:
    """``"NODE:-DIR"`` → (``"NODE:DIR"``, −1); any other name → (name, +1)."""
    node, sep, direction = name.strip().rpartition(":")
    if sep and direction.startswith("-") and len(direction) > 1:
        return f"{node}:{direction[1:]}", -1.0
    return name.strip(), 1.0


def _run_coordinates(run: dict[str, Any], where: str, path: Path, options: ReadOptions) -> tuple[str, str, float]:
    stated = options.coordinates_of(str(path))
    if stated is not None:
        names = stated
    elif isinstance(run.get("response_dof"), str) and isinstance(run.get("input_dof"), str):
        names = (run["response_dof"], run["input_dof"])
    else:
        raise MeasurementTableError(
            f"{where}: the run names no coordinates (fields response_dof, input_dof); state them with --coordinates "
            f"{path.name}=RESPONSE,INPUT (e.g. tip:uz,tip:uz for a driving point; tip:-uz for a sensor along −z), in a "
            f"study with the reading table's coordinates = {{ \"{path.name}\" = [\"RESPONSE\", \"INPUT\"] }}")
    (response, sign_r), (inp, sign_i) = _signed(names[0]), _signed(names[1])
    return response, inp, sign_r * sign_i


def _run_vector(run: dict[str, Any], name: str, count: int, where: str) -> np.ndarray:
    value = np.asarray(run[name], dtype=float).ravel()
    if value.size == 1 and name == "force":
        value = np.full(count, float(value[0]))
    if value.size != count:
        raise MeasurementTableError(f"{where}: field '{name}' holds {value.size} values; expected one per frequency "
                                    f"({count})")
    if not np.all(np.isfinite(value)):
        raise MeasurementTableError(f"{where}: field '{name}' holds a value that is not a finite number")
    return value


def _spread(values: np.ndarray) -> float:
    return float(values.max() / values.min()) if values.min() > 0 else np.inf


def _read_runs(groups: list[tuple[str, list[dict[str, Any]]]], path: Path, options: ReadOptions) -> pd.DataFrame:
    """The force-controlled stepped-sine runs of the groups as a raw measured-FRF table."""
    curves, left_out, unheld, powers = [], [], [], set()
    for group, runs in groups:
        for index, run in enumerate(runs, start=1):
            where = f"{path}: {group}({index})" if len(runs) > 1 else f"{path}: {group}"
            try:
                frequency = np.asarray(run["frequency"], dtype=float).ravel()
            except (TypeError, ValueError):
                raise MeasurementTableError(f"{where}: field 'frequency' is not numeric") from None
            force, amplitude, phase = (_run_vector(run, name, frequency.size, where) for name in _RUN_FIELDS[1:])
            if np.any(force <= 0) or np.any(frequency < 0):
                raise MeasurementTableError(f"{where}: field '{'force' if np.any(force <= 0) else 'frequency'}' holds "
                                            f"a value ≤ 0; expected amplitudes > 0 and frequencies ≥ 0 (Hz)")
            power, response_factor, unit, reference_factor, phase_factor = _run_units(run, where, options.reference_unit)
            if _spread(np.abs(amplitude)) < _spread(force):  # the controller held the response, not the force
                left_out.append((group, index, unit, force, amplitude, run.get("units", "")))
                continue
            response, inp, sign = _run_coordinates(run, where, path, options)
            force = force * reference_factor
            h = sign * amplitude * response_factor * np.exp(1j * phase * phase_factor) / force
            keep = frequency > 0 if power else np.ones(frequency.size, dtype=bool)
            h = h[keep] / (1j * 2 * np.pi * frequency[keep]) ** power
            if power:
                powers.add(power)
            level = float(f"{force.mean():.4g}")
            if np.max(np.abs(force / force.mean() - 1)) > _HELD_FORCE_SPREAD:
                unheld.append((where.split(": ", 1)[1], level, force.min(), force.max(), unit))
            curves.append(pd.DataFrame({
                "frequency_hz": frequency[keep], "force_level_n": level, "response_dof": response, "input_dof": inp,
                "h_real": h.real, "h_imag": h.imag, "level_achieved": force[keep], "excitation": "stepped_sine",
                "reference_unit": unit,
            }))
    if left_out:
        names = sorted({group for group, *_ in left_out})
        amplitudes = np.concatenate([a for *_, a, _ in left_out])
        forces = np.concatenate([f for *_, f, _, _ in left_out])
        unit = left_out[0][2]
        response_unit = str(left_out[0][5]).split(",")[2].strip() if str(left_out[0][5]).count(",") == 3 else ""
        message = (f"{path}: left out {len(left_out)} run(s) of {', '.join(names)} that held the response amplitude "
                   f"({np.abs(amplitudes).min():.3g}–{np.abs(amplitudes).max():.3g} {response_unit}) and let the "
                   f"force vary ({forces.min():.3g}–{forces.max():.3g} {unit}): response-controlled stepped sine, not "
                   f"FRFs at a force level")
        if not curves:
            raise MeasurementTableError(message + "; the file holds no force-controlled run")
        if not options.reads_runs_apart(str(path)):  # else read as response-controlled runs: not lost
            warnings.warn(message, NlupdateWarning, stacklevel=4)
    if unheld:
        worst = max(unheld, key=lambda u: max(u[1] / u[2], u[3] / u[1]))
        warnings.warn(
            f"{path}: the force was not held along {len(unheld)} run(s) (e.g. {worst[0]}: {worst[2]:.3g}–{worst[3]:.3g} "
            f"{worst[4]} about its level {worst[1]:g} {worst[4]}): each line keeps the force it was measured at "
            f"(level_achieved), which identify uses; discover simulates a run at its level", NlupdateWarning,
            stacklevel=4)
    if powers:
        name = {1: "mobility (velocity/force)", 2: "accelerance (acceleration/force)"}[max(powers)]
        warnings.warn(f"{path}: converted {name} to receptance: H = {'A' if max(powers) == 2 else 'V'}/(iω)"
                      f"{'²' if max(powers) == 2 else ''}", NlupdateWarning, stacklevel=4)
    return pd.concat(curves, ignore_index=True)
