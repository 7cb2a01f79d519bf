"""Dask is an optional part (``pip install 'nlupdate[dask]'``): the base install leaves its
15 packages out, every command runs without it, and --dask / --dask-address without it say
in one line what to install (issue "rough edges a new user hit": ``pip install .`` brought
~150 packages)."""
from __future__ import annotations

import subprocess
import sys
import time
import tomllib
from pathlib import Path

import pytest

from nlupdate.cli import main

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
    started = time.perf_counter()
    code = main(["run", str(two_dof_study_file), *option, "--out", str(tmp_path / "results")])
    assert code == 2
    assert capsys.readouterr().err.splitlines() == [
        f"nlupdate run: error: {option[0]} needs Dask, an optional part of nlupdate that is not installed: "
        f"pip install 'nlupdate[dask]'"]
    assert not (tmp_path / "results").exists() and time.perf_counter() - started < 10  # no server started


def test_a_dask_execution_without_dask_says_what_to_install(without_dask):
    from nlupdate.flows.runners import Execution, ExecutionError, task_runner

    with pytest.raises(ExecutionError, match=r"not installed: pip install 'nlupdate\[dask\]'"):
        with task_runner(Execution(workers=1, dask=True)):
            pass


def test_the_flows_import_and_run_on_threads_without_dask():
    """In a fresh interpreter where Dask cannot be imported: the flows import, the default
    task runner is a thread pool, and the commands' parser is built."""
    code = BLOCK + (
        "from nlupdate.cli import build_parser\n"
        "build_parser()\n"
        "import nlupdate.flows.run, nlupdate.flows.study, nlupdate.flows.discovery\n"
        "from nlupdate.flows.runners import Execution, task_runner\n"
        "with task_runner(Execution(workers=2)) as (runner, what):\n"
        "    print(type(runner).__name__, what)\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stdout.strip() == "ThreadPoolTaskRunner 2 threads"
