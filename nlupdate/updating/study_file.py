"""Updating study files (TOML): reading and validation.

File format (relative paths are relative to the study file; see ``examples/``)::

    [study]                  name = "…", description = "…"            (optional)
    [adapter]                kind = "lumped" | "surrogate" | "calculix" | "mapdl"
                             model = "tbeam" | "gunbarrel"  (surrogate, calculix)
    [adapter.options]        constructor options of the adapter       (optional)
    [adapter.fixed]          values of adapter parameters that are not updated (optional)
    [[parameters]]           name, unit, start, lower, upper, relative_step (optional)
    [targets]                frequencies_hz = [...]  — or —
                             identification = "<result dir | .json | FRF table>", n_modes,
                             band_hz = [lo, hi], force_level_n, frf_method = "peak" |
                             "line_fit" (optional; nlupdate.updating.targets);
                             response_dof, input_dof (FRF curve; also used for FRAC),
                             model_response_dof, model_input_dof (the model coordinates
                             of that curve when named differently; default the same),
                             weights, labels, model_modes, coordinates + mode_shapes
                             (one list per target mode)                (optional)
    [updating]               pairing = "order" | "nearest" | "mac", min_mac,
                             use_mode_shapes, mode_shape_weight       (optional)
    [eigensensitivity]       formulas = ["forward", "backward", "central2", "central4"],
                             parameters = [names] (default all), max_iterations,
                             frequency_tolerance, parameter_tolerance, regularisation,
                             max_step
    [optimisation]           method = "dogbox" | "trf", formula, max_evaluations,
                             ftol, xtol, gtol
    [[optimisation.candidates]]  name, parameters = [names], weights (optional),
                             start = {name = value} (optional)
    [comparison]             user_weights (list per target mode or {label = w}),
                             damping_ratios, loss_factors (scalar or per target mode),
                             band_fraction, frf = "<path>" (default: the identification)

At least one of ``[eigensensitivity]`` and ``[optimisation]`` is required. Every table
rejects unknown keys, so a misspelt option is an error, not a silent default.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import tomllib

from nlupdate.adapters.base import Parameter
from nlupdate.updating.adapter_factory import ADAPTER_KINDS, AdapterSpec
from nlupdate.updating.optimisation import OPTIMISATION_METHODS
from nlupdate.updating.pairing import PAIRING_METHODS
from nlupdate.updating.sensitivity import FORMULA_LABELS, FORMULAS
from nlupdate.updating.targets import FRF_METHODS


class StudyError(ValueError):
    """A study file is malformed; the message names the file, table, key and expected form."""


_NUMBER = "a number"
_ALLOWED = {
    "": {"study", "adapter", "parameters", "targets", "updating", "eigensensitivity", "optimisation", "comparison"},
    "study": {"name", "description"},
    "adapter": {"kind", "model", "options", "fixed"},
    "parameters": {"name", "unit", "start", "lower", "upper", "relative_step"},
    "targets": {
        "frequencies_hz", "identification", "n_modes", "band_hz", "force_level_n", "frf_method", "response_dof", "input_dof",
        "model_response_dof", "model_input_dof", "weights", "labels", "model_modes", "coordinates", "mode_shapes",
    },
    "updating": {"pairing", "min_mac", "use_mode_shapes", "mode_shape_weight"},
    "eigensensitivity": {
        "formulas", "parameters", "max_iterations", "frequency_tolerance", "parameter_tolerance", "regularisation", "max_step",
    },
    "optimisation": {"method", "formula", "max_evaluations", "ftol", "xtol", "gtol", "candidates"},
    "optimisation.candidates": {"name", "parameters", "weights", "start"},
    "comparison": {"user_weights", "damping_ratios", "loss_factors", "band_fraction", "frf"},
}


@dataclass(frozen=True)
class CandidateEntry:
    name: str
    parameters: tuple[str, ...]
    weights: tuple[float, ...] | None
    start: dict[str, float]


@dataclass(frozen=True, eq=False)
class Study:
    """A parsed and checked study file (see the module docstring)."""

    path: Path
    name: str
    description: str
    adapter: AdapterSpec
    fixed: dict[str, float]
    parameters: tuple[Parameter, ...]
    targets: Mapping[str, Any]
    updating: Mapping[str, Any]
    eigensensitivity: Mapping[str, Any] | None
    optimisation: Mapping[str, Any] | None
    candidates: tuple[CandidateEntry, ...]
    comparison: Mapping[str, Any]
    text: str = field(default="", repr=False)

    def resolve(self, relative: str) -> Path:
        """A path of the study file, relative to the file's directory."""
        return _resolve(self.path, relative)


# ----------------------------------------------------------------------------- reading
class _Reader:
    def __init__(self, path: Path) -> None:
        self.path = path

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
        allowed = _ALLOWED[allowed_key if allowed_key is not None else where]
        unknown = sorted(set(table) - allowed)
        if unknown:
            place = f"[{where}]" if where else "the top level"
            raise StudyError(f"{self.path}: unknown key(s) {unknown} in {place}; allowed: {sorted(allowed)}")

    def number(self, table: Mapping[str, Any], where: str, key: str, default: float | None = None,
               required: bool = False, positive: bool = False, nonnegative: bool = False) -> float | None:
        if key not in table:
            if required:
                raise self.fail(where, key, "a number (required)")
            return default
        value = table[key]
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise self.fail(where, key, "a finite number", value)
        if positive and not value > 0:
            raise self.fail(where, key, "a number > 0", value)
        if nonnegative and value < 0:
            raise self.fail(where, key, "a number ≥ 0", value)
        return float(value)

    def integer(self, table: Mapping[str, Any], where: str, key: str, default: int | None = None, minimum: int = 1) -> int | None:
        if key not in table:
            return default
        value = table[key]
        if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
            raise self.fail(where, key, f"an integer ≥ {minimum}", value)
        return value

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

    def boolean(self, table: Mapping[str, Any], where: str, key: str, default: bool) -> bool:
        value = table.get(key, default)
        if not isinstance(value, bool):
            raise self.fail(where, key, "true or false", value)
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

    def strings(self, table: Mapping[str, Any], where: str, key: str, required: bool = False) -> list[str] | None:
        if key not in table:
            if required:
                raise self.fail(where, key, "a list of strings (required)")
            return None
        value = table[key]
        if not isinstance(value, list) or not value or any(not isinstance(v, str) for v in value):
            raise self.fail(where, key, "a non-empty list of strings", value)
        return list(value)

    def scalar_or_numbers(self, table: Mapping[str, Any], where: str, key: str, default: float, length: int) -> float | list[float]:
        if key not in table:
            return default
        value = table[key]
        if isinstance(value, list):
            values = self.numbers(table, where, key, length=length)
            if min(values) < 0:
                raise self.fail(where, key, f"a number ≥ 0 or a list of {length} numbers ≥ 0", value)
            return values
        return self.number(table, where, key, nonnegative=True)

    def number_table(self, table: Mapping[str, Any], where: str, key: str) -> dict[str, float]:
        value = table.get(key, {})
        if not isinstance(value, dict):
            raise self.fail(where, key, "a table of name = number", value)
        for name, v in value.items():
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise self.fail(f"{where}.{key}" if where else key, name, "a finite number", v)
        return {name: float(v) for name, v in value.items()}


def load_study(path: str | os.PathLike) -> Study:
    """Read and check a study file; raises :class:`StudyError` or FileNotFoundError."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"study file not found: {path}")
    text = path.read_text()
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise StudyError(f"{path}: not valid TOML ({error})") from error
    read = _Reader(path)
    read.check_keys(data, "")

    meta = read.table(data, "study") or {}
    name = read.string(meta, "study", "name", default=path.stem)
    description = read.string(meta, "study", "description", default="")

    adapter_table = read.table(data, "adapter", required=True)
    kind = read.string(adapter_table, "adapter", "kind", required=True, choices=ADAPTER_KINDS)
    model = read.string(adapter_table, "adapter", "model")
    if kind in ("surrogate", "calculix") and model is None:
        raise read.fail("adapter", "model", f"a model name for kind {kind!r} (e.g. 'tbeam')")
    options = adapter_table.get("options", {})
    if not isinstance(options, dict):
        raise read.fail("adapter", "options", "a table of constructor options", options)
    if kind == "mapdl":
        deck = read.string(options, "adapter.options", "deck", required=True)
        options = {**options, "deck": str(_resolve(path, deck))}
    adapter = AdapterSpec(kind, model, options)
    fixed = read.number_table(adapter_table, "adapter", "fixed")

    parameters = _read_parameters(read, data)
    names = [p.name for p in parameters]
    overlap = sorted(set(names) & set(fixed))
    if overlap:
        raise read.fail("adapter.fixed", overlap[0], "parameters that are not also updated ([[parameters]])")

    targets = read.table(data, "targets", required=True)
    n_targets = _check_targets(read, targets)
    labels = targets.get("labels") or [f"mode{i + 1}" for i in range(n_targets)]

    updating = read.table(data, "updating") or {}
    updating_options = {
        "pairing": read.string(updating, "updating", "pairing", "order", choices=PAIRING_METHODS),
        "min_mac": read.number(updating, "updating", "min_mac", 0.0, nonnegative=True),
        "use_mode_shapes": read.boolean(updating, "updating", "use_mode_shapes", False),
        "mode_shape_weight": read.number(updating, "updating", "mode_shape_weight", 1.0, nonnegative=True),
    }

    eigen_table = read.table(data, "eigensensitivity")
    eigensensitivity = None
    if eigen_table is not None:
        where = "eigensensitivity"
        formulas = read.strings(eigen_table, where, "formulas") or ["forward"]
        bad = [f for f in formulas if f not in FORMULAS]
        if bad or len(set(formulas)) != len(formulas):
            raise read.fail(where, "formulas", f"distinct names from {list(FORMULAS)}", formulas)
        subset = read.strings(eigen_table, where, "parameters") or names
        _check_subset(read, where, "parameters", subset, names)
        eigensensitivity = {
            "formulas": formulas,
            "parameters": subset,
            "options": {
                "max_iterations": read.integer(eigen_table, where, "max_iterations", 20),
                "frequency_tolerance": read.number(eigen_table, where, "frequency_tolerance", 1e-4, positive=True),
                "parameter_tolerance": read.number(eigen_table, where, "parameter_tolerance", 1e-6, positive=True),
                "regularisation": read.number(eigen_table, where, "regularisation", 0.0, nonnegative=True),
                "max_step": read.number(eigen_table, where, "max_step", 0.5, positive=True),
            },
        }

    optimisation_table = read.table(data, "optimisation")
    optimisation, candidates = None, ()
    if optimisation_table is not None:
        where = "optimisation"
        optimisation = {
            "method": read.string(optimisation_table, where, "method", "dogbox", choices=OPTIMISATION_METHODS),
            "formula": read.string(optimisation_table, where, "formula", "forward", choices=tuple(FORMULAS)),
            "max_evaluations": read.integer(optimisation_table, where, "max_evaluations", 100),
            "ftol": read.number(optimisation_table, where, "ftol", 1e-10, positive=True),
            "xtol": read.number(optimisation_table, where, "xtol", 1e-10, positive=True),
            "gtol": read.number(optimisation_table, where, "gtol", 1e-10, positive=True),
        }
        candidates = _read_candidates(read, optimisation_table, names, n_targets)
    if eigensensitivity is None and optimisation is None:
        raise StudyError(f"{path}: needs an [eigensensitivity] table, an [optimisation] table or both")

    comparison = read.table(data, "comparison") or {}
    where = "comparison"
    comparison_options = {
        "damping_ratios": read.scalar_or_numbers(comparison, where, "damping_ratios", 0.0, n_targets),
        "loss_factors": read.scalar_or_numbers(comparison, where, "loss_factors", 0.0, n_targets),
        "band_fraction": read.number(comparison, where, "band_fraction", 0.1, positive=True),
        "frf": read.string(comparison, where, "frf"),
        "user_weights": comparison.get("user_weights"),
    }
    weights = comparison_options["user_weights"]
    if isinstance(weights, dict):
        unknown = sorted(set(read.number_table(comparison, where, "user_weights")) - set(labels))
        if unknown:
            raise read.fail(where, "user_weights", f"weights of target modes {labels}", unknown)
    elif weights is not None:
        read.numbers(comparison, where, "user_weights", length=n_targets)
    run_names = [f"eigensensitivity {FORMULA_LABELS[f]}" for f in (eigensensitivity or {}).get("formulas", [])]
    run_names += [c.name for c in candidates]
    if len(set(run_names)) != len(run_names) or "initial" in run_names:
        raise read.fail("optimisation.candidates", "name", "distinct names, not 'initial'", run_names)

    return Study(
        path=path, name=name, description=description, adapter=adapter, fixed=fixed, parameters=parameters,
        targets=targets, updating=updating_options, eigensensitivity=eigensensitivity, optimisation=optimisation,
        candidates=candidates, comparison=comparison_options, text=text,
    )


def _resolve(study_path: Path, relative: str) -> Path:
    path = Path(relative)
    return path if path.is_absolute() else study_path.parent / path


def _read_parameters(read: _Reader, data: Mapping[str, Any]) -> tuple[Parameter, ...]:
    entries = data.get("parameters")
    if not isinstance(entries, list) or not entries or any(not isinstance(e, dict) for e in entries):
        raise StudyError(f"{read.path}: expected one or more [[parameters]] tables (name, unit, start, lower, upper)")
    parameters = []
    for i, entry in enumerate(entries):
        where = f"parameters #{i + 1}"
        read.check_keys(entry, where, "parameters")
        name = read.string(entry, where, "name", required=True)
        unit = read.string(entry, where, "unit", default="")
        values = {key: read.number(entry, where, key, required=True) for key in ("start", "lower", "upper")}
        step = read.number(entry, where, "relative_step", 1e-3, positive=True)
        try:
            parameters.append(Parameter(name, unit, values["start"], values["lower"], values["upper"], step))
        except ValueError as error:
            raise StudyError(f"{read.path}: [{where}]: {error}") from None
        if not values["lower"] < values["upper"]:
            raise read.fail(where, "upper", f"a value above lower = {values['lower']}", values["upper"])
    names = [p.name for p in parameters]
    duplicates = sorted({n for n in names if names.count(n) > 1})
    if duplicates:
        raise read.fail("parameters", "name", "distinct parameter names", duplicates)
    return tuple(parameters)


def _check_subset(read: _Reader, where: str, key: str, subset: list[str], names: list[str]) -> None:
    unknown = [n for n in subset if n not in names]
    if unknown or len(set(subset)) != len(subset):
        raise read.fail(where, key, f"distinct names of [[parameters]] {names}", subset)


def _read_candidates(read: _Reader, table: Mapping[str, Any], names: list[str], n_targets: int) -> tuple[CandidateEntry, ...]:
    entries = table.get("candidates")
    if not isinstance(entries, list) or not entries or any(not isinstance(e, dict) for e in entries):
        raise read.fail("optimisation", "candidates", "one or more [[optimisation.candidates]] tables (name, parameters)")
    candidates = []
    for i, entry in enumerate(entries):
        where = f"optimisation.candidates #{i + 1}"
        read.check_keys(entry, where, "optimisation.candidates")
        subset = read.strings(entry, where, "parameters", required=True)
        _check_subset(read, where, "parameters", subset, names)
        weights = read.numbers(entry, where, "weights", length=n_targets)
        start = read.number_table(entry, where, "start")
        _check_subset(read, where, "start", list(start), subset)
        name = read.string(entry, where, "name", default=f"candidate {i + 1}")
        candidates.append(CandidateEntry(name, tuple(subset), tuple(weights) if weights else None, start))
    return tuple(candidates)


def _check_targets(read: _Reader, targets: Mapping[str, Any]) -> int:
    """Check the [targets] table; returns the number of target modes."""
    where = "targets"
    has_list = "frequencies_hz" in targets
    has_ident = "identification" in targets
    if has_list == has_ident:
        raise read.fail(where, None, "exactly one of 'frequencies_hz' (list, Hz) or 'identification' (path)")
    if has_list:
        read.numbers(targets, where, "frequencies_hz", required=True)
        n = len(targets["frequencies_hz"])
    else:
        read.string(targets, where, "identification", required=True)
        n = read.integer(targets, where, "n_modes")
        if n is None:
            raise read.fail(where, "n_modes", "the number of peaks to pick from the identified FRF (integer ≥ 1)")
        for key in ("response_dof", "input_dof"):
            read.string(targets, where, key, required=True)
    for key in ("response_dof", "input_dof", "model_response_dof", "model_input_dof"):
        read.string(targets, where, key)
    if not has_list:
        if "band_hz" in targets:
            low, high = read.numbers(targets, where, "band_hz", length=2)
            if not 0 <= low < high:
                raise read.fail(where, "band_hz", "[low, high] with 0 ≤ low < high (Hz)", targets["band_hz"])
        read.number(targets, where, "force_level_n", positive=True)
        read.string(targets, where, "frf_method", choices=FRF_METHODS)
    read.numbers(targets, where, "weights", length=n)
    labels = read.strings(targets, where, "labels")
    if labels is not None and len(labels) != n:
        raise read.fail(where, "labels", f"{n} names", labels)
    if "model_modes" in targets:
        modes = targets["model_modes"]
        if not isinstance(modes, list) or len(modes) != n or any(isinstance(m, bool) or not isinstance(m, int) or m < 1 for m in modes):
            raise read.fail(where, "model_modes", f"a list of {n} mode numbers ≥ 1", modes)
    if ("coordinates" in targets) != ("mode_shapes" in targets):
        raise read.fail(where, None, "'coordinates' and 'mode_shapes' together")
    if "coordinates" in targets:
        coordinates = read.strings(targets, where, "coordinates")
        shapes = targets["mode_shapes"]
        if (not isinstance(shapes, list) or len(shapes) != n
                or any(not isinstance(s, list) or len(s) != len(coordinates) for s in shapes)):
            raise read.fail(where, "mode_shapes", f"{n} lists (one per target mode) of {len(coordinates)} numbers", shapes)
        for row in shapes:
            if any(isinstance(v, bool) or not isinstance(v, (int, float)) for v in row):
                raise read.fail(where, "mode_shapes", "numbers", row)
    return n
