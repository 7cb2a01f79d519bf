"""Reading the tables of a study file: which tables and keys a study may hold
(:data:`ALLOWED`: the declared tables' keys, :mod:`nlupdate.study.declared`, and the
hand-read ones'), and the readers of the tables whose keys are declared settings —
``[identification]``, ``[updating]``, ``[eigensensitivity]``, ``[optimisation]``,
``[comparison]``, ``[prediction]``, ``[validation]``, ``[amplitude]``: each key checked by its declaration,
then the rules across keys and tables. ``[measured]`` is :mod:`nlupdate.study.measured_section`;
``[adapter]``, ``[[parameters]]`` and ``[targets]``, :mod:`nlupdate.study.model_sections`.
Every mistake is one line naming the file, the table, the key, the expected form and what
was found (:class:`~nlupdate.study.reader.Reader`).
"""
from __future__ import annotations

import dataclasses
from typing import Any, Mapping

from nlupdate.core.identification.modal_samples import SHAPE_FORM, usable_shape
from nlupdate.core.identification.settings import IdentificationSettings
from nlupdate.core.response.method import samples_form, valid_samples
from nlupdate.core.updating.optimisation import OptimisationOptions
from nlupdate.core.updating.residuals import ResponseOptions
from nlupdate.core.updating.sensitivity import FORMULAS
from nlupdate.core.validation.held_type import BACKBONE_OF_MODEL
from nlupdate.core.validation.impact_limit import LIMIT_MODELS, refused_model
from nlupdate.core.validation.models import model_fitter
from nlupdate.fe.adapters.registry import AdapterSpec
from nlupdate.study.declared import TABLES, build, classes, declared_keys, read_declared
from nlupdate.study.reader import Reader
from nlupdate.study.amplitude import FILE_KEYS, AmplitudeSpec
from nlupdate.study.spec import CandidateEntry, ComparisonSpec, EigensensitivitySpec, PredictionSpec, ValidationSpec

ALLOWED: dict[str, set[str]] = {
    "": {"study", "measured", "identification", "adapter", "parameters", "targets", "updating", "eigensensitivity",
         "optimisation", "comparison", "prediction", "validation", "fe_validation", "amplitude"},
    **{table: set(declared_keys(table)) for table in TABLES},
}
ALLOWED["optimisation"] |= {"candidates"}  # the [[optimisation.candidates]] tables
MOVED = {
    ("updating", "max_workers"): "parallel runs are chosen when running: nlupdate run STUDY --workers N",
    ("updating", "executor"): "parallel runs are chosen when running: nlupdate run STUDY --workers N (or --dask)",
    ("adapter", "cache_dir"): "FE results are cached by nlupdate run in one store (--cache-dir, NLUPDATE_CACHE_DIR)",
}


def read_identification(read: Reader, data: Mapping[str, Any]) -> IdentificationSettings | None:
    """The ``[identification]`` table, read by the settings' own declaration."""
    table = read.table(data, "identification")
    if table is None:
        return None
    (cls,) = classes("identification")
    return build(read, "identification", cls, read_declared(read, table, "identification"))


def read_updating(read: Reader, data: Mapping[str, Any]) -> ResponseOptions:
    """``[updating]``: pairing and mode-shape settings shared by every run."""
    table = read.table(data, "updating") or {}
    (cls,) = classes("updating")
    return build(read, "updating", cls, read_declared(read, table, "updating"))


def _shared(updating: ResponseOptions) -> dict[str, Any]:
    """The ``[updating]`` settings every method takes (not the formula, set per run)."""
    return {f.name: getattr(updating, f.name) for f in dataclasses.fields(ResponseOptions) if f.name != "formula"}


def _check_subset(read: Reader, where: str, key: str, subset: list[str] | tuple[str, ...], names: list[str]) -> None:
    unknown = [n for n in subset if n not in names]
    if unknown or len(set(subset)) != len(subset):
        raise read.fail(where, key, f"distinct names of [[parameters]] {names}", list(subset))


def read_eigensensitivity(read: Reader, data: Mapping[str, Any], names: list[str],
                          updating: ResponseOptions) -> EigensensitivitySpec | None:
    table = read.table(data, "eigensensitivity")
    if table is None:
        return None
    where = "eigensensitivity"
    values = read_declared(read, table, where)
    keys_class, options_class = classes(where)
    keys = build(read, where, keys_class, values)
    formulas = keys.formulas
    if [f for f in formulas if f not in FORMULAS] or len(set(formulas)) != len(formulas):
        raise read.fail(where, "formulas", f"distinct names from {list(FORMULAS)}", list(formulas))
    if keys.parameters is not None and keys.parameter_sets is not None:
        raise read.fail(where, "parameter_sets", "either parameters = [...] (one set) or parameter_sets, not both")
    sets = keys.parameter_sets or (keys.parameters or tuple(names),)
    for subset in sets:
        _check_subset(read, where, "parameter_sets" if keys.parameter_sets is not None else "parameters", subset, names)
    if len(set(sets)) != len(sets):
        raise read.fail(where, "parameter_sets", "distinct parameter sets", [list(s) for s in sets])
    options = build(read, where, options_class, {**values, **_shared(updating)})
    return EigensensitivitySpec(formulas, sets, options)


def read_optimisation(read: Reader, data: Mapping[str, Any], names: list[str], n_targets: int,
                      updating: ResponseOptions) -> tuple[OptimisationOptions | None, tuple[CandidateEntry, ...]]:
    """``[optimisation]`` and its ``[[optimisation.candidates]]``."""
    table = read.table(data, "optimisation")
    if table is None:
        return None, ()
    where = "optimisation"
    values = read_declared(read, {k: v for k, v in table.items() if k != "candidates"}, where)
    (options_class,), (candidate_class,) = classes(where), classes("optimisation.candidates")
    options = build(read, where, options_class, {**values, **_shared(updating)})
    entries = table.get("candidates")
    if not isinstance(entries, list) or not entries or any(not isinstance(e, dict) for e in entries):
        raise read.fail(where, "candidates", "one or more [[optimisation.candidates]] tables (name, parameters)")
    candidates = []
    for i, entry in enumerate(entries):
        at = f"optimisation.candidates #{i + 1}"
        read.check_keys(entry, at, "optimisation.candidates")
        values = read_declared(read, entry, at, "optimisation.candidates")
        candidate = build(read, at, candidate_class, {"name": f"candidate {i + 1}", **values})
        _check_subset(read, at, "parameters", candidate.parameters, names)
        if candidate.weights is not None and n_targets < 0:
            raise read.fail(at, "weights", "a [targets] modes = [...] list first (the number of target modes)")
        if candidate.weights is not None and len(candidate.weights) != n_targets:
            raise read.fail(at, "weights", f"a list of {n_targets} numbers", entry["weights"])
        _check_subset(read, at, "start", list(candidate.start), list(candidate.parameters))
        candidates.append(candidate)
    run_names = [c.name for c in candidates]
    if len(set(run_names)) != len(run_names) or "initial" in run_names:
        raise read.fail("optimisation.candidates", "name", "distinct names, not 'initial'", run_names)
    return options, tuple(candidates)


def read_comparison(read: Reader, data: Mapping[str, Any], labels: list[str], n_targets: int) -> ComparisonSpec:
    """``[comparison]``: the keys by their declaration; the lengths the targets set."""
    table = read.table(data, "comparison") or {}
    where = "comparison"
    values = read_declared(read, table, where)
    weights = values.get("user_weights")
    if isinstance(weights, dict):
        unknown = sorted(set(weights) - set(labels))
        if unknown and n_targets > 0:
            raise read.fail(where, "user_weights", f"weights of target modes {labels}", unknown)
    elif weights is not None and n_targets > 0 and len(weights) != n_targets:
        raise read.fail(where, "user_weights", f"a list of {n_targets} numbers", table["user_weights"])
    length = max(n_targets, 1)
    for key in ("damping_ratios", "loss_factors"):
        if isinstance(values.get(key), tuple) and len(values[key]) != length:
            raise read.fail(where, key, f"a number ≥ 0 or a list of {length} numbers ≥ 0", table[key])
    values["frf"] = str(read.path_of(values["frf"])) if values.get("frf") else None
    (cls,) = classes(where)
    return build(read, where, cls, values)


def read_prediction(read: Reader, data: Mapping[str, Any], identification: IdentificationSettings | None,
                    adapter: AdapterSpec | None) -> PredictionSpec | None:
    """``[prediction]``: the keys by their declaration; the harmonic balance's keys only with
    ``method = "hb"``, ``samples`` enough for ``harmonics``."""
    table = read.table(data, "prediction")
    if table is None:
        return None
    where = "prediction"
    if identification is None or adapter is None:
        raise read.fail(where, None, "an [identification] (the elements) and an [adapter] (the updated linear model) "
                                     "to predict with")
    values = read_declared(read, table, where)
    if values.get("force_levels_n") is not None:
        values["force_levels_n"] = tuple(sorted(values["force_levels_n"]))
    (cls,) = classes(where)
    spec = build(read, where, cls, values)
    if spec.method != "hb":
        for key in ("harmonics", "samples", "stability"):
            if key in table:
                raise read.fail(where, key, 'nothing unless method = "hb" (harmonic balance)', table[key])
    elif not valid_samples(spec.samples, spec.harmonics):
        raise read.fail(where, "samples", samples_form(spec.harmonics), spec.samples)
    return spec


def _check_shapes(read: Reader, where: str, shapes: Mapping[str, float]) -> None:
    """Every shape of ``[where] shapes`` usable (:data:`~nlupdate.core.identification.modal_samples.SHAPE_FORM`, as
    ``--shape`` takes it)."""
    for name, value in shapes.items():
        if not usable_shape(value):
            raise read.fail(where, "shapes", f"a table {{ coordinate = shape }}, each {SHAPE_FORM}", {name: value})


def read_validation(read: Reader, data: Mapping[str, Any], measured: Any) -> ValidationSpec | None:
    """``[validation]`` (:class:`~nlupdate.study.spec.ValidationSpec`); it needs measured data."""
    table = read.table(data, "validation")
    if table is None:
        return None
    where = "validation"
    if measured is None:
        raise read.fail(where, None, "a [measured] table: the levels to hold out")
    values = read_declared(read, table, where)
    models = list(values.get("models", ()))
    if len(set(models)) < len(models):
        raise read.fail(where, "models", "distinct names (each model is fitted and judged once)", models)
    for name in models:
        if name != "auto":
            try:
                model_fitter(name)
            except ValueError as error:
                raise read.fail(where, "models", str(error).split(": expected ", 1)[1], name) from None
    (cls,) = classes(where)
    spec = build(read, where, cls, values)
    typed = ("hold_out_type", "shapes", "ring_down")
    if "channel" in table and spec.impact is None:
        raise read.fail(where, "channel", "nothing unless impact is given", table["channel"])
    if spec.hold_out_type is None:
        for key in typed[1:]:
            if key in table:
                raise read.fail(where, key, "nothing unless hold_out_type is given", table[key])
        if spec.impact is None:
            return spec
        refused = refused_model(spec.models)
        if refused is not None:
            raise read.fail(where, "models", f"with impact, models among {list(LIMIT_MODELS)} (a linear limit is "
                                             f"kept beside the levels by the lines models only)", list(spec.models))
        impact = read.path_of(spec.impact)
        if not read.redirect and not impact.is_file():
            raise read.fail(where, "impact", "an existing file (relative to the study file)", spec.impact)
        return dataclasses.replace(spec, impact=str(impact))
    if spec.impact is not None:
        raise read.fail(where, "impact", "nothing with hold_out_type (levels held out only)", table["impact"])
    if spec.models[0] not in BACKBONE_OF_MODEL:
        raise read.fail(where, "models", f"with hold_out_type, a first model among {list(BACKBONE_OF_MODEL)}",
                        list(spec.models))
    if not spec.shapes:
        raise read.fail(where, "shapes", "with hold_out_type, the mode shape at each source's coordinate: "
                                         "{ \"<coordinate>\" = value (1/√kg) }")
    _check_shapes(read, where, spec.shapes)
    ring_down = tuple(read.path_of(path) for path in spec.ring_down)
    for written, path in zip(spec.ring_down, ring_down):
        if not read.redirect and not path.is_file():
            raise read.fail(where, "ring_down", "existing files (relative to the study file)", written)
    return dataclasses.replace(spec, ring_down=tuple(map(str, ring_down)))


def read_amplitude(read: Reader, data: Mapping[str, Any], measured: object | None) -> AmplitudeSpec | None:
    """``[amplitude]``, or None when the study has none: each key by its declaration; at least
    one source; every file existing (relative to the study file); ``measured`` needs a
    ``[measured]`` table."""
    where = "amplitude"
    table = read.table(data, where)
    if table is None:
        return None
    values = read_declared(read, table, where)
    (cls,) = classes(where)
    spec = build(read, where, cls, values)
    if spec.band_hz is not None and not spec.band_hz[0] < spec.band_hz[1]:
        raise read.fail(where, "band_hz", "[LOW, HIGH] in Hz with LOW < HIGH", list(spec.band_hz))
    _check_shapes(read, where, spec.shapes)
    for name, pair in spec.coordinates.items():
        if (not isinstance(pair, (list, tuple)) or len(pair) != 2
                or not all(isinstance(p, str) and p for p in pair)):
            raise read.fail(where, "coordinates", 'a table { FILE = ["RESPONSE", "INPUT"] }', {name: pair})
    stated = dict(getattr(measured, "coordinates", ()))
    for name, pair in spec.coordinates.items():
        path = str(read.path_of(name, record=False))
        if path in stated and tuple(pair) != stated[path]:
            raise read.fail(where, "coordinates", f"nothing for a file [measured] states them for (it is read with "
                                                  f"those: {list(stated[path])})", {name: pair})
    if spec.measured and measured is None:
        raise read.fail(where, "measured", "false without a [measured] table (the stepped sine to take)", True)
    if not spec.measured and not spec.file_count:
        raise read.fail(where, None, "a source: `measured = true` or a file in ring_down, impact, "
                                     "response_controlled or phase_resonance")
    if spec.held_amplitudes and not spec.response_controlled:
        raise read.fail(where, "held_amplitudes", "nothing without response_controlled files (the held amplitude of "
                                                  "their runs; no other source reads it)", dict(spec.held_amplitudes))
    if not spec.measured:
        for key in ("input_dof", "response_dof"):
            if key in table:
                raise read.fail(where, key, "nothing unless measured = true", table[key])
    for key in FILE_KEYS:
        for written in getattr(spec, key):
            path = read.path_of(written)
            if not read.redirect and not path.is_file():
                raise read.fail(where, key, "existing files (relative to the study file)", written)
    return dataclasses.replace(spec, coordinates={k: tuple(v) for k, v in spec.coordinates.items()})
