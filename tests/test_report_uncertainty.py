"""An updated value without an uncertainty is reported as the value and why it has none —
the CalculiX example's report printed ``E = 1.567e+11 ± –`` (issue "rough edges a new user
hit") — and with ``std_hz`` on the targets the ± is there."""
from __future__ import annotations

import re

import numpy as np
import pytest

from nlupdate.app.cli import main
import studies

MASSES = [0.1, 0.5]  # kg
TRUE_K1 = 1.0e6  # N/m


def mode2_hz(k1: float = TRUE_K1) -> float:
    """Mode 2 (Hz) of ground–k1–0.1 kg–1e6 N/m–0.5 kg–1e6 N/m–ground, from its matrices."""
    k = np.array([[k1 + 1e6, -1e6], [-1e6, 2e6]])
    return float(np.sqrt(np.linalg.eigvals(np.linalg.solve(np.diag(MASSES), k)).real.max()) / (2 * np.pi))


def report(tmp_path, std_hz: list[float] | None) -> str:
    targets = {"frequencies_hz": [mode2_hz()], "model_modes": [2]}
    if std_hz is not None:
        targets["std_hz"] = std_hz
    study = {"study": {"name": "chain"},
             "adapter": {"kind": "lumped", "options": {"masses": MASSES, "stiffnesses": [0.8e6, 1e6, 1e6]}},
             "parameters": [{"name": "k1", "unit": "N/m", "start": 0.8e6, "lower": 0.5e6, "upper": 1.5e6}],
             "targets": targets, "eigensensitivity": {"formulas": ["central2"]}}
    path = studies.write_study(tmp_path / "study.toml", study)
    assert main(["update", str(path), "--out", str(tmp_path / "out")]) == 0
    return (tmp_path / "out" / "report.md").read_text()


def test_no_target_std_reports_the_value_and_why(tmp_path):
    text = report(tmp_path, None)
    assert "± –" not in text
    best = next(line for line in text.splitlines() if line.startswith("* **Best updated model**"))
    value = re.search(r"k1 = (\S+) N/m \(no uncertainty: the targets state no std_hz\)$", best)  # its declared unit
    assert value, best
    assert float(value.group(1)) == pytest.approx(TRUE_K1, rel=1e-3)
    assert "No ± on the updated values: the targets state no std_hz" in text


def test_target_std_gives_a_plus_minus(tmp_path):
    text = report(tmp_path, [0.5])
    best = next(line for line in text.splitlines() if line.startswith("* **Best updated model**"))
    value, std = map(float, re.search(r"k1 = (\S+) ± (\S+) N/m$", best).groups())
    assert value == pytest.approx(TRUE_K1, rel=1e-3)
    # linearised: σ_k1 = σ_f / (∂f2/∂k1), the derivative by central differences of the eigenvalue
    h = 1e3
    expected = 0.5 / ((mode2_hz(TRUE_K1 + h) - mode2_hz(TRUE_K1 - h)) / (2 * h))
    assert std == pytest.approx(expected, rel=0.05)
    assert "No ± on" not in text
