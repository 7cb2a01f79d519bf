"""Reading a study's ``[measured]`` table: which measurement (one file, several files with
their levels, time histories, or a simulated test on a hidden truth, ``[measured.simulate]``)
and the statements about it (reference unit and calibration, coordinates and levels of files
that do not hold them). Each source takes its own keys; every mistake is one line naming the
file, the table, the key, the expected form and what was found."""
from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from nlupdate.core.response.method import MAX_FREQUENCIES
from nlupdate.fe.adapters.registry import AdapterSpec
from nlupdate.study.declared import read_declared
from nlupdate.study.model_sections import adapter_from
from nlupdate.study.reader import Reader, StudyError
from nlupdate.study.spec import MeasuredSpec, SimulationSpec


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
    """``[measured]``: each key by its declaration (:class:`~nlupdate.study.table_keys.MeasuredTable`),
    then its one source, the files it names (existing, of a format the readers take) and the
    statements that go with that source."""
    table = read.table(data, "measured")
    if table is None:
        return None
    sources = [key for key in ("file", "files", "time_histories", "simulate") if key in table]
    if len(sources) != 1:
        raise read.fail("measured", None, "exactly one of file = \"<FRF table>\", files = {\"<file>\" = level, …}, "
                                          "time_histories = [\"<time record>\", …] or a [measured.simulate] table",
                        sources or None)
    values = read_declared(read, table, "measured")
    statements = _measured_statements(read, values, sources[0])
    if "file" in values:
        file = read.path_of(values["file"])
        if not file.is_file() or file.suffix.lower() not in MEASURED_SUFFIXES:
            raise read.fail("measured", "file", f"an existing FRF table ({', '.join(MEASURED_SUFFIXES)})", str(file))
        return MeasuredSpec(file=str(file), **statements)
    if "files" in values:
        files = _measured_files(read, values["files"])
        in_files = {path: level for path, level in files if level is not None}
        for (key, level), name in zip(statements.get("levels", ()), values.get("levels", {})):
            if in_files.get(key, level) != level:
                raise read.fail("measured.levels", name, f"the level [measured] files gives the file "
                                                         f"({in_files[key]:g}), or none", level)
        return MeasuredSpec(files=files, **statements)
    if "time_histories" in values:
        paths = []
        for name in values["time_histories"]:
            path = read.path_of(name)
            if not path.is_file() or path.suffix.lower() not in MEASURED_SUFFIXES:
                raise read.fail("measured", "time_histories",
                                f"existing time-record files ({', '.join(MEASURED_SUFFIXES)})", name)
            paths.append(str(path))
        return MeasuredSpec(time_histories=tuple(paths), **statements)
    return MeasuredSpec(simulate=_read_simulation(read, table, study_adapter))


def _read_simulation(read: Reader, table: Mapping[str, Any], study_adapter: AdapterSpec | None) -> SimulationSpec:
    """``[measured.simulate]``: each key by its declaration (:class:`~nlupdate.study.table_keys.SimulationTable`),
    then the truth — a model file, or an FE model (its own table, else the study's) — and the
    test's forces and frequency grid."""
    where = "measured.simulate"
    sim = read.table(table, where, required=True)
    values = read_declared(read, sim, where)
    if "model" in values and ({"adapter", "parameters", "loss_factor", "nonlinear"} & set(sim)):
        raise read.fail(where, "model", "either a model file or adapter/parameters/loss_factor/nonlinear, not both")
    forces = values["forces_n"]
    if min(forces) <= 0 or len(set(forces)) != len(forces):
        raise read.fail(where, "forces_n", "distinct force amplitudes > 0 (N)", sim["forces_n"])
    common = dict(input_dof=values["input_dof"], forces_n=tuple(sorted(forces)), frequencies_hz=_grid(read, sim, where),
                  **{key: values[key] for key in ("noise", "seed", "sweep") if key in values})
    if "model" in values:
        model = read.path_of(values["model"])
        if not model.is_file() or model.suffix.lower() != ".toml":
            raise read.fail(where, "model", "an existing model file (.toml)", str(model))
        return SimulationSpec(model_file=str(model), **common)
    adapter_table = read.table(sim, f"{where}.adapter")
    adapter = adapter_from(read, adapter_table, f"{where}.adapter")[0] if adapter_table is not None else study_adapter
    if adapter is None:
        raise read.fail(where, None, "model = \"<model file>\", or the truth's FE model: a [measured.simulate.adapter] "
                                     "table or the study's [adapter]")
    return SimulationSpec(adapter=adapter, elements=values.get("nonlinear", ()), **common,
                          **{key: values[key] for key in ("parameters", "loss_factor") if key in values})


def _measured_statements(read: Reader, values: Mapping[str, Any], source: str) -> dict[str, Any]:
    """reference_unit, reference_calibration, coordinates, levels and the time-history keys
    of ``[measured]`` (its declared values), each where its source takes it."""
    out: dict[str, Any] = {key: values[key] for key in ("reference_unit", "reference_calibration") if key in values}
    if "reference_calibration" in out and out.get("reference_unit", "V") != "V":
        raise read.fail("measured", "reference_calibration", "a voltage reference (reference_unit = \"V\")",
                        out["reference_calibration"])
    if "coordinates" in values:
        out["coordinates"] = _measured_coordinates(read, values["coordinates"], source)
    if "levels" in values:
        out["levels"] = _measured_levels(read, values["levels"], source)
    history_keys = {"input_dof", "excitation", "response_quantity"} & set(values)
    if history_keys and source != "time_histories":
        raise read.fail("measured", sorted(history_keys)[0], "nothing: it applies to time_histories = [...]")
    out.update({key: values[key] for key in history_keys})
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


def _measured_files(read: Reader, value: tuple[str, ...] | Mapping[str, float]) -> tuple[tuple[str, float | None], ...]:
    """``files = ["a.uff", …]`` (levels in the files) or ``{"a.uff" = 0.1, …}`` (levels given),
    as declared: each level > 0, each file existing and of a format the readers take."""
    if not value:
        raise read.fail("measured", "files", "a list of files, or a table \"<file>\" = level", value)
    if isinstance(value, Mapping):
        for name, level in value.items():
            if not level > 0:
                raise read.fail("measured.files", name, "a level > 0 in the reference unit", level)
    entries = list(value.items()) if isinstance(value, Mapping) else [(name, None) for name in value]
    out = []
    for name, level in entries:
        path = read.path_of(name)
        if not path.is_file() or path.suffix.lower() not in MEASURED_SUFFIXES:
            raise read.fail("measured", "files", f"existing measured-FRF files ({', '.join(MEASURED_SUFFIXES)})", name)
        out.append((str(path), level))
    return tuple(out)
