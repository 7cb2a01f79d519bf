"""Study files for the tests, built as data: a study is the parsed TOML (a dict), edited
as a dict and written back with tomli-w — never by editing TOML text.

``two_dof_study()`` is ``tests/data/studies/two_dof.toml`` (the 2-DOF of docs/methods.md §8, the flow
tests' whole-chain study) with its truth model's path made absolute, so the copy runs
from any folder.
``three_dof_chain_study()`` updates k2, k3 of a 3-DOF chain from three modes its model
cannot all meet (its k1 is wrong): undamped Gauss–Newton steps cycle there.
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


#: The 3-DOF chain ground –k1– m1 –k2– m2 –k3– m3 (kg, N/m): the structure, and the
#: analyst's model, whose k1 is half the structure's.
CHAIN_MASSES = [2.0, 1.0, 0.5]
CHAIN_TRUTH = {"k1": 1.0e5, "k2": 1.0e5, "k3": 5.0e4}
CHAIN_MODEL_K1 = 0.5e5


def three_dof_chain_study(target_hz: list[float], parameter_sets: list[list[str]] | None = None,
                          step_control: str | None = None) -> dict[str, Any]:
    """k2 and k3 of the 3-DOF chain updated from the three modes ``target_hz`` (Hz) identified
    on the structure (:data:`CHAIN_TRUTH`); the model's k1 is :data:`CHAIN_MODEL_K1`, so no
    k2, k3 meets all three. Both start at 5e4 N/m, bounds 1e4–1e6; central differences;
    ``parameter_sets`` (default: both together) and ``step_control`` (default: the code's)."""
    eigensensitivity: dict[str, Any] = {"formulas": ["central2"], "parameter_sets": parameter_sets or [["k2", "k3"]]}
    if step_control is not None:
        eigensensitivity["step_control"] = step_control
    return {
        "study": {"name": "three-dof chain"},
        "adapter": {"kind": "lumped", "options": {"masses": CHAIN_MASSES,
                                                   "stiffnesses": [CHAIN_MODEL_K1, 5.0e4, 5.0e4]}},
        "parameters": [{"name": name, "unit": "N/m", "start": 5.0e4, "lower": 1.0e4, "upper": 1.0e6}
                       for name in ("k2", "k3")],
        "targets": {"frequencies_hz": [float(f) for f in target_hz]},
        "eigensensitivity": eigensensitivity,
    }


def study_text(study: dict[str, Any]) -> str:
    """The TOML text of a study dict."""
    return tomli_w.dumps(study)


def write_study(path: Path, study: dict[str, Any]) -> Path:
    """Write ``study`` to ``path`` (folders made) and return the path."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(study_text(study))
    return path
