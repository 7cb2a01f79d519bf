"""Measured FRFs in universal files (UFF dataset 58, ``.uff`` / ``.unv``), read and written with pyuff.

Length: the format notes below and one small function per record field that test
systems fill differently (reference, level, abscissa, coherence); they share the
dataset-walking code.

Writing (nlupdate's own files)
------------------------------
One dataset 58 per curve (level, response, input); function type 4 (FRF), complex
double-precision ordinate, receptance: abscissa specific data type 18 (frequency, Hz),
ordinate 8 (displacement, m), ordinate denominator 13 (excitation force, N) — or, for a
table per volt, denominator 0 with the unit label ``V``. The binary variant ("58b", IEEE
doubles) keeps the data bit-exact; evenly spaced frequencies are stored with even
abscissa spacing, others as (x, Re, Im) triples. The ID lines carry the exact metadata::

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

Reading files from test systems
-------------------------------
Datasets other than 58 are skipped, and so are 58 datasets of spectra and time records
(function types 1, 2, 3, 8, 9 …, with a warning naming them). An FRF (function type 4)
must have a frequency abscissa (specific data type 18, or 0/1 labelled ``Hz``: a time
abscissa, type 17, is refused — time records become FRFs with ``nlupdate frf``) and a
complex ordinate. Transmissibility (function type 5, or a displacement denominator,
type 8) is refused.

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
  stated unit. A stated unit that contradicts the file is refused.
* **Runs**: a file may hold several runs (one per level); a dataset's run name comes
  from its ID lines (:func:`nlupdate.core.measurement.run_levels.run_names`).
* **Level**, in this order: the level the user gave for the run (``--level
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
* **Coordinates**: the ID lines ``response_dof=``/``input_dof=`` when present (taken as
  they are), else the node/direction fields: ``"<node>"`` (direction 0) or
  ``"<node>:<ux|uy|uz|rx|ry|rz>"``. A negative direction in those fields (``-3``:
  measured along −z) is applied: H is multiplied by sign(response dir)·sign(reference
  dir) and the coordinate is named by its positive direction, so a ``1:-uz`` response is
  read as ``1:uz``.
* **Coherence**: datasets of function type 6 (coherence) are attached to the FRF of the
  same response, reference and level as the column ``coherence``.
* **Excitation**: named in an ID line (``stepped sine``, ``sweep``, ``chirp``,
  ``random``/``noise``, ``burst``) → column ``excitation``; else ``unknown``.
* A last dataset without its end delimiter (a truncated file) is refused.
"""
from __future__ import annotations

import re
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pyuff

from nlupdate.files import atomic_file
from nlupdate.core.measurement.frf_table import MeasurementTableError, validate_frf_table
from nlupdate.core.measurement.run_levels import levels_in_text, run_names
from nlupdate.core.measurement.units import (
    REFERENCE_UNIT_LABELS, RESPONSE_QUANTITY, RESPONSE_UNIT_LABELS, ReadOptions, table_reference_unit,
)
from nlupdate.notices import NlupdateWarning

# function types
_TIME, _FRF, _TRANSMISSIBILITY, _COHERENCE = 1, 4, 5, 6
_FUNCTION_NAMES = {0: "general", 1: "time response", 2: "auto spectrum", 3: "cross spectrum", 4: "frequency response",
                   5: "transmissibility", 6: "coherence", 7: "auto correlation", 8: "cross correlation",
                   9: "power spectral density", 10: "energy spectral density", 11: "probability density",
                   12: "spectrum"}
# specific data types
_UNKNOWN, _GENERAL, _DISPLACEMENT, _REACTION, _VELOCITY, _ACCELERATION, _FORCE, _TIME_AXIS, _FREQUENCY = (
    0, 1, 8, 9, 11, 12, 13, 17, 18)
_DIRECTIONS = {"ux": 1, "uy": 2, "uz": 3, "rx": 4, "ry": 5, "rz": 6}
_DIRECTION_NAMES = {code: name for name, code in _DIRECTIONS.items()}
_ID_LINE_WIDTH = 80
_EVEN_RTOL = 1e-13  # relative deviation below which a grid counts as evenly spaced
_ORDINATE_LABELS = RESPONSE_UNIT_LABELS
_ORDINATE_TYPES = {_DISPLACEMENT: 0, _VELOCITY: 1, _ACCELERATION: 2}
_QUANTITY = RESPONSE_QUANTITY
_REFERENCE_LABELS = REFERENCE_UNIT_LABELS
_EXCITATION_WORDS = (
    (re.compile(r"step(?:ped)?[\s_-]*sine", re.I), "stepped_sine"),
    (re.compile(r"chirp", re.I), "chirp"),
    (re.compile(r"burst", re.I), "burst"),
    (re.compile(r"swe(?:ep|pt)", re.I), "sine_sweep"),
    (re.compile(r"random|noise", re.I), "random"),
)


def _label(dataset: dict, field: str) -> str:
    return str(dataset.get(field, "") or "").strip().replace(" ", "")


# --------------------------------------------------------------------------- reading
def _id_lines(dataset: dict) -> list[str]:
    return [str(dataset.get(f"id{n}", "") or "") for n in range(1, 6)]


def _id_keys(dataset: dict) -> dict[str, str]:
    keys = {}
    for line in _id_lines(dataset):
        key, sep, value = line.partition("=")
        if sep:
            keys[key.strip()] = value
    return keys


def _id_floats(keys: dict[str, str], key: str, count: int, where: str) -> list[float]:
    try:
        values = [float(v) for v in keys[key].split(",")]
    except ValueError:
        values = []
    if len(values) != count:
        raise MeasurementTableError(f"{where}: ID line '{key}={keys[key]}' should hold {count} comma-separated number(s)")
    return values


def _name_from_node(node: int, direction: int) -> str:
    """The coordinate name of a node and a direction, without the direction's sign."""
    if direction == 0:
        return str(node)
    if abs(direction) in _DIRECTION_NAMES:
        return f"{node}:{_DIRECTION_NAMES[abs(direction)]}"
    return f"{node}:{abs(direction)}"


def _ordinate(dataset: dict, where: str) -> tuple[int, float]:
    """(power of iω that turns the ordinate into receptance, factor to SI)."""
    code = dataset.get("ordinate_spec_data_type", _UNKNOWN)
    label = _label(dataset, "ordinate_axis_units_lab")
    numerator = label
    if "/" in label and label.rsplit("/", 1)[1].lower() in _REFERENCE_LABELS:  # "m/s/N", "(m/s)/V"
        numerator = label.rsplit("/", 1)[0].strip("()")
    if code in _ORDINATE_TYPES:
        power = _ORDINATE_TYPES[code]
        known = _ORDINATE_LABELS.get(numerator)
        return power, known[1] if known is not None and known[0] == power else 1.0
    if code in (_UNKNOWN, _GENERAL):
        known = _ORDINATE_LABELS.get(numerator)
        if known is not None:
            return known
        raise MeasurementTableError(
            f"{where}: cannot tell what the ordinate is: specific data type {code} with unit label {label!r}; expected "
            f"type 8 (displacement), 11 (velocity) or 12 (acceleration), or a label m, mm, m/s, mm/s, m/s^2 or g")
    raise MeasurementTableError(
        f"{where}: ordinate specific data type {code}; expected 8 (displacement, receptance), 11 (velocity, "
        f"mobility) or 12 (acceleration, accelerance)")


def _reference(dataset: dict, where: str, stated: str | None) -> tuple[str, float]:
    """(reference unit "N"/"V", factor that turns the file's per-reference values into the unit's)."""
    code = dataset.get("orddenom_spec_data_type", _UNKNOWN)
    label = _label(dataset, "orddenom_axis_units_lab")
    by_label = _REFERENCE_LABELS.get(label.lower())
    if code in (_FORCE, _REACTION):
        unit, factor = ("N", by_label[1]) if by_label is not None and by_label[0] == "N" else ("N", 1.0)
    elif code == _DISPLACEMENT:
        raise MeasurementTableError(
            f"{where}: ordinate denominator specific data type 8 (displacement): a transmissibility, not an FRF per "
            f"force; expected 13 (excitation force, N) or a voltage reference (type 0 with unit label 'V')")
    elif code in (_UNKNOWN, _GENERAL) and by_label is not None:
        unit, factor = by_label
    elif code in (_UNKNOWN, _GENERAL):
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


def _level_in_id_lines(dataset: dict, where: str, unit: str) -> tuple[float, str] | None:
    """(value, unit) of the level the ID lines name (run name included), in the styles of
    :mod:`nlupdate.core.measurement.run_levels`; a number without a unit is in ``unit``."""
    found = set()
    for line in _id_lines(dataset):
        if not line.strip().startswith(("response_dof=", "input_dof=", "abscissa_hz=")):
            found |= {(value, named or unit) for value, named in levels_in_text(line)}
    distinct = sorted(found)
    if len(distinct) > 1:
        raise MeasurementTableError(
            f"{where}: the ID lines name several levels {[f'{v:g} {u}' for v, u in distinct]}; give the level with "
            f"--level FILE=VALUE or FILE#RUN=VALUE (study: [measured] levels)")
    return distinct[0] if distinct else None


def _z_axis_level(dataset: dict) -> tuple[float, str, str] | None:
    """(value, unit, how it is typed) of a z-axis value typed as a force (specific data
    type 13/9) or labelled with a reference unit (N, kN, V, mV); None otherwise."""
    z_type = dataset.get("z_axis_spec_data_type")
    label = _label(dataset, "z_axis_axis_units_lab")
    value = float(dataset.get("z_axis_value", 0.0) or 0.0)
    if not value > 0:
        return None
    if label.lower() in _REFERENCE_LABELS:
        unit, factor = _REFERENCE_LABELS[label.lower()]
        return value * factor, unit, f"labelled {label!r} (specific data type {z_type})"
    if z_type in (_FORCE, _REACTION):
        return value, "N", f"typed as force (specific data type {z_type})"
    return None


def _check_id_lines_agree(dataset: dict, where: str, z_axis: tuple[float, str, str]) -> None:
    """Refuse a z-axis level that a level in the ID lines, stated in the same unit,
    contradicts: which one holds is the user's call, not the reader's."""
    value, unit, typed = z_axis
    for line in _id_lines(dataset):
        if line.strip().startswith(("response_dof=", "input_dof=", "abscissa_hz=")):
            continue
        for named, named_unit in levels_in_text(line):
            if named_unit == unit and not np.isclose(named, value, rtol=1e-6):
                raise MeasurementTableError(
                    f"{where}: the z-axis level {value:g} {unit}, {typed}, and the ID line {line.strip()!r} "
                    f"({named:g} {unit}) contradict each other; give the level with --level FILE=VALUE, FILE#RUN=VALUE or RUN=VALUE (study: "
                    f"[measured] levels)")


def _level(dataset: dict, where: str, unit: str, given: float | None, runs: str,
           contradictions: list | None = None) -> float:
    """The level of a dataset (module docstring, **Level**); a z-axis level whose unit
    contradicts the reference ``unit`` is used in ``unit`` and recorded in ``contradictions``."""
    if given is not None:
        return given
    keys = _id_keys(dataset)
    if "force_level_n" in keys:
        return _id_floats(keys, "force_level_n", 1, where)[0]
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
    z_label = _label(dataset, "z_axis_axis_units_lab")
    if dataset.get("z_axis_spec_data_type") in (_FORCE, _REACTION) or z_label.lower() in _REFERENCE_LABELS:
        raise MeasurementTableError(
            f"{where}: the z-axis level (record 7 field 6; specific data type {dataset.get('z_axis_spec_data_type')}, "
            f"label {z_label!r}) is {z_value:g}; expected a level > 0, or give the level with --level FILE=VALUE, "
            f"FILE#RUN=VALUE or RUN=VALUE (study: [measured] levels){runs}")
    raise MeasurementTableError(
        f"{where}: no level: expected an ID line 'force_level_n=<amplitude>', a z-axis value typed as force (specific "
        f"data type 13) or labelled N or V, a level in an ID line or run name ('0.10 V', '0p10V', 'F=2.5N', "
        f"'Chirp0p05'), or the level given with --level FILE=VALUE, FILE#RUN=VALUE or RUN=VALUE (study: [measured] "
        f"levels); found ID lines {_id_lines(dataset)} and z-axis specific data type "
        f"{dataset.get('z_axis_spec_data_type')} (value {float(dataset.get('z_axis_value', 0.0) or 0.0):g}){runs}")


def _excitation(dataset: dict) -> str:
    text = " ".join(_id_lines(dataset))
    for pattern, name in _EXCITATION_WORDS:
        if pattern.search(text):
            return name
    return "unknown"


def _abscissa_hz(dataset: dict, where: str) -> np.ndarray:
    code = dataset.get("abscissa_spec_data_type", _UNKNOWN)
    label = _label(dataset, "abscissa_axis_units_lab")
    if code == _TIME_AXIS or label.lower() == "s":
        raise MeasurementTableError(
            f"{where}: abscissa specific data type {code} (time, label {label!r}): a time record, not an FRF; expected "
            f"18 (frequency, Hz) — time histories become FRFs with 'nlupdate frf'")
    if not (code == _FREQUENCY or (code in (_UNKNOWN, _GENERAL) and label.lower() in ("hz", ""))):
        raise MeasurementTableError(f"{where}: abscissa specific data type {code} (label {label!r}); expected 18 "
                                    f"(frequency, Hz)")
    frequency = np.asarray(dataset["x"], dtype=float)
    keys = _id_keys(dataset)
    if "abscissa_hz" in keys and dataset.get("abscissa_spacing") == 1:
        first, increment = _id_floats(keys, "abscissa_hz", 2, where)
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


def _check_count(dataset: dict, where: str) -> None:
    if len(dataset["data"]) != int(dataset.get("num_pts", len(dataset["data"]))):
        raise MeasurementTableError(
            f"{where}: incomplete record: {len(dataset['data'])} of the {dataset['num_pts']} values its header "
            f"announces (is the file truncated?)")


def _coordinates(dataset: dict) -> tuple[str, str, int]:
    """(response name, input name, sign applied to H)."""
    keys = _id_keys(dataset)
    sign = 1
    if "response_dof" in keys:
        response = keys["response_dof"]
    else:
        response = _name_from_node(dataset["rsp_node"], dataset["rsp_dir"])
        sign *= -1 if dataset["rsp_dir"] < 0 else 1
    if "input_dof" in keys:
        inp = keys["input_dof"]
    else:
        inp = _name_from_node(dataset["ref_node"], dataset["ref_dir"])
        sign *= -1 if dataset["ref_dir"] < 0 else 1
    return response, inp, sign


def check_directions(dataset: dict, where: str) -> None:
    """Refuse a direction code other than 0 (scalar) and ±1…±6 (record 6 fields 7, 10)."""
    for field, what in (("rsp_dir", "response"), ("ref_dir", "reference")):
        code = dataset.get(field, 0)
        if abs(int(code)) > 6:
            raise MeasurementTableError(
                f"{where}: {what} direction code {code} (record 6); expected 0 (scalar) or ±1…±6 (x, y, z, rx, ry, rz)")


def _frf_curve(dataset: dict, where: str, options: ReadOptions, given_level: float | None, runs: str,
               contradictions: list) -> pd.DataFrame:
    check_directions(dataset, where)
    if dataset.get("ord_data_type") not in (5, 6):
        raise MeasurementTableError(f"{where}: ordinate data type {dataset.get('ord_data_type')} is real; an FRF needs "
                                    f"complex data (5 or 6)")
    _check_count(dataset, where)
    frequency = _abscissa_hz(dataset, where)
    power, to_si = _ordinate(dataset, where)
    unit, per_unit = _reference(dataset, where, options.reference_unit)
    level = _level(dataset, where, unit, given_level, runs, contradictions)
    response, inp, sign = _coordinates(dataset)
    h = np.asarray(dataset["data"], dtype=complex) * (sign * to_si * per_unit)
    if power:
        dc = frequency <= 0
        if dc.any():
            frequency, h = frequency[~dc], h[~dc]
            warnings.warn(f"{where}: dropped the 0 Hz line: {_QUANTITY[power]} cannot be converted to receptance "
                          f"at 0 Hz", NlupdateWarning, stacklevel=5)
        h = h / (1j * 2 * np.pi * frequency) ** power
        name = {1: "mobility (velocity/force)", 2: "accelerance (acceleration/force)"}[power]
        warnings.warn(f"{where}: converted {name} to receptance: H = {'A' if power == 2 else 'V'}/(iω)"
                      f"{'²' if power == 2 else ''}", NlupdateWarning, stacklevel=5)
    curve = pd.DataFrame({
        "frequency_hz": frequency, "force_level_n": level, "response_dof": response, "input_dof": inp,
        "h_real": h.real, "h_imag": h.imag,
    })
    excitation = _excitation(dataset)
    if excitation != "unknown":
        curve["excitation"] = excitation
    if unit == "V":
        curve["reference_unit"] = "V"
    return curve


def _coherence_curve(dataset: dict, where: str, options: ReadOptions, given_level: float | None, unit: str):
    """(response, input, level or None, frequencies, coherence) of a coherence dataset."""
    check_directions(dataset, where)
    _check_count(dataset, where)
    frequency = _abscissa_hz(dataset, where)
    values = np.real(np.asarray(dataset["data"]))
    response, inp, _ = _coordinates(dataset)
    try:
        level = _level(dataset, where, unit, given_level, "")
    except MeasurementTableError:
        level = None
    return response, inp, level, frequency, values


def _check_complete(data: bytes, uff: pyuff.UFF, source: str) -> None:
    """Refuse a file whose last dataset has no end delimiter (a truncated file).

    pyuff indexes only complete datasets (between ``-1`` delimiter lines) and would
    silently drop a cut-off last one.
    """
    blocks = getattr(uff, "_block_ind", None)
    end = int(blocks[-1][1]) + 1 if blocks is not None and len(blocks) else 0  # [first, last] byte
    rest = data[end:].replace(b"-1", b"", 1).strip() if end else data.strip()
    if end and rest or not end and data.strip():
        count = len(blocks) if blocks is not None else 0
        raise MeasurementTableError(
            f"{source}: incomplete record: dataset {count} (from byte {end}) has no end delimiter '-1'; the file "
            f"is truncated or not a complete UFF file ({len(data)} bytes)")


def uff_datasets(data: bytes, source: str | Path) -> tuple[list[int], list[dict]]:
    """(indices, contents) of the datasets 58 in the UFF bytes ``data`` (pyuff reads a
    private temporary copy, so what is parsed is exactly what was read)."""
    with tempfile.TemporaryDirectory(prefix="nlupdate-uff-") as folder:
        copy = Path(folder) / "data.uff"
        copy.write_bytes(data)
        try:
            uff = pyuff.UFF(str(copy))
            indices = [i for i, t in enumerate(uff.get_set_types()) if t == 58]
            datasets = [uff.read_sets(i) for i in indices]
        except Exception as error:  # pyuff raises bare Exception on malformed files
            raise MeasurementTableError(f"{source}: not a readable UFF file ({error})") from None
    _check_complete(data, uff, str(source))
    return indices, datasets


def read_uff_frf(data: bytes, path: Path, options: ReadOptions) -> pd.DataFrame:
    """The FRFs (and their coherences) of a UFF file's bytes as a raw table (module docstring)."""
    indices, datasets = uff_datasets(data, path)
    if not datasets:
        raise MeasurementTableError(f"{path}: no dataset 58 (function at nodal DOF) found")
    runs = run_names([_id_lines(d) for d in datasets], [(d.get("func_type"), *_coordinates(d)[:2]) for d in datasets])
    distinct_runs = list(dict.fromkeys(r for r, d in zip(runs, datasets) if d.get("func_type") == _FRF))
    several = len(distinct_runs) > 1
    listing = f"; the file's runs: {', '.join(repr(r) for r in distinct_runs)} — give a run's level with --level " \
              f"{Path(path).name}#RUN=VALUE" if several else ""
    file_level = options.level_of(str(path))
    if file_level is not None and several:
        raise MeasurementTableError(
            f"{path}: holds {len(distinct_runs)} runs ({', '.join(repr(r) for r in distinct_runs)}); a level given for "
            f"the file ({file_level:g}) fits a file of one run: give each run's level with --level "
            f"{Path(path).name}#RUN=VALUE (study: [measured] levels = {{\"{Path(path).name}#RUN\" = VALUE}})")
    curves, seen, coherences, skipped, contradictions = [], {}, [], {}, {}
    for index, dataset, run in zip(indices, datasets, runs):
        where = f"{path}, dataset {index}" + (f" (run {run!r})" if several else "")
        given = options.level_of_run(str(path), run) if run else None
        if given is not None and file_level is not None and given != file_level:
            raise MeasurementTableError(
                f"{path}: levels given for the file ({file_level:g}) and for its run {run!r} ({given:g}) contradict "
                f"each other (--level, study [measured] levels); expected one level")
        given = file_level if given is None else given
        function = dataset.get("func_type")
        if function == _FRF:
            found: list = []
            curve = validate_frf_table(_frf_curve(dataset, where, options, given, listing, found), source=where)
            if found:
                contradictions.setdefault((run, found[0][1]), set()).add(found[0][0])
            key = tuple(curve.loc[0, ["force_level_n", "response_dof", "input_dof"]]) if len(curve) else None
            if key in seen:
                raise MeasurementTableError(
                    f"{path}: datasets {seen[key]} and {index} hold the same curve (level, response_dof, input_dof) = "
                    f"{key}{listing or ''}")
            seen[key] = index
            curves.append(curve)
        elif function == _COHERENCE:
            coherences.append((index, _coherence_curve(dataset, where, options, given, options.reference_unit or "N")))
        elif function == _TRANSMISSIBILITY:
            raise MeasurementTableError(f"{where}: function type 5 (transmissibility); expected 4 (frequency response "
                                        f"function) or 6 (coherence)")
        else:
            skipped.setdefault(function, []).append(index)
    if not curves:
        kinds = ", ".join(f"{len(v)} × type {k} ({_FUNCTION_NAMES.get(k, 'other')})" for k, v in skipped.items())
        hint = " — time records become FRFs with 'nlupdate frf'" if _TIME in skipped else ""
        raise MeasurementTableError(f"{path}: no frequency response function (dataset 58, function type 4); found "
                                    f"{kinds}{hint}")
    if skipped:
        kinds = ", ".join(f"{_FUNCTION_NAMES.get(k, f'type {k}')} (datasets {v})" for k, v in skipped.items())
        warnings.warn(f"{path}: skipped datasets that are no FRF: {kinds}", NlupdateWarning, stacklevel=4)
    for index, (response, inp, level, frequency, values) in coherences:
        _attach_coherence(curves, f"{path}, dataset {index}", response, inp, level, frequency, values)
    if len({table_reference_unit(c) for c in curves}) > 1:
        raise MeasurementTableError(f"{path}: the datasets mix force (N) and voltage (V) references")
    unit = table_reference_unit(curves[0])
    for (run, typed), values in contradictions.items():
        levels = ", ".join(f"{v:g}" for v in sorted(values))
        warnings.warn(f"{path}{f' run {run!r}' if run else ''}: the z-axis level {levels} is {typed}, while the "
                      f"reference is {unit}; used as {levels} {unit} (state another with --level "
                      f"{Path(path).name}{f'#{run}' if run else ''}=VALUE)", NlupdateWarning, stacklevel=4)
    for column, missing in (("coherence", np.nan), ("excitation", "unknown")):
        if any(column in c.columns for c in curves):
            for curve in curves:
                if column not in curve.columns:
                    curve[column] = missing
    table = pd.concat(curves, ignore_index=True)
    if "coherence" in table.columns and table["coherence"].isna().any():
        missing = table.loc[table["coherence"].isna(), ["response_dof", "input_dof", "force_level_n"]].iloc[0]
        warnings.warn(f"{path}: no coherence for response {missing['response_dof']!r}, input {missing['input_dof']!r}, "
                      f"level {missing['force_level_n']:g}: the coherence column is left out", NlupdateWarning,
                      stacklevel=4)
        table = table.drop(columns="coherence")
    table.attrs["runs"] = tuple(r for r in distinct_runs if r)  # the run names, for --level FILE#RUN / RUN
    return table


def _attach_coherence(curves: list[pd.DataFrame], where: str, response: str, inp: str, level: float | None,
                      frequency: np.ndarray, values: np.ndarray) -> None:
    matches = [c for c in curves if c["response_dof"].iloc[0] == response and c["input_dof"].iloc[0] == inp
               and (level is None or np.isclose(c["force_level_n"].iloc[0], level, rtol=1e-9))]
    if len(matches) != 1:
        raise MeasurementTableError(
            f"{where}: coherence of response {response!r}, input {inp!r}"
            f"{'' if level is None else f', level {level:g}'} fits {len(matches)} FRF curves; it must fit exactly one "
            f"(same coordinates and level)")
    curve = matches[0]
    f = curve["frequency_hz"].to_numpy()
    position = np.clip(np.searchsorted(frequency, f), 0, frequency.size - 1)
    hit = np.isclose(frequency[position], f, rtol=1e-9, atol=1e-9)
    before = np.clip(position - 1, 0, frequency.size - 1)
    hit_before = np.isclose(frequency[before], f, rtol=1e-9, atol=1e-9)
    index = np.where(hit, position, before)
    if not np.all(hit | hit_before):
        missing = f[~(hit | hit_before)][0]
        raise MeasurementTableError(f"{where}: the coherence has no value at {missing:g} Hz, where its FRF has one")
    coherence = values[index]
    if np.any(~np.isfinite(coherence)) or np.any(coherence < -1e-9) or np.any(coherence > 1 + 1e-9):
        raise MeasurementTableError(f"{where}: coherence values outside 0…1 (min {np.min(coherence):.3g}, max "
                                    f"{np.max(coherence):.3g})")
    curve["coherence"] = np.clip(coherence, 0.0, 1.0)


# --------------------------------------------------------------------------- writing
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


def _id_line(key: str, value: str, where: str) -> str:
    line = f"{key}={value}"
    if len(line) > _ID_LINE_WIDTH or value != value.strip() or not value.isascii() or not value.isprintable():
        raise MeasurementTableError(
            f"{where}: cannot store {key} {value!r} in a UFF58 ID line: '{key}=<value>' must be at "
            f"most {_ID_LINE_WIDTH} printable ASCII characters without leading/trailing blanks")
    return line


def _uff_datasets(table: pd.DataFrame, where: str) -> list[dict]:
    if table.empty:
        raise MeasurementTableError(f"{where}: an empty table cannot be written as UFF58 (no curve to store)")
    unit = table_reference_unit(table)
    reference = dict(orddenom_spec_data_type=_FORCE, orddenom_force_unit_exp=1, orddenom_axis_units_lab="N",
                     z_axis_spec_data_type=_FORCE, z_axis_force_unit_exp=1, z_axis_axis_units_lab="N") if unit == "N" \
        else dict(orddenom_spec_data_type=_UNKNOWN, orddenom_axis_units_lab="V", z_axis_spec_data_type=_UNKNOWN,
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
            binary=1, func_type=_FRF, load_case_id=0,
            id1=_id_line("response_dof", resp, where),
            id2=_id_line("input_dof", inp, where),
            id3=f"force_level_n={float(level)!r}",
            id4=f"abscissa_hz={float(f[0])!r},{float(df)!r}" if even else "NONE",
            id5=f"nlupdate receptance m/{unit}",
            rsp_ent_name=rsp_ent, rsp_node=rsp_node, rsp_dir=rsp_dir,
            ref_ent_name=ref_ent, ref_node=ref_node, ref_dir=ref_dir,
            abscissa_spacing=int(even), z_axis_value=float(level),
            abscissa_spec_data_type=_FREQUENCY, abscissa_axis_units_lab="Hz",
            ordinate_spec_data_type=_DISPLACEMENT, ordinate_len_unit_exp=1, ordinate_axis_units_lab="m",
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
