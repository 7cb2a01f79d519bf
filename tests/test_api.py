"""The public API (``import nlupdate as nlu``): importing it loads no numerics, every
public name resolves to a documented, type-hinted function or class, and the names the
package lists for type checkers (read by tests/test_layering.py's import graph) are the
names it exports. What the functions compute is checked through the tutorial scripts
(tests/test_examples_py.py)."""
from __future__ import annotations

import ast
import inspect
import subprocess
import sys
from pathlib import Path

import nlupdate

HEAVY = ("numpy", "scipy", "pandas", "matplotlib", "prefect")


def test_import_nlupdate_loads_no_numerics():
    script = "import sys, nlupdate\nprint(' '.join(sorted(sys.modules)))"
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True)
    loaded = sorted(m for m in done.stdout.split() if m.split(".")[0] in HEAVY or m.startswith("nlupdate."))
    assert loaded == []


def test_every_public_name_is_documented_with_units_and_type_hints():
    for name in nlupdate._EXPORTS:
        value = getattr(nlupdate, name)
        assert name in dir(nlupdate) and name in nlupdate.__all__
        assert inspect.getdoc(value), name
        if inspect.isfunction(value):
            signature = inspect.signature(value)
            missing = [p for p, v in signature.parameters.items() if v.annotation is inspect.Parameter.empty]
            assert not missing and signature.return_annotation is not inspect.Signature.empty, (name, missing)
    for name in ("simulate", "identify", "update", "predict"):  # the docstrings state units
        doc = inspect.getdoc(getattr(nlupdate, name))
        assert "Hz" in doc and ("m/N" in doc or "N/m" in doc), name


def test_the_fronts_defaults_are_those_of_the_functions_they_call():
    """A front imports its numerics inside (``import nlupdate`` stays light), so it declares its
    keywords' defaults again instead of reading them from the function it calls; they must be
    that function's. ``harmonic_balance=None`` on a front stands for the core's default settings."""
    from nlupdate.core.prediction.predict import predict_measured
    from nlupdate.core.response.simulate import simulate_frf_table

    for front, core in ((nlupdate.simulate, simulate_frf_table), (nlupdate.predict, predict_measured)):
        ours, theirs = inspect.signature(front).parameters, inspect.signature(core).parameters
        shared = [name for name, p in ours.items() if name in theirs and name != "harmonic_balance"
                  and inspect.Parameter.empty not in (p.default, theirs[name].default)]
        assert shared, front.__name__
        assert {n: ours[n].default for n in shared} == {n: theirs[n].default for n in shared}, front.__name__


def test_names_for_type_checkers_are_the_exported_names():
    tree = ast.parse(Path(nlupdate.__file__).read_text())
    block = next(node for node in tree.body if isinstance(node, ast.If) and ast.unparse(node.test) == "TYPE_CHECKING")
    listed = {(node.module, alias.name) for node in block.body for alias in node.names}
    assert listed == {(module, name) for name, module in nlupdate._EXPORTS.items()}


def test_an_unknown_name_is_an_attribute_error():
    try:
        nlupdate.no_such_function  # noqa: B018
    except AttributeError as error:
        assert "no_such_function" in str(error)
    else:
        raise AssertionError("nlupdate.no_such_function resolved")
