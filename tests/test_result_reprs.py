"""Results print as one short line and say more through ``summary()``: ``print(nlu.discover(…))``
printed 90 kB (every measured point), and so did the other results (issue "rough edges a
new user hit"). The numbers shown are checked against the truth the data were made from."""
from __future__ import annotations

import re

import numpy as np
import pytest

import nlupdate as nlu

LEVELS_N = [0.01, 20.0, 60.0, 100.0]


@pytest.fixture(scope="module")
def chain():
    """The 2-DOF rig of examples/two_dof.toml (k3 = 1e10 N/m³, kf = 8e4 N/m, slip force 1 N at
    "0") measured at four levels; a chain model whose k1 (truth 1e6 N/m) starts 20 % low."""
    truth = nlu.load_model("examples/two_dof.toml")
    measured = nlu.simulate(truth, "0", np.linspace(690.0, 770.0, 81), LEVELS_N, noise=0.01, seed=3)
    found = nlu.identify(measured, elements=("cubic", "jenkins"), samples=4, seed=1)
    model = nlu.fe_model("lumped", masses=[0.1, 0.5], stiffnesses=[0.8e6, 1.0e6, 1.0e6])
    updated = nlu.update(model, [nlu.Parameter("k1", "N/m", 0.8e6, 0.5e6, 1.5e6)], found.natural_frequencies_hz[:1],
                         model_modes=[2])
    prediction = nlu.predict(updated, found, measured, model_response_dof="x1")
    return found, updated, prediction


def numbers_after(text: str, name: str) -> float:
    return float(re.search(rf"{name} = ([-+0-9.e]+)", text).group(1))


def short(result) -> str:
    text = repr(result)
    assert str(result) == text and "\n" not in text and len(text) < 300, text
    return text


def test_identification_prints_one_line(chain):
    text = short(chain[0])
    assert text.startswith("<Identification PRD at 0/0: k3 = ")
    assert numbers_after(text, "k3") == pytest.approx(1e10, rel=0.02)
    assert numbers_after(text, "kf") == pytest.approx(8e4, rel=0.02)
    assert numbers_after(text, "slip_force") == pytest.approx(1.0, rel=0.05)
    assert re.search(r"k3 = \S+ ± \S+,", text)  # the Monte-Carlo std beside the value


def test_updating_result_prints_one_line_and_a_summary(chain):
    _, updated, _ = chain
    assert numbers_after(short(updated), "k1") == pytest.approx(1e6, rel=1e-3)
    lines = updated.summary().splitlines()
    assert lines[0].startswith("eigensensitivity forward: k1 = ") and lines[1].startswith("converged")
    before, after, target = map(float, re.fullmatch(r"mode1: (\S+) → (\S+) Hz \(target (\S+) Hz\)", lines[-1]).groups())
    # the chain's mode 2 with k1 = 0.8e6 N/m, from its matrices
    mass, stiffness = np.diag([0.1, 0.5]), np.array([[1.8e6, -1e6], [-1e6, 2e6]])
    expected = np.sqrt(np.linalg.eigvals(np.linalg.solve(mass, stiffness)).real.max()) / (2 * np.pi)
    assert before == pytest.approx(expected, abs=1e-4) and after == pytest.approx(target, abs=2e-3)


def test_predictions_print_one_line_and_a_summary(chain):
    _, _, prediction = chain
    text = short(prediction)
    assert text.startswith("<LevelPredictions at 0.01 20 60 100 N: FRAC ")
    lines = prediction.summary().splitlines()
    assert lines[0].startswith("loss factor ") and "fitted to the 0.01 N measurement" in lines[0]
    assert len(lines) == 1 + len(LEVELS_N)
    assert all(float(re.search(r"FRAC (\S+),", line).group(1)) > 0.99 for line in lines[1:])  # the truth's model


def test_a_study_result_prints_one_line_and_a_summary():
    """examples/two_dof_study.toml: the chain's k1 starts 20 % low, its truth is 1e6 N/m."""
    result = nlu.run_study(nlu.load_study("examples/two_dof_study.toml"))
    text = short(result)
    assert text == ("<StudyResult 'two-dof-python': 3 updating run(s); best 'optimisation {k1}'; 2 prediction(s); "
                    "0 warning(s)>")
    lines = result.summary().splitlines()
    runs = [line for line in lines if line.startswith("run ")]
    assert len(runs) == 3 and all(numbers_after(line, "k1") == pytest.approx(1e6, rel=1e-3) for line in runs)
    assert "best ranked: optimisation {k1}" in lines
    assert any(line.startswith("identified (PRD): k3 = ") for line in lines)
