"""Reading the tables of the FE model a study updates: ``[adapter]``, ``[[parameters]]`` (each
checked by its declaration, :mod:`nlupdate.study.declared`), the parameters' domain in the
model, and ``[targets]`` (its sources and the keys that go with each). Every mistake is one
line naming the file, the table, the key and the expected form."""
from __future__ import annotations

from typing import Any, Mapping

from nlupdate.core.identification.settings import IdentificationSettings
from nlupdate.core.updating.targets import FRF_METHODS
from nlupdate.fe.adapters.base import Parameter
from nlupdate.fe.adapters.registry import AdapterSpec, build_adapter
from nlupdate.study.declared import build, classes, read_declared
from nlupdate.study.reader import Reader, StudyError
from nlupdate.study.spec import TargetsSpec

#: The most [[parameters]] and target modes a study may hold: updating solves the FE model once
#: per parameter and step, and pairs every target with the model's modes (more is a mistake).
MAX_PARAMETERS = 1_000
MAX_TARGETS = 1_000


def adapter_from(read: Reader, table: Mapping[str, Any], where: str,
                 declared: str = "measured.simulate.adapter") -> tuple[AdapterSpec, dict[str, Any]]:
    """The FE model a table names (``declared``: its entry in the declared tables), and the
    table's values."""
    values = read_declared(read, table, where, declared)
    kind, model = values["kind"], values.get("model")
    if kind in ("surrogate", "calculix") and model is None:
        raise read.fail(where, "model", f"a model name for kind {kind!r} (e.g. 'tbeam')")
    options = values.get("options", {})
    if kind == "mapdl":
        deck = read.string(options, f"{where}.options", "deck", required=True)
        options = {**options, "deck": str(read.path_of(deck))}
    try:
        return AdapterSpec(kind, model, options), values
    except ValueError as error:
        raise StudyError(f"{read.path}: [{where}]: {error}") from None


def read_adapter(read: Reader, data: Mapping[str, Any]) -> tuple[AdapterSpec, dict[str, float]]:
    """``[adapter]``: the FE model and the parameters it holds fixed."""
    spec, values = adapter_from(read, read.table(data, "adapter", required=True), "adapter", "adapter")
    return spec, values.get("fixed", {})


def read_parameters(read: Reader, data: Mapping[str, Any]) -> tuple[Parameter, ...]:
    """The ``[[parameters]]`` tables, each by its declaration (:class:`~nlupdate.study.spec.ParameterEntry`)."""
    entries = data.get("parameters")
    if not isinstance(entries, list) or not entries or any(not isinstance(e, dict) for e in entries):
        raise StudyError(f"{read.path}: expected one or more [[parameters]] tables (name, unit, start, lower, upper)")
    if len(entries) > MAX_PARAMETERS:
        raise StudyError(f"{read.path}: {len(entries)} [[parameters]] tables; expected at most {MAX_PARAMETERS} (each "
                         f"costs one FE solve per sensitivity step)")
    (entry_class,) = classes("parameters")
    parameters = []
    for i, entry in enumerate(entries):
        where = f"parameters #{i + 1}"
        read.check_keys(entry, where, "parameters")
        values = build(read, where, entry_class, read_declared(read, entry, where, "parameters"))
        if not values.lower < values.upper:
            raise read.fail(where, "upper", f"a value above lower = {values.lower}", values.upper)
        try:
            parameters.append(values.parameter())
        except ValueError as error:
            raise StudyError(f"{read.path}: [{where}]: {error}") from None
    names = [p.name for p in parameters]
    duplicates = sorted({n for n in names if names.count(n) > 1})
    if duplicates:
        raise read.fail("parameters", "name", "distinct parameter names", duplicates)
    return tuple(parameters)


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
