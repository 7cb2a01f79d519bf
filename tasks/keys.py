"""Cache keys from the project's own fingerprints.

Every task takes a ``key`` string as its first argument and its cache policy hashes that
key (and the task's source), never the heavy or live arguments beside it (tables, models,
evaluators), which Prefect could not hash reliably. A key is the SHA-256 of a canonical
description of everything the result depends on:

* the code that computes it — :data:`NUMERICS_CODE` (the numerics the study steps run)
  for the study steps, :data:`FE_CODE` (adapters and the built-in FE) for FE points, so editing a
  report template does not throw away hours of FE runs;
* the inputs: study sections as parsed, content hashes of input files and tables,
  an adapter's model fingerprint (deck, mesh) and the parameter values.

:func:`canonical` turns dataclasses, arrays, mappings and floats into JSON with floats
written exactly (``float.hex``), so two keys are equal only for equal inputs.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from pathlib import Path
from typing import Any, Iterable, Mapping

import numpy as np
import pandas as pd

import nlupdate
import nlupdate.adapters
from nlupdate.fingerprints import file_hash, table_hash
from nlupdate.study.spec import Study
from nlupdate.adapters.registry import AdapterSpec, build_adapter
from nlupdate.updating.candidates import UpdatingTask

#: The subpackages a study step runs (not the CLI, flows, tasks, reports or discovery).
STUDY_PACKAGES = ("model", "response", "measurement", "identification", "updating", "prediction", "correlation",
                  "study", "fe")


def _source_hash(roots: Iterable[Path], skip: set[str]) -> str:
    digest = hashlib.sha256()
    for root in sorted(roots):
        for path in sorted(root.rglob("*.py")):
            if skip & set(path.relative_to(root).parts):
                continue
            digest.update(str(path.relative_to(root)).encode())
            digest.update(path.read_bytes())
    return digest.hexdigest()


_PACKAGE = Path(nlupdate.__file__).parent
_ADAPTERS = Path(nlupdate.adapters.__file__).parent
#: Hash of the source of the study steps (:data:`STUDY_PACKAGES`) and the adapters.
NUMERICS_CODE = _source_hash([_PACKAGE / name for name in STUDY_PACKAGES] + [_ADAPTERS], {"__pycache__"})
#: Hash of the code a discovery candidate fit depends on.
DISCOVERY_CODE = _source_hash([_PACKAGE / name for name in ("discovery", "model", "response", "identification",
                                                             "measurement", "correlation")], {"__pycache__"})
#: Hash of the code an FE evaluation depends on (adapters, built-in FE, linear models).
FE_CODE = _source_hash({_ADAPTERS, _PACKAGE / "fe", _PACKAGE / "model"}, {"__pycache__"})


def canonical(value: Any) -> Any:
    """A JSON-serialisable, exact and order-independent description of ``value``."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {"__type__": type(value).__name__,
                **{f.name: canonical(getattr(value, f.name)) for f in dataclasses.fields(value)}}
    if isinstance(value, Mapping):
        return {str(k): canonical(v) for k, v in sorted(value.items(), key=lambda item: str(item[0]))}
    if isinstance(value, (list, tuple)):
        return [canonical(v) for v in value]
    if isinstance(value, np.ndarray):
        return {"shape": list(value.shape), "values": [canonical(v) for v in value.ravel().tolist()]}
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value).hex() if math.isfinite(value) else repr(float(value))
    if isinstance(value, complex):
        return [canonical(value.real), canonical(value.imag)]
    if isinstance(value, pd.DataFrame):
        return {"table": table_hash(value)}
    if isinstance(value, Path):
        return str(value)
    if value is None or isinstance(value, str):
        return value
    raise TypeError(f"no canonical form for {type(value).__name__}")


def digest(*parts: Any) -> str:
    """SHA-256 (hex) of the canonical form of ``parts``."""
    text = json.dumps(canonical(list(parts)), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


_ADAPTER_CACHE: dict[str, Any] = {}


def adapter_for(spec: AdapterSpec):
    """The adapter of ``spec``, built once per process (adapters are stateless solvers)."""
    identity = spec.identity()
    if identity not in _ADAPTER_CACHE:
        _ADAPTER_CACHE[identity] = build_adapter(spec)
    return _ADAPTER_CACHE[identity]


def _input_files(study: Study) -> dict[str, str]:
    """Content hashes of the files the study reads (data, truth model, APDL decks)."""
    files = {}
    measured = study.measured
    if measured is not None and measured.file is not None:
        files["measured"] = file_hash(measured.file)
    if measured is not None and measured.simulate is not None and measured.simulate.model_file is not None:
        files["truth_model"] = file_hash(measured.simulate.model_file)
    return files


def measured_key(study: Study) -> str:
    """The measured-data step: its study section and input files."""
    spec = study.measured
    model = None
    if spec.simulate is not None and spec.simulate.adapter is not None:
        model = adapter_for(spec.simulate.adapter).model_fingerprint()
    return digest("measured", NUMERICS_CODE, spec, model, _input_files(study))


def identification_key(study: Study, measured_hash: str) -> str:
    """The identification step: its settings and the measured table's content."""
    return digest("identification", NUMERICS_CODE, study.identification, measured_hash)


def adapter_identity(spec: AdapterSpec) -> str:
    """An adapter description and its built model's fingerprint (a deck's content, …)."""
    return digest("adapter", spec, adapter_for(spec).model_fingerprint())


def point_key(spec: AdapterSpec, point: Mapping[str, float]) -> str:
    """One FE evaluation: the adapter's own point key (model fingerprint and values) and
    the FE code."""
    return digest("point", FE_CODE, spec.identity(), adapter_for(spec).key(point))


def run_key(task: UpdatingTask) -> str:
    """One updating run: its task (parameters with bounds, targets, method, options, fixed
    values) and the model."""
    return digest("run", NUMERICS_CODE, adapter_identity(task.adapter), dataclasses.replace(task, adapter=None))


def step_key(name: str, *parts: Any) -> str:
    """Any other step: a name and the keys or values it depends on."""
    return digest(name, NUMERICS_CODE, *parts)


def prediction_key(study: Study, spec: AdapterSpec, point: Mapping[str, float], identification_key: str,
                   measured_hash: str) -> str:
    """One prediction: the FE point of its model, the identification and the measured
    table, the ``[prediction]`` settings (levels, loss factor, sweep, response method:
    describing function or harmonic balance with its harmonics, samples and stability) and
    the targets (the measured curve)."""
    return step_key("prediction", point_key(spec, point), identification_key, measured_hash, study.prediction,
                    study.targets)


def candidate_key(job: Any) -> str:
    """One discovery candidate fit: the job's content (data, model, place and effect) and
    the discovery code."""
    return digest("candidate", DISCOVERY_CODE, job)
