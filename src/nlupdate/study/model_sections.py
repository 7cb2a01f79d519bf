"""Reading the tables of the FE model a study updates: ``[adapter]``, ``[[parameters]]`` (each
checked by its declaration, :mod:`nlupdate.study.declared`), the parameters' domain in the
model, and ``[targets]`` (its sources and the keys that go with each). Every mistake is one
line naming the file, the table, the key and the expected form."""
from __future__ import annotations

from typing import Any, Mapping

from nlupdate.core.identification.settings import IdentificationSettings
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
    """The [targets] table — each key by its declaration (:class:`~nlupdate.study.spec.TargetsSpec`),
    then its one source and the keys that go with it — and the number of target modes (−1:
    all modes the identification finds, known only after it ran)."""
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
    if isinstance(targets[source], list) and len(targets[source]) > MAX_TARGETS:
        raise read.fail(where, source, f"at most {MAX_TARGETS} target modes, found {len(targets[source])}")
    values = read_declared(read, targets, where)
    n = _source_modes(read, values, source, identification)
    if n > MAX_TARGETS:
        key = {"from_identification": "modes", "identification": "n_modes"}.get(source, source)
        raise read.fail(where, key, f"at most {MAX_TARGETS} target modes, found {n}")
    if source != "identification":
        for key in ("n_modes", "band_hz", "force_level_n", "frf_method"):
            if key in targets:
                raise read.fail(where, key, "nothing: it applies to identification = \"<identify output>\"")
    if source != "from_identification" and "modes" in targets:
        raise read.fail(where, "modes", "nothing: it applies to from_identification = true")
    _per_mode(read, values, n)
    return build(read, where, TargetsSpec, values), n


def _source_modes(read: Reader, values: Mapping[str, Any], source: str,
                  identification: IdentificationSettings | None) -> int:
    """The number of target modes ``[targets]``'s source gives (−1: not known before the
    identification ran), its own keys checked."""
    where = "targets"
    if source == "frequencies_hz":
        frequencies = values["frequencies_hz"]
        if any(f <= 0 for f in frequencies) or any(b <= a for a, b in zip(frequencies, frequencies[1:])):
            raise read.fail(where, "frequencies_hz", "increasing natural frequencies > 0 Hz, each once (mode by mode; "
                                                     "pair them with model modes through model_modes)",
                            list(frequencies))
        if values.get("std_hz") is not None and len(values["std_hz"]) != len(frequencies):
            raise read.fail(where, "std_hz", f"a list of {len(frequencies)} numbers", list(values["std_hz"]))
        return len(frequencies)
    if source == "amplitude_models":
        for written in values["amplitude_models"]:
            if not read.path_of(written).is_file():
                raise read.fail(where, "amplitude_models", "existing amplitude-dependent modal model files (JSON)",
                                written)
        return len(values["amplitude_models"])
    if source == "from_identification":
        if values["from_identification"] is not True:
            raise read.fail(where, "from_identification", "true (or leave the key out)", False)
        if identification is None:
            raise read.fail(where, "from_identification", "an [identification] table to take the targets from")
        modes = values.get("modes")
        if modes is not None and any(b <= a for a, b in zip(modes, modes[1:])):
            raise read.fail(where, "modes", "a list of mode numbers ≥ 1 (of the extracted linear FRF, ascending, "
                                            "each once)", list(modes))
        return len(modes) if modes is not None else -1
    written = values["identification"]
    if not read.path_of(written).exists():
        raise read.fail(where, "identification", "an existing identify output (folder, .json or FRF table)", written)
    if values.get("n_modes") is None:
        raise read.fail(where, "n_modes", "the number of peaks to pick from the identified FRF (integer ≥ 1)")
    for key in ("response_dof", "input_dof"):
        if values.get(key) is None:
            raise read.fail(where, key, "a string (required)")
    if "band_hz" in values and not values["band_hz"][0] < values["band_hz"][1]:
        raise read.fail(where, "band_hz", "[low, high] with 0 ≤ low < high (Hz)", list(values["band_hz"]))
    return values["n_modes"]


def _per_mode(read: Reader, values: Mapping[str, Any], n: int) -> None:
    """The keys given per target mode: one entry per mode (``n`` of them; none known when
    ``n`` < 0), and shapes at every coordinate."""
    where = "targets"
    if n > 0:
        if values.get("weights") is not None and len(values["weights"]) != n:
            raise read.fail(where, "weights", f"a list of {n} numbers", list(values["weights"]))
        if "labels" in values and len(values["labels"]) != n:
            raise read.fail(where, "labels", f"{n} names", list(values["labels"]))
    elif any(key in values for key in ("weights", "labels", "model_modes", "mode_shapes")):
        raise read.fail(where, "modes", "the list of modes to take (weights, labels, model_modes and mode_shapes "
                                        "are given per target mode)")
    modes = values.get("model_modes")
    if modes is not None and (len(modes) != n or len(set(modes)) != len(modes)):
        raise read.fail(where, "model_modes", f"a list of {n} distinct mode numbers ≥ 1", list(modes))
    if ("coordinates" in values) != ("mode_shapes" in values):
        raise read.fail(where, None, "'coordinates' and 'mode_shapes' together")
    if "coordinates" in values:
        size, shapes = len(values["coordinates"]), values["mode_shapes"]
        if len(shapes) != n or any(len(row) != size for row in shapes):
            raise read.fail(where, "mode_shapes", f"{n} lists (one per target mode) of {size} numbers",
                            [list(row) for row in shapes])
