"""The layers, checked: CLI → flows → tasks → reporting → numerics and adapters.

* Every module of the numerics (``nlupdate`` without ``cli``, ``flows``, ``tasks``) and of
  the adapters is imported in a fresh interpreter, which must not have loaded Prefect,
  the flows, the tasks, the CLI or ``matplotlib.pyplot`` afterwards; no source file of
  theirs selects a matplotlib backend.
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
import pkgutil
import subprocess
import sys
from pathlib import Path

import nlupdate
import nlupdate.adapters

FORBIDDEN = ("prefect", "prefect_dask", "distributed", "nlupdate.flows", "nlupdate.tasks", "nlupdate.cli",
             "matplotlib.pyplot")
ORCHESTRATION = {"nlupdate.cli", "nlupdate.flows", "nlupdate.tasks"}


def numerics_modules() -> list[str]:
    names = []
    for package in (nlupdate, nlupdate.adapters):
        for info in pkgutil.walk_packages(package.__path__, package.__name__ + "."):
            if not any(info.name == p or info.name.startswith(p + ".") for p in ORCHESTRATION):
                names.append(info.name)
    return sorted(set(names) - {"nlupdate.__main__"})


def test_numerics_modules_import_no_orchestration_cli_or_pyplot():
    modules = numerics_modules()
    assert len(modules) > 40 and "nlupdate.study.steps" in modules and "nlupdate.adapters.calculix" in modules
    script = (
        "import importlib, sys\n"
        f"for name in {modules!r}:\n"
        "    importlib.import_module(name)\n"
        f"print(sorted(m for m in sys.modules if m in {FORBIDDEN!r} or any(m.startswith(f + '.') for f in {FORBIDDEN!r})))\n"
    )
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "[]", f"numerics import {done.stdout.strip()}"


def test_no_module_selects_a_matplotlib_backend():
    roots = [Path(nlupdate.__file__).parent, Path(nlupdate.adapters.__file__).parent]
    offenders = [str(path) for root in roots for path in root.rglob("*.py") if "matplotlib.use(" in path.read_text()]
    assert offenders == []


# ----------------------------------------------------------------------------- the import graph
ROOTS = {"nlupdate": Path(nlupdate.__file__).parent, "nlupdate.adapters": Path(nlupdate.adapters.__file__).parent}
ROOTS.update({f"nlupdate.{name}": ROOTS["nlupdate"].parent / name for name in ("flows", "tasks")})
#: Top to bottom; a module may import its own layer and the ones below it only.
LAYERS = ("nlupdate.cli", "nlupdate.flows", "nlupdate.tasks", "nlupdate.reporting")
NUMERICS_PACKAGES = ("nlupdate.model", "nlupdate.response", "nlupdate.measurement", "nlupdate.identification",
                     "nlupdate.updating", "nlupdate.prediction", "nlupdate.correlation", "nlupdate.discovery",
                     "nlupdate.fe", "nlupdate.study", "nlupdate.validation", "nlupdate.adapters",
                     "nlupdate.response_method")
#: Functions reporting may import from the numerics, and why.
REPORTING_MAY_CALL = {
    ("nlupdate.response_method", "describe"): "the wording of the response method's settings",
    ("nlupdate.study", "study_from_text"): "the catalogue loads an archived study to rerun it",
}


def _modules() -> dict[str, Path]:
    found = {}
    for prefix, folder in ROOTS.items():
        for path in folder.rglob("*.py"):
            parts = list(path.relative_to(folder).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            if prefix == "nlupdate" and parts and parts[0] in ("flows", "tasks", "adapters"):
                continue
            found[".".join([prefix, *parts])] = path
    return found


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
    for rank, prefix in enumerate(LAYERS):
        if module == prefix or module.startswith(prefix + "."):
            return len(LAYERS) - rank
    return 0  # the numerics and adapters


def test_no_module_imports_a_layer_above_its_own():
    upward = sorted((module, target) for module, targets in _graph().items() for target in targets
                    if _layer(target) > _layer(module) and module != "nlupdate.__main__")
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


def test_editing_a_plot_or_the_report_keeps_every_cached_result(tmp_path, monkeypatch):
    """The code part of a step's key covers the numerics the step runs: editing a plot or
    the report (here in a copy of the package) changes no identification or updating key;
    editing the identification's code changes the identification key."""
    import shutil

    from nlupdate.study import load_study
    from nlupdate.study.chain import STEPS
    from nlupdate.study.steps import study_targets, updating_runs
    from nlupdate.tasks import keys

    package, adapters = tmp_path / "nlupdate", tmp_path / "adapters"
    shutil.copytree(ROOTS["nlupdate"], package, ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copytree(ROOTS["nlupdate.adapters"], adapters, ignore=shutil.ignore_patterns("__pycache__"))
    monkeypatch.setattr(keys, "_PACKAGE", package)
    monkeypatch.setattr(keys, "_ADAPTERS", adapters)
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
    (package / "identification" / "prd.py").write_text((package / "identification" / "prd.py").read_text() + "\n#\n")
    assert step_keys()[0] != before[0]


def test_every_package_a_study_step_runs_is_in_its_cache_key():
    """STUDY_PACKAGES is kept by hand: a package the steps import but the list leaves out
    would leave a cached step stale after its code changed (the new validation package was
    such a one). The steps' own imports, followed through nlupdate, decide."""
    import subprocess
    import sys

    from nlupdate.tasks.keys import NUMERICS_MODULES, STUDY_PACKAGES

    code = ("import sys, nlupdate.study.chain, nlupdate.study.steps; "
            "print(' '.join(sorted(m for m in sys.modules if m.startswith('nlupdate.'))))")
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    packages, modules = set(), set()
    for name in loaded:
        parts = name.split(".")
        if parts[1] in ("adapters", "tasks", "flows", "cli", "reporting"):  # hashed apart, or not run by a step
            continue
        target = packages if (ROOTS["nlupdate"] / parts[1]).is_dir() else modules
        target.add(parts[1] if target is packages else f"{parts[1]}.py")
    assert packages <= set(STUDY_PACKAGES), sorted(packages - set(STUDY_PACKAGES))
    assert modules <= set(NUMERICS_MODULES) | {"__init__.py"}, sorted(modules - set(NUMERICS_MODULES))
