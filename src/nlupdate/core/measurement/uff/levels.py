"""The level (force amplitude or drive voltage) of a dataset 58.

**Level**, in this order: the level the user gave for the run (``--level
FILE#RUN=VALUE`` or ``RUN=VALUE``) or for a file of one run (``FILE=VALUE``; refused
for a file of several runs); the ID line ``force_level_n=<value>`` (nlupdate's own
files); the z-axis value typed as force (13/9) or labelled ``N``/``kN``/``V``/``mV``,
when that is the reference's unit; a level in an ID line or the run name in the
styles of :mod:`nlupdate.core.measurement.run_levels` (``"0.10 V"``, ``"0p10V"``,
``"F=2.5N"``, ``"Chirp0p05"``; two different ones are refused as ambiguous; a unit
in the ID line must agree with the reference); last, a z-axis value typed in the
unit the reference contradicts: used in the reference's unit with a warning (never
skipped silently). Without any: one line naming the dataset, its run, what was
looked for and the file's runs.
"""
from __future__ import annotations

from typing import Callable, TypeVar

import numpy as np

from nlupdate.core.measurement.frf_table import MeasurementTableError
from nlupdate.core.measurement.run_levels import held_amplitudes_in_text, levels_in_text
from nlupdate.core.measurement.uff.codes import FORCE, REACTION, field_label, id_floats, id_keys, id_lines
from nlupdate.core.measurement.units import REFERENCE_UNIT_LABELS

T = TypeVar("T")
_SI = {0: "m", 1: "m/s", 2: "m/s²"}


def named_in_id_lines(dataset: dict, find: Callable[[str], set[T]] = levels_in_text) -> set[T]:
    """What ``find`` (a finder of :mod:`nlupdate.core.measurement.run_levels`) reads in the ID
    lines (run name included) other than nlupdate's coordinate and abscissa keys."""
    found: set[T] = set()
    for line in id_lines(dataset):
        if not line.strip().startswith(("response_dof=", "input_dof=", "abscissa_hz=")):
            found |= find(line)
    return found


def _level_in_id_lines(dataset: dict, where: str, unit: str) -> tuple[float, str] | None:
    """(value, unit) of the level the ID lines name (run name included), in the styles of
    :mod:`nlupdate.core.measurement.run_levels`; a number without a unit is in ``unit``."""
    distinct = sorted({(value, named or unit) for value, named in named_in_id_lines(dataset)})
    if len(distinct) > 1:
        raise MeasurementTableError(
            f"{where}: the ID lines name several levels {[f'{v:g} {u}' for v, u in distinct]}; give the level with "
            f"--level FILE=VALUE or FILE#RUN=VALUE (study: [measured] levels)")
    return distinct[0] if distinct else None


def _z_axis_level(dataset: dict) -> tuple[float, str, str] | None:
    """(value, unit, how it is typed) of a z-axis value typed as a force (specific data
    type 13/9) or labelled with a reference unit (N, kN, V, mV); None otherwise."""
    z_type = dataset.get("z_axis_spec_data_type")
    label = field_label(dataset, "z_axis_axis_units_lab")
    value = float(dataset.get("z_axis_value", 0.0) or 0.0)
    if not value > 0:
        return None
    if label.lower() in REFERENCE_UNIT_LABELS:
        unit, factor = REFERENCE_UNIT_LABELS[label.lower()]
        return value * factor, unit, f"labelled {label!r} (specific data type {z_type})"
    if z_type in (FORCE, REACTION):
        return value, "N", f"typed as force (specific data type {z_type})"
    return None


def _check_id_lines_agree(dataset: dict, where: str, z_axis: tuple[float, str, str]) -> None:
    """Refuse a z-axis level that a level in the ID lines, stated in the same unit,
    contradicts: which one holds is the user's call, not the reader's."""
    value, unit, typed = z_axis
    for line in id_lines(dataset):
        if line.strip().startswith(("response_dof=", "input_dof=", "abscissa_hz=")):
            continue
        for named, named_unit in levels_in_text(line):
            if named_unit == unit and not np.isclose(named, value, rtol=1e-6):
                raise MeasurementTableError(
                    f"{where}: the z-axis level {value:g} {unit}, {typed}, and the ID line {line.strip()!r} "
                    f"({named:g} {unit}) contradict each other; give the level with --level FILE=VALUE, FILE#RUN=VALUE or RUN=VALUE (study: "
                    f"[measured] levels)")


def dataset_level(dataset: dict, where: str, unit: str, given: float | None, runs: str,
           contradictions: list | None = None) -> float:
    """The level of a dataset (module docstring); a z-axis level whose unit
    contradicts the reference ``unit`` is used in ``unit`` and recorded in ``contradictions``."""
    if given is not None:
        return given
    keys = id_keys(dataset)
    if "force_level_n" in keys:
        return id_floats(keys, "force_level_n", 1, where)[0]
    z_axis = _z_axis_level(dataset)
    if z_axis is not None and z_axis[1] == unit:
        _check_id_lines_agree(dataset, where, z_axis)
        return z_axis[0]
    in_id = _level_in_id_lines(dataset, where, unit)
    if in_id is not None:
        value, id_unit = in_id
        if id_unit != unit:
            raise MeasurementTableError(f"{where}: the ID lines give the level {value:g} {id_unit}, but the reference "
                                        f"is in {unit}; give the level with --level FILE=VALUE or FILE#RUN=VALUE")
        return value
    if z_axis is not None:  # typed in the other unit: used as the reference unit, and said so
        if contradictions is not None:
            contradictions.append((z_axis[0], z_axis[2]))
        return z_axis[0]
    z_value = float(dataset.get("z_axis_value", 0.0) or 0.0)
    z_label = field_label(dataset, "z_axis_axis_units_lab")
    if dataset.get("z_axis_spec_data_type") in (FORCE, REACTION) or z_label.lower() in REFERENCE_UNIT_LABELS:
        raise MeasurementTableError(
            f"{where}: the z-axis level (record 7 field 6; specific data type {dataset.get('z_axis_spec_data_type')}, "
            f"label {z_label!r}) is {z_value:g}; expected a level > 0, or give the level with --level FILE=VALUE, "
            f"FILE#RUN=VALUE or RUN=VALUE (study: [measured] levels){runs}")
    raise MeasurementTableError(
        f"{where}: no level: expected an ID line 'force_level_n=<amplitude>', a z-axis value typed as force (specific "
        f"data type 13) or labelled N or V, a level in an ID line or run name ('0.10 V', '0p10V', 'F=2.5N', "
        f"'Chirp0p05'), or the level given with --level FILE=VALUE, FILE#RUN=VALUE or RUN=VALUE (study: [measured] "
        f"levels); found ID lines {id_lines(dataset)} and z-axis specific data type "
        f"{dataset.get('z_axis_spec_data_type')} (value {float(dataset.get('z_axis_value', 0.0) or 0.0):g}){runs}"
        f"{_held_hint(dataset)}")


def _held_hint(dataset: dict) -> str:
    """A note that the ID lines name a held response amplitude: a response-controlled run."""
    held = sorted(named_in_id_lines(dataset, held_amplitudes_in_text))
    return (f"; the ID lines name a held response amplitude ({', '.join(f'{v:g} {_SI[p]}' for v, p in held)}): a "
            f"response-controlled run, read with 'nlupdate amplitude --response-controlled FILE'") if held else ""


