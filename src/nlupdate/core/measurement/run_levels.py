"""Runs and levels in the text test systems write: run names and ID lines of UFF 58 exports.

A test system's export holds several runs (one per excitation level) in one file and
often names the level only in the run name. Two things are read from that text:

**Levels** (:func:`levels_in_text`). A number is a level in these styles, and only
these (each has a test in tests/test_measured_run_levels.py):

==========================  ===============  =====================================
style                       example          read as
==========================  ===============  =====================================
number and unit             ``0.10 V``       0.1 V  (units ``V``, ``mV``, ``N``, ``kN``)
``p`` as decimal point      ``0p10V``        0.1 V
key, ``=`` and unit         ``F=2.5N``       2.5 N  (any key: ``Level=0.2V``)
unit directly after         ``2.5N``, ``10mV``  2.5 N, 0.01 V
number after an             ``Chirp0p05``    0.05 in the reference unit
excitation word             ``Sine_0.2V``    0.2 V
==========================  ===============  =====================================

A number with a unit must not be glued to a letter or digit before it (``X2N`` is not a
level; ``Run_0p10V`` is: ``_`` separates) nor followed by a letter (``2.5Nm`` is not).
The excitation words are ``chirp``, ``sweep``/``swept``, ``sine``, ``random``,
``noise``, ``burst``, ``level``, ``amp``/``amplitude``, ``force`` and ``exc``/
``excitation`` (any case), followed directly or after one ``_``, ``=`` or ``:`` by the
number; without a unit the number must have a decimal point (``.`` or ``p``) — an
integer there (``Chirp2``, ``Sweep1``) is a run number, not a level — and is in the
reference unit. A number followed by another letter or digit run (``70to110Hz``,
``0-512Hz``) is a frequency range, never a level.

**Held response amplitudes** (:func:`held_amplitudes_in_text`): the target of a
response-controlled run, read by the same rules with response units instead of N and V —
``m``, ``mm``, ``um``/``µm``, ``m/s``, ``mm/s``, ``m/s^2`` (also ``m/s2``, ``m/s²``,
``m/s**2`` and, where a ``/`` cannot be typed, ``ms2``/``ms-2``), ``mm/s^2``, ``g`` — and the
words ``rc``, ``response``/``resp``, ``responsecontrol``, ``control``/``controlled``,
``target``, ``held``/``hold`` before a number glued to its unit: ``ResponseControl 20 m/s2``
(20 m/s²), ``Rc5ms2`` (5 m/s²), ``a=0.5 g`` (0.5 g), ``Target_0p1mm`` (0.1 mm). A unit is
required (a number alone is never a held amplitude).

**Run names** (:func:`run_names`), for a file of several datasets: an ID line
``run=<name>`` names the run; otherwise the run name is the ID line (the first of lines
1, 2, 4, 5 — line 3 holds the date by the UFF convention) whose text differs between
datasets of the same function and coordinates: that is the line that tells the runs
apart. In a file of one run, the run name is the first of ID lines 2, 4, 5, 1 that is
the same in every dataset and not blank or ``NONE``. nlupdate's own key lines
(``response_dof=``, ``input_dof=``, ``force_level_n=``, ``abscissa_hz=``, ``nlupdate …``)
are never a run name.
"""
from __future__ import annotations

import re
from typing import Sequence

from nlupdate.core.measurement.units import RESPONSE_UNIT_LABELS

# unit label → (reference unit, factor to it)
_UNITS = {"V": ("V", 1.0), "mV": ("V", 1e-3), "N": ("N", 1.0), "kN": ("N", 1e3)}
# response unit label → (power of iω that makes it a displacement, factor to SI)
_RESPONSE_UNITS = {**RESPONSE_UNIT_LABELS, "ms2": RESPONSE_UNIT_LABELS["m/s^2"], "ms-2": RESPONSE_UNIT_LABELS["m/s^2"]}
_NUMBER = r"(\d+(?:[.p]\d+)?|\.\d+)(?:[eE]([-+]?\d+))?"
_EXCITATION_WORD = r"(?i:chirp|sweep|swept|sine|random|noise|burst|level|amplitude|amp|force|excitation|exc)"
_HELD_WORD = r"(?i:responsecontrol|response|resp|controlled|control|target|held|hold|rc)"


def _unit_pattern(labels: Sequence[str]) -> str:
    """A regex alternation of unit labels, longest first (``m/s2`` before ``m``)."""
    return "|".join(re.escape(label) for label in sorted(labels, key=len, reverse=True))


_LEVEL_UNIT = _unit_pattern(list(_UNITS))
_WITH_UNIT = re.compile(rf"(?<![A-Za-z0-9.]){_NUMBER}\s*({_LEVEL_UNIT})(?![A-Za-z])")
_AFTER_WORD = re.compile(rf"{_EXCITATION_WORD}[_=:]?{_NUMBER}({_LEVEL_UNIT})?(?![A-Za-z0-9.])")
_HELD_UNIT = _unit_pattern(list(_RESPONSE_UNITS))
_HELD_WITH_UNIT = re.compile(rf"(?<![A-Za-z0-9.]){_NUMBER}\s*({_HELD_UNIT})(?![A-Za-z0-9^²*/])")
_HELD_AFTER_WORD = re.compile(rf"{_HELD_WORD}[_=:]?{_NUMBER}({_HELD_UNIT})(?![A-Za-z0-9^²*/.])")
_OWN_KEYS = ("response_dof=", "input_dof=", "force_level_n=", "abscissa_hz=", "run=", "nlupdate ")
_RUN_POSITIONS = (0, 1, 3, 4)  # ID lines 1, 2, 4, 5 (line 3: date)
_SINGLE_RUN_POSITIONS = (1, 3, 4, 0)


def _number(mantissa: str, exponent: str | None) -> float:
    return float(mantissa.replace("p", ".")) * 10.0 ** int(exponent or 0)


def levels_in_text(text: str) -> set[tuple[float, str | None]]:
    """The levels a text names, as (value, unit ``"N"``/``"V"``, or None: in the reference
    unit), in the styles of the module docstring; an empty set when it names none."""
    found: set[tuple[float, str | None]] = set()
    for match in _WITH_UNIT.finditer(text):
        mantissa, exponent, label = match.groups()
        unit, factor = _UNITS[label]
        found.add((_number(mantissa, exponent) * factor, unit))
    for match in _AFTER_WORD.finditer(text):
        mantissa, exponent, label = match.groups()
        if label is not None:
            unit, factor = _UNITS[label]
            found.add((_number(mantissa, exponent) * factor, unit))
        elif "." in mantissa or "p" in mantissa:
            found.add((_number(mantissa, exponent), None))
    return found


def held_amplitudes_in_text(text: str) -> set[tuple[float, int]]:
    """The held response amplitudes a text names, as (value in SI: m, m/s or m/s², power of
    iω that makes it a displacement: 0, 1, 2), in the styles of the module docstring; an
    empty set when it names none."""
    found: set[tuple[float, int]] = set()
    for pattern in (_HELD_WITH_UNIT, _HELD_AFTER_WORD):
        for match in pattern.finditer(text):
            mantissa, exponent, label = match.groups()
            power, factor = _RESPONSE_UNITS[label]
            found.add((_number(mantissa, exponent) * factor, power))
    return found


def _is_own(line: str) -> bool:
    return line.strip().startswith(_OWN_KEYS)


def _blank(line: str) -> bool:
    return not line.strip() or line.strip().upper() == "NONE"


def run_names(id_lines: Sequence[Sequence[str]], keys: Sequence[object]) -> list[str]:
    """The run name of each dataset (module docstring): ``id_lines[i]`` are the five ID
    lines of dataset i and ``keys[i]`` its function and coordinates; ``""`` when nothing
    names the run."""
    names = []
    for lines in id_lines:
        explicit = [line.strip()[4:].strip() for line in lines if line.strip().startswith("run=")]
        names.append(explicit[0] if explicit else None)
    if all(name is not None for name in names):
        return names
    for position in _RUN_POSITIONS:
        texts = [lines[position].strip() for lines in id_lines]
        if any(_is_own(text) for text in texts):
            continue
        seen: dict[object, str] = {}
        if any(seen.setdefault(key, text) != text for key, text in zip(keys, texts)):
            return [name if name is not None else text for name, text in zip(names, texts)]
    for position in _SINGLE_RUN_POSITIONS:
        texts = {lines[position].strip() for lines in id_lines}
        if len(texts) == 1 and not any(_blank(t) or _is_own(t) for t in texts):
            text = texts.pop()
            return [name if name is not None else text for name in names]
    return [name if name is not None else "" for name in names]
