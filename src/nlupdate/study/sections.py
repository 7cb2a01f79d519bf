"""Reading the tables of a study file: each checked, each turned into its typed section
(:mod:`nlupdate.study.spec`); every mistake is one line naming the file, the table, the
key, the expected form and what was found (:class:`~nlupdate.study.reader.Reader`). The
tables and keys are documented in docs/study-files.md.

Length: one reader per study table, kept together in the order of
docs/study-files.md so that the checks can be read against it; each is short.
"""
from __future__ import annotations

import dataclasses
from typing import Any, Mapping

import numpy as np

from nlupdate.fe.adapters.base import Parameter
from nlupdate.fe.adapters.registry import ADAPTER_KINDS, AdapterSpec, build_adapter
from nlupdate.core.identification.settings import IdentificationSettings
from nlupdate.settings import SettingError, from_mapping, settings_of
from nlupdate.core.response.harmonic_balance import HarmonicSettings
from nlupdate.core.response.method import HARMONICS_FORM, MAX_FREQUENCIES, RESPONSE_METHODS, samples_form, valid_harmonics, valid_samples
from nlupdate.study.reader import Reader, StudyError
from nlupdate.study.spec import (
    LOSS_FACTOR_SOURCES, CandidateEntry, ComparisonSpec, EigensensitivitySpec, MeasuredSpec, PredictionSpec,
    SimulationSpec, TargetsSpec, ValidationSpec,
)
from nlupdate.core.updating.eigensensitivity import STEP_CONTROLS, EigensensitivityOptions
from nlupdate.core.validation.models import model_fitter
from nlupdate.core.updating.optimisation import OPTIMISATION_METHODS, OptimisationOptions
from nlupdate.core.updating.pairing import PAIRING_METHODS
from nlupdate.core.updating.residuals import ResponseOptions
from nlupdate.core.updating.sensitivity import FORMULAS
from nlupdate.core.updating.targets import FRF_METHODS

ALLOWED: dict[str, set[str]] = {
    "": {"study", "measured", "identification", "adapter", "parameters", "targets", "updating", "eigensensitivity",
         "optimisation", "comparison", "prediction", "validation"},
    "study": {"name", "description"},
    "measured": {"file", "files", "time_histories", "simulate", "reference_unit", "reference_calibration", "coordinates",
                 "levels", "input_dof",
                 "excitation", "response_quantity"},
    "measured.simulate": {"model", "adapter", "parameters", "loss_factor", "nonlinear", "input_dof", "forces_n",
                          "frequencies_hz", "noise", "seed", "sweep"},
    "measured.simulate.adapter": {"kind", "model", "options"},
    "identification": set(settings_of(IdentificationSettings)),
    "adapter": {"kind", "model", "options", "fixed"},
    "parameters": {"name", "unit", "start", "lower", "upper", "relative_step"},
    "targets": {
        "frequencies_hz", "std_hz", "from_identification", "modes", "identification", "amplitude_models", "n_modes",
        "band_hz",
        "force_level_n", "frf_method", "response_dof", "input_dof", "model_response_dof", "model_input_dof", "weights",
        "labels", "model_modes", "coordinates", "mode_shapes",
    },
    "updating": {"pairing", "min_mac", "use_mode_shapes", "mode_shape_weight"},
    "eigensensitivity": {
        "formulas", "parameters", "parameter_sets", "max_iterations", "frequency_tolerance", "parameter_tolerance",
        "regularisation", "max_step", "step_control",
    },
    "optimisation": {"method", "formula", "max_evaluations", "ftol", "xtol", "gtol", "candidates"},
    "optimisation.candidates": {"name", "parameters", "weights", "start"},
    "comparison": {"user_weights", "damping_ratios", "loss_factors", "band_fraction", "frf"},
    "prediction": {"force_levels_n", "candidates", "loss_factor", "sweep", "adapter_options", "method", "harmonics",
                   "samples", "stability"},
    "validation": {"hold_out", "models", "input_dof", "response_controlled"},
}
MOVED = {
    ("updating", "max_workers"): "parallel runs are chosen when running: nlupdate run STUDY --workers N",
    ("updating", "executor"): "parallel runs are chosen when running: nlupdate run STUDY --workers N (or --dask)",
    ("adapter", "cache_dir"): "FE results are cached by nlupdate run in one store (--cache-dir, NLUPDATE_CACHE_DIR)",
}



def adapter_from(read: Reader, table: Mapping[str, Any], where: str) -> AdapterSpec:
    kind = read.string(table, where, "kind", required=True, choices=ADAPTER_KINDS)
    model = read.string(table, where, "model")
    if kind in ("surrogate", "calculix") and model is None:
        raise read.fail(where, "model", f"a model name for kind {kind!r} (e.g. 'tbeam')")
    options = table.get("options", {})
    if not isinstance(options, dict):
        raise read.fail(where, "options", "a table of constructor options", options)
    if kind == "mapdl":
        deck = read.string(options, f"{where}.options", "deck", required=True)
        options = {**options, "deck": str(read.path_of(deck))}
    try:
        return AdapterSpec(kind, model, options)
    except ValueError as error:
        raise StudyError(f"{read.path}: [{where}]: {error}") from None


def read_adapter(read: Reader, data: Mapping[str, Any]) -> tuple[AdapterSpec, dict[str, float]]:
    table = read.table(data, "adapter", required=True)
    return adapter_from(read, table, "adapter"), read.number_table(table, "adapter", "fixed")


def _grid(read: Reader, table: Mapping[str, Any], where: str) -> tuple[float, ...]:
    value = table.get("frequencies_hz")
    if isinstance(value, dict) and set(value) == {"list"}:
        grid = read.numbers(value, f"{where}.frequencies_hz", "list")
    elif isinstance(value, list) and len(value) == 3 and float(value[2]).is_integer() and value[2] >= 2:
        start, stop, count = read.numbers(table, where, "frequencies_hz", length=3)
        if not 0 < start < stop:
            raise read.fail(where, "frequencies_hz", "[start, stop, count] with 0 < start < stop (Hz)", value)
        if count > MAX_FREQUENCIES:
            raise read.fail(where, "frequencies_hz", f"[start, stop, count] with 2 ≤ count ≤ {MAX_FREQUENCIES}", value)
        grid = list(np.linspace(start, stop, int(count)))
    else:
        raise read.fail(where, "frequencies_hz", "[start, stop, count] (Hz, count ≥ 2) or {list = [f1, f2, …]}", value)
    if len(grid) > MAX_FREQUENCIES:
        raise read.fail(where, "frequencies_hz", f"at most {MAX_FREQUENCIES} frequencies, found {len(grid)}")
    if min(grid) <= 0:
        raise read.fail(where, "frequencies_hz", "frequencies > 0 Hz", value)
    return tuple(float(f) for f in grid)


#: What a study's measured files may be: the formats the readers take (a study naming
#: another kind of file is refused when read, so no step runs and no archive copies it).
MEASURED_SUFFIXES = (".parquet", ".csv", ".uff", ".unv", ".mat")


def read_measured(read: Reader, data: Mapping[str, Any], study_adapter: AdapterSpec | None) -> MeasuredSpec | None:
    table = read.table(data, "measured")
    if table is None:
        return None
    sources = [key for key in ("file", "files", "time_histories", "simulate") if key in table]
    if len(sources) != 1:
        raise read.fail("measured", None, "exactly one of file = \"<FRF table>\", files = {\"<file>\" = level, …}, "
                                          "time_histories = [\"<time record>\", …] or a [measured.simulate] table",
                        sources or None)
    statements = _measured_statements(read, table, sources[0])
    if "file" in table:
        file = read.path_of(read.string(table, "measured", "file", required=True))
        if not file.is_file() or file.suffix.lower() not in MEASURED_SUFFIXES:
            raise read.fail("measured", "file", f"an existing FRF table ({', '.join(MEASURED_SUFFIXES)})", str(file))
        return MeasuredSpec(file=str(file), **statements)
    if "files" in table:
        files = _measured_files(read, table["files"])
        in_files = {path: level for path, level in files if level is not None}
        for (key, level), name in zip(statements.get("levels", ()), table.get("levels", {})):
            if in_files.get(key, level) != level:
                raise read.fail("measured.levels", name, f"the level [measured] files gives the file "
                                                         f"({in_files[key]:g}), or none", level)
        return MeasuredSpec(files=files, **statements)
    if "time_histories" in table:
        written = read.strings(table, "measured", "time_histories", required=True)
        paths = []
        for name in written:
            path = read.path_of(name)
            if not path.is_file() or path.suffix.lower() not in MEASURED_SUFFIXES:
                raise read.fail("measured", "time_histories",
                                f"existing time-record files ({', '.join(MEASURED_SUFFIXES)})", name)
            paths.append(str(path))
        if not paths:
            raise read.fail("measured", "time_histories", "at least one time-record file", written)
        return MeasuredSpec(time_histories=tuple(paths), **statements)
    where = "measured.simulate"
    sim = read.table(table, where, required=True)
    has_model = "model" in sim
    if has_model and ({"adapter", "parameters", "loss_factor", "nonlinear"} & set(sim)):
        raise read.fail(where, "model", "either a model file or adapter/parameters/loss_factor/nonlinear, not both")
    forces = read.numbers(sim, where, "forces_n", required=True)
    if min(forces) <= 0 or len(set(forces)) != len(forces):
        raise read.fail(where, "forces_n", "distinct force amplitudes > 0 (N)", sim["forces_n"])
    noise = read.number(sim, where, "noise", 0.0, nonnegative=True)
    common = dict(
        input_dof=read.string(sim, where, "input_dof", required=True), forces_n=tuple(sorted(forces)),
        frequencies_hz=_grid(read, sim, where), noise=noise,
        seed=read.integer(sim, where, "seed", 0, minimum=0), sweep=read.string(sim, where, "sweep", "up", choices=("up", "down")),
    )
    if has_model:
        model = read.path_of(read.string(sim, where, "model", required=True))
        if not model.is_file() or model.suffix.lower() != ".toml":
            raise read.fail(where, "model", "an existing model file (.toml)", str(model))
        return MeasuredSpec(simulate=SimulationSpec(model_file=str(model), **common))
    adapter_table = read.table(sim, f"{where}.adapter")
    adapter = adapter_from(read, adapter_table, f"{where}.adapter") if adapter_table is not None else study_adapter
    if adapter is None:
        raise read.fail(where, None, "model = \"<model file>\", or the truth's FE model: a [measured.simulate.adapter] "
                                     "table or the study's [adapter]")
    elements = sim.get("nonlinear", [])
    if not isinstance(elements, list) or any(not isinstance(e, dict) for e in elements):
        raise read.fail(where, "nonlinear", "[[measured.simulate.nonlinear]] tables", elements)
    return MeasuredSpec(simulate=SimulationSpec(
        adapter=adapter, parameters=read.number_table(sim, where, "parameters"),
        loss_factor=read.number(sim, where, "loss_factor", 0.0, nonnegative=True), elements=tuple(elements), **common,
    ))


def _measured_statements(read: Reader, table: Mapping[str, Any], source: str) -> dict[str, Any]:
    """reference_unit, reference_calibration and the time-history keys of ``[measured]``."""
    out: dict[str, Any] = {}
    if "reference_unit" in table:
        out["reference_unit"] = read.string(table, "measured", "reference_unit", choices=("N", "V"))
    if "reference_calibration" in table:
        value = read.number(table, "measured", "reference_calibration", nonnegative=True)
        if not value > 0:
            raise read.fail("measured", "reference_calibration", "newtons per volt, a number > 0", value)
        if out.get("reference_unit", "V") != "V":
            raise read.fail("measured", "reference_calibration", "a voltage reference (reference_unit = \"V\")", value)
        out["reference_calibration"] = value
    if "coordinates" in table:
        out["coordinates"] = _measured_coordinates(read, table["coordinates"], source)
    if "levels" in table:
        out["levels"] = _measured_levels(read, table["levels"], source)
    history_keys = {"input_dof", "excitation", "response_quantity"} & set(table)
    if history_keys and source != "time_histories":
        raise read.fail("measured", sorted(history_keys)[0], "nothing: it applies to time_histories = [...]")
    if "input_dof" in table:
        out["input_dof"] = read.string(table, "measured", "input_dof")
    if "excitation" in table:
        out["excitation"] = read.string(table, "measured", "excitation",
                                        choices=("auto", "stepped_sine", "sine_sweep", "random", "burst"))
    if "response_quantity" in table:
        out["response_quantity"] = read.string(table, "measured", "response_quantity",
                                               choices=("displacement", "velocity", "acceleration"))
    return out


def _measured_coordinates(read: Reader, value: Any, source: str) -> tuple[tuple[str, tuple[str, str]], ...]:
    """``coordinates = { "runs.mat" = ["tip:-uz", "tip:uz"] }``: (response, input) of files
    that name none (MATLAB stepped-sine runs)."""
    if source not in ("file", "files"):
        raise read.fail("measured", "coordinates", "nothing: it applies to file = or files = measured FRFs", value)
    if not isinstance(value, dict) or not value:
        raise read.fail("measured", "coordinates", "a table \"<file>\" = [\"<response>\", \"<input>\"]", value)
    out = []
    for name, pair in value.items():
        if not (isinstance(pair, list) and len(pair) == 2 and all(isinstance(c, str) and c.strip() for c in pair)):
            raise read.fail("measured.coordinates", name, "[\"<response>\", \"<input>\"] (e.g. [\"tip:-uz\", \"tip:uz\"])",
                            pair)
        out.append((str(read.path_of(name, record=False)), (pair[0].strip(), pair[1].strip())))
    return tuple(out)


def _measured_levels(read: Reader, value: Any, source: str) -> tuple[tuple[str, float], ...]:
    """``levels = { "export.uff#Run 3" = 0.15, "Run 4" = 0.2, "b.uff" = 0.1 }``: the level (in
    the reference unit) of a file, of one run of a file (``FILE#RUN``) or of a run by its
    name, as ``--level`` takes them; a file name is resolved against the study's folder."""
    if source not in ("file", "files"):
        raise read.fail("measured", "levels", "nothing: it applies to file = or files = measured FRFs", value)
    if not isinstance(value, dict) or not value:
        raise read.fail("measured", "levels", "a table \"<file>\" | \"<file>#<run>\" | \"<run>\" = level", value)
    out = []
    for name, level in value.items():
        if isinstance(level, bool) or not isinstance(level, (int, float)) or not level > 0:
            raise read.fail("measured.levels", name, "a level > 0 in the reference unit", level)
        key = name
        file, sep, run = name.partition("#")
        if _existing_file(read, name) is not None:
            key = str(_existing_file(read, name))
        elif sep and file and _existing_file(read, file) is not None:
            key = f"{_existing_file(read, file)}#{run}"
        earlier = next((written for written, (k, v) in zip(value, out) if k == key and v != float(level)), None)
        if earlier is not None:
            raise read.fail("measured.levels", name, f"one level per file or run: {earlier!r} names the same one "
                                                     f"with {value[earlier]:g}", level)
        out.append((key, float(level)))
    return tuple(out)


def _existing_file(read: Reader, name: str):
    """The path of ``name`` when it names an existing file (None for a run name)."""
    try:  # not recorded as an input: the key refers to a file [measured] reads (or to a run)
        path = read.path_of(name, record=False)
    except StudyError:  # a rerun reads only the files kept with the study: a run name is none of them
        return None
    return path if path.is_file() else None


def _measured_files(read: Reader, value: Any) -> tuple[tuple[str, float | None], ...]:
    """``files = ["a.uff", …]`` (levels in the files) or ``{"a.uff" = 0.1, …}`` (levels given)."""
    if isinstance(value, list) and all(isinstance(v, str) for v in value) and value:
        entries = [(name, None) for name in value]
    elif isinstance(value, dict) and value:
        entries = []
        for name, level in value.items():
            if isinstance(level, bool) or not isinstance(level, (int, float)) or not level > 0:
                raise read.fail("measured.files", name, "a level > 0 in the reference unit", level)
            entries.append((name, float(level)))
    else:
        raise read.fail("measured", "files", "a list of files, or a table \"<file>\" = level", value)
    out = []
    for name, level in entries:
        path = read.path_of(name)
        if not path.is_file() or path.suffix.lower() not in MEASURED_SUFFIXES:
            raise read.fail("measured", "files", f"existing measured-FRF files ({', '.join(MEASURED_SUFFIXES)})", name)
        out.append((str(path), level))
    return tuple(out)


def read_identification(read: Reader, data: Mapping[str, Any]) -> IdentificationSettings | None:
    """The ``[identification]`` table, read by the settings' own declaration."""
    table = read.table(data, "identification")
    if table is None:
        return None
    try:
        return from_mapping(IdentificationSettings, table)
    except SettingError as error:
        raise read.fail("identification", error.key, error.expected, error.got) from None
    except ValueError as error:
        raise StudyError(f"{read.path}: [identification]: {error}") from None


def check_parameter_domain(read: Reader, spec: AdapterSpec, parameters: tuple[Parameter, ...],
                            fixed: Mapping[str, float]) -> None:
    """Every updated and fixed parameter is one the model has, and every bound a value it
    can take (with the others at their start): checked now, not part-way through a run."""
    try:
        adapter = build_adapter(spec)
    except ValueError as error:
        raise StudyError(f"{read.path}: [adapter]: {error}") from None
    known = list(adapter.parameter_names)
    for p in parameters:
        if p.name not in known:
            raise read.fail("[parameters]", "name", f"a parameter of the {adapter.name} model ({', '.join(known)})", p.name)
    for name in fixed:
        if name not in known:
            raise read.fail("adapter.fixed", name, f"a parameter of the {adapter.name} model ({', '.join(known)})")
    for name, value in fixed.items():  # each on the model's defaults: a fixed value is not a parameter's fault
        try:
            adapter.check_values({name: value})
        except ValueError as error:
            raise read.fail("adapter.fixed", name, f"a value the {adapter.name} model can take ({error})",
                            value) from None
    start = {**fixed, **{p.name: p.start for p in parameters}}
    for p in parameters:
        for bound, value in (("start", p.start), ("lower", p.lower), ("upper", p.upper)):
            try:
                adapter.check_values({**start, p.name: value})
            except ValueError as error:
                raise StudyError(f"{read.path}: [[parameters]] '{p.name}': {bound} = {value:g} is a value the "
                                 f"{adapter.name} model cannot take ({error})") from None


#: The most [[parameters]] and target modes a study may hold: updating solves the FE model once
#: per parameter and step, and pairs every target with the model's modes (more is a mistake).
MAX_PARAMETERS = 1_000
MAX_TARGETS = 1_000


def read_parameters(read: Reader, data: Mapping[str, Any]) -> tuple[Parameter, ...]:
    entries = data.get("parameters")
    if not isinstance(entries, list) or not entries or any(not isinstance(e, dict) for e in entries):
        raise StudyError(f"{read.path}: expected one or more [[parameters]] tables (name, unit, start, lower, upper)")
    if len(entries) > MAX_PARAMETERS:
        raise StudyError(f"{read.path}: {len(entries)} [[parameters]] tables; expected at most {MAX_PARAMETERS} (each "
                         f"costs one FE solve per sensitivity step)")
    parameters = []
    for i, entry in enumerate(entries):
        where = f"parameters #{i + 1}"
        read.check_keys(entry, where, "parameters")
        name = read.string(entry, where, "name", required=True)
        unit = read.string(entry, where, "unit", default="")
        values = {key: read.number(entry, where, key, required=True) for key in ("start", "lower", "upper")}
        step = read.number(entry, where, "relative_step", 1e-3, positive=True)
        if not values["lower"] < values["upper"]:
            raise read.fail(where, "upper", f"a value above lower = {values['lower']}", values["upper"])
        try:
            parameters.append(Parameter(name, unit, values["start"], values["lower"], values["upper"], step))
        except ValueError as error:
            raise StudyError(f"{read.path}: [{where}]: {error}") from None
    names = [p.name for p in parameters]
    duplicates = sorted({n for n in names if names.count(n) > 1})
    if duplicates:
        raise read.fail("parameters", "name", "distinct parameter names", duplicates)
    return tuple(parameters)


def _check_subset(read: Reader, where: str, key: str, subset: list[str], names: list[str]) -> None:
    unknown = [n for n in subset if n not in names]
    if unknown or len(set(subset)) != len(subset):
        raise read.fail(where, key, f"distinct names of [[parameters]] {names}", subset)


def read_targets(read: Reader, targets: Mapping[str, Any],
                 identification: IdentificationSettings | None) -> tuple[TargetsSpec, int]:
    """The [targets] table, checked, and the number of target modes (−1: all modes the
    identification finds, known only after it ran)."""
    where = "targets"
    sources = [key for key in ("frequencies_hz", "identification", "from_identification", "amplitude_models")
               if key in targets]
    if len(sources) != 1:
        raise read.fail(where, None, "exactly one of frequencies_hz = [...] (Hz), from_identification = true, "
                                     "identification = \"<identify output>\" or amplitude_models = [\"<model.json>\", …]",
                        sources or None)
    source = sources[0]
    if source != "frequencies_hz" and "std_hz" in targets:
        raise read.fail(where, "std_hz", "nothing: target uncertainties come from the identification")
    if source == "frequencies_hz":
        if isinstance(targets["frequencies_hz"], list) and len(targets["frequencies_hz"]) > MAX_TARGETS:
            raise read.fail(where, "frequencies_hz", f"at most {MAX_TARGETS} target modes, "
                                                     f"found {len(targets['frequencies_hz'])}")
        frequencies = read.numbers(targets, where, "frequencies_hz", required=True)
        n = len(frequencies)
        if any(f <= 0 for f in frequencies) or any(b <= a for a, b in zip(frequencies, frequencies[1:])):
            raise read.fail(where, "frequencies_hz", "increasing natural frequencies > 0 Hz, each once (mode by mode; "
                                                     "pair them with model modes through model_modes)", frequencies)
        read.numbers(targets, where, "std_hz", length=n)
    elif source == "amplitude_models":
        paths = read.strings(targets, where, "amplitude_models")
        if not paths:
            raise read.fail(where, "amplitude_models", "a list of amplitude-dependent modal model files (JSON), one per "
                                                       "target mode", targets["amplitude_models"])
        for written in paths:
            if not read.path_of(written).is_file():
                raise read.fail(where, "amplitude_models", "existing amplitude-dependent modal model files (JSON)",
                                written)
        n = len(paths)
    elif source == "from_identification":
        if read.boolean(targets, where, "from_identification", False) is not True:
            raise read.fail(where, "from_identification", "true (or leave the key out)", False)
        if identification is None:
            raise read.fail(where, "from_identification", "an [identification] table to take the targets from")
        modes = targets.get("modes")
        if modes is not None and (not isinstance(modes, list) or not modes
                                  or any(isinstance(m, bool) or not isinstance(m, int) or m < 1 for m in modes)
                                  or any(b <= a for a, b in zip(modes, modes[1:]))):
            raise read.fail(where, "modes", "a list of mode numbers ≥ 1 (of the extracted linear FRF, ascending, "
                                            "each once)", modes)
        n = len(modes) if modes is not None else -1
    else:
        written = read.string(targets, where, "identification", required=True)
        if not read.path_of(written).exists():
            raise read.fail(where, "identification", "an existing identify output (folder, .json or FRF table)",
                            written)
        n = read.integer(targets, where, "n_modes")
        if n is None:
            raise read.fail(where, "n_modes", "the number of peaks to pick from the identified FRF (integer ≥ 1)")
        for key in ("response_dof", "input_dof"):
            read.string(targets, where, key, required=True)
        if "band_hz" in targets:
            low, high = read.numbers(targets, where, "band_hz", length=2)
            if not 0 <= low < high:
                raise read.fail(where, "band_hz", "[low, high] with 0 ≤ low < high (Hz)", targets["band_hz"])
        read.number(targets, where, "force_level_n", positive=True)
        read.string(targets, where, "frf_method", choices=FRF_METHODS)
    if n > MAX_TARGETS:
        key = {"from_identification": "modes", "identification": "n_modes"}.get(source, source)
        raise read.fail(where, key, f"at most {MAX_TARGETS} target modes, found {n}")
    if source != "identification":
        for key in ("n_modes", "band_hz", "force_level_n", "frf_method"):
            if key in targets:
                raise read.fail(where, key, "nothing: it applies to identification = \"<identify output>\"")
    if source != "from_identification" and "modes" in targets:
        raise read.fail(where, "modes", "nothing: it applies to from_identification = true")
    for key in ("response_dof", "input_dof", "model_response_dof", "model_input_dof"):
        read.string(targets, where, key)
    if n > 0:
        read.numbers(targets, where, "weights", length=n)
        labels = read.strings(targets, where, "labels")
        if labels is not None and len(labels) != n:
            raise read.fail(where, "labels", f"{n} names", labels)
    elif any(key in targets for key in ("weights", "labels", "model_modes", "mode_shapes")):
        raise read.fail(where, "modes", "the list of modes to take (weights, labels, model_modes and mode_shapes "
                                        "are given per target mode)")
    if "model_modes" in targets:
        modes = targets["model_modes"]
        if (not isinstance(modes, list) or len(modes) != n
                or any(isinstance(m, bool) or not isinstance(m, int) or m < 1 for m in modes)
                or len(set(modes)) != len(modes)):
            raise read.fail(where, "model_modes", f"a list of {n} distinct mode numbers ≥ 1", modes)
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

    def numbers(key: str) -> tuple | None:
        return None if key not in targets else tuple(float(v) for v in targets[key])

    spec = TargetsSpec(
        frequencies_hz=numbers("frequencies_hz"), std_hz=numbers("std_hz"),
        from_identification=bool(targets.get("from_identification", False)),
        modes=None if "modes" not in targets else tuple(targets["modes"]), identification=targets.get("identification"),
        n_modes=targets.get("n_modes"), band_hz=numbers("band_hz"),
        force_level_n=None if "force_level_n" not in targets else float(targets["force_level_n"]),
        frf_method=targets.get("frf_method", TargetsSpec.frf_method),
        amplitude_models=tuple(targets.get("amplitude_models", ())),
        **{key: targets.get(key) for key in ("response_dof", "input_dof", "model_response_dof", "model_input_dof")},
        weights=numbers("weights"), labels=tuple(targets.get("labels", ())), model_modes=tuple(targets.get("model_modes", ())),
        coordinates=tuple(targets.get("coordinates", ())),
        mode_shapes=None if "mode_shapes" not in targets else tuple(tuple(float(v) for v in row)
                                                                     for row in targets["mode_shapes"]),
    )
    return spec, n


def read_updating(read: Reader, data: Mapping[str, Any]) -> ResponseOptions:
    """``[updating]``: pairing and mode-shape settings shared by every run."""
    table = read.table(data, "updating") or {}
    where = "updating"
    return ResponseOptions(
        pairing=read.string(table, where, "pairing", ResponseOptions.pairing, choices=PAIRING_METHODS),
        min_mac=read.number(table, where, "min_mac", ResponseOptions.min_mac, nonnegative=True),
        use_mode_shapes=read.boolean(table, where, "use_mode_shapes", ResponseOptions.use_mode_shapes),
        mode_shape_weight=read.number(table, where, "mode_shape_weight", ResponseOptions.mode_shape_weight,
                                      nonnegative=True),
    )


def _shared(updating: ResponseOptions) -> dict[str, Any]:
    """The ``[updating]`` settings every method takes (not the formula, set per run)."""
    return {f.name: getattr(updating, f.name) for f in dataclasses.fields(ResponseOptions) if f.name != "formula"}


def read_eigensensitivity(read: Reader, data: Mapping[str, Any], names: list[str],
                          updating: ResponseOptions) -> EigensensitivitySpec | None:
    table = read.table(data, "eigensensitivity")
    if table is None:
        return None
    where = "eigensensitivity"
    formulas = read.strings(table, where, "formulas") or ["forward"]
    if [f for f in formulas if f not in FORMULAS] or len(set(formulas)) != len(formulas):
        raise read.fail(where, "formulas", f"distinct names from {list(FORMULAS)}", formulas)
    if "parameters" in table and "parameter_sets" in table:
        raise read.fail(where, "parameter_sets", "either parameters = [...] (one set) or parameter_sets, not both")
    if "parameter_sets" in table:
        sets = table["parameter_sets"]
        if not isinstance(sets, list) or not sets or any(not isinstance(s, list) or not s for s in sets):
            raise read.fail(where, "parameter_sets", "a list of non-empty lists of parameter names", sets)
    else:
        sets = [read.strings(table, where, "parameters") or names]
    for subset in sets:
        _check_subset(read, where, "parameter_sets" if "parameter_sets" in table else "parameters", subset, names)
    if len({tuple(s) for s in sets}) != len(sets):
        raise read.fail(where, "parameter_sets", "distinct parameter sets", sets)
    defaults = EigensensitivityOptions
    options = EigensensitivityOptions(
        max_iterations=read.integer(table, where, "max_iterations", defaults.max_iterations),
        frequency_tolerance=read.number(table, where, "frequency_tolerance", defaults.frequency_tolerance, positive=True),
        parameter_tolerance=read.number(table, where, "parameter_tolerance", defaults.parameter_tolerance, positive=True),
        regularisation=read.number(table, where, "regularisation", defaults.regularisation, nonnegative=True),
        max_step=read.number(table, where, "max_step", defaults.max_step, positive=True),
        step_control=read.string(table, where, "step_control", defaults.step_control, choices=STEP_CONTROLS),
        **_shared(updating),
    )
    return EigensensitivitySpec(tuple(formulas), tuple(tuple(s) for s in sets), options)


def read_optimisation(read: Reader, data: Mapping[str, Any], names: list[str], n_targets: int,
                      updating: ResponseOptions) -> tuple[OptimisationOptions | None, tuple[CandidateEntry, ...]]:
    """``[optimisation]`` and its ``[[optimisation.candidates]]``."""
    table = read.table(data, "optimisation")
    if table is None:
        return None, ()
    where = "optimisation"
    defaults = OptimisationOptions
    options = OptimisationOptions(
        method=read.string(table, where, "method", defaults.method, choices=OPTIMISATION_METHODS),
        formula=read.string(table, where, "formula", defaults.formula, choices=tuple(FORMULAS)),
        max_evaluations=read.integer(table, where, "max_evaluations", defaults.max_evaluations),
        ftol=read.number(table, where, "ftol", defaults.ftol, positive=True),
        xtol=read.number(table, where, "xtol", defaults.xtol, positive=True),
        gtol=read.number(table, where, "gtol", defaults.gtol, positive=True), **_shared(updating),
    )
    entries = table.get("candidates")
    if not isinstance(entries, list) or not entries or any(not isinstance(e, dict) for e in entries):
        raise read.fail(where, "candidates", "one or more [[optimisation.candidates]] tables (name, parameters)")
    candidates = []
    for i, entry in enumerate(entries):
        at = f"optimisation.candidates #{i + 1}"
        read.check_keys(entry, at, "optimisation.candidates")
        subset = read.strings(entry, at, "parameters", required=True)
        _check_subset(read, at, "parameters", subset, names)
        if "weights" in entry and n_targets < 0:
            raise read.fail(at, "weights", "a [targets] modes = [...] list first (the number of target modes)")
        weights = read.numbers(entry, at, "weights", length=n_targets)
        start = read.number_table(entry, at, "start")
        _check_subset(read, at, "start", list(start), subset)
        name = read.string(entry, at, "name", default=f"candidate {i + 1}")
        candidates.append(CandidateEntry(name, tuple(subset), tuple(weights) if weights else None, start))
    run_names = [c.name for c in candidates]
    if len(set(run_names)) != len(run_names) or "initial" in run_names:
        raise read.fail("optimisation.candidates", "name", "distinct names, not 'initial'", run_names)
    return options, tuple(candidates)


def read_comparison(read: Reader, data: Mapping[str, Any], labels: list[str], n_targets: int) -> ComparisonSpec:
    """``[comparison]``."""
    table = read.table(data, "comparison") or {}
    where = "comparison"
    length = max(n_targets, 1)
    weights = table.get("user_weights")
    if isinstance(weights, dict):
        weights = read.number_table(table, where, "user_weights")
        unknown = sorted(set(weights) - set(labels))
        if unknown and n_targets > 0:
            raise read.fail(where, "user_weights", f"weights of target modes {labels}", unknown)
    elif weights is not None:
        weights = tuple(read.numbers(table, where, "user_weights", length=n_targets if n_targets > 0 else None))

    def scalar_or_tuple(key: str) -> float | tuple[float, ...] | None:
        value = read.scalar_or_numbers(table, where, key, None, length)
        return tuple(value) if isinstance(value, list) else value

    return ComparisonSpec(
        user_weights=weights, damping_ratios=scalar_or_tuple("damping_ratios"),
        loss_factors=scalar_or_tuple("loss_factors"),
        band_fraction=read.number(table, where, "band_fraction", ComparisonSpec.band_fraction, positive=True),
        frf=str(read.path_of(table["frf"])) if read.string(table, where, "frf") else None,
    )


def read_prediction(read: Reader, data: Mapping[str, Any], identification: IdentificationSettings | None,
                     adapter: AdapterSpec | None) -> PredictionSpec | None:
    table = read.table(data, "prediction")
    if table is None:
        return None
    where = "prediction"
    if identification is None or adapter is None:
        raise read.fail(where, None, "an [identification] (the elements) and an [adapter] (the updated linear model) "
                                     "to predict with")
    levels = read.numbers(table, where, "force_levels_n")
    if levels is not None and min(levels) <= 0:
        raise read.fail(where, "force_levels_n", "force amplitudes > 0 (N)", levels)
    candidates: str | tuple[str, ...] = "best"
    if "candidates" in table:
        value = table["candidates"]
        if isinstance(value, str) and value in ("best", "all"):
            candidates = value
        elif isinstance(value, list):
            candidates = tuple(read.strings(table, where, "candidates"))
        else:
            raise read.fail(where, "candidates", "\"best\", \"all\" or a list of run names", value)
    loss_factor: str | float = "low_force_fit"
    if "loss_factor" in table:
        value = table["loss_factor"]
        if isinstance(value, str):
            loss_factor = read.string(table, where, "loss_factor", choices=LOSS_FACTOR_SOURCES)
        else:
            loss_factor = read.number(table, where, "loss_factor", nonnegative=True)
    overrides = table.get("adapter_options", {})
    if not isinstance(overrides, dict):
        raise read.fail(where, "adapter_options", "a table of adapter constructor options", overrides)
    return PredictionSpec(
        force_levels_n=None if levels is None else tuple(sorted(levels)), candidates=candidates, loss_factor=loss_factor,
        sweep=read.string(table, where, "sweep", "up", choices=("up", "down")), adapter_options=overrides,
        harmonic_balance=_read_response_method(read, table, where),
    )


def _read_response_method(read: Reader, table: Mapping[str, Any], where: str) -> HarmonicSettings | None:
    """``method`` with, for ``"hb"``, ``harmonics``, ``samples`` and ``stability``: None for the
    describing-function continuation, else the harmonic balance settings."""
    method = read.string(table, where, "method", "continuation", choices=RESPONSE_METHODS)
    if method != "hb":
        for key in ("harmonics", "samples", "stability"):
            if key in table:
                raise read.fail(where, key, 'nothing unless method = "hb" (harmonic balance)', table[key])
        return None
    harmonics = table.get("harmonics", HarmonicSettings.harmonics)
    if not valid_harmonics(harmonics):
        raise read.fail(where, "harmonics", f"{HARMONICS_FORM} (harmonics of the balance)", harmonics)
    samples = table.get("samples")
    if not valid_samples(samples, harmonics):
        raise read.fail(where, "samples", samples_form(harmonics), samples)
    return HarmonicSettings(harmonics=harmonics, samples=samples, stability=read.boolean(table, where, "stability", True))


def read_validation(read: Reader, data: Mapping[str, Any], measured: Any) -> ValidationSpec | None:
    """``[validation]`` (:class:`~nlupdate.study.spec.ValidationSpec`); it needs measured data."""
    table = read.table(data, "validation")
    if table is None:
        return None
    where = "validation"
    if measured is None:
        raise read.fail(where, None, "a [measured] table: the levels to hold out")
    hold_out: str | tuple[float, ...] = "each"
    if "hold_out" in table:
        value = table["hold_out"]
        if isinstance(value, str) and value in ("each", "top"):
            hold_out = value
        elif isinstance(value, list) and value and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                                       and v > 0 for v in value):
            hold_out = tuple(float(v) for v in value)
        else:
            raise read.fail(where, "hold_out", '"each", "top" or a list of measured levels > 0', value)
    models = tuple(read.strings(table, where, "models")) if "models" in table else ("auto",)
    for name in models:
        if name != "auto":
            try:
                model_fitter(name)
            except ValueError as error:
                raise read.fail(where, "models", str(error).split(": expected ", 1)[1], name) from None
    return ValidationSpec(hold_out=hold_out, models=models or ("auto",),
                          input_dof=read.string(table, where, "input_dof") if "input_dof" in table else None,
                          response_controlled=read.boolean(table, where, "response_controlled", True))
