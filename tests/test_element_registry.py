"""An element is written once: its module in src/nlupdate/core/model/elements/ (issue 36).

Outside that package no source dispatches on element classes (``isinstance``, ``type(x) is``,
tables keyed by class) and no source branches on an element's name (a comparison with a
``type_name``); consumers ask the element (its protocol) or the registry
:data:`~nlupdate.core.model.elements.ELEMENT_TYPES`. Each module there defines one element.
"""
from __future__ import annotations

import ast
import functools
from pathlib import Path

import pytest

import nlupdate
from nlupdate.core.model.elements import ELEMENT_TYPES, ElementBase, ElementParameter

PACKAGE = Path(nlupdate.__file__).parent
ELEMENTS = PACKAGE / "core" / "model" / "elements"
CLASS_NAMES = {cls.__name__ for cls in ELEMENT_TYPES.values()}
TYPE_NAMES = set(ELEMENT_TYPES)
#: Modules comparing a string that is also an element's type name, and why that is not an element branch.
NOT_ELEMENTS = {
    "core/model/amplitude_modal.py": "the modal backbone kinds 'iwan' and 'polynomial' (BACKBONES), a model setting",
    "core/identification/amplitude_modal_fit.py": "the modal backbone kinds (BACKBONES)",
    "app/cli/amplitude.py": "the --backbone choice (BACKBONES)",
    "app/cli/validate_type.py": "the backbone of the held-out type's amplitude model (BACKBONES)",
    "core/identification/backbone_samples.py": "the backbone kind whose own fit weighs a source (BACKBONES)",
}


@functools.cache
def _parsed() -> tuple[tuple[str, ast.AST], ...]:
    return tuple((path.relative_to(PACKAGE).as_posix(), ast.parse(path.read_text(), str(path)))
                 for path in sorted(PACKAGE.rglob("*.py")) if ELEMENTS not in path.parents)


def _sources():
    """(path below the package, syntax tree) of every source outside the element package."""
    return _parsed()


def _names(node: ast.AST) -> set[str]:
    return {n.id if isinstance(n, ast.Name) else n.attr for n in ast.walk(node) if isinstance(n, (ast.Name, ast.Attribute))}


def test_no_dispatch_on_element_classes_outside_their_modules():
    found = []
    for where, tree in _sources():
        for node in ast.walk(tree):
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in ("isinstance", "issubclass"):
                hit = _names(node.args[1]) & CLASS_NAMES
            elif isinstance(node, ast.Compare) and any(isinstance(op, (ast.Is, ast.IsNot, ast.In, ast.NotIn, ast.Eq))
                                                        for op in node.ops):
                calls = [n for n in ast.walk(node) if isinstance(n, ast.Call) and isinstance(n.func, ast.Name)
                         and n.func.id == "type"]
                hit = (_names(node) & CLASS_NAMES) if calls else set()
            elif isinstance(node, ast.Dict):
                hit = {k.id for k in node.keys if isinstance(k, ast.Name)} & CLASS_NAMES
            else:
                continue
            if hit:
                found.append(f"{where}:{node.lineno} {sorted(hit)}")
    assert found == []


def test_no_branch_on_element_names_outside_the_registry():
    found = []
    for where, tree in _sources():
        if where in NOT_ELEMENTS:
            continue
        for node in ast.walk(tree):
            if isinstance(node, ast.Compare):
                strings = {n.value for n in ast.walk(node) if isinstance(n, ast.Constant) and isinstance(n.value, str)}
                if strings & TYPE_NAMES:
                    found.append(f"{where}:{node.lineno} {sorted(strings & TYPE_NAMES)}")
    assert found == []


def test_every_module_of_the_package_defines_one_registered_element():
    modules = {path.stem for path in ELEMENTS.glob("*.py")} - {"__init__", "base"}
    owners = {cls.__module__.rsplit(".", 1)[1]: cls for cls in ELEMENT_TYPES.values()}
    assert set(owners) == modules
    assert all(issubclass(cls, ElementBase) and cls.parameters for cls in ELEMENT_TYPES.values())


def test_every_parameter_of_every_element_says_what_it_is():
    """A report explains an identified parameter (``kf``, ``slip_force``) by its element's
    declaration (``ElementParameter.meaning``): a new element cannot leave it out, and the
    text is one ``Terms:`` entry (no ';', which separates them there)."""
    for name, cls in ELEMENT_TYPES.items():
        for parameter in cls.parameters:
            assert parameter.meaning.strip() and ";" not in parameter.meaning, (name, parameter.name)
    with pytest.raises(TypeError, match="meaning"):
        ElementParameter("k5", "N/m^5")  # type: ignore[call-arg]
    for meaning in ("", "  ", "stiffness; of a spring"):
        with pytest.raises(ValueError, match="meaning"):
            ElementParameter("k5", "N/m^5", meaning=meaning)
