"""The layers, read from the folders of src/nlupdate (top to bottom):

``app`` (CLI, Python API) → ``orchestration`` (flows, tasks) → ``reporting`` → ``study``
(study files and the chain's steps) → ``core`` (numerics) and ``fe`` (FE models and
adapters) → the foundation modules at the package root (files, fingerprints, notices …).

* Every module below orchestration is imported in a fresh interpreter, which must not have
  loaded Prefect, the orchestration, the app layer or ``matplotlib.pyplot`` afterwards; no
  source file of theirs selects a matplotlib backend.
* In the import graph (read from the sources, imports inside functions included) no
  module imports a layer above its own, and no modules import each other in a circle.
* Reporting renders: from the numerics it imports types and constants, not functions.
* Editing a plot or the report changes no cached identification or updating result.
"""
from __future__ import annotations

import ast
import dataclasses
import importlib
import inspect
import subprocess
import sys
from pathlib import Path

import pytest

import nlupdate

PACKAGE = Path(nlupdate.__file__).parent
#: The layer folders, top to bottom; a module may import its own layer and the ones below.
LAYERS = ("app", "orchestration", "reporting", "study")
#: The bottom layer: the numerics and the FE models and adapters (they use each other).
BOTTOM = ("core", "fe")
FORBIDDEN = ("prefect", "prefect_dask", "distributed", "nlupdate.orchestration", "nlupdate.app",
             "matplotlib.pyplot")
NUMERICS_PACKAGES = ("nlupdate.core", "nlupdate.fe")
#: Functions reporting may import from the layers below it, and why.
REPORTING_MAY_CALL = {
    ("nlupdate.core.response.method", "describe"): "the wording of the response method's settings",
    ("nlupdate.study", "study_from_text"): "the catalogue loads an archived study to rerun it",
    ("nlupdate.core.measurement.units", "table_reference_unit"): "the unit a table's levels are in (its column)",
    ("nlupdate.core.updating.runs", "best_ranked"): "which run the study's ranking put first: one owner of 'best'",
    ("nlupdate.core.identification.linear_limit", "zeta_text"): "the wording of a damping ratio at its bound 0: one "
                                                                 "owner with the fit's warnings",
    ("nlupdate.core.updating.sensitivity", "order_labels"): "the O(·) labels of the difference formulas the runs "
                                                            "are named by: one owner with the formulas' stencils",
    ("nlupdate.core.identification.trust", "warning_texts"): "the wording of the warnings, a line per distinct "
                                                             "message: one owner with the warnings step's line",
}


def _modules() -> dict[str, Path]:
    """Every module of the package (dotted name → source file), read from the folders."""
    found = {}
    for path in PACKAGE.rglob("*.py"):
        parts = ["nlupdate", *path.relative_to(PACKAGE).with_suffix("").parts]
        if parts[-1] == "__init__":
            parts = parts[:-1]
        found[".".join(parts)] = path
    return found


def test_every_folder_is_a_layer():
    """A new folder is placed in a layer on purpose, not by accident."""
    folders = {path.name for path in PACKAGE.iterdir() if path.is_dir() and path.name not in ("__pycache__", "data")}
    assert folders == set(LAYERS) | set(BOTTOM)


def lower_modules() -> list[str]:
    """The modules below orchestration (study, core, fe, the foundation; not reporting)."""
    return sorted(name for name in _modules() if _layer(name) <= _layer("nlupdate.study")
                  and name not in ("nlupdate", "nlupdate.__main__"))


def test_lower_layers_import_no_orchestration_app_or_pyplot():
    modules = lower_modules()
    assert len(modules) > 40 and "nlupdate.study.steps" in modules and "nlupdate.fe.adapters.calculix" in modules
    script = (
        "import importlib, sys\n"
        f"for name in {modules!r}:\n"
        "    importlib.import_module(name)\n"
        f"print(sorted(m for m in sys.modules if m in {FORBIDDEN!r} or any(m.startswith(f + '.') for f in {FORBIDDEN!r})))\n"
    )
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "[]", f"lower layers import {done.stdout.strip()}"


def test_no_module_selects_a_matplotlib_backend():
    offenders = [str(path) for path in PACKAGE.rglob("*.py") if "matplotlib.use(" in path.read_text()]
    assert offenders == []


# ----------------------------------------------------------------------------- the import graph
def _imports(path: Path) -> list[tuple[str, str | None]]:
    """(module, name) of every nlupdate import in a file, function bodies included."""
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found += [(alias.name, None) for alias in node.names if alias.name.startswith("nlupdate")]
        elif isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("nlupdate"):
            found += [(node.module, alias.name) for alias in node.names]
    return found


def _graph() -> dict[str, set[str]]:
    modules = _modules()
    graph = {}
    for name, path in modules.items():
        targets = set()
        for module, imported in _imports(path):
            if imported is not None and f"{module}.{imported}" in modules:
                targets.add(f"{module}.{imported}")
            elif module in modules:
                targets.add(module)
        graph[name] = targets - {name}
    return graph


def _layer(module: str) -> int:
    """The module's rank: 0 for the bottom and the foundation, higher for higher layers."""
    parts = module.split(".")
    if len(parts) > 1 and parts[1] in LAYERS:
        return len(LAYERS) - LAYERS.index(parts[1])
    return 0


def test_no_module_imports_a_layer_above_its_own():
    upward = sorted((module, target) for module, targets in _graph().items() for target in targets
                    if _layer(target) > _layer(module) and module not in ("nlupdate", "nlupdate.__main__"))
    assert upward == []


def test_no_modules_import_each_other_in_a_circle():
    graph = _graph()
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    circles = []

    def visit(node: str) -> None:  # Tarjan's strongly connected components
        index[node] = low[node] = len(index)
        stack.append(node)
        for target in graph[node]:
            if target not in index:
                visit(target)
                low[node] = min(low[node], low[target])
            elif target in stack:
                low[node] = min(low[node], index[target])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                circles.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    assert circles == []


def test_reporting_imports_types_and_constants_from_the_numerics_not_functions():
    """Reporting renders the results the chain computed; it calls no numerics function."""
    offenders = []
    for name, path in _modules().items():
        if not name.startswith("nlupdate.reporting"):
            continue
        for module, imported in _imports(path):
            if imported is None or not module.startswith(NUMERICS_PACKAGES):
                continue
            value = getattr(importlib.import_module(module), imported)
            if callable(value) and not inspect.isclass(value) and (module, imported) not in REPORTING_MAY_CALL:
                offenders.append(f"{name} imports {module}.{imported}")
    assert offenders == []


# ----------------------------------------------------------------------------- cache keys and the code


@pytest.fixture
def fresh_code_hashes():
    """The code hashes this process keeps (functools.cache) forgotten after a test that
    computed them from a copy of the package: otherwise every later run of the same test
    worker keys its results by the copy's code, and a run in another process (the cache
    answered without Prefect) finds none of them."""
    from nlupdate.orchestration.tasks import keys

    yield
    for cached in (keys.numerics_code, keys.discovery_code, keys.fe_code, keys.reporting_code):
        cached.cache_clear()


def test_editing_a_plot_or_the_report_keeps_every_cached_result(tmp_path, monkeypatch, fresh_code_hashes):
    """The code part of a step's key covers the numerics the step runs: editing a plot or
    the report (here in a copy of the package) changes no identification or updating key;
    editing the identification's code changes the identification key."""
    import shutil

    from nlupdate.study import load_study
    from nlupdate.study.chain import STEPS
    from nlupdate.study.steps.updating import study_targets, updating_runs
    from nlupdate.orchestration.tasks import keys

    package = tmp_path / "nlupdate"
    shutil.copytree(PACKAGE, package, ignore=shutil.ignore_patterns("__pycache__"))
    monkeypatch.setattr(keys, "_PACKAGE", package)
    study = load_study(Path(__file__).parent / "data" / "studies" / "two_dof.toml")
    from nlupdate.study.spec import TargetsSpec

    targets = TargetsSpec(frequencies_hz=(732.0,), model_modes=(2,))
    run = updating_runs(study, study_targets(dataclasses.replace(study, targets=targets), None))[0]

    def step_keys() -> tuple[str, str]:
        keys.numerics_code.cache_clear()
        return (keys.step_key(STEPS["identification"], study, ["measured"]),
                keys.job_key(STEPS["updating"], study, run, "model", ["targets"]))

    before = step_keys()
    for plots in ("reporting/updating_plots.py", "reporting/identification_plots.py", "reporting/report.py"):
        (package / plots).write_text((package / plots).read_text() + "\n# a plot or a sentence changed\n")
    assert step_keys() == before
    prd = package / "core" / "identification" / "prd.py"
    prd.write_text(prd.read_text() + "\n#\n")
    assert step_keys()[0] != before[0]


def test_import_sets_kept_between_runs_follow_an_edited_source(tmp_path, monkeypatch):
    """A run reads the import sets earlier runs found (``code-imports.json``, so as not to
    parse 171 modules each time) by each source's content: an import added to a source is
    followed at once, and what a run covers equals a fresh parse of every source."""
    import json
    import shutil

    from nlupdate.orchestration.tasks import keys

    package = tmp_path / "nlupdate"
    shutil.copytree(PACKAGE, package, ignore=shutil.ignore_patterns("__pycache__"))

    def covered(config: Path) -> list[Path]:  # as a new run (process) would
        monkeypatch.setenv("NLUPDATE_CONFIG_DIR", str(config))
        monkeypatch.setattr(keys, "_IMPORT_SETS", keys._ImportSets())
        keys._parsed_imports.cache_clear()
        return keys.imported_modules(keys.FE_ROOTS, package)

    first = covered(tmp_path / "kept")
    assert json.loads((tmp_path / "kept" / "code-imports.json").read_text())  # kept for the next run
    registry = package / "fe" / "adapters" / "registry.py"
    registry.write_text(registry.read_text() + "\n\ndef _added():\n    import nlupdate.reporting.report  # noqa\n")
    again = covered(tmp_path / "kept")
    assert package / "reporting" / "report.py" in again and package / "reporting" / "report.py" not in first
    assert again == covered(tmp_path / "nothing-kept")


def test_every_module_a_study_step_loads_is_in_its_cache_key():
    """The code a step's key covers is derived from the imports (read from the sources);
    here it is checked against what Python actually loads when the chain and its steps
    are imported and an FE adapter of each kind is looked up."""
    import subprocess
    import sys

    from nlupdate.orchestration.tasks.keys import FE_ROOTS, STUDY_ROOTS, _PACKAGE, imported_modules

    code = ("import sys, importlib, nlupdate.study.chain, nlupdate.study.steps\n"
            "from nlupdate.fe.adapters.registry import ADAPTERS\n"
            "[importlib.import_module(m) for m in ADAPTERS.values()]\n"
            "print(' '.join(sorted(m for m in sys.modules if m.startswith('nlupdate'))))")
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    covered = {path.relative_to(_PACKAGE) for path in imported_modules(STUDY_ROOTS + FE_ROOTS, _PACKAGE)}
    missing = []
    for name in loaded:
        parts = name.split(".")[1:]
        candidates = [Path(*parts, "__init__.py"), Path(*parts).with_suffix(".py")] if parts else [Path("__init__.py")]
        if not any(c in covered for c in candidates):
            missing.append(name)
    assert missing == []
    assert not any(str(path).startswith(("reporting", "orchestration", "app")) for path in covered)
