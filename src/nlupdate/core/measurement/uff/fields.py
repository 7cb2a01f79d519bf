"""What a dataset 58 measured: its ordinate, reference, abscissa, coordinates and excitation.

An FRF must have a frequency abscissa (specific data type 18, or 0/1 labelled ``Hz``: a time
abscissa, type 17, is refused — time records become FRFs with ``nlupdate frf``) and a complex
ordinate.

* **Numerator** (ordinate): displacement (8), velocity (11) or acceleration (12);
  velocity and acceleration are converted to receptance, ``H = V/(iω)`` or ``A/(iω)²``,
  with a warning, and the 0 Hz line (where that division is infinite) is dropped and
  said so. A type 0/1 ordinate is read by its unit label (``m``, ``mm``, ``m/s``,
  ``mm/s``, ``m/s^2``/``m/s2``/``m/s²``, ``g``); labels ``mm``, ``mm/s`` and ``g`` scale
  the values to SI. Anything else is refused naming the dataset and the field.
* **Reference** (ordinate denominator): force (13 excitation, 9 reaction; label ``N`` or
  ``kN``) or a voltage (type 0/1 with the label ``V`` or ``mV``). A voltage reference is
  read only when the user says so (``--reference-unit V``): the FRFs are then per volt;
  a reference the file does not name (type 0/1 without a label) is read only with a
  stated unit. A stated unit that contradicts the file is refused. A displacement
  denominator (type 8, a transmissibility) is refused.
* **Coordinates**: the ID lines ``response_dof=``/``input_dof=`` when present (taken as
  they are), else the node/direction fields: ``"<node>"`` (direction 0) or
  ``"<node>:<ux|uy|uz|rx|ry|rz>"``. A negative direction in those fields (``-3``:
  measured along −z) is applied: H is multiplied by sign(response dir)·sign(reference
  dir) and the coordinate is named by its positive direction, so a ``1:-uz`` response is
  read as ``1:uz``.
* **Excitation**: named in an ID line (``stepped sine``, ``sweep``, ``chirp``,
  ``random``/``noise``, ``burst``) → column ``excitation``; else ``unknown``.
"""
from __future__ import annotations

import re

import numpy as np

from nlupdate.core.measurement.frf_table import MeasurementTableError
from nlupdate.core.measurement.uff.codes import (
    ACCELERATION, DISPLACEMENT, FORCE, FREQUENCY, GENERAL, REACTION, TIME_AXIS, UNKNOWN, VELOCITY, field_label, id_floats,
    id_keys, id_lines, name_from_node,
)
from nlupdate.core.measurement.units import REFERENCE_UNIT_LABELS, RESPONSE_UNIT_LABELS

_ORDINATE_TYPES = {DISPLACEMENT: 0, VELOCITY: 1, ACCELERATION: 2}
_EXCITATION_WORDS = (
    (re.compile(r"step(?:ped)?[\s_-]*sine", re.I), "stepped_sine"),
    (re.compile(r"chirp", re.I), "chirp"),
    (re.compile(r"burst", re.I), "burst"),
    (re.compile(r"swe(?:ep|pt)", re.I), "sine_sweep"),
    (re.compile(r"random|noise", re.I), "random"),
)


def read_ordinate(dataset: dict, where: str) -> tuple[int, float]:
    """(power of iω that turns the ordinate into receptance, factor to SI)."""
    code = dataset.get("ordinate_spec_data_type", UNKNOWN)
    label = field_label(dataset, "ordinate_axis_units_lab")
    numerator = label
    if "/" in label and label.rsplit("/", 1)[1].lower() in REFERENCE_UNIT_LABELS:  # "m/s/N", "(m/s)/V"
        numerator = label.rsplit("/", 1)[0].strip("()")
    if code in _ORDINATE_TYPES:
        power = _ORDINATE_TYPES[code]
        known = RESPONSE_UNIT_LABELS.get(numerator)
        return power, known[1] if known is not None and known[0] == power else 1.0
    if code in (UNKNOWN, GENERAL):
        known = RESPONSE_UNIT_LABELS.get(numerator)
        if known is not None:
            return known
        raise MeasurementTableError(
            f"{where}: cannot tell what the ordinate is: specific data type {code} with unit label {label!r}; expected "
            f"type 8 (displacement), 11 (velocity) or 12 (acceleration), or a label m, mm, m/s, mm/s, m/s^2 or g")
    raise MeasurementTableError(
        f"{where}: ordinate specific data type {code}; expected 8 (displacement, receptance), 11 (velocity, "
        f"mobility) or 12 (acceleration, accelerance)")


def read_reference(dataset: dict, where: str, stated: str | None) -> tuple[str, float]:
    """(reference unit "N"/"V", factor that turns the file's per-reference values into the unit's)."""
    code = dataset.get("orddenom_spec_data_type", UNKNOWN)
    label = field_label(dataset, "orddenom_axis_units_lab")
    by_label = REFERENCE_UNIT_LABELS.get(label.lower())
    if code in (FORCE, REACTION):
        unit, factor = ("N", by_label[1]) if by_label is not None and by_label[0] == "N" else ("N", 1.0)
    elif code == DISPLACEMENT:
        raise MeasurementTableError(
            f"{where}: ordinate denominator specific data type 8 (displacement): a transmissibility, not an FRF per "
            f"force; expected 13 (excitation force, N) or a voltage reference (type 0 with unit label 'V')")
    elif code in (UNKNOWN, GENERAL) and by_label is not None:
        unit, factor = by_label
    elif code in (UNKNOWN, GENERAL):
        if stated is None:
            raise MeasurementTableError(
                f"{where}: the reference's unit cannot be determined (ordinate denominator specific data type {code}, "
                f"unit label {label!r}); expected type 13 (force, N) or the label 'N' or 'V', or state it with "
                f"--reference-unit N|V (study: [measured] reference_unit)")
        return stated, 1.0
    else:
        raise MeasurementTableError(
            f"{where}: ordinate denominator specific data type {code}; expected 13 (excitation force, N) or a voltage "
            f"reference (type 0 with unit label 'V')")
    if stated is None and unit == "V":
        raise MeasurementTableError(
            f"{where}: the FRF is per volt (ordinate denominator type {code}, unit label {label!r}): a voltage "
            f"reference is read only when stated: --reference-unit V (study: [measured] reference_unit = \"V\")")
    if stated is not None and stated != unit:
        raise MeasurementTableError(
            f"{where}: the file's reference is in {unit} (ordinate denominator type {code}, unit label {label!r}), "
            f"not in {stated} as stated")
    return unit, 1.0 / factor  # H per label unit → per table unit: (m/mV) → m/V is ×1000

def read_excitation(dataset: dict) -> str:
    """The excitation an ID line names (``stepped_sine``, ``sine_sweep``, ``chirp``, ``random``, ``burst``), else ``unknown``."""
    text = " ".join(id_lines(dataset))
    for pattern, name in _EXCITATION_WORDS:
        if pattern.search(text):
            return name
    return "unknown"


def read_abscissa_hz(dataset: dict, where: str) -> np.ndarray:
    """The frequencies (Hz) of a dataset; the ID line ``abscissa_hz=`` refines record 7's 5-digit grid."""
    code = dataset.get("abscissa_spec_data_type", UNKNOWN)
    label = field_label(dataset, "abscissa_axis_units_lab")
    if code == TIME_AXIS or label.lower() == "s":
        raise MeasurementTableError(
            f"{where}: abscissa specific data type {code} (time, label {label!r}): a time record, not an FRF; expected "
            f"18 (frequency, Hz) — time histories become FRFs with 'nlupdate frf'")
    if not (code == FREQUENCY or (code in (UNKNOWN, GENERAL) and label.lower() in ("hz", ""))):
        raise MeasurementTableError(f"{where}: abscissa specific data type {code} (label {label!r}); expected 18 "
                                    f"(frequency, Hz)")
    frequency = np.asarray(dataset["x"], dtype=float)
    keys = id_keys(dataset)
    if "abscissa_hz" in keys and dataset.get("abscissa_spacing") == 1:
        first, increment = id_floats(keys, "abscissa_hz", 2, where)
        exact = first + increment * np.arange(len(dataset["data"]))
        # record 7 holds the same grid to 5 significant digits (E13.5): the ID line only refines it
        if exact.size != frequency.size or not np.allclose(frequency, exact, rtol=0.0,
                                                           atol=1e-4 * max(float(np.max(np.abs(exact))), 1e-300)):
            raise MeasurementTableError(
                f"{where}: the ID line 'abscissa_hz={keys['abscissa_hz'].strip()}' ({exact[0]:g} Hz + {increment:g} Hz "
                f"steps) and record 7 (abscissa minimum {frequency[0]:g} Hz, increment "
                f"{(frequency[1] - frequency[0]) if frequency.size > 1 else 0.0:g} Hz) contradict each other; expected "
                f"the same frequencies (remove the ID line to use record 7's)")
        frequency = exact
    return frequency


def check_count(dataset: dict, where: str) -> None:
    """Refuse a dataset holding fewer values than its header announces."""
    if len(dataset["data"]) != int(dataset.get("num_pts", len(dataset["data"]))):
        raise MeasurementTableError(
            f"{where}: incomplete record: {len(dataset['data'])} of the {dataset['num_pts']} values its header "
            f"announces (is the file truncated?)")


def read_coordinates(dataset: dict) -> tuple[str, str, int]:
    """(response name, input name, sign applied to H)."""
    keys = id_keys(dataset)
    sign = 1
    if "response_dof" in keys:
        response = keys["response_dof"]
    else:
        response = name_from_node(dataset["rsp_node"], dataset["rsp_dir"])
        sign *= -1 if dataset["rsp_dir"] < 0 else 1
    if "input_dof" in keys:
        inp = keys["input_dof"]
    else:
        inp = name_from_node(dataset["ref_node"], dataset["ref_dir"])
        sign *= -1 if dataset["ref_dir"] < 0 else 1
    return response, inp, sign


