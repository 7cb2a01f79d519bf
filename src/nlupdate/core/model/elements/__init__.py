"""Local nonlinear elements, one module per element type (docs/architecture.md, "a new element").

Every module of this package is imported here, and every element class it defines
registers itself in :data:`ELEMENT_TYPES` (:class:`~nlupdate.core.model.elements.base.ElementBase`);
the classes are also importable from this package by their class names. So a new element
is one new module here: model files, the response solvers (describing function, harmonic
balance, time integration), identification and discovery read it from the registry.
"""
from __future__ import annotations

import importlib
import pkgutil

from nlupdate.core.model.elements.base import (
    ELEMENT_TYPES,
    EffectForm,
    ElementBase,
    ElementParameter,
    NonlinearElement,
    PeriodForces,
    nonlinear_dofs,
)

for _module in sorted(m.name for m in pkgutil.iter_modules(__path__) if m.name != "base"):
    importlib.import_module(f"{__name__}.{_module}")
globals().update({cls.__name__: cls for cls in ELEMENT_TYPES.values()})

__all__ = ["ELEMENT_TYPES", "EffectForm", "ElementBase", "ElementParameter", "NonlinearElement", "PeriodForces",
           "nonlinear_dofs", *(cls.__name__ for cls in ELEMENT_TYPES.values())]
