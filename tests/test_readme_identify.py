"""The README's `identify` example (section "Commands") recovers the truth it simulates.

The two commands are read from the README as written (simulate the 2-DOF of docs/methods.md §8 of
examples/two_dof.toml with 5 % noise, then identify cubic + Jenkins by PRD) and run in a
fresh folder; the truth is read from the model file. Tolerances: k3 within 5 %, kf and the
slip force within 2 % (seeds 1–6 give at most 2.7 %, 0.9 % and 0.5 %; the slow test
checks seeds 2–6), and no warning.
"""
from __future__ import annotations

import json
import re
import shlex
import tomllib
import warnings
from pathlib import Path

import pytest

from nlupdate.app.cli import main

ROOT = Path(__file__).resolve().parents[1]
TOLERANCE = {"k3": 0.05, "kf": 0.02, "slip_force": 0.02}


def readme_commands() -> dict[str, list[str]]:
    """The README's ``nlupdate simulate examples/two_dof.toml`` and ``nlupdate identify``
    commands of its "Commands" block (argv without ``nlupdate``, paths into examples/ absolute)."""
    text = (ROOT / "README.md").read_text()
    block = re.search(r"## Commands\n+```bash\n(.*?)```", text, re.S).group(1)
    lines = re.sub(r"\\\n\s*", " ", block).splitlines()  # join continued lines
    commands = {}
    for line in lines:
        argv = shlex.split(line, comments=True)
        if argv[:3] == ["nlupdate", "simulate", "examples/two_dof.toml"] or argv[:2] == ["nlupdate", "identify"]:
            commands.setdefault(argv[1], [str(ROOT / a) if a.startswith("examples/") else a for a in argv[1:]])
    assert set(commands) == {"simulate", "identify"}, commands
    return commands


def truth() -> dict[str, float]:
    model = tomllib.loads((ROOT / "examples" / "two_dof.toml").read_text())
    elements = {element["type"]: element for element in model["nonlinear"]}
    return {"k3": elements["cubic"]["k3"], "kf": elements["jenkins"]["kf"], "slip_force": elements["jenkins"]["slip_force"]}


def identify(folder: Path, capsys, seed: int | None = None, samples: int | None = None) -> dict:
    commands = readme_commands()
    simulate, ident = commands["simulate"], commands["identify"]
    if seed is not None:
        simulate[simulate.index("--seed") + 1] = str(seed)
    if samples is not None:
        ident += ["--samples", str(samples)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(simulate) == 0
        assert main(ident) == 0
    out = capsys.readouterr().out
    result = json.loads((folder / ident[ident.index("--out") + 1] / "identification.json").read_text())
    return {"parameters": result["parameters"], "warnings": result["warnings"], "stdout": out}


def test_the_readme_identify_example_recovers_the_truth(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    result = identify(tmp_path, capsys)
    for name, value in truth().items():
        estimate = result["parameters"][name]
        assert estimate["value"] == pytest.approx(value, rel=TOLERANCE[name]), name
        assert abs(estimate["value"] - value) < 4 * estimate["std"] + 0.005 * value, name  # its own ± is honest
    assert result["warnings"] == [] and "warning" not in result["stdout"]


@pytest.mark.slow
@pytest.mark.parametrize("seed", [2, 3, 4, 5, 6])
def test_the_readme_identify_example_holds_over_noise_seeds(seed, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    result = identify(tmp_path, capsys, seed=seed, samples=5)
    for name, value in truth().items():
        assert result["parameters"][name]["value"] == pytest.approx(value, rel=TOLERANCE[name]), (seed, name)
