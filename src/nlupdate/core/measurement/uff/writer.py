"""Writing nlupdate's own UFF files: one dataset 58 per curve (level, response, input).

Function type 4 (FRF), complex double-precision ordinate, receptance: abscissa specific data
type 18 (frequency, Hz), ordinate 8 (displacement, m), ordinate denominator 13 (excitation
force, N) — or, for a table per volt, denominator 0 with the unit label ``V``. The binary
variant ("58b", IEEE doubles) keeps the data bit-exact; evenly spaced frequencies are stored
with even abscissa spacing, others as (x, Re, Im) triples. The ID lines carry the exact
metadata::

    ID line 1   response_dof=<name>
    ID line 2   input_dof=<name>
    ID line 3   force_level_n=<float, shortest round-trip repr>   (in the reference unit)
    ID line 4   abscissa_hz=<first>,<increment>   (even spacing; else NONE)
    ID line 5   nlupdate receptance m/N           (m/V for a per-volt table)

The level is also the z-axis value (record 7 field 6: specific data type 13 with the label
``N``, or 0 with ``V``). Coordinate names are mapped to node/direction fields where
possible: ``"<n>"`` is node n, scalar direction 0; ``"<label>:<d>"`` with d ∈ {ux, uy, uz,
rx, ry, rz} (optionally signed) is direction ±1..±6, node = label if it is an integer, else
node 0 with the label as entity name when it fits.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd
import pyuff

from nlupdate.core.measurement.frf_table import MeasurementTableError
from nlupdate.core.measurement.uff.codes import DIRECTIONS, DISPLACEMENT, FORCE, FREQUENCY, FRF, UNKNOWN
from nlupdate.core.measurement.units import table_reference_unit
from nlupdate.files import atomic_file

_ID_LINE_WIDTH = 80
_EVEN_RTOL = 1e-13  # relative deviation below which a grid counts as evenly spaced


def _node_fields(name: str) -> tuple[str, int, int]:
    """(entity name, node, direction) best representing a coordinate name."""
    if re.fullmatch(r"[0-9]{1,9}", name):
        return "NONE", int(name), 0
    match = re.fullmatch(r"(.+):([+-]?)([ur][xyz])", name)
    if match is None:
        return "NONE", 0, 0
    label, sign, direction = match.groups()
    code = DIRECTIONS[direction] * (-1 if sign == "-" else 1)
    if re.fullmatch(r"[0-9]{1,9}", label):
        return "NONE", int(label), code
    entity = label if len(label) <= 10 and not any(ch.isspace() for ch in label) else "NONE"
    return entity, 0, code


def _id_line(key: str, value: str, where: str) -> str:
    """The ID line ``key=value``; refused when it does not fit the format's 80 printable ASCII characters."""
    line = f"{key}={value}"
    if len(line) > _ID_LINE_WIDTH or value != value.strip() or not value.isascii() or not value.isprintable():
        raise MeasurementTableError(
            f"{where}: cannot store {key} {value!r} in a UFF58 ID line: '{key}=<value>' must be at "
            f"most {_ID_LINE_WIDTH} printable ASCII characters without leading/trailing blanks")
    return line


def _uff_datasets(table: pd.DataFrame, where: str) -> list[dict]:
    """The pyuff datasets 58 of a validated table, one per (level, input, response) curve."""
    if table.empty:
        raise MeasurementTableError(f"{where}: an empty table cannot be written as UFF58 (no curve to store)")
    unit = table_reference_unit(table)
    reference = dict(orddenom_spec_data_type=FORCE, orddenom_force_unit_exp=1, orddenom_axis_units_lab="N",
                     z_axis_spec_data_type=FORCE, z_axis_force_unit_exp=1, z_axis_axis_units_lab="N") if unit == "N" \
        else dict(orddenom_spec_data_type=UNKNOWN, orddenom_axis_units_lab="V", z_axis_spec_data_type=UNKNOWN,
                  z_axis_axis_units_lab="V")
    datasets = []
    for (level, inp, resp), curve in table.groupby(["force_level_n", "input_dof", "response_dof"], sort=False):
        f = curve["frequency_hz"].to_numpy()
        h = curve["h_real"].to_numpy() + 1j * curve["h_imag"].to_numpy()
        df = (f[-1] - f[0]) / (len(f) - 1) if len(f) > 1 else 0.0
        even = bool(np.all(np.abs(f[0] + df * np.arange(len(f)) - f) <= _EVEN_RTOL * np.abs(f)))
        rsp_ent, rsp_node, rsp_dir = _node_fields(resp)
        ref_ent, ref_node, ref_dir = _node_fields(inp)
        dataset = pyuff.prepare_58(
            binary=1, func_type=FRF, load_case_id=0,
            id1=_id_line("response_dof", resp, where),
            id2=_id_line("input_dof", inp, where),
            id3=f"force_level_n={float(level)!r}",
            id4=f"abscissa_hz={float(f[0])!r},{float(df)!r}" if even else "NONE",
            id5=f"nlupdate receptance m/{unit}",
            rsp_ent_name=rsp_ent, rsp_node=rsp_node, rsp_dir=rsp_dir,
            ref_ent_name=ref_ent, ref_node=ref_node, ref_dir=ref_dir,
            abscissa_spacing=int(even), z_axis_value=float(level),
            abscissa_spec_data_type=FREQUENCY, abscissa_axis_units_lab="Hz",
            ordinate_spec_data_type=DISPLACEMENT, ordinate_len_unit_exp=1, ordinate_axis_units_lab="m",
            data=h,
            # pyuff computes the increment from x[1] - x[0] even for a single point
            x=f if len(f) > 1 else np.repeat(f, 2),
            **reference,
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


def write_uff_frf(table: pd.DataFrame, path: Path) -> None:
    """Write a validated table as binary UFF 58 datasets, atomically (module docstring)."""
    datasets = _uff_datasets(table, str(path))
    with atomic_file(path) as temporary:
        # 'add' to a fresh file: pyuff's 'overwrite' truncates the file when it switches
        # to binary mode, erasing the first dataset's header
        pyuff.UFF(str(temporary)).write_sets(datasets, mode="add")
        _fix_binary_byte_counts(temporary, datasets)
