"""The layers, checked: numerics and adapters import no orchestration, CLI or pyplot.

Every module of the numerics (``nlupdate`` without ``cli``, ``flows``, ``tasks``) and of
the adapters is imported in a fresh interpreter, which must not have loaded Prefect,
the flows, the tasks, the CLI or ``matplotlib.pyplot`` afterwards; no source file of
theirs selects a matplotlib backend.
"""
from __future__ import annotations

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
