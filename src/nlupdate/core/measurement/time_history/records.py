"""Reading measured time records: CSV, parquet, UFF 58 (function type 1) or MATLAB files.

A time record holds the sample times ``time_s`` (s), the reference — the excitation
``force`` (N) or the amplifier ``voltage`` (V) — and one signal per response coordinate
(displacement in m by default; velocity or acceleration are converted by the estimators,
``H = V/(iω)``, ``A/(iω)²``). A stepped-sine record also holds the controller's
``frequency_hz`` column (one dwell per constant value) and a ``level`` column when several
levels share a file.
"""
from __future__ import annotations

import io
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from nlupdate.core.measurement.frf_table import MeasurementTableError
from nlupdate.input_files import check_parquet_size, decode_text, read_input_bytes, sniff

_RESERVED = ("time_s", "force", "voltage", "frequency_hz", "level")


class TimeHistoryError(MeasurementTableError):
    """A time record cannot be turned into FRFs as asked (the message names the file and what is wrong)."""


@dataclass(frozen=True)
class TimeRecord:
    """One measured time record (SI; the reference in N or V)."""

    source: str
    time_s: NDArray[np.float64]
    reference: NDArray[np.float64]
    reference_unit: str
    responses: dict[str, NDArray[np.float64]]
    frequency_hz: NDArray[np.float64] | None = None
    level: NDArray[np.float64] | None = None

    @property
    def sample_rate_hz(self) -> float:
        """Samples per second (Hz) of the evenly sampled ``time_s``."""
        return float((self.time_s.size - 1) / (self.time_s[-1] - self.time_s[0]))


def _record_from_columns(columns: dict[str, np.ndarray], source: str, sample_rate_hz: float | None = None,
                         reference: str | None = None) -> TimeRecord:
    """A record from named columns. Names are matched without regard to case (``Force``
    is ``force``). Without ``time_s`` the samples are taken as evenly spaced at
    ``sample_rate_hz`` (or at the value of a constant column ``fs``, as some benchmark
    exports carry it). With both a ``force`` and a ``voltage`` column the force is the
    reference unless ``reference`` says ``voltage``; the other one is not a response.
    Trailing samples where every signal is exactly 0 (padding some exports add) are dropped."""
    columns = {str(name).strip().lower() if str(name).strip().lower() in _RESERVED + ("fs",) else str(name).strip():
               value for name, value in columns.items()}
    if columns and all(np.asarray(v).size == 0 for v in columns.values()):
        raise TimeHistoryError(f"{source}: no samples: the columns {sorted(columns)} hold no values (a header "
                               f"without data rows)")
    if sample_rate_hz is not None and not (math.isfinite(sample_rate_hz) and sample_rate_hz > 0):
        raise TimeHistoryError(f"{source}: sample rate {sample_rate_hz:g} Hz: expected a number > 0 (Hz)")
    if "time_s" not in columns:
        rate = sample_rate_hz
        if rate is None and "fs" in columns:
            rate = _fs_column(columns["fs"], source)
        if rate is None:
            raise TimeHistoryError(f"{source}: no 'time_s' column (sample times in s) and no sample rate (give "
                                   f"--sample-rate HZ); found {sorted(columns)}")
        columns["time_s"] = np.arange(len(next(iter(columns.values())))) / rate
    columns.pop("fs", None)
    present = [name for name in ("force", "voltage") if name in columns]
    if not present:
        raise TimeHistoryError(f"{source}: expected a reference column, 'force' (N) or 'voltage' (V); found "
                               f"neither among {sorted(columns)}")
    chosen = reference or present[0]
    if chosen not in present:
        raise TimeHistoryError(f"{source}: no '{chosen}' column to take as the reference; found {present}")
    for other in present:
        if other != chosen:
            columns.pop(other)
    numbers = {}
    for name, values in columns.items():
        array = np.asarray(values)
        if array.dtype == object or array.dtype.kind in "USb":
            raise TimeHistoryError(f"{source}: column '{name}' holds {array.dtype.kind == 'b' and 'booleans' or 'text'}; "
                                   f"expected numbers")
        array = array.astype(float).ravel()
        bad = np.flatnonzero(~np.isfinite(array))
        if bad.size:
            raise TimeHistoryError(f"{source}: column '{name}', sample {bad[0]}: {array[bad[0]]!r} is not a finite number")
        numbers[name] = array
    lengths = {name: v.size for name, v in numbers.items()}
    if len(set(lengths.values())) > 1:
        shown = ", ".join(f"'{name}' {size}" for name, size in lengths.items())
        raise TimeHistoryError(f"{source}: the columns differ in length ({shown} samples); expected one value per "
                               f"sample in every column")
    signals = np.vstack([v for name, v in numbers.items() if name != "time_s"])
    nonzero = np.flatnonzero(np.any(signals != 0, axis=0))
    end = int(nonzero[-1]) + 1 if nonzero.size else 0
    if end < signals.shape[1]:  # some exports pad records with zeros: drop the padding
        numbers = {name: v[:end] for name, v in numbers.items()}
    time = numbers["time_s"]
    if time.size < 16 or np.any(np.diff(time) <= 0):
        raise TimeHistoryError(f"{source}: 'time_s' must increase strictly over at least 16 samples")
    steps = np.diff(time)
    if np.ptp(steps) > 1e-6 * np.mean(steps):
        raise TimeHistoryError(f"{source}: 'time_s' is not evenly sampled (steps {steps.min():.6g}…{steps.max():.6g} s)")
    responses = {name: v for name, v in numbers.items() if name not in _RESERVED}
    if not responses:
        raise TimeHistoryError(f"{source}: no response column (one per response coordinate, named by its header)")
    for name in (chosen, *responses):
        if not np.any(numbers[name]):
            what = "the reference" if name == chosen else "the response"
            raise TimeHistoryError(f"{source}: column '{name}' ({what}) is 0 at every sample: nothing was recorded "
                                   f"on that channel; expected a measured signal")
    return TimeRecord(source, time, numbers[chosen], "N" if chosen == "force" else "V", responses,
                      numbers.get("frequency_hz"), numbers.get("level"))


def _fs_column(values: object, source: str) -> float:
    """The sample rate (Hz) a constant ``Fs`` column states; an error naming the column
    when it varies or is not a number > 0."""
    array = np.asarray(values)
    try:
        array = array.astype(float).ravel()
    except (TypeError, ValueError):
        raise TimeHistoryError(f"{source}: column 'Fs' (sample rate) holds text; expected one number > 0 in Hz, the "
                               f"same in every row") from None
    finite = array[np.isfinite(array)]
    if finite.size < array.size or np.ptp(array) != 0:
        shown = f"{finite.min():g}…{finite.max():g} Hz" if finite.size else "no finite value"
        raise TimeHistoryError(f"{source}: column 'Fs' (sample rate) varies ({shown}); expected one number > 0 in Hz, "
                               f"the same in every row (or a 'time_s' column, or --sample-rate HZ)")
    if not array[0] > 0:
        raise TimeHistoryError(f"{source}: column 'Fs' (sample rate) is {array[0]:g}; expected a number > 0 in Hz")
    return float(array[0])


def uff_time_columns(data: bytes, path: Path) -> dict[str, np.ndarray]:
    """The time records (function type 1) of a UFF file's datasets 58 as columns: ``time_s``
    (s, shared by all), ``force`` (N; ordinate type 9 or 13, or label ``N``), ``voltage`` (V;
    label ``V`` or ``mV``) and one column per response (ordinate type 8, 11 or 12), named by
    its node and direction (``NODE:DIR``, e.g. ``3:z``), the sign of a negative direction
    applied: the table the CSV and MATLAB readers give."""
    from nlupdate.core.measurement.uff import check_directions, name_from_node, uff_datasets

    indices, datasets = uff_datasets(data, path)
    records = [(i, d) for i, d in zip(indices, datasets) if d.get("func_type") == 1]
    if not records:
        raise TimeHistoryError(f"{path}: no time record (dataset 58, function type 1)")
    columns: dict[str, np.ndarray] = {}
    time = None
    for index, dataset in records:
        where = f"{path}, dataset {index}"
        check_directions(dataset, where)
        if dataset.get("abscissa_spec_data_type") not in (17, 0, 1):
            raise TimeHistoryError(f"{where}: abscissa specific data type {dataset.get('abscissa_spec_data_type')}; a "
                                   f"time record has 17 (time, s)")
        t = np.asarray(dataset["x"], dtype=float)
        if time is None:
            time = t
        elif t.size != time.size or not np.allclose(t, time, rtol=1e-9, atol=1e-12):
            raise TimeHistoryError(f"{where}: its time axis differs from the first record's")
        ordinate = dataset.get("ordinate_spec_data_type")
        label = str(dataset.get("ordinate_axis_units_lab", "") or "").strip()
        values = np.real(np.asarray(dataset["data"], dtype=complex))
        if ordinate in (9, 13) or label == "N":
            name = "force"
        elif label in ("V", "mV"):
            name, values = "voltage", values * (1e-3 if label == "mV" else 1.0)
        elif ordinate in (8, 11, 12):
            sign = -1.0 if dataset["rsp_dir"] < 0 else 1.0
            name, values = name_from_node(dataset["rsp_node"], dataset["rsp_dir"]), sign * values
        else:
            raise TimeHistoryError(f"{where}: ordinate specific data type {ordinate} (label {label!r}); expected a "
                                   f"force (13), a voltage (label 'V') or a response (8, 11, 12)")
        if name in columns:
            raise TimeHistoryError(f"{where}: a second '{name}' record")
        columns[name] = values
    return {"time_s": time, **columns}


def _uff_record(data: bytes, path: Path) -> TimeRecord:
    """A record from the time records (function type 1) of a UFF file's datasets 58."""
    return _record_from_columns(uff_time_columns(data, path), str(path))


def read_time_record(path: str | Path, sample_rate_hz: float | None = None, reference: str | None = None) -> TimeRecord:
    """A time record from CSV, parquet, UFF 58 (function type 1) or MATLAB (module
    docstring of :mod:`nlupdate.core.measurement.matfile`), read through the input gate;
    ``sample_rate_hz`` and ``reference`` as for :func:`_record_from_columns`."""
    path = Path(path)
    suffix = path.suffix.lower()
    data = read_input_bytes(path, "time-history file")
    kind = sniff(data[:4096])
    if kind == "binary" and data.lstrip(b"\r\n ").startswith(b"-1"):
        kind = "uff"
    if suffix == ".csv" and kind == "text":
        frame = csv_frame(data, path, "time-history file", TimeHistoryError)
        if len(frame.columns) == 1 and ";" in str(frame.columns[0]):
            raise TimeHistoryError(f"{path}: columns are separated by ';'; nlupdate reads comma-separated values with "
                                   f"'.' as the decimal point")
        return _record_from_columns({c: frame[c].to_numpy() for c in frame.columns}, str(path), sample_rate_hz,
                                    reference)
    if suffix == ".parquet" and kind == "parquet":
        check_parquet_size(data, path, "time-history file")
        try:
            frame = pd.read_parquet(io.BytesIO(data))
        except Exception as error:
            raise TimeHistoryError(f"{path}: not a readable parquet file ({error})") from None
        return _record_from_columns({c: frame[c].to_numpy() for c in frame.columns}, str(path), sample_rate_hz,
                                    reference)
    if suffix in (".uff", ".unv") and kind in ("uff", "text"):
        return _uff_record(data, path)
    if suffix == ".mat" and kind in ("mat5", "hdf5"):
        from nlupdate.core.measurement.matfile import mat_variables

        variables = mat_variables(data, path, kind, "time-history file")
        columns = {name: value for name, value in variables.items()
                   if isinstance(value, np.ndarray) and value.size > 1 and value.squeeze().ndim == 1}
        return _record_from_columns(columns, str(path), sample_rate_hz, reference)
    raise TimeHistoryError(f"{path}: a {suffix or 'suffix-less'} file holding {kind}; time histories are read from "
                           f".csv, .parquet, .uff/.unv (dataset 58, function type 1) or .mat")


def csv_frame(data: bytes, path: Path, what: str, error: type[ValueError]) -> pd.DataFrame:
    """The table of a CSV file's bytes (decoded as :func:`decode_text` does); ``error`` with
    one line naming ``path`` when pandas cannot read it. Time histories and ring-down
    records share it."""
    text = decode_text(data, path, what)
    try:
        return pd.read_csv(io.StringIO(text))
    except (pd.errors.ParserError, pd.errors.EmptyDataError, ValueError) as problem:
        raise error(f"{path}: not a readable CSV file ({problem})") from None
