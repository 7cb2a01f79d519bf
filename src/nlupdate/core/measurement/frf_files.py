"""Measured-FRF files: reading (parquet, CSV, UFF 58, MATLAB) and writing, checked.

Files are read through :mod:`nlupdate.input_files` (regular files only, a size limit,
content sniffed before parsing), once: :func:`frf_table_from_bytes` parses the bytes that
were read. Formats: parquet, CSV (comma-separated, ``.`` decimals), UFF 58
(:mod:`nlupdate.core.measurement.uff`) and MATLAB v5 / v7.3 (:mod:`nlupdate.core.measurement.matfile`).
What the reference is (N or V) and the level of each file can be stated by the user
(:class:`~nlupdate.core.measurement.units.ReadOptions`).
"""
from __future__ import annotations

import io
import os
import re
from pathlib import Path
from typing import Iterable

import numpy as np
import pandas as pd

from nlupdate.files import atomic_file
from nlupdate.input_files import check_parquet_size, decode_text, read_input_bytes, sniff
from nlupdate.core.measurement.frf_table import (
    _DOF_COLUMNS, _KEY_COLUMNS, FRF_COLUMNS, OPTIONAL_COLUMNS, MeasurementTableError, _canonical, validate_frf_table,
)
from nlupdate.core.measurement.matfile import read_mat_frf
from nlupdate.core.measurement.uff import read_uff_frf, write_uff_frf
from nlupdate.core.measurement.units import (
    ReadOptions, calibrated, checked_reference_unit, table_reference_unit,
)

SUPPORTED_SUFFIXES: tuple[str, ...] = (".parquet", ".csv", ".uff", ".unv", ".mat")


def table_suffix(path: Path) -> str:
    """The format suffix of a measured-FRF file (.parquet, .csv, .uff, .unv, .mat), or an error naming the file."""
    suffix = Path(path).suffix.lower()
    if suffix not in SUPPORTED_SUFFIXES:
        raise MeasurementTableError(
            f"{path}: unsupported file type {suffix!r}; supported: {', '.join(SUPPORTED_SUFFIXES)}"
        )
    return suffix


_EXPECTED_CONTENT = {".parquet": "parquet", ".csv": "text", ".uff": "uff", ".unv": "uff", ".mat": "mat"}
_CONTENT_NAMES = {"parquet": "a parquet file", "hdf5": "an HDF5 (MATLAB v7.3) file", "mat5": "a MATLAB v5 file",
                  "uff": "a universal file (UFF)", "text": "text", "binary": "binary data"}


def _check_content(data: bytes, path: Path, suffix: str) -> str:
    """The sniffed kind of ``data``; an error when it does not fit the suffix."""
    kind = sniff(data[:4096])
    if kind == "binary" and data.lstrip(b"\r\n ").startswith(b"-1"):
        kind = "uff"  # binary UFF (58b): a '-1' delimiter line, then binary records
    expected = _EXPECTED_CONTENT[suffix]
    fits = kind == expected or (expected == "mat" and kind in ("mat5", "hdf5")) or (expected == "uff" and kind == "text")
    if not data.strip():
        raise MeasurementTableError(f"{path}: the file is empty; expected a measured-FRF table")
    if not fits:
        raise MeasurementTableError(f"{path}: holds {_CONTENT_NAMES[kind]}, not what its suffix {suffix!r} says "
                                    f"({_CONTENT_NAMES.get(expected, 'a MATLAB file')})")
    return kind


def _csv_separator_problem(text: str, path: Path) -> str | None:
    """Why a CSV header does not look comma-separated (None when it does)."""
    header = next((line for line in text.splitlines() if line.strip()), "")
    if "," in header:
        names = header.rstrip("\r\n").split(",")
        if len(names) > 1 and any(name != name.strip() for name in names[1:]):
            return (f"{path}: the header's column names have blanks around the commas (header "
                    f"{header.strip()[:80]!r}: separator ', '); nlupdate reads comma-separated values with nothing "
                    f"but the comma between them, e.g. 'frequency_hz,force_level_n,...'")
        return None
    for separator, name in ((";", "';'"), ("\t", "tabs"), ("|", "'|'")):
        if separator in header:
            decimal = " and decimal commas" if re.search(r"\d,\d", text[:4096]) else ""
            return (f"{path}: columns are separated by {name}{decimal} (header {header.strip()[:80]!r}); nlupdate reads "
                    f"comma-separated values with '.' as the decimal point")
    return None


def _read_csv(data: bytes, path: Path) -> pd.DataFrame:
    text = decode_text(data, path, "measured-FRF table")
    problem = _csv_separator_problem(text, path)
    if problem:
        raise MeasurementTableError(problem)
    try:
        return pd.read_csv(io.StringIO(text), dtype={c: str for c in _DOF_COLUMNS + ("excitation", "reference_unit")},
                           keep_default_na=False)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, ValueError) as error:
        raise MeasurementTableError(f"{path}: not a readable CSV file ({error})") from None


def _read_parquet(data: bytes, path: Path) -> pd.DataFrame:
    check_parquet_size(data, path, "measured-FRF file")
    try:
        return pd.read_parquet(io.BytesIO(data))
    except Exception as error:  # pyarrow raises its own errors on corrupt files
        raise MeasurementTableError(f"{path}: not a readable parquet file ({error})") from None


def frf_table_from_bytes(
    data: bytes, path: str | os.PathLike, known_dofs: Iterable[str] | None = None, options: ReadOptions | None = None,
) -> pd.DataFrame:
    """A measured-FRF table parsed from the bytes ``data`` of the file ``path`` (its
    suffix names the format); validated, in canonical order, with the user's statements
    ``options`` applied (reference unit, calibration, level of the file)."""
    path = Path(path)
    options = options or ReadOptions()
    suffix = table_suffix(path)
    kind = _check_content(data, path, suffix)
    if suffix == ".parquet":
        raw = _read_parquet(data, path)
    elif suffix == ".csv":
        raw = _read_csv(data, path)
    elif suffix == ".mat":
        raw = read_mat_frf(data, path, kind, options)
    else:
        raw = read_uff_frf(data, path, options)
    if len(raw) == 0:
        raise MeasurementTableError(f"{path}: holds no measurement (no data rows); a measured-FRF table has one row "
                                    f"per frequency, level, response and input")
    runs = tuple(raw.attrs.get("runs", ()))
    raw = _with_user_statements(raw, path, suffix, options)
    table = validate_frf_table(raw, source=str(path), known_dofs=known_dofs)
    if options.reference_calibration is not None:
        table = calibrated(table, options.reference_calibration, str(path))
    table = _canonical(table)
    table.attrs["runs"] = runs  # the run names of a UFF export (for levels keyed FILE#RUN or RUN)
    return table


def _with_user_statements(raw: pd.DataFrame, path: Path, suffix: str, options: ReadOptions) -> pd.DataFrame:
    """The reference unit and the file's level as the user stated them, checked against the file."""
    raw = raw.copy()
    if suffix != ".mat" and options.coordinates_of(str(path)) is not None:
        raise MeasurementTableError(f"{path}: names its coordinates itself; --coordinates is for MATLAB stepped-sine "
                                    f"runs that name none")
    if "reference_unit" in raw.columns:
        units = sorted({checked_reference_unit(u, f"{path}: column 'reference_unit'") for u in raw["reference_unit"]})
        if options.reference_unit is not None and units != [options.reference_unit]:
            raise MeasurementTableError(f"{path}: the file's reference is in {', '.join(units)} (column "
                                        f"'reference_unit'), not in {options.reference_unit} as stated")
    elif options.reference_unit == "V":  # a table without the column is in N
        raw["reference_unit"] = "V"
    level = options.level_of(str(path))
    if level is not None and suffix not in (".uff", ".unv"):  # the UFF reader applies it per dataset
        if "force_level_n" in raw.columns and len(set(np.asarray(raw["force_level_n"]).tolist())) > 1:
            raise MeasurementTableError(f"{path}: holds several levels {sorted(set(raw['force_level_n']))}; a level "
                                        f"given for the file ({level:g}) fits a file of one level")
        raw["force_level_n"] = level
    if options.reference_calibration is not None and table_reference_unit(raw) != "V":
        raise MeasurementTableError(f"{path}: a reference calibration (N per V) applies to FRFs per volt; this file's "
                                    f"reference is in N")
    return raw


def read_frf_table(
    path: str | os.PathLike, known_dofs: Iterable[str] | None = None, options: ReadOptions | None = None,
) -> pd.DataFrame:
    """Read and validate a measured-FRF table (.parquet, .csv, .uff/.unv, .mat); canonical order.

    The file is read once through :func:`nlupdate.input_files.read_input_bytes` (a regular
    file within the input size limit) and its content sniffed before any parser sees it.
    """
    path = Path(path)
    table_suffix(path)
    data = read_input_bytes(path, "measured-FRF file")
    return frf_table_from_bytes(data, path, known_dofs, options)


def is_frf_table(path: str | os.PathLike) -> bool:
    """Whether ``path`` reads as a measured-FRF table: the only kind of existing file that
    ``simulate`` and ``frf`` (which write such tables) replace with ``--overwrite``."""
    try:
        read_frf_table(path)
    except (ValueError, OSError):
        return False
    return True


def read_frf_tables(
    paths: Iterable[str | os.PathLike], known_dofs: Iterable[str] | None = None, options: ReadOptions | None = None,
) -> pd.DataFrame:
    """Several files of one measurement (one per level, or per run) as one table.

    The files must share their reference unit; a curve (frequency, level, response,
    input) found in two files is an error naming both. Optional columns present in only
    some files are dropped.
    """
    paths = [Path(p) for p in paths]
    if not paths:
        raise MeasurementTableError("no measured-FRF file given")
    tables = [read_frf_table(p, known_dofs, options) for p in paths]
    _check_level_keys(options, paths, tables)
    if len(tables) == 1:
        return tables[0]
    units = {p: table_reference_unit(t) for p, t in zip(paths, tables)}
    if len(set(units.values())) > 1:
        described = ", ".join(f"{p.name}: {u}" for p, u in units.items())
        raise MeasurementTableError(f"the files mix references ({described}); one measurement has one reference unit")
    common = [c for c in OPTIONAL_COLUMNS if all(c in t.columns for t in tables)]
    origin = np.concatenate([np.full(len(t), i) for i, t in enumerate(tables)])
    combined = pd.concat([t[list(FRF_COLUMNS) + common] for t in tables], ignore_index=True)
    duplicated = combined.duplicated(list(_KEY_COLUMNS), keep=False).to_numpy()
    if duplicated.any():
        first = np.flatnonzero(duplicated)[0]
        key = combined.loc[first, list(_KEY_COLUMNS)]
        both = sorted({paths[origin[i]].name for i in np.flatnonzero(duplicated)
                       if combined.loc[i, list(_KEY_COLUMNS)].equals(key)})
        raise MeasurementTableError(
            f"{' and '.join(both)} hold the same measurement (frequency {key['frequency_hz']:g} Hz, level "
            f"{key['force_level_n']:g}, response {key['response_dof']!r}, input {key['input_dof']!r}); give each level "
            f"once (a file's level: --level FILE=VALUE)")
    return _canonical(validate_frf_table(combined, source=", ".join(str(p) for p in paths), known_dofs=known_dofs))


def _check_level_keys(options: ReadOptions | None, paths: list[Path], tables: list[pd.DataFrame]) -> None:
    """Every level the user gave names a file or a run that was read."""
    if options is None or not options.levels:
        return
    runs = {str(p): tuple(t.attrs.get("runs", ())) for p, t in zip(paths, tables)}
    unmatched = options.unmatched_levels(runs)
    if unmatched:
        named = [f"{Path(p).name}#{r}" for p, rs in runs.items() for r in rs]
        raise MeasurementTableError(
            f"level given for {unmatched[0]!r} (--level, study [measured] levels): no file read and no run of them has "
            f"that name; expected FILE, FILE#RUN or RUN among the files {', '.join(Path(p).name for p in runs)}"
            + (f" and the runs {', '.join(named)}" if named else " (which name no runs)"))


def write_frf_table(table: pd.DataFrame, path: str | os.PathLike) -> Path:
    """Validate ``table`` and write it atomically (temp file + os.replace); returns the path.

    The format follows the suffix (.parquet, .csv, .uff/.unv, see
    :mod:`nlupdate.core.measurement.uff`); rows are written in canonical order. CSV floats use
    the shortest round-trip repr. Optional columns go into parquet and CSV files; a UFF
    file holds the receptances (and states a per-volt reference in its units).
    """
    path = Path(path)
    suffix = table_suffix(path)
    if suffix == ".mat":
        raise MeasurementTableError(f"{path}: nlupdate reads MATLAB files but writes measured FRFs as .parquet, .csv "
                                    f"or .uff")
    clean = _canonical(validate_frf_table(table, source=f"table to write to {path}"))
    if suffix in (".uff", ".unv"):
        write_uff_frf(clean, path)
        return path
    with atomic_file(path) as temporary:
        if suffix == ".parquet":
            clean.to_parquet(temporary, index=False)
        else:
            clean.to_csv(temporary, index=False)
    return path
