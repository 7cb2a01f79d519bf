"""What a held-out validation says before its numbers, as data: :class:`Said` lines (the
verdict, then each warning: an extrapolation, what a comparison's table cannot show, the
response-controlled runs' notes, auto's refusals) and the counts they rest on
(:class:`InBand`: values with a band, inside it, of those in bands that test nothing —
:attr:`~nlupdate.core.validation.compared.Compared.informative` False).

:func:`said` judges a :class:`~nlupdate.core.validation.held_out.Validation` (its held-out
levels and response-controlled runs), :func:`held_type_said` validation.json's
``held_out_type`` entry (:meth:`~nlupdate.core.validation.held_type.HeldType.summary`), the
bad news first in both. The verdict is a warning when a measured value lies outside its 95 %
band, when in-band values lie in uninformative bands, or when what is judged lies outside
what the fit kept (an extrapolation). :func:`worst_by_model` gives the study summary's
largest errors per model. Reporting (:mod:`nlupdate.reporting.validation_text`) renders
these; the archive's manifest keeps every warning's text.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Iterable, Mapping, NamedTuple, Protocol

import numpy as np

from nlupdate.core.validation.compared import QUANTITIES, Compared

#: the held-out levels' quantities, as the lines name them
QUANTITY_NAMES = dict(zip(QUANTITIES, ("resonance", "damping ratio", "peak |H|"), strict=True))
#: the quantities a held-out test type is judged on: a held stepped sine's, and a held sample's frequency
HELD_NAMES = {**QUANTITY_NAMES, "natural_frequency_hz": "natural frequency"}
#: below this many lines in the measured half-power band its damping ratio is said to be poorly resolved
FEW_HALF_POWER_LINES = 5


@dataclass(frozen=True)
class Said:
    """One line a validation says before its numbers: ``kind`` (``verdict``, ``extrapolation``,
    ``note``, ``response_controlled``, ``auto``; for a held-out test type ``held_verdict``,
    ``held_model``), whether it ``warns`` (the manifest keeps those) and its ``text`` (one line,
    without a ``warning:`` prefix)."""

    kind: str
    warns: bool
    text: str


class Comparison(Protocol):
    """What the verdict reads of one comparison, a held-out level's or a predicted run's
    (:class:`~nlupdate.core.validation.held_out.CurveComparison`, which imports this module)."""

    @property
    def compared(self) -> Mapping[str, Compared]: ...

    @property
    def half_power_lines(self) -> int: ...

    @property
    def note(self) -> str: ...


class InBand(NamedTuple):
    """Values with a band, values inside it, and of those the ones whose band is uninformative."""

    banded: int
    inside: int
    idle: int


def in_band(results: Iterable, keys: tuple[str, ...] | None = None) -> InBand:
    """:class:`InBand` over ``results``' (comparisons with a ``compared`` dict) quantities
    ``keys`` (every one compared when None)."""
    compared = [c for r in results for key, c in r.compared.items()
                if (keys is None or key in keys) and c.inside is not None]
    inside = [c for c in compared if c.inside]
    return InBand(len(compared), len(inside), sum(c.informative is False for c in inside))


def counted_clause(counts: InBand, single: bool = False) -> str:
    """How many in-band values lie in uninformative bands, they test nothing ('' when none
    does). ``single``: the held test is one value, judged against the kept sources' spread
    (:mod:`nlupdate.core.validation.held_type`)."""
    if not counts.idle:
        return ""
    spread = ("the kept sources' spread of the quantity (one held value has none of its own) and than its own "
              "resolution" if single else "the test's own spread of the quantity over its curves and than its "
              "resolution (a resonance band: or than the measured lines)")
    return (f"{counts.inside} of {counts.banded} values in band, {counts.idle} of them in bands wider than twice "
            f"{spread}: they test nothing")


def outside(result: Comparison) -> list[str]:
    """The quantities (names) of one comparison whose measured value lies outside the band, or
    that have no predicted value."""
    return [QUANTITY_NAMES[key] for key, c in result.compared.items()
            if c.inside is False or not np.isfinite(c.predicted)]


def comparison_notes(result: Comparison) -> list[str]:
    """What the table cannot show of one comparison: no predicted value, the prediction
    outside its own band, a half-power band of few lines, the model's own note."""
    notes = []
    for key, c in result.compared.items():
        name = QUANTITY_NAMES.get(key, key)
        if not np.isfinite(c.predicted):
            notes.append(f"no predicted {name} (the predicted curve gives none)")
        elif c.predicted_inside is False:
            notes.append(f"the predicted {name} {c.predicted:.6g} lies OUTSIDE its own 95 % band [{c.low:.6g}, "
                         f"{c.high:.6g}]")
    if result.half_power_lines < FEW_HALF_POWER_LINES:
        notes.append(f"the measured half-power band spans {result.half_power_lines} lines: its damping ratio is "
                     f"poorly resolved")
    if result.note:
        notes.append(result.note)
    return notes


def _extrapolated_clause(validation: Judged, unit: str) -> str:
    """The held-out levels and runs outside what the fit kept ('' when none is): an all-in-band
    verdict on them alone read as a confident pass (the transmitter beam's ``--hold-out top``:
    "every held-out level … lies within its prediction's 95 % band", the warning that 0.45 V
    is an extrapolation after it)."""
    names = list(dict.fromkeys([f"{r.level:g} {unit}" for r in validation.held_out if r.extrapolation]
                               + [r.run for r in validation.response_controlled if r.extrapolation]))
    if not names:
        return ""
    return (f"{', '.join(names)} {'lies' if len(names) == 1 else 'lie'} outside what the fit kept, where a band does "
            f"not measure the form's error")


def said(validation: Judged, unit: str) -> list[Said]:
    """The verdict — every held-out level (and predicted run) inside its bands, or each one
    that is not, naming level and model, with how many in-band values test nothing — then each
    held-out level outside the kept levels and each response-controlled run outside the kept
    amplitudes (an extrapolation, once each); what the table cannot show of each comparison
    (:func:`comparison_notes`) and the response-controlled runs' notes (a model that cannot
    predict them, their modal constants against the one the models take), before the numbers
    they qualify; auto's warnings. ``unit``: the levels' reference unit."""
    misses = [f"{r.level:g} {unit} {', '.join(outside(r))} ({r.label})" for r in validation.held_out if outside(r)]
    misses += [f"{r.run} {', '.join(outside(r))} ({r.label})" for r in validation.response_controlled
               if outside(r)]
    what = "held-out level" + (" and response-controlled run" if validation.response_controlled else "")
    idle = counted_clause(in_band([*validation.held_out, *validation.response_controlled]))
    extrapolated = _extrapolated_clause(validation, unit)
    if misses:
        first = Said("verdict", True, f"measured OUTSIDE the prediction's 95 % band: {'; '.join(misses)}"
                     + (f"; {idle}" if idle else ""))
    elif idle or extrapolated:
        first = Said("verdict", True, f"every {what}'s resonance, damping ratio and peak |H| lies within its "
                                      f"prediction's 95 % band, but "
                                      f"{'; '.join(text for text in (idle, extrapolated) if text)}")
    else:
        first = Said("verdict", False, f"every {what}'s resonance, damping ratio and peak |H| lies within its "
                                       f"prediction's 95 % band")
    out = [first]
    out += [Said("extrapolation", True, w) for w in dict.fromkeys(
        r.extrapolation for r in (*validation.held_out, *validation.response_controlled) if r.extrapolation)]
    out += [Said("note", True, f"at {r.level:g} {unit} ({r.label}): {note}") for r in validation.held_out
            for note in comparison_notes(r)]
    out += [Said("note", True, f"at {r.run} ({r.label}): {note}") for r in validation.response_controlled
            for note in comparison_notes(r)]
    out += [Said("response_controlled", True, f"response-controlled runs: {note}")
            for note in validation.response_controlled_notes]
    return out + [Said("auto", True, choice.warning) for choice in validation.choices.values() if choice.warning]


def held_type_in_band(summary: dict) -> InBand:
    """:class:`InBand` of validation.json's ``held_out_type`` entry: over every level's
    quantities, the samples within the fitted amplitudes and the impacts compared at the
    linear limit (those the verdict judges)."""
    entries = [*summary["levels"], *(entry for entry in summary["samples"]
                                     if entry["within_fit"] or "extrapolation" in entry)]
    compared = [c for entry in entries for key, c in entry.items()
                if key in HELD_NAMES and isinstance(c, dict) and "inside" in c]
    inside = [c for c in compared if c["inside"]]
    return InBand(len(compared), len(inside), sum(c.get("informative") is False for c in inside))


def held_type_said(summary: dict, unit: str) -> list[Said]:
    """What a held-out test type says before its table (validation.json's ``held_out_type``
    entry, ``unit`` the levels' reference unit), the bad news first: an impact compared with
    the model's linear limit extrapolated to zero amplitude (said before anything else); each
    held-out level or sample whose measured value lies outside the prediction's 95 % band; the
    in-band values whose band tests nothing (:func:`held_type_in_band`: the rule of the
    held-out levels) — the verdict, then the fitted model's own warnings (its linear limit
    extrapolated or on a bound, a poor fit)."""
    names = HELD_NAMES
    misses = [f"{entry['level']:g} {unit} {names[key]}" for entry in summary["levels"]
              for key in QUANTITIES if entry[key].get("inside") is False]
    sampled = [entry for entry in summary["samples"] if entry["within_fit"]]
    extrapolated = [entry for entry in summary["samples"] if "extrapolation" in entry]
    for key in ("natural_frequency_hz", "damping_ratio"):
        count = sum(entry[key].get("inside") is False for entry in sampled)
        if count:
            misses.append(f"{names[key]} of {count} of the {len(sampled)} held-out samples within the fitted amplitudes")
        misses += [f"{names[key]} of {entry['source']} (its linear limit)" for entry in extrapolated
                   if entry[key].get("inside") is False]
    what = f"{summary['test_type']} held out"
    idle = counted_clause(held_type_in_band(summary), single=len(summary["samples"]) == 1 and not summary["levels"])
    if extrapolated:  # first: every number below it qualifies
        banded = all("inside" in entry[key] for entry in extrapolated for key in ("natural_frequency_hz",
                                                                                   "damping_ratio"))
        verdict = (f"measured OUTSIDE the prediction's 95 % band: {'; '.join(misses)}" if misses
                   else "measured within the prediction's 95 % band" if banded
                   else "without a band (no bootstrap refits: --bootstrap N)")
        first = Said("held_verdict", True, f"{what}: {'; '.join(entry['extrapolation'] for entry in extrapolated)}; "
                                           f"{verdict}" + (f"; {idle}" if idle else ""))
    elif misses:
        first = Said("held_verdict", True, f"{what}: measured OUTSIDE the prediction's 95 % band: {'; '.join(misses)}"
                     + (f"; {idle}" if idle else ""))
    elif not summary["levels"] and not sampled:
        first = Said("held_verdict", True, f"{what}: no held-out sample lies within the fitted amplitudes: each "
                                           f"prediction is an extrapolation, without a band")
    elif idle:
        first = Said("held_verdict", True, f"{what}: every measured value within the fitted amplitudes lies within "
                                           f"the prediction's 95 % band, but {idle}")
    else:
        first = Said("held_verdict", False, f"{what}: every measured value within the fitted amplitudes lies within "
                                            f"the prediction's 95 % band")
    return [first] + [Said("held_model", True, f"the model fitted without {summary['test_type']}: {warning}")
                      for warning in summary["model"].get("warnings", [])]


@dataclass(frozen=True)
class ModelWorst:
    """One requested model's held-out levels at a glance: how many, the largest |error| of the
    resonance (Hz) and the largest |relative error| of the damping ratio and the peak (fractions)
    of the model and of the baseline (NaN where none is finite), and the resonance's in-band counts."""

    requested: str
    levels: int
    model: dict[str, float]
    baseline: dict[str, float]
    resonance: InBand


def _largest(values) -> float:
    return max((v for v in values if np.isfinite(v)), default=float("nan"))


def worst_by_model(validation: Judged) -> list[ModelWorst]:
    """:class:`ModelWorst` per requested model of ``validation``'s held-out levels, in the order requested."""
    out = []
    for requested in dict.fromkeys(r.requested for r in validation.held_out):
        rows = [r for r in validation.held_out if r.requested == requested]
        worst = {}
        for source in ("compared", "baseline"):
            worst[source] = {name: _largest(abs(getattr(r, source)[name].relative_error if name != "resonance_hz"
                                                else getattr(r, source)[name].error) for r in rows)
                             for name in QUANTITIES}
        out.append(ModelWorst(requested, len(rows), worst["compared"], worst["baseline"],
                              in_band(rows, ("resonance_hz",))))
    return out


class Judged:
    """What a :class:`~nlupdate.core.validation.held_out.Validation` says and its largest
    errors, as methods of the result (reporting renders them)."""

    #: what the functions above read of it (the dataclass Validation's fields)
    held_out: tuple[Any, ...]
    response_controlled: tuple[Any, ...]
    response_controlled_notes: tuple[str, ...]
    choices: dict[float, Any]
    reference_unit: str

    def said(self, unit: str | None = None) -> list[Said]:
        """:func:`said`, levels in ``unit`` (the validation's reference unit when None)."""
        return said(self, unit or self.reference_unit)

    def warnings(self) -> list[Said]:
        """Every warning it says (the archive's manifest keeps them)."""
        return [line for line in self.said() if line.warns]

    def worst_by_model(self) -> list[ModelWorst]:
        """:func:`worst_by_model`."""
        return worst_by_model(self)
