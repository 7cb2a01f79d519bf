"""Measured FRF tables: validation, selection and file I/O (parquet, CSV, UFF58).

A measured-FRF table is a long ("tidy") :class:`pandas.DataFrame` with one row per
(frequency, force level, response coordinate, input coordinate):

==============  =====  ==============================================================
column          type   meaning
==============  =====  ==============================================================
frequency_hz    float  excitation frequency, Hz (≥ 0)
force_level_n   float  amplitude of the harmonic force, N (≥ 0; 0 marks a linear FRF)
response_dof    str    name of the response coordinate ("0", "1", ... or "tip:uz")
input_dof       str    name of the forced coordinate
h_real, h_imag  float  receptance H = X/F, m/N, with x(t) = Re(X e^{iωt}) (METHODS §1)
==============  =====  ==============================================================

Coordinates are identified by NAME (always str). Tables built or read here are sorted by
force level, input, response and frequency ("canonical order").

Errors in a table raise :class:`MeasurementTableError` naming the source, the 0-based
data row, the column and the offending value; for a ``.csv`` source the line number in
the file (row + 2: line 1 is the header) is given as well.

UFF58 convention (``.uff`` / ``.unv``)
--------------------------------------
One dataset 58 per curve (force level, response, input); function type 4 (FRF), complex
double-precision ordinate, receptance: abscissa specific data type 18 (frequency, Hz),
ordinate 8 (displacement, m), ordinate denominator 13 (excitation force, N). The files
are written in the binary variant ("58b", IEEE doubles) so the data round-trip
bit-exactly; the ASCII variant (12 significant digits for the ordinate, 6 for the
abscissa) would not. Evenly spaced frequencies are stored with even abscissa spacing,
others as uneven (x, Re, Im) triples. The ID lines carry the exact metadata as
``key=value`` (value = rest of the line, which is at most 80 characters)::

    ID line 1   response_dof=<name>
    ID line 2   input_dof=<name>
    ID line 3   force_level_n=<float, shortest round-trip repr>
    ID line 4   abscissa_hz=<first>,<increment>   (even spacing; else NONE)
    ID line 5   nlupdate receptance m/N

The header record 7 holds the abscissa minimum and increment with only 6 significant
digits, hence ID line 4. The force level is also written as the z-axis value (record 7
field 6, z-axis specific data type 13 = excitation force, 6 digits). Coordinate names
are also mapped to node/direction fields where possible: a name ``"<n>"`` (n a
non-negative integer of up to 9 digits) is node n, scalar direction 0; ``"<label>:<d>"`` with
d ∈ {ux, uy, uz, rx, ry, rz} (optionally signed, e.g. ``-uz``) is direction ±1..±6 and
node = label if it is an integer, else node 0 with the label as entity name when it fits
(10 characters, no blanks).

Reading UFF files written by other tools: datasets other than 58 are skipped; the
function must be an FRF (type 4) with complex ordinate and an ordinate that is not
velocity or acceleration. Missing ID-line keys are replaced by the header fields: the
coordinate name becomes ``"<node>"`` (direction 0) or ``"<node>:<d>"``, and the force
level is taken from the z-axis value when the z-axis specific data type is 13 (otherwise
the read fails and says which fields are missing).
"""
from __future__ import annotations

import io
import os
import re
import tempfile
import warnings
from pathlib import Path
from typing import Iterable

import numpy as np
import pandas as pd
import pyuff
from numpy.typing import ArrayLike, NDArray

from nlupdate.files import atomic_file
from nlupdate.input_files import read_input_bytes
from nlupdate.notices import NlupdateWarning

FRF_COLUMNS: tuple[str, ...] = (
    "frequency_hz", "force_level_n", "response_dof", "input_dof", "h_real", "h_imag",
)
_FLOAT_COLUMNS = ("frequency_hz", "force_level_n", "h_real", "h_imag")
_DOF_COLUMNS = ("response_dof", "input_dof")
_KEY_COLUMNS = ("frequency_hz", "force_level_n", "response_dof", "input_dof")
_SORT_COLUMNS = ["force_level_n", "input_dof", "response_dof", "frequency_hz"]
SUPPORTED_SUFFIXES: tuple[str, ...] = (".parquet", ".csv", ".uff", ".unv")

# UFF58 codes (see module docstring)
_FRF_FUNCTION = 4
_FREQUENCY, _DISPLACEMENT, _FORCE = 18, 8, 13
# ordinate specific data type → power of iω that turns it into receptance (0: unknown, read as receptance)
_RECEPTANCE_POWER = {0: 0, _DISPLACEMENT: 0, 11: 1, 12: 2}
_DIRECTIONS = {"ux": 1, "uy": 2, "uz": 3, "rx": 4, "ry": 5, "rz": 6}
_DIRECTION_NAMES = {code: name for name, code in _DIRECTIONS.items()}
_ID_LINE_WIDTH = 80
_EVEN_RTOL = 1e-13  # relative deviation below which a grid counts as evenly spaced


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

    The copy has exactly the columns :data:`FRF_COLUMNS` (others are dropped), float
    columns as float64 and coordinate names as str (ints such as 0 become "0").
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
        raw = table[column].reset_index(drop=True)
        values = pd.to_numeric(raw, errors="coerce").to_numpy(dtype=float, na_value=np.nan)
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            more = f" (and {bad.size - 1} more row(s))" if bad.size > 1 else ""
            raise MeasurementTableError(
                f"{_where(source, int(bad[0]))}, column '{column}': {raw.iloc[bad[0]]!r} is not a "
                f"finite number{more}"
            )
        clean[column] = values
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
    return clean[list(FRF_COLUMNS)]


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


# --------------------------------------------------------------------------- UFF58
def _node_fields(name: str) -> tuple[str, int, int]:
    """(entity name, node, direction) best representing a coordinate name."""
    if re.fullmatch(r"[0-9]{1,9}", name):
        return "NONE", int(name), 0
    match = re.fullmatch(r"(.+):([+-]?)([ur][xyz])", name)
    if match is None:
        return "NONE", 0, 0
    label, sign, direction = match.groups()
    code = _DIRECTIONS[direction] * (-1 if sign == "-" else 1)
    if re.fullmatch(r"[0-9]{1,9}", label):
        return "NONE", int(label), code
    entity = label if len(label) <= 10 and not any(ch.isspace() for ch in label) else "NONE"
    return entity, 0, code


def _name_from_node(node: int, direction: int) -> str:
    if direction == 0 or abs(direction) not in _DIRECTION_NAMES:
        return str(node) if direction == 0 else f"{node}:{direction}"
    sign = "-" if direction < 0 else ""
    return f"{node}:{sign}{_DIRECTION_NAMES[abs(direction)]}"


def _id_line(key: str, value: str, where: str) -> str:
    line = f"{key}={value}"
    if len(line) > _ID_LINE_WIDTH or value != value.strip() or not value.isascii() or not value.isprintable():
        raise MeasurementTableError(
            f"{where}: cannot store {key} {value!r} in a UFF58 ID line: '{key}=<value>' must be at "
            f"most {_ID_LINE_WIDTH} printable ASCII characters without leading/trailing blanks"
        )
    return line


def _uff_datasets(table: pd.DataFrame, where: str) -> list[dict]:
    if table.empty:
        raise MeasurementTableError(f"{where}: an empty table cannot be written as UFF58 (no curve to store)")
    datasets = []
    for (level, inp, resp), curve in table.groupby(["force_level_n", "input_dof", "response_dof"], sort=False):
        f = curve["frequency_hz"].to_numpy()
        h = curve["h_real"].to_numpy() + 1j * curve["h_imag"].to_numpy()
        df = (f[-1] - f[0]) / (len(f) - 1) if len(f) > 1 else 0.0
        even = bool(np.all(np.abs(f[0] + df * np.arange(len(f)) - f) <= _EVEN_RTOL * np.abs(f)))
        rsp_ent, rsp_node, rsp_dir = _node_fields(resp)
        ref_ent, ref_node, ref_dir = _node_fields(inp)
        dataset = pyuff.prepare_58(
            binary=1, func_type=_FRF_FUNCTION, load_case_id=0,
            id1=_id_line("response_dof", resp, where),
            id2=_id_line("input_dof", inp, where),
            id3=f"force_level_n={float(level)!r}",
            id4=f"abscissa_hz={float(f[0])!r},{float(df)!r}" if even else "NONE",
            id5="nlupdate receptance m/N",
            rsp_ent_name=rsp_ent, rsp_node=rsp_node, rsp_dir=rsp_dir,
            ref_ent_name=ref_ent, ref_node=ref_node, ref_dir=ref_dir,
            abscissa_spacing=int(even), z_axis_value=float(level),
            abscissa_spec_data_type=_FREQUENCY, abscissa_axis_units_lab="Hz",
            ordinate_spec_data_type=_DISPLACEMENT, ordinate_len_unit_exp=1, ordinate_axis_units_lab="m",
            orddenom_spec_data_type=_FORCE, orddenom_force_unit_exp=1, orddenom_axis_units_lab="N",
            z_axis_spec_data_type=_FORCE, z_axis_force_unit_exp=1, z_axis_axis_units_lab="N",
            data=h,
            # pyuff computes the increment from x[1] - x[0] even for a single point
            x=f if len(f) > 1 else np.repeat(f, 2),
        )
        datasets.append(dataset)
    return datasets


def _fix_binary_byte_counts(path: Path, datasets: list[dict]) -> None:
    """Patch record 1 field 6 (bytes of binary data) in a file written by pyuff.

    pyuff writes 8·n there also for complex data, which holds 16·n (even abscissa) or
    24·n (uneven) bytes; readers that trust the field would truncate the data.
    """
    content = bytearray(path.read_bytes())
    position = 0
    for dataset in datasets:
        n_bytes = 8 * len(dataset["data"]) * (2 if dataset["abscissa_spacing"] else 3)
        start = content.index(b"    58b", position)
        # '    58', 'b', byte order and float format ('%6i' each), ASCII lines ('%12i'), n_bytes
        field = slice(start + 31, start + 43)
        content[field] = b"%12i" % n_bytes
        position = content.index(b"\n", start) + 1
        for _ in range(11):  # ID lines 1-5 and records 6-11, then the binary data
            position = content.index(b"\n", position) + 1
        position += n_bytes
    path.write_bytes(bytes(content))


def _id_keys(dataset: dict) -> dict[str, str]:
    keys = {}
    for n in range(1, 6):
        key, sep, value = str(dataset.get(f"id{n}", "")).partition("=")
        if sep:
            keys[key.strip()] = value
    return keys


def _id_floats(keys: dict[str, str], key: str, count: int, where: str) -> list[float]:
    try:
        values = [float(v) for v in keys[key].split(",")]
    except ValueError:
        values = []
    if len(values) != count:
        raise MeasurementTableError(
            f"{where}: ID line '{key}={keys[key]}' should hold {count} comma-separated number(s)"
        )
    return values


def _curve_from_uff(dataset: dict, where: str) -> pd.DataFrame:
    if dataset.get("func_type") != _FRF_FUNCTION:
        raise MeasurementTableError(
            f"{where}: function type {dataset.get('func_type')}, expected 4 (frequency response function)"
        )
    if dataset.get("ord_data_type") not in (5, 6):
        raise MeasurementTableError(
            f"{where}: ordinate data type {dataset.get('ord_data_type')} is real; a receptance "
            f"needs complex data (5 or 6)"
        )
    ordinate = dataset.get("ordinate_spec_data_type", 0)
    if ordinate not in _RECEPTANCE_POWER:
        raise MeasurementTableError(
            f"{where}: ordinate specific data type {ordinate}; expected 8 (displacement, receptance), 11 (velocity, "
            f"mobility) or 12 (acceleration, accelerance)"
        )
    if len(dataset["data"]) != int(dataset.get("num_pts", len(dataset["data"]))):
        raise MeasurementTableError(
            f"{where}: incomplete record: {len(dataset['data'])} of the {dataset['num_pts']} values its header "
            f"announces (is the file truncated?)"
        )
    keys = _id_keys(dataset)
    if "force_level_n" in keys:
        (level,) = _id_floats(keys, "force_level_n", 1, where)
    elif dataset.get("z_axis_spec_data_type") == _FORCE:
        level = float(dataset["z_axis_value"])
    else:
        raise MeasurementTableError(
            f"{where}: no force level: expected an ID line 'force_level_n=<amplitude in N>' or a "
            f"z-axis specific data type 13 (excitation force) with the amplitude as z-axis value "
            f"(record 7 field 6); found ID lines {[dataset.get(f'id{n}') for n in range(1, 6)]} and "
            f"z-axis specific data type {dataset.get('z_axis_spec_data_type')}"
        )
    response = keys.get("response_dof", _name_from_node(dataset["rsp_node"], dataset["rsp_dir"]))
    inp = keys.get("input_dof", _name_from_node(dataset["ref_node"], dataset["ref_dir"]))
    h = np.asarray(dataset["data"], dtype=complex)
    frequency = np.asarray(dataset["x"], dtype=float)
    if "abscissa_hz" in keys and dataset.get("abscissa_spacing") == 1:
        first, increment = _id_floats(keys, "abscissa_hz", 2, where)
        frequency = first + increment * np.arange(len(h))
    power = _RECEPTANCE_POWER[ordinate]
    if power:
        h = h / (1j * 2 * np.pi * frequency) ** power
        name = {1: "mobility (velocity/force)", 2: "accelerance (acceleration/force)"}[power]
        warnings.warn(f"{where}: converted {name} to receptance: H = {'A' if power == 2 else 'V'}/(iω)"
                      f"{'²' if power == 2 else ''}", NlupdateWarning, stacklevel=4)
    return pd.DataFrame({
        "frequency_hz": frequency, "force_level_n": level, "response_dof": response,
        "input_dof": inp, "h_real": h.real, "h_imag": h.imag,
    })


def _check_complete(path: Path, uff: pyuff.UFF, content: bytes) -> None:
    """Refuse a file whose last dataset has no end delimiter (a truncated file).

    pyuff indexes only complete datasets (between ``-1`` delimiter lines) and would
    silently drop a cut-off last one.
    """
    blocks = getattr(uff, "_block_ind", None)
    end = int(blocks[-1][1]) + 1 if blocks is not None and len(blocks) else 0  # [first, last] byte
    rest = content[end:].replace(b"-1", b"", 1).strip() if end else content.strip()
    if end and rest or not end and content.strip():
        count = len(blocks) if blocks is not None else 0
        raise MeasurementTableError(
            f"{path}: incomplete record: dataset {count} (from byte {end}) has no end delimiter '-1'; the file "
            f"is truncated or not a complete UFF file ({len(content)} bytes)"
        )


def _read_uff(path: Path, content: bytes) -> pd.DataFrame:
    """The datasets 58 of the universal file ``content`` (read from ``path``); pyuff reads
    files only, so it parses a private temporary copy of exactly these bytes."""
    with tempfile.TemporaryDirectory(prefix="nlupdate-uff-") as folder:
        copy = Path(folder) / path.name
        copy.write_bytes(content)
        try:
            uff = pyuff.UFF(str(copy))
            indices = [i for i, t in enumerate(uff.get_set_types()) if t == 58]
            datasets = [uff.read_sets(i) for i in indices]
        except Exception as error:  # pyuff raises bare Exception on malformed files
            raise MeasurementTableError(f"{path}: not a readable UFF file ({error})") from error
    _check_complete(path, uff, content)
    if not datasets:
        raise MeasurementTableError(f"{path}: no dataset 58 (function at nodal DOF) found")
    curves, seen = [], {}
    for index, dataset in zip(indices, datasets):
        where = f"{path}, dataset {index}"
        curve = validate_frf_table(_curve_from_uff(dataset, where), source=where)
        key = tuple(curve.loc[0, ["force_level_n", "response_dof", "input_dof"]])
        if key in seen:
            raise MeasurementTableError(
                f"{path}: datasets {seen[key]} and {index} hold the same curve (force_level_n, "
                f"response_dof, input_dof) = {key}"
            )
        seen[key] = index
        curves.append(curve)
    return pd.concat(curves, ignore_index=True)


# --------------------------------------------------------------------------- files
def table_suffix(path: Path) -> str:
    """The format suffix of a measured-FRF file (.parquet, .csv, .uff, .unv), or an error naming the file."""
    suffix = path.suffix.lower()
    if suffix not in SUPPORTED_SUFFIXES:
        raise MeasurementTableError(
            f"{path}: unsupported file type {suffix!r}; supported: {', '.join(SUPPORTED_SUFFIXES)}"
        )
    return suffix


def read_frf_table(path: str | os.PathLike, known_dofs: Iterable[str] | None = None) -> pd.DataFrame:
    """Read and validate a measured-FRF table (.parquet, .csv, .uff/.unv); canonical order."""
    path = Path(path)
    suffix = table_suffix(path)
    content = read_input_bytes(path, "measured-FRF table")
    if suffix == ".parquet":
        try:
            raw = pd.read_parquet(io.BytesIO(content))
        except (OSError, ValueError) as error:
            raise MeasurementTableError(f"{path}: not a readable parquet file ({error})") from error
    elif suffix == ".csv":
        try:
            raw = pd.read_csv(io.BytesIO(content), dtype={c: str for c in _DOF_COLUMNS}, keep_default_na=False)
        except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as error:
            raise MeasurementTableError(f"{path}: not a readable CSV file ({error})") from error
    else:
        raw = _read_uff(path, content)
    return _canonical(validate_frf_table(raw, source=str(path), known_dofs=known_dofs))


def write_frf_table(table: pd.DataFrame, path: str | os.PathLike) -> Path:
    """Validate ``table`` and write it atomically (temp file + os.replace); returns the path.

    The format follows the suffix (.parquet, .csv, .uff/.unv, see the module docstring);
    rows are written in canonical order. CSV floats use the shortest round-trip repr.
    """
    path = Path(path)
    suffix = table_suffix(path)
    clean = _canonical(validate_frf_table(table, source=f"table to write to {path}"))
    datasets = _uff_datasets(clean, str(path)) if suffix in (".uff", ".unv") else None
    with atomic_file(path) as temporary:
        if suffix == ".parquet":
            clean.to_parquet(temporary, index=False)
        elif suffix == ".csv":
            clean.to_csv(temporary, index=False)
        else:
            # 'add' to a fresh file: pyuff's 'overwrite' truncates the file when it switches
            # to binary mode, erasing the first dataset's header
            pyuff.UFF(str(temporary)).write_sets(datasets, mode="add")
            _fix_binary_byte_counts(temporary, datasets)
    return path
