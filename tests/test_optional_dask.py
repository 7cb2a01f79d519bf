"""Dask is an optional part (``pip install 'nlupdate[dask]'``): the base install leaves its
14 packages out, every command runs without it, and --dask / --dask-address without it say
in one line what to install (issue "rough edges a new user hit": ``pip install .`` brought
~150 packages)."""
from __future__ import annotations

import ast
import importlib.metadata as metadata
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

from nlupdate.app.cli import main

ROOT = Path(__file__).resolve().parents[1]
DASK = ("dask", "distributed", "prefect_dask")
BLOCK = "import sys\nfor name in ('dask', 'distributed', 'prefect_dask'):\n    sys.modules[name] = None\n"


@pytest.fixture
def without_dask(monkeypatch):
    """Python as it is without the [dask] extra: importing Dask fails."""
    for name in DASK:
        monkeypatch.setitem(sys.modules, name, None)


def test_dask_is_an_extra_that_the_tests_install():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    names = [requirement.split("[")[0].split(">")[0].split("<")[0].strip() for requirement in project["dependencies"]]
    assert not {"dask", "prefect-dask", "distributed"} & set(names), names
    assert {r.split("[")[0].split(">")[0] for r in project["optional-dependencies"]["dask"]} == {"prefect-dask", "dask"}
    assert "nlupdate[dask]" in project["optional-dependencies"]["test"]  # .ci/run installs .[test]


@pytest.mark.parametrize("option", [["--dask"], ["--dask-address", "tcp://127.0.0.1:8786"]])
def test_dask_options_without_dask_say_what_to_install(option, without_dask, two_dof_study_file, tmp_path, capsys):
    code = main(["run", str(two_dof_study_file), *option, "--out", str(tmp_path / "results")])
    assert code == 2
    assert capsys.readouterr().err.splitlines() == [
        f"nlupdate run: error: {option[0]} needs Dask, an optional part of nlupdate that is not installed: "
        f"pip install 'nlupdate[dask]'"]
    assert not (tmp_path / "results").exists()


def test_a_dask_execution_without_dask_says_what_to_install(without_dask):
    from nlupdate.orchestration.flows.runners import Execution, ExecutionError, task_runner

    with pytest.raises(ExecutionError, match=r"not installed: pip install 'nlupdate\[dask\]'"):
        with task_runner(Execution(workers=1, dask=True)):
            pass


def test_the_flows_import_and_run_on_threads_without_dask():
    """In a fresh interpreter where Dask cannot be imported: the flows import, the default
    task runner is a thread pool, and the commands' parser is built."""
    code = BLOCK + (
        "from nlupdate.app.cli import build_parser\n"
        "build_parser()\n"
        "import nlupdate.orchestration.flows.run, nlupdate.orchestration.flows.study, nlupdate.orchestration.flows.discovery\n"
        "from nlupdate.orchestration.flows.runners import Execution, task_runner\n"
        "with task_runner(Execution(workers=2)) as (runner, what):\n"
        "    print(type(runner).__name__, what)\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stdout.strip() == "ThreadPoolTaskRunner 2 threads"


def pulled_in(requirements: list[str]) -> set[str]:
    """The distributions ``requirements`` install (their requirements' closure, extras as
    named, no optional ones), from the installed packages' metadata."""
    seen: set[tuple[str, frozenset]] = set()
    todo = [(Requirement(r), {""}) for r in requirements]
    while todo:
        requirement, extras = todo.pop()
        if requirement.marker is not None and not any(requirement.marker.evaluate({"extra": e}) for e in extras):
            continue
        key = (canonicalize_name(requirement.name), frozenset(requirement.extras))
        if key in seen:
            continue
        seen.add(key)
        try:
            todo += [(Requirement(r), {"", *requirement.extras}) for r in metadata.requires(requirement.name) or []]
        except metadata.PackageNotFoundError:
            continue
    return {name for name, _ in seen}


def test_every_package_the_code_imports_comes_with_the_base_install():
    """Leaving Dask out left psutil out (src/nlupdate/orchestration/flows/liveness.py imports it: it came with Dask);
    every package imported by the installed code comes with the base dependencies, but
    the [dask] extra's, which src/nlupdate/orchestration/flows/runners.py imports only when asked."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    base, providers = pulled_in(project["dependencies"]), metadata.packages_distributions()
    missing = {}
    sources = sorted((ROOT / "src" / "nlupdate").rglob("*.py"))
    assert len(sources) > 100  # the code was found (the check would pass vacuously otherwise)
    for path in sources:
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            else:
                continue
            for top in {name.split(".")[0] for name in names} - set(sys.stdlib_module_names) - {"nlupdate"}:
                if not {canonicalize_name(d) for d in providers.get(top, [])} & base:
                    missing.setdefault(top, set()).add(path.relative_to(ROOT).as_posix())
    assert missing == {"distributed": {"src/nlupdate/orchestration/flows/runners.py"}, "prefect_dask": {"src/nlupdate/orchestration/flows/runners.py"}}, missing
