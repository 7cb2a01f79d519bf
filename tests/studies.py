"""Study files for the tests, built as data: a study is the parsed TOML (a dict), edited
as a dict and written back with tomli-w — never by editing TOML text.

``two_dof_study()`` is ``tests/data/studies/two_dof.toml`` (the 2-DOF of docs/methods.md §8, the flow
tests' whole-chain study) with its truth model's path made absolute, so the copy runs
from any folder.
"""
from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

import tomli_w

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
TWO_DOF_MODEL = EXAMPLES / "two_dof.toml"
TWO_DOF_STUDY = ROOT / "tests" / "data" / "studies" / "two_dof.toml"


def two_dof_study(model: str | Path = TWO_DOF_MODEL) -> dict[str, Any]:
    """The two-dof study as a dict, its ``[measured.simulate] model`` set to ``model``."""
    study = tomllib.loads(TWO_DOF_STUDY.read_text())
    study["measured"]["simulate"]["model"] = str(model)
    return study


def small_two_dof_study() -> dict[str, Any]:
    """The two-dof study made small: two force levels, 41 frequencies, 4 Monte-Carlo
    samples, k1 alone, forward differences, no optimisation."""
    study = two_dof_study()
    study["measured"]["simulate"].update(forces_n=[0.01, 60], frequencies_hz=[690.0, 770.0, 41])
    study["identification"]["samples"] = 4
    study["parameters"] = [p for p in study["parameters"] if p["name"] == "k1"]
    study["eigensensitivity"] = {"formulas": ["forward"]}
    del study["optimisation"]
    return study


def study_text(study: dict[str, Any]) -> str:
    """The TOML text of a study dict."""
    return tomli_w.dumps(study)


def write_study(path: Path, study: dict[str, Any]) -> Path:
    """Write ``study`` to ``path`` (folders made) and return the path."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(study_text(study))
    return path
