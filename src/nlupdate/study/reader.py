"""Checked reading of TOML study files: every mistake is one line naming the file, the
table, the key, the expected form and what was found. The keys' forms are their
declarations' (:mod:`nlupdate.study.declared`); the reader holds the tables, the allowed
keys, the paths a study names and the few values a rule reads before any declaration does."""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Mapping


class StudyError(ValueError):
    """A study file is malformed; the message names the file, table, key and expected form."""


class Reader:
    """Access to a parsed TOML document; every failure names the file, the table, the key
    and the expected form. ``allowed`` maps table names (dotted) to their keys.

    ``redirect`` maps paths as written in the file to the files to read instead (a rerun
    reads the copies kept in its archive); :attr:`files` records every path the file
    names, as written → the path read. With ``redirect_only``, a path that ``redirect``
    does not map is refused (a rerun reads nothing outside its archive)."""

    def __init__(self, path: Path, allowed: Mapping[str, set[str]], redirect: Mapping[str, Path] | None = None,
                 redirect_only: bool = False) -> None:
        self.path = path
        self.allowed = allowed
        self.redirect = dict(redirect or {})
        self.redirect_only = redirect_only
        self.files: dict[str, Path] = {}

    def fail(self, where: str, key: str | None, expected: str, got: object = None) -> StudyError:
        place = f"[{where}]" if where else "top level"
        what = f"{place} key '{key}'" if key else place
        suffix = f", got {got!r}" if got is not None else ""
        return StudyError(f"{self.path}: {what}: expected {expected}{suffix}")

    def table(self, data: Mapping[str, Any], where: str, required: bool = False) -> dict[str, Any] | None:
        parent, _, key = where.rpartition(".")
        value = data.get(key)
        if value is None:
            if required:
                raise StudyError(f"{self.path}: missing table [{where}]")
            return None
        if not isinstance(value, dict):
            raise self.fail(parent, key, "a table", value)
        self.check_keys(value, where)
        return value

    def check_keys(self, table: Mapping[str, Any], where: str, allowed_key: str | None = None) -> None:
        allowed = self.allowed[allowed_key if allowed_key is not None else where]
        unknown = sorted(set(table) - allowed)
        if unknown:
            place = f"[{where}]" if where else "the top level"
            raise StudyError(f"{self.path}: unknown key(s) {unknown} in {place}; allowed: {sorted(allowed)}")

    def string(self, table: Mapping[str, Any], where: str, key: str, default: str | None = None,
               required: bool = False, choices: tuple[str, ...] | None = None) -> str | None:
        if key not in table:
            if required:
                expected = f"one of {list(choices)}" if choices else "a string"
                raise self.fail(where, key, f"{expected} (required)")
            return default
        value = table[key]
        if not isinstance(value, str) or (choices is not None and value not in choices):
            raise self.fail(where, key, f"one of {list(choices)}" if choices else "a string", value)
        return value

    def numbers(self, table: Mapping[str, Any], where: str, key: str, length: int | None = None,
                required: bool = False) -> list[float] | None:
        if key not in table:
            if required:
                raise self.fail(where, key, "a list of numbers (required)")
            return None
        value = table[key]
        expected = f"a list of {length} numbers" if length is not None else "a non-empty list of numbers"
        if (not isinstance(value, list) or not value or (length is not None and len(value) != length)
                or any(isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) for v in value)):
            raise self.fail(where, key, expected, value)
        return [float(v) for v in value]

    def path_of(self, written: str, record: bool = True) -> Path:
        """A path given in the file (relative to the file's directory), or its redirect;
        recorded in :attr:`files` (the files the run reads and archives) unless ``record``
        is False (a name that only refers to a file read elsewhere, as a level's key)."""
        if written in self.redirect:
            path = Path(self.redirect[written])
        elif self.redirect_only:
            raise StudyError(f"{self.path}: names {written!r}, which is not among the files kept with it; "
                             f"only those are read")
        else:
            path = Path(written)
            path = path if path.is_absolute() else self.path.parent / path
        if record:
            self.files[written] = path
        return path
