"""Test references computed once per test session, whichever module asks first.

Several modules build their truth from the same independent reference — the same RK4 ring-down
of a test-type system (tests/test_test_type_truth.py: test_decay_fit, test_validate_held_impact,
test_study_amplitude and the module itself), the same harmonic-balance stepped sine or
phase-resonance points — and each computed it again (26 ring-downs of which 10 were distinct).
:func:`session_cached` keeps a pure function's result in the session's folder
``NLUPDATE_TEST_REFERENCE_CACHE`` (made by tests/conftest.py and shared by the pytest-xdist
workers, removed with the session), keyed by the function's own source and its arguments as
pickled: a reference whose code or inputs change is computed again. Each call returns a fresh
copy, so a caller that changes what it got changes nothing for the next one. Without that
folder (a helper imported outside pytest) the function simply runs.

The results are kept as data, never as code (the project's rule for caches): a tuple or list
of arrays as ``.npz`` read with ``allow_pickle=False``, a table as parquet; a result of any
other type is not kept (the function runs each time).
"""
from __future__ import annotations

import functools
import hashlib
import inspect
import os
import pickle
import tempfile
from pathlib import Path
from typing import Callable, TypeVar

import numpy as np
import pandas as pd

F = TypeVar("F", bound=Callable)

#: the environment variable naming the session's folder of references
FOLDER_VARIABLE = "NLUPDATE_TEST_REFERENCE_CACHE"


def session_cached(function: F) -> F:
    """``function`` (pure: its result depends on its picklable arguments and its module's constants
    alone), its results
    kept for the test session (module docstring)."""
    source = inspect.getsource(function)

    @functools.wraps(function)
    def cached(*args, **kwargs):
        folder = os.environ.get(FOLDER_VARIABLE)
        if not folder:
            return function(*args, **kwargs)
        try:
            key = hashlib.sha256(pickle.dumps((function.__module__, function.__qualname__, source, args, kwargs),
                                              protocol=5)).hexdigest()
        except (pickle.PicklingError, TypeError, AttributeError):
            return function(*args, **kwargs)
        stem = Path(folder) / f"{function.__name__}-{key}"
        for suffix, read in READERS.items():
            if stem.with_suffix(suffix).is_file():
                return read(stem.with_suffix(suffix))
        result = function(*args, **kwargs)
        written = _write(result, stem)
        return READERS[written.suffix](written) if written is not None else result

    return cached  # type: ignore[return-value]


def _read_arrays(path: Path) -> tuple | list:
    with np.load(path, allow_pickle=False) as stored:
        arrays = [stored[f"a{i}"] for i in range(int(stored["count"]))]
        return tuple(arrays) if bool(stored["is_tuple"]) else arrays


#: how each kept form is read back (a fresh copy per call)
READERS: dict[str, Callable] = {".npz": _read_arrays, ".parquet": pd.read_parquet}


def _write(result, stem: Path) -> Path | None:
    """Keep ``result`` at ``stem`` + its form's suffix, written whole under another name and
    then renamed (a worker reading it at the same time sees the whole file or none); None when
    its type is not one kept as data."""
    if isinstance(result, pd.DataFrame):
        path, write = stem.with_suffix(".parquet"), lambda stream: result.to_parquet(stream)
    elif isinstance(result, (tuple, list)) and all(isinstance(a, np.ndarray) and a.dtype != object for a in result):
        path = stem.with_suffix(".npz")
        arrays = {f"a{i}": a for i, a in enumerate(result)}

        def write(stream):
            np.savez(stream, count=len(result), is_tuple=isinstance(result, tuple), **arrays)
    else:
        return None
    handle, partial = tempfile.mkstemp(dir=stem.parent, prefix=f".{path.name}.")
    with os.fdopen(handle, "wb") as stream:
        write(stream)
    os.replace(partial, path)
    return path
