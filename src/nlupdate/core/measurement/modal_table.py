"""Modal tables: natural frequency and damping ratio per mode at several force levels.

What a random or phase-resonance test gives when it is analysed mode by mode. A modal
table is a long :class:`pandas.DataFrame` (CSV on disk) with one row per (force level, mode):

====================  =====  ==========================================================
column                type   meaning
====================  =====  ==========================================================
force_level_n         float  force level of the test, N (> 0; for a random test its RMS)
mode                  int    mode number, 1 = the lowest mode of the model (≥ 1)
natural_frequency_hz  float  identified natural frequency, Hz (> 0)
damping_ratio         float  identified viscous damping ratio ζ, a fraction (0.01 = 1 %), ≥ 0
input_dof             str    optional: the excited coordinate (name in the model)
====================  =====  ==========================================================

Rows are returned sorted by force level and mode. Errors raise :class:`ModalTableError`
naming the source, the 0-based row (and the CSV line), the column and the value.
"""
from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike

from nlupdate.files import atomic_file
from nlupdate.input_files import read_input_text

MODAL_COLUMNS: tuple[str, ...] = ("force_level_n", "mode", "natural_frequency_hz", "damping_ratio")
OPTIONAL_COLUMNS: tuple[str, ...] = ("input_dof",)


class ModalTableError(ValueError):
    """A modal table (or file) does not have the expected form."""


def _where(source: str, row: int) -> str:
    line = f" (line {row + 2})" if str(source).lower().endswith(".csv") else ""
    return f"{source}: row {row}{line}"


def validate_modal_table(table: pd.DataFrame, source: str = "<modal table>") -> pd.DataFrame:
    """Check a modal table and return a clean, sorted copy (columns as documented above)."""
    if not isinstance(table, pd.DataFrame):
        raise ModalTableError(f"{source}: expected a pandas DataFrame, got {type(table).__name__}")
    missing = [c for c in MODAL_COLUMNS if c not in table.columns]
    if missing:
        raise ModalTableError(f"{source}: missing column(s) {missing}; a modal table has columns {list(MODAL_COLUMNS)}")
    clean = pd.DataFrame(index=pd.RangeIndex(len(table)))
    rules = {
        "force_level_n": (lambda v: v > 0, "a force level > 0 N"),
        "mode": (lambda v: (v >= 1) & (v == np.round(v)), "a mode number 1, 2, …"),
        "natural_frequency_hz": (lambda v: v > 0, "a natural frequency > 0 Hz"),
        "damping_ratio": (lambda v: (v >= 0) & (v < 1), "a damping ratio as a fraction, 0 ≤ ζ < 1"),
    }
    for column, (valid, expected) in rules.items():
        raw = table[column].reset_index(drop=True)
        values = pd.to_numeric(raw, errors="coerce").to_numpy(dtype=float, na_value=np.nan)
        bad = np.flatnonzero(~np.isfinite(values) | ~valid(np.nan_to_num(values, nan=-1.0)))
        if bad.size:
            raise ModalTableError(f"{_where(source, int(bad[0]))}, column '{column}': {raw.iloc[bad[0]]!r}, expected {expected}")
        clean[column] = values
    clean["mode"] = clean["mode"].astype(int)
    if "input_dof" in table.columns:
        names = [str(v).strip() for v in table["input_dof"]]
        bad = [row for row, name in enumerate(names) if not name]
        if bad:
            raise ModalTableError(f"{_where(source, bad[0])}, column 'input_dof': empty coordinate name")
        clean["input_dof"] = names
    duplicated = np.flatnonzero(clean.duplicated(["force_level_n", "mode"], keep=False).to_numpy())
    if duplicated.size:
        row = int(duplicated[0])
        raise ModalTableError(
            f"{_where(source, row)}: force level {clean.loc[row, 'force_level_n']:g} N, mode "
            f"{clean.loc[row, 'mode']} appears more than once"
        )
    return clean.sort_values(["force_level_n", "mode"], kind="mergesort").reset_index(drop=True)


def modal_table(
    force_level_n: ArrayLike, mode: ArrayLike, natural_frequency_hz: ArrayLike, damping_ratio: ArrayLike,
    input_dof: str | None = None,
) -> pd.DataFrame:
    """A validated modal table from broadcastable arrays (Hz, damping ratio as a fraction)."""
    force, number, frequency, zeta = np.broadcast_arrays(
        np.asarray(force_level_n, dtype=float), np.asarray(mode), np.asarray(natural_frequency_hz, dtype=float),
        np.asarray(damping_ratio, dtype=float),
    )
    table = pd.DataFrame({
        "force_level_n": force.ravel(), "mode": number.ravel(), "natural_frequency_hz": frequency.ravel(),
        "damping_ratio": zeta.ravel(),
    })
    if input_dof is not None:
        table["input_dof"] = str(input_dof)
    return validate_modal_table(table, "modal_table()")


def is_modal_table_file(path: str | os.PathLike) -> bool:
    """Whether a file is a CSV whose header has the modal-table columns."""
    path = Path(path)
    if path.suffix.lower() != ".csv" or not path.is_file():
        return False
    with path.open("rb") as handle:  # only the first line: the file is read through the gate later
        header = {name.strip() for name in handle.readline(4096).decode("utf-8", "replace").strip().split(",")}
    return set(MODAL_COLUMNS) <= header


def read_modal_table(path: str | os.PathLike) -> pd.DataFrame:
    """Read and validate a modal table from CSV, through the input gate
    (:mod:`nlupdate.input_files`: a regular file within the size limit, UTF-8 text)."""
    path = Path(path)
    if path.suffix.lower() != ".csv":
        raise ModalTableError(f"{path}: a modal table is a .csv file, got {path.suffix!r}")
    text = read_input_text(path, "modal table")
    try:
        raw = pd.read_csv(io.StringIO(text), dtype={"input_dof": str}, keep_default_na=False)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, ValueError) as error:
        raise ModalTableError(f"{path}: not a readable CSV file ({error})") from None
    if len(raw) == 0:
        raise ModalTableError(f"{path}: holds no mode (no data rows)")
    return validate_modal_table(raw, str(path))


def write_modal_table(table: pd.DataFrame, path: str | os.PathLike) -> Path:
    """Validate and write a modal table as CSV (atomically); returns the path."""
    path = Path(path)
    clean = validate_modal_table(table, f"table to write to {path}")
    with atomic_file(path) as temporary:
        clean.to_csv(temporary, index=False)
    return path
