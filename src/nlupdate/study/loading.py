"""Loading a study file: :func:`load_study`, :func:`study_from_text`."""
from __future__ import annotations

import os
from pathlib import Path
from typing import Mapping

from nlupdate.files import MAX_NAME, name_problem
from nlupdate.input_files import parse_toml, read_input_text
from nlupdate.study import sections
from nlupdate.study.declared import build, classes, read_declared
from nlupdate.study.measured_section import read_measured
from nlupdate.study.model_sections import check_parameter_domain, read_adapter, read_parameters, read_targets
from nlupdate.study.fe_validation import read_fe_validation
from nlupdate.study.reader import Reader, StudyError
from nlupdate.study.spec import Study

def load_study(path: str | os.PathLike) -> Study:
    """Read and check a study file; raises :class:`StudyError` or FileNotFoundError."""
    path = Path(path)
    return study_from_text(read_input_text(path, "study file"), path)


def study_from_text(text: str, path: str | os.PathLike, redirect: Mapping[str, Path] | None = None,
                    redirect_only: bool = False) -> Study:
    """Parse and check study ``text``; ``path`` names it in errors and anchors relative paths.

    ``redirect``: files to read instead of those the study names (path as written → path),
    e.g. the copies kept in a run archive; with ``redirect_only`` no other file is read."""
    path = Path(path)
    data = parse_toml(text, path, StudyError)
    read = Reader(path, sections.ALLOWED, redirect, redirect_only)
    for (table, key), hint in sections.MOVED.items():
        if isinstance(data.get(table), dict) and key in data[table]:
            raise read.fail(table, key, f"nothing: this key was removed ({hint})", data[table][key])
    read.check_keys(data, "")
    meta = read.table(data, "study") or {}
    (info_class,) = classes("study")
    info = build(read, "study", info_class, read_declared(read, meta, "study"))
    name = info.name if info.name is not None else path.stem
    problem = name_problem(name)
    if problem is not None:
        if "name" in meta:
            raise read.fail("study", "name", f"one folder name (printable, at most {MAX_NAME} characters, no '/' "
                                             f"or '\\', not starting with '.'), not {problem}", name)
        raise StudyError(f"{path}: the study is named after its file, {name!r}, which is {problem}; give it a "
                         f"[study] name")
    description = info.description

    adapter, fixed, parameters = None, {}, ()
    if "adapter" in data:
        adapter, fixed = read_adapter(read, data)
        parameters = read_parameters(read, data)
        overlap = sorted({p.name for p in parameters} & set(fixed))
        if overlap:
            raise read.fail("adapter.fixed", overlap[0], "parameters that are not also updated ([[parameters]])")
        check_parameter_domain(read, adapter, parameters, fixed)
    elif "parameters" in data or "targets" in data:
        raise StudyError(f"{path}: [[parameters]] and [targets] need an [adapter] table (the FE model to update)")

    measured = read_measured(read, data, adapter)
    identification = sections.read_identification(read, data)
    names = [p.name for p in parameters]

    table = read.table(data, "targets")
    targets, n_targets = None, 0
    if adapter is not None:
        if table is None:
            raise StudyError(f"{path}: missing table [targets] (what the updated model must match)")
        targets, n_targets = read_targets(read, table, identification)
    labels = list(targets.labels) if targets is not None and targets.labels else [
        f"mode{i + 1}" for i in range(max(n_targets, 0))]

    updating = sections.read_updating(read, data)
    eigensensitivity = sections.read_eigensensitivity(read, data, names, updating)
    optimisation, candidates = sections.read_optimisation(read, data, names, n_targets, updating)
    if adapter is not None and eigensensitivity is None and optimisation is None:
        raise StudyError(f"{path}: an [adapter] needs an [eigensensitivity] table, an [optimisation] table or both")
    comparison = sections.read_comparison(read, data, labels, n_targets)
    prediction = sections.read_prediction(read, data, identification, adapter)
    validation = sections.read_validation(read, data, measured)
    fe_validation = read_fe_validation(read, data, adapter, validation)
    amplitude = sections.read_amplitude(read, data, measured)
    if measured is None and identification is not None:
        raise StudyError(f"{path}: [identification] needs measured data: a [measured] table (file or simulate)")
    if adapter is None and measured is None and amplitude is None:
        raise StudyError(f"{path}: nothing to do: give [measured] data to identify, an [adapter] to update and/or "
                         f"[amplitude] tests of one mode")
    return Study(
        path=path, name=name, description=description, text=text, measured=measured, identification=identification,
        adapter=adapter, fixed=fixed, parameters=parameters, targets=targets, updating=updating,
        eigensensitivity=eigensensitivity, optimisation=optimisation, candidates=candidates, comparison=comparison,
        prediction=prediction, validation=validation, fe_validation=fe_validation, amplitude=amplitude,
        input_files=dict(read.files),
    )
