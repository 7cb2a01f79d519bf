"""Which settings classes declare which study table, and reading a table by its declaration.

A study table whose keys are plain settings is declared once, on the class it becomes
(:mod:`nlupdate.settings`); :data:`TABLES` names those classes. From it

* the reader's allowed keys (:data:`nlupdate.study.sections.ALLOWED`),
* each key's check (:func:`read_declared`: one line naming the file, the table, the key, the
  expected form and what was found), and
* docs/study-files.md's table of keys (:mod:`nlupdate.study.keys_docs`)

follow. Rules across keys (which keys go together, a length another table sets, a file that
must exist) stay with the table's reader.
"""
from __future__ import annotations

import dataclasses
from typing import Any, Mapping

from nlupdate.core.identification.settings import IdentificationSettings
from nlupdate.core.updating.eigensensitivity import EigensensitivityOptions
from nlupdate.core.updating.optimisation import OptimisationOptions
from nlupdate.core.updating.residuals import ResponseOptions
from nlupdate.settings import Setting, SettingError, parse_mapping, settings_of
from nlupdate.study.amplitude import AmplitudeSpec
from nlupdate.study.reader import Reader, StudyError
from nlupdate.study.spec import CandidateEntry, ComparisonSpec, PredictionSpec, TargetsSpec, ValidationSpec
from nlupdate.study.table_keys import (
    AdapterTable, EigensensitivityKeys, MeasuredTable, ParameterEntry, SimulationTable, StudyAdapterTable, StudyInfo,
)

#: Study table (dotted; an array of tables by its name) → the classes declaring its keys,
#: each with ``own``: only the fields the class itself declares (not its base's: the
#: ``[updating]`` keys are the updating methods' base class, not their tables').
TABLES: dict[str, tuple[tuple[type, bool], ...]] = {
    "study": ((StudyInfo, False),),
    "measured": ((MeasuredTable, False),),
    "measured.simulate": ((SimulationTable, False),),
    "identification": ((IdentificationSettings, False),),
    "adapter": ((StudyAdapterTable, False),),
    "measured.simulate.adapter": ((AdapterTable, False),),
    "parameters": ((ParameterEntry, False),),
    "targets": ((TargetsSpec, False),),
    "updating": ((ResponseOptions, False),),
    "eigensensitivity": ((EigensensitivityKeys, False), (EigensensitivityOptions, True)),
    "optimisation": ((OptimisationOptions, True),),
    "optimisation.candidates": ((CandidateEntry, False),),
    "comparison": ((ComparisonSpec, False),),
    "prediction": ((PredictionSpec, False),),
    "validation": ((ValidationSpec, False),),
    "amplitude": ((AmplitudeSpec, False),),
}


def declared_keys(table: str) -> dict[str, tuple[dataclasses.Field, Setting]]:
    """Key → (field, declaration) of a declared study table, in the order of the docs."""
    keys: dict[str, tuple[dataclasses.Field, Setting]] = {}
    for cls, own in TABLES[table]:
        keys.update(settings_of(cls, own=own))
    return keys


def classes(table: str) -> tuple[type, ...]:
    """The classes declaring a study table, in order (its reader builds them)."""
    return tuple(cls for cls, _ in TABLES[table])


def read_declared(read: Reader, mapping: Mapping[str, Any], where: str, table: str | None = None) -> dict[str, Any]:
    """The values of the keys given in a study table (``where`` names it in messages;
    ``table``: its entry in :data:`TABLES`, default ``where``), each checked by its
    declaration; keys left out are left out (the class's default applies)."""
    try:
        return parse_mapping(declared_keys(table or where), mapping)
    except SettingError as error:
        raise read.fail(where, error.key, error.expected, error.got) from None


def build(read: Reader, where: str, cls: type, values: Mapping[str, Any]) -> Any:
    """``cls`` from the values of its fields among ``values``; a rule of the class broken is
    one line naming the file and the table."""
    names = {f.name for f in dataclasses.fields(cls)}
    try:
        return cls(**{name: value for name, value in values.items() if name in names})
    except ValueError as error:
        raise StudyError(f"{read.path}: [{where}]: {error}") from None
