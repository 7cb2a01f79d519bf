"""The study's ``[fe_validation]`` table: read by its settings' declaration
(:class:`~nlupdate.core.validation.fe_settings.FEValidationSettings`), its files recorded
(archived, and part of the step's cache key).

It needs the reduced model with bolts (``[adapter] kind = "calculix", model = "brb"``),
updating runs (the updated model) and stands instead of ``[validation]``: both write the
archive's ``tables/validation.parquet``.
"""
from __future__ import annotations

from typing import Any, Mapping

from nlupdate.core.validation.fe_settings import FEValidationSettings
from nlupdate.fe.adapters.registry import AdapterSpec
from nlupdate.settings import SettingError, from_mapping
from nlupdate.study.reader import Reader, StudyError

WHERE = "fe_validation"


def read_fe_validation(read: Reader, data: Mapping[str, Any], adapter: AdapterSpec | None,
                       validation: object | None) -> FEValidationSettings | None:
    """``[fe_validation]``, or None when the study has none."""
    table = data.get(WHERE)
    if table is None:
        return None
    if not isinstance(table, dict):
        raise read.fail("", WHERE, "a table", table)
    if adapter is None or (adapter.kind, adapter.model) != ("calculix", "brb"):
        raise read.fail(WHERE, None, 'an [adapter] kind = "calculix", model = "brb" (the reduced model with its bolts)')
    if validation is not None:
        raise read.fail(WHERE, None, "no [validation] table beside it (both write tables/validation.parquet)")
    try:
        settings = from_mapping(FEValidationSettings, table)
    except SettingError as error:
        raise read.fail(WHERE, error.key, error.expected, error.got) from None
    except ValueError as error:
        raise StudyError(f"{read.path}: [{WHERE}]: {error}") from None
    for key in ("file", "impact_file"):
        written = getattr(settings, key)
        if written is None:
            continue
        if not written.lower().endswith(".mat"):
            raise read.fail(WHERE, key, "a MATLAB file (.mat)", written)
        path = read.path_of(written)
        if not read.redirect and not path.is_file():
            raise read.fail(WHERE, key, "an existing file (relative to the study file)", written)
    return settings
