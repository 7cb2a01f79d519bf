"""nlupdate: model updating of nonlinear structures from vibration tests.

The public Python API (docs/python-api.md)::

    import nlupdate as nlu
    model = nlu.load_model("examples/two_dof.toml")
    measured = nlu.simulate(model, "0", frequencies_hz, [0.01, 100, 150], noise=0.05, seed=1)
    found = nlu.identify(measured, elements=("cubic", "jenkins"))

loads a model and measurements, simulates, identifies, updates, predicts, discovers and
runs a study (:mod:`nlupdate.app.api`); SI units, Hz at interfaces, receptance in m/N,
``x(t) = Re(X e^{iωt})``. The names are imported when first used, so ``import nlupdate``
(and ``nlupdate --version``) loads no numerics. A study as Prefect flows:
``from nlupdate.orchestration.flows.run import run_study_flow``.

The numerics in this package are pure functions on plain inputs (no Prefect);
``nlupdate.orchestration.tasks`` and ``nlupdate.orchestration.flows`` wrap them for orchestration.
"""
from typing import TYPE_CHECKING

__version__ = "0.1.0"

#: Public name → module that defines it (imported on first use, :func:`__getattr__`).
_EXPORTS: dict[str, str] = {
    **{name: "nlupdate.app.api" for name in (
        "load_model", "model_from_dict", "save_model", "load_measurements", "save_measurements", "select_frf",
        "simulate", "identify", "fe_model", "update", "predict", "discover", "load_study", "run_study",
    )},
    "Parameter": "nlupdate.fe.adapters.base",
    "HarmonicSettings": "nlupdate.core.response.harmonic_balance",
}

__all__ = ["__version__", *_EXPORTS]

if TYPE_CHECKING:  # the same names for type checkers and the import graph (tests/test_layering.py)
    from nlupdate.fe.adapters.base import Parameter  # noqa: F401 (exported through __getattr__)
    from nlupdate.app.api import (  # noqa: F401
        discover, fe_model, identify, load_measurements, load_model, load_study, model_from_dict, predict, run_study,
        save_measurements, save_model, select_frf, simulate, update,
    )
    from nlupdate.core.response.harmonic_balance import HarmonicSettings  # noqa: F401


def __getattr__(name: str):
    """Import a public name on first use (PEP 562) and keep it in the module."""
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'nlupdate' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))
