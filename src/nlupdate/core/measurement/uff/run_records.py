"""The records of a test-type UFF file, run by run: FRFs, and spectra of the force and the response.

Response-controlled stepped-sine runs and phase-resonance points
(:mod:`nlupdate.core.identification.response_controlled`,
:mod:`nlupdate.core.identification.phase_resonance`) are exported by test systems as datasets 58
of three kinds, grouped into runs by their ID lines
(:func:`nlupdate.core.measurement.run_levels.run_names`, as for force-controlled files):

* an **FRF** (function type 4, complex): made receptance, ``H = (value/(iΩ)^p)·to_SI`` per N,
  p = 0, 1, 2 for a displacement, velocity or acceleration numerator
  (:func:`~nlupdate.core.measurement.uff.fields.read_ordinate`); a voltage reference is refused
  (these tests need the force);
* a **force spectrum** — function type 12 (spectrum: the first-harmonic amplitude per line,
  peak, complex or real) or 2 (auto spectrum: its square, N², real) of a channel whose ordinate
  is typed as force (13, 9) or labelled ``N``/``kN`` (``N^2``, ``N2``, ``N²``, ``N**2`` for an
  auto spectrum): the force amplitude in N;
* a **response spectrum** — function type 12 of a displacement, velocity or acceleration
  ordinate: made displacement, ``X = value·to_SI/(iΩ)^p`` (m). (A response's auto spectrum has
  no phase: it is returned with the other datasets.)

A negative direction (record 6) is applied to the values, as for FRFs. An auto spectrum has no
phase (``has_phase`` False). Other datasets 58 (time records, coherences …) are returned apart,
for the reader to skip or refuse.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.measurement.frf_table import MeasurementTableError
from nlupdate.core.measurement.run_levels import run_names
from nlupdate.core.measurement.uff.codes import (
    ACCELERATION, DISPLACEMENT, FORCE, FRF, FUNCTION_NAMES, REACTION, VELOCITY, check_directions, field_label,
    id_lines, name_from_node,
)
from nlupdate.core.measurement.uff.fields import (
    check_count, read_abscissa_hz, read_coordinates, read_ordinate, read_reference,
)
from nlupdate.core.measurement.uff.reader import uff_datasets
from nlupdate.core.measurement.units import REFERENCE_UNIT_LABELS

SPECTRUM, AUTO_SPECTRUM = 12, 2
_SQUARED = ("**2", "^2", "²", "2")


def uff_content(data: bytes, kind: str) -> bool:
    """Whether bytes sniffed as ``kind`` (:func:`nlupdate.input_files.sniff`) hold a universal
    file: text, or binary datasets 58 (``58b``) after a ``-1`` delimiter."""
    return kind in ("uff", "text") or kind == "binary" and data.lstrip(b"\r\n ").startswith(b"-1")


@dataclass(frozen=True)
class RunRecord:
    """One dataset 58 of a run: ``kind`` ``"frf"`` (``values`` receptance, m/N), ``"force"``
    (N) or ``"response"`` (displacement, m), complex, over ``frequency_hz`` (Hz), the sign of a
    negative direction applied. ``power``/``to_si``: the response's quantity in the file
    (0, 1, 2: displacement, velocity, acceleration) and its unit's factor to SI (for an amplitude
    the user states in that unit); ``response_dof`` the channel's coordinate (a force spectrum's:
    where the force acts), ``input_dof`` an FRF's reference (else ``""``)."""

    index: int
    run: str
    where: str
    kind: str
    frequency_hz: NDArray[np.float64]
    values: NDArray[np.complex128]
    has_phase: bool
    power: int
    to_si: float
    response_dof: str
    input_dof: str
    dataset: dict


def _force_factor(dataset: dict, function: int) -> float | None:
    """The factor from the force spectrum's unit to N (None: not a force)."""
    label = field_label(dataset, "ordinate_axis_units_lab").lower()
    if function == AUTO_SPECTRUM:
        for tail in _SQUARED:
            if label.endswith(tail) and label[:-len(tail)] in REFERENCE_UNIT_LABELS:
                label = label[:-len(tail)]
                break
        else:
            label = label if label in ("", "n") else "?"
    known = REFERENCE_UNIT_LABELS.get(label)
    if known is not None and known[0] == "V":
        return None
    if known is not None:
        return known[1]
    return 1.0 if dataset.get("ordinate_spec_data_type") in (FORCE, REACTION) else None


def _spectrum(index: int, dataset: dict, where: str, run: str) -> RunRecord:
    function = int(dataset["func_type"])
    frequency = read_abscissa_hz(dataset, where)
    force = _force_factor(dataset, function)
    raw = np.asarray(dataset["data"])
    has_phase = function == SPECTRUM and np.iscomplexobj(raw) and dataset.get("ord_data_type") in (5, 6)
    values = np.asarray(raw, dtype=complex)
    if function == AUTO_SPECTRUM:
        if np.any(values.real < 0):
            raise MeasurementTableError(f"{where}: an auto spectrum (function type 2) with a value < 0; expected the "
                                        f"squared amplitude per line (≥ 0)")
        values = np.sqrt(values.real).astype(complex)
    sign = -1.0 if dataset.get("rsp_dir", 0) < 0 else 1.0
    coordinate = name_from_node(dataset.get("rsp_node", 0), dataset.get("rsp_dir", 0))
    if force is not None:
        return RunRecord(index, run, where, "force", frequency, sign * values * force, has_phase, 0, 1.0, coordinate,
                         "", dataset)
    label = field_label(dataset, "ordinate_axis_units_lab")
    if REFERENCE_UNIT_LABELS.get(label.lower().rstrip("^²*2"), ("",))[0] == "V":
        raise MeasurementTableError(f"{where}: a spectrum in volts (label {label!r}); expected the force (ordinate "
                                    f"type 13, label N) — these tests need the force, not the drive voltage")
    if dataset.get("ordinate_spec_data_type") not in (DISPLACEMENT, VELOCITY, ACCELERATION, 0, 1):
        raise MeasurementTableError(
            f"{where}: a spectrum (function type {function}) of ordinate specific data type "
            f"{dataset.get('ordinate_spec_data_type')} (label {label!r}); "
            f"expected a force (13, label N) or a response (8, 11, 12: m, m/s, m/s^2)")
    power, to_si = read_ordinate(dataset, where)
    if np.any(frequency <= 0):
        raise MeasurementTableError(f"{where}: a frequency ≤ 0 Hz; expected the lines of a stepped sine (> 0 Hz)")
    x = sign * values * to_si / (2j * np.pi * frequency) ** power
    return RunRecord(index, run, where, "response", frequency, x, has_phase, power, to_si, coordinate, "", dataset)


def _frf(index: int, dataset: dict, where: str, run: str) -> RunRecord:
    if dataset.get("ord_data_type") not in (5, 6):
        raise MeasurementTableError(f"{where}: ordinate data type {dataset.get('ord_data_type')} is real; an FRF needs "
                                    f"complex data (5 or 6)")
    frequency = read_abscissa_hz(dataset, where)
    power, to_si = read_ordinate(dataset, where)
    unit, per_unit = read_reference(dataset, where, "N")
    if np.any(frequency <= 0):
        raise MeasurementTableError(f"{where}: a frequency ≤ 0 Hz; expected the lines of a stepped sine (> 0 Hz)")
    response, inp, sign = read_coordinates(dataset)
    h = np.asarray(dataset["data"], dtype=complex) * (sign * to_si * per_unit) / (2j * np.pi * frequency) ** power
    return RunRecord(index, run, where, "frf", frequency, h, True, power, to_si, response, inp, dataset)


def run_records(data: bytes, path: str | Path) -> tuple[list[RunRecord], list[tuple[int, str, str]]]:
    """(the FRFs and spectra of a UFF file's bytes, by run: module docstring; the other datasets
    58 as (index, where, what)). Every dataset is named ``"PATH, dataset I (run 'NAME')"``."""
    indices, datasets = uff_datasets(data, path)
    if not datasets:
        raise MeasurementTableError(f"{path}: no dataset 58 (function at nodal DOF) found")
    runs = run_names([id_lines(d) for d in datasets], [(d.get("func_type"), *read_coordinates(d)[:2])
                                                       for d in datasets])
    records, others = [], []
    for index, dataset, run in zip(indices, datasets, runs):
        where = f"{path}, dataset {index}" + (f" (run {run!r})" if run else "")
        check_directions(dataset, where)
        check_count(dataset, where)
        function = dataset.get("func_type")
        if function == FRF:
            records.append(_frf(index, dataset, where, run))
        elif function == SPECTRUM or function == AUTO_SPECTRUM and _force_factor(dataset, function) is not None:
            records.append(_spectrum(index, dataset, where, run))
        else:
            others.append((index, where, f"function type {function} ({FUNCTION_NAMES.get(function, 'other')})"))
    return records, others


def by_run(records: list[RunRecord]) -> dict[str, list[RunRecord]]:
    """The records grouped by run, in the file's order."""
    groups: dict[str, list[RunRecord]] = {}
    for record in records:
        groups.setdefault(record.run, []).append(record)
    return groups
