"""What the reference of a measured FRF is: a force in newtons, or a voltage.

A test without a force transducer takes the shaker amplifier's voltage as its reference:
its FRFs are *per volt* (m/V), its "force levels" are volts and every parameter
identified from them carries volts where newtons would stand (a stiffness in V/m, a slip
force in V). nlupdate reads such data only when the user says so
(``--reference-unit V``, study ``[measured] reference_unit = "V"``); then every table,
JSON file, report line and plot label states the per-volt unit. A calibration
``N_PER_V`` (``--reference-calibration``, ``[measured] reference_calibration``) turns
per-volt data into per-newton data on reading: ``F = c·V``, ``H_N = H_V / c``
(m/N = (m/V)/(N/V)).

The measured-FRF table carries the reference as the column ``reference_unit`` (``"N"``
or ``"V"``, one value for the whole table); a table without it is in newtons.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from collections.abc import Iterable
from pathlib import Path
from typing import Mapping

import pandas as pd

from nlupdate.core.model.elements import ELEMENT_TYPES

REFERENCE_UNITS: tuple[str, ...] = ("N", "V")
REFERENCE_QUANTITY = {"N": "force", "V": "voltage"}
# unit labels of a reference (lower case) → (unit, factor from the label's unit to the table's)
REFERENCE_UNIT_LABELS = {"n": ("N", 1.0), "kn": ("N", 1e3), "v": ("V", 1.0), "mv": ("V", 1e-3)}
# unit labels of a response → (power of iω that turns it into a displacement, factor to SI)
_G = 9.80665
RESPONSE_UNIT_LABELS = {
    "m": (0, 1.0), "mm": (0, 1e-3), "um": (0, 1e-6), "µm": (0, 1e-6),
    "m/s": (1, 1.0), "mm/s": (1, 1e-3),
    "m/s^2": (2, 1.0), "m/s2": (2, 1.0), "m/s²": (2, 1.0), "m/s**2": (2, 1.0), "g": (2, _G), "mm/s^2": (2, 1e-3),
    "mm/s2": (2, 1e-3), "mm/s²": (2, 1e-3),
}
RESPONSE_QUANTITY = {0: "displacement", 1: "velocity", 2: "acceleration"}


class ReferenceUnitError(ValueError):
    """The reference of a measured FRF is not what the user said, or cannot be determined."""


@dataclass(frozen=True)
class ReadOptions:
    """What the user states about measured data files.

    reference_unit: ``"N"`` or ``"V"`` — the unit of the FRF's reference (denominator)
        and of its levels; None: as the file says (a file that says nothing is in N,
        except a UFF dataset, whose denominator must say it).
    reference_calibration: newtons per volt; converts per-volt data to per-newton on reading.
    levels: the level (in the reference unit) of a file, keyed by the file name as given,
        its resolved path or its base name; of one run of a file, keyed ``FILE#RUN``; or of
        a run wherever it is, keyed by the run name (RUN as the reader names runs,
        :mod:`nlupdate.core.measurement.run_levels`). It takes precedence over what the file holds.
    coordinates: the (response, input) coordinate names of each file that does not name
        them (keyed like ``levels``); a name ``NODE:-DIR`` states a sensor or force along
        the negative direction: the FRF is negated and the coordinate named ``NODE:DIR``.
    runs_read_apart: the files (keyed like ``levels``) whose response-controlled runs the
        command reads as such (``nlupdate validate``, ``amplitude --response-controlled``):
        the FRF reader leaves those runs out of its table without warning that they are lost.
    """

    reference_unit: str | None = None
    reference_calibration: float | None = None
    levels: Mapping[str, float] = field(default_factory=dict)
    coordinates: Mapping[str, tuple[str, str]] = field(default_factory=dict)
    runs_read_apart: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if self.reference_unit is not None:
            object.__setattr__(self, "reference_unit", checked_reference_unit(self.reference_unit, "reference unit"))
        if self.reference_calibration is not None:
            value = float(self.reference_calibration)
            if not (math.isfinite(value) and value > 0):
                raise ReferenceUnitError(f"reference calibration {self.reference_calibration!r}: expected newtons per "
                                         f"volt, a number > 0")
            object.__setattr__(self, "reference_calibration", value)
        for name, level in self.levels.items():
            if not (isinstance(level, (int, float)) and math.isfinite(level) and level > 0):
                raise ReferenceUnitError(f"level of {name}: {level!r}; expected a number > 0 (in the reference unit)")
        for name, pair in self.coordinates.items():
            if not (isinstance(pair, tuple) and len(pair) == 2 and all(isinstance(c, str) and c.strip() for c in pair)):
                raise ReferenceUnitError(f"coordinates of {name}: {pair!r}; expected two names (response, input)")

    def level_of(self, path: str) -> float | None:
        """The level the user gave for the file ``path`` (None when none); an error when
        two keys name the file (``a.csv`` and ``./a.csv``) with different levels."""
        return _one_level({key: value for key, value in self.levels.items() if _statement_for({key: True}, path)},
                          f"the file {path}")

    def level_of_run(self, path: str, run: str) -> float | None:
        """The level the user gave for the run ``run`` of the file ``path``, keyed
        ``FILE#RUN`` or by the run name alone (None when neither); an error when two keys
        name the run with different levels."""
        named = {key: value for key, value in self.levels.items() if _names_run(key, path, run)}
        return _one_level(named, f"the run {run!r} of {path}")

    def unmatched_levels(self, runs: Mapping[str, tuple[str, ...]]) -> list[str]:
        """The keys of ``levels`` that name none of the files ``runs`` holds (file → its
        run names) nor any of their runs."""
        return [key for key in self.levels
                if not any(_statement_for({key: True}, path) or any(_names_run(key, path, r) for r in names)
                           for path, names in runs.items())]

    def coordinates_of(self, path: str) -> tuple[str, str] | None:
        """The (response, input) names the user gave for the file ``path`` (None when none)."""
        return _statement_for(self.coordinates, path)

    def reads_runs_apart(self, path: str) -> bool:
        """Whether the response-controlled runs of the file ``path`` are read as such
        (``runs_read_apart``)."""
        return bool(_statement_for({key: True for key in self.runs_read_apart}, path))


def validate_reads_runs_apart(paths: Iterable[str | Path], response_controlled: str) -> tuple[str, ...]:
    """The files among ``paths`` whose response-controlled runs ``validate`` (or a study's
    ``[validation]``) reads as such — the MATLAB ones, unless ``response_controlled`` is off —
    for :attr:`ReadOptions.runs_read_apart`."""
    if str(response_controlled).lower() in ("off", "false"):
        return ()
    return tuple(str(path) for path in paths if str(path).lower().endswith(".mat"))


def _one_level(matches: Mapping[str, float], what: str) -> float | None:
    """The one level ``matches`` (key → level) give for ``what``; None when none."""
    if len({float(v) for v in matches.values()}) > 1:
        given = ", ".join(f"{key}={value:g}" for key, value in matches.items())
        raise ReferenceUnitError(f"levels given for {what} contradict each other ({given}; --level, study [measured] "
                                 f"levels); expected one level per file or run")
    return float(next(iter(matches.values()))) if matches else None


def _statement_for(statements: Mapping[str, object], path: str) -> object | None:
    """The statement about the file ``path``, keyed by its name as given, its resolved path
    or (for a key without folder) its base name."""
    from pathlib import Path

    candidates = {str(path), Path(path).name}
    try:
        candidates.add(str(Path(path).resolve()))
    except OSError:
        pass
    for key, value in statements.items():
        if key in candidates or Path(key).name == Path(path).name and Path(key).parent == Path("."):
            return value
        try:
            if str(Path(key).resolve()) in candidates:
                return value
        except OSError:
            continue
    return None


def _names_run(key: str, path: str, run: str) -> bool:
    """Whether the level key ``key`` names the run ``run`` of the file ``path``: ``FILE#RUN``
    (any ``#`` may split the file from the run) or the run name alone."""
    if not run:
        return False
    if key == run:
        return True
    position = key.find("#")
    while position > 0:
        if key[position + 1:] == run and _statement_for({key[:position]: True}, path):
            return True
        position = key.find("#", position + 1)
    return False


def checked_reference_unit(value: object, where: str) -> str:
    """``"N"`` or ``"V"`` (case as written: ``n``/``v`` accepted); else an error naming ``where``."""
    text = str(value).strip()
    for unit in REFERENCE_UNITS:
        if text.upper() == unit:
            return unit
    raise ReferenceUnitError(f"{where}: {value!r}; expected 'N' (force reference) or 'V' (voltage reference: FRFs "
                             f"and levels per volt)")


def table_reference_unit(table: pd.DataFrame) -> str:
    """The reference unit of a (validated) measured-FRF table: its ``reference_unit`` column, else ``"N"``."""
    if "reference_unit" not in table.columns or table.empty:
        return "N"
    return str(table["reference_unit"].iloc[0])


def calibrated(table: pd.DataFrame, newtons_per_volt: float, source: str) -> pd.DataFrame:
    """A per-volt table converted to newtons: levels × c, H ÷ c (and h_std ÷ c)."""
    if table_reference_unit(table) != "V":
        raise ReferenceUnitError(f"{source}: a reference calibration (N per V) applies to FRFs per volt; this table's "
                                 f"reference is in N")
    out = table.copy()
    out["force_level_n"] = out["force_level_n"] * newtons_per_volt
    for column in ("h_real", "h_imag", "h_std"):
        if column in out.columns:
            out[column] = out[column] / newtons_per_volt
    if "level_achieved" in out.columns:
        out["level_achieved"] = out["level_achieved"] * newtons_per_volt
    out["reference_unit"] = "N"
    return out


# ------------------------------------------------------------------------------ unit strings
def _printed(unit: str) -> str:
    """An element parameter's unit as reports print it: ``"N s^2/m^2"`` → ``"N·s²/m²"``; "1" → ""."""
    return "" if unit == "1" else unit.replace(" ", "·").replace("^2", "²").replace("^3", "³")


#: Units of identified parameters: every element parameter as its class declares it, and Δ_f1's.
_PARAMETER_UNITS = {
    **{p.name: _printed(p.unit) for kind in ELEMENT_TYPES.values() for p in kind.parameters if p.fitted},
    "delta_f1_imag": "N/m",
}
_COEFFICIENT = re.compile(r"^(re|im)_c(\d+)$")
#: the suffix a physical model's reported name carries: a copy's number, its element type, or both
_ELEMENT_SUFFIX = re.compile(rf"_(?:{'|'.join(sorted(map(re.escape, ELEMENT_TYPES), key=len, reverse=True))})?\d*$")
_SUPERSCRIPT = str.maketrans("0123456789", "⁰¹²³⁴⁵⁶⁷⁸⁹")


def per_reference(unit: str, reference_unit: str) -> str:
    """An SI unit string with the force unit N replaced by the reference unit (V for a
    voltage reference): ``"N/m"`` → ``"V/m"``; ``"m/N"`` → ``"m/V"``."""
    if reference_unit == "N":
        return unit
    return re.sub(r"(?<![A-Za-z])N(?![A-Za-z])", reference_unit, unit)


def parameter_unit(name: str, reference_unit: str = "N") -> str:
    """Unit of an identified parameter (``k3``, ``kf``, ``slip_force``, ``re_c2`` …,
    a numbered copy ``kf_2``, a name that carries its element type because another type
    of the model has it too, ``slip_force_coulomb``, ``kf_jenkins1``:
    :meth:`~nlupdate.core.identification.dfmodels.PhysicalModel.names`), with volts for
    newtons when the reference is V; ``""`` for a dimensionless or unknown name."""
    base = _ELEMENT_SUFFIX.sub("", name)
    match = _COEFFICIENT.match(name)
    if match:  # the DF ν(A) in N/m: the coefficient of A^k is in N/m^(k+1)
        power = int(match.group(2)) + 1
        unit = "N/m" if power == 1 else f"N/m{str(power).translate(_SUPERSCRIPT)}"
    elif name.startswith("linear_f") and name.endswith("_hz"):
        return "Hz"
    else:
        unit = _PARAMETER_UNITS.get(name, _PARAMETER_UNITS.get(base, ""))
    return per_reference(unit, reference_unit) if unit else ""


def units_block(reference_unit: str, calibration: float | None = None) -> dict[str, object]:
    """The ``units`` entry of a JSON output: what the levels, receptances and describing
    functions are measured in."""
    block: dict[str, object] = {
        "reference": REFERENCE_QUANTITY[reference_unit],
        "force_level": reference_unit,
        "receptance": per_reference("m/N", reference_unit),
        "describing_function": per_reference("N/m", reference_unit),
    }
    if reference_unit == "V":
        block["note"] = ("the reference is the excitation voltage: levels in V, FRFs in m/V and every force-like "
                         "parameter per volt (V where N would stand); give a calibration in N/V to convert")
    if calibration is not None:
        block["calibration_n_per_v"] = calibration
    return block
