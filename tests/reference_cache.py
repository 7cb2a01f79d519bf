"""Test references computed once per test session, whichever module asks first.

Several modules build their truth from the same independent reference — the same RK4 ring-down
of a test-type system (tests/test_test_type_truth.py: test_decay_fit, test_validate_held_impact,
test_study_amplitude and the module itself), the same harmonic-balance stepped sine or
phase-resonance points — and each computed it again (26 ring-downs of which 10 were distinct).
:func:`session_cached` keeps a pure function's result, pickled, in the session's folder
``NLUPDATE_TEST_REFERENCE_CACHE`` (made by tests/conftest.py and shared by the pytest-xdist
workers, removed with the session), keyed by the function's own source and its arguments as
pickled: a reference whose code or inputs change is computed again. Each call returns a fresh
copy, so a caller that changes what it got changes nothing for the next one. Without that
folder (a helper imported outside pytest) the function simply runs.
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
        path = Path(folder) / f"{function.__name__}-{key}.pickle"
        if path.is_file():
            return pickle.loads(path.read_bytes())
        result = function(*args, **kwargs)
        # written whole under another name, then renamed: a worker reading it at the same time
        # sees the whole file or none
        handle, partial = tempfile.mkstemp(dir=folder, prefix=f".{path.name}.")
        with os.fdopen(handle, "wb") as stream:
            pickle.dump(result, stream, protocol=5)
        os.replace(partial, path)
        return pickle.loads(path.read_bytes())

    return cached  # type: ignore[return-value]
