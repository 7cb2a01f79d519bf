"""Runs that do not converge: why they stopped, how they rank, what the summary says.

The case is the 3-DOF chain ground –k1– m1 –k2– m2 –k3– m3 (2, 1, 0.5 kg) with k2, k3
updated from its three modes (truth k1 = k2 = 1e5, k3 = 5e4 N/m) in a model whose k1 is
half the structure's (:func:`studies.three_dof_chain_study`): no k2, k3 meets all three
modes, the residual stays large, and undamped Gauss–Newton steps from k2 = k3 = 5e4 N/m
jump between two points for ever. The references are computed here: the chain's
frequencies by ``scipy.linalg.eigh`` of K and M written out, its least-squares optimum
by ``scipy.optimize.least_squares`` on them. The last test predicts the 2-DOF study of
the flow tests with a wrong target, so the best model predicts worse than the initial one.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.linalg
import scipy.optimize

from nlupdate.fe.adapters.base import FEAdapter, ModalResult, Parameter
from nlupdate.app.cli import main
from nlupdate.reporting.archive import write_archive
from nlupdate.reporting.report import summary_section
from nlupdate.study import load_study, run_study
from nlupdate.core.updating import EigensensitivityOptions, UpdatingTargets, inverse_eigensensitivity
from studies import CHAIN_MASSES, CHAIN_MODEL_K1, CHAIN_TRUTH, small_two_dof_study, three_dof_chain_study, write_study

BOTH = "eigensensitivity central O(h²) {k2, k3}"
K3_ONLY = "eigensensitivity central O(h²) {k3}"


def chain_hz(k1: float, k2: float, k3: float) -> np.ndarray:
    """Natural frequencies (Hz) of the free-ended chain, solved here."""
    stiffness = np.array([[k1 + k2, -k2, 0.0], [-k2, k2 + k3, -k3], [0.0, -k3, k3]])
    return np.sqrt(scipy.linalg.eigh(stiffness, np.diag(CHAIN_MASSES), eigvals_only=True)) / (2 * np.pi)


TARGETS = chain_hz(**CHAIN_TRUTH)


def model_errors(k2: float, k3: float) -> np.ndarray:
    """f_model / f_target − 1 of the analyst's model (its k1 half the truth's)."""
    return chain_hz(CHAIN_MODEL_K1, k2, k3) / TARGETS - 1


def least_squares_optimum() -> np.ndarray:
    """(k2, k3) minimising Σ (f/f_target − 1)², independently of the code."""
    fit = scipy.optimize.least_squares(lambda x: model_errors(*(1e5 * x)), [0.5, 0.5], xtol=1e-14, ftol=1e-14)
    return 1e5 * fit.x


def run(tmp_path: Path, name: str, **options):
    return run_study(load_study(write_study(tmp_path / name / "study.toml", three_dof_chain_study(TARGETS, **options))))


def test_undamped_steps_cycle_and_the_trust_region_reaches_the_least_squares_optimum(tmp_path):
    undamped = run(tmp_path, "none", step_control="none").runs[0]
    assert not undamped.converged and undamped.stop == "cycle detected"
    k = undamped.history[["p:k2", "p:k3"]].to_numpy()
    # a 2-cycle: the last point is the one before the previous (within the parameter
    # tolerance, 1e-6 of the 5e4 N/m start), far from the previous
    assert np.max(np.abs(k[-1] - k[-3])) <= 1e-6 * 5e4
    assert np.max(np.abs(k[-1] / k[-2] - 1)) > 0.05
    assert undamped.iterations < 20  # stopped when the cycle was seen, not at the limit

    damped = run(tmp_path, "trust region").runs[0]  # the default step control
    assert damped.converged and damped.stop == "converged" and damped.reason == "parameter change"
    np.testing.assert_allclose([damped.parameters["k2"], damped.parameters["k3"]], least_squares_optimum(), rtol=1e-4)
    cost = [np.sum(model_errors(k2, k3) ** 2) for k2, k3 in damped.history[["p:k2", "p:k3"]].to_numpy()]
    assert np.all(np.diff(cost) <= 1e-15)  # every step taken lowers the residual
    assert damped.history["rejected_steps"].sum() > 0  # the steps that would have cycled were cut


def test_a_run_that_cycles_ranks_after_one_that_converged_though_its_errors_are_smaller(tmp_path):
    result = run(tmp_path, "ranked", parameter_sets=[["k2", "k3"], ["k3"]], step_control="none")
    runs = {r.name: r for r in result.runs}
    assert runs[BOTH].stop == "cycle detected" and runs[K3_ONLY].converged
    # where the cycling run stopped its mean |error| is below the converged run's: ranked by
    # the errors alone it would be the best model
    mean_error = {name: np.mean(np.abs(model_errors(r.parameters.get("k2", 5e4), r.parameters["k3"])))
                  for name, r in runs.items()}
    assert mean_error[BOTH] < mean_error[K3_ONLY]
    ranking = result.ranking.set_index("candidate")
    assert ranking.loc[K3_ONLY, "rank"] < ranking.loc[BOTH, "rank"]
    assert [n for n in result.ranking["candidate"] if n != "initial"] == [K3_ONLY, BOTH]
    assert bool(ranking.loc[K3_ONLY, "converged"]) and not bool(ranking.loc[BOTH, "converged"])

    folder = write_archive(result, tmp_path / "ranked" / "archive", {"orchestration": "test"})
    summary = summary_section((folder / "report.md").read_text())
    assert f"Best updated model for the user weights: {K3_ONLY}" in summary
    assert not summary.startswith("The updating run") and "None of the" not in summary
    assert f"{BOTH}: did not converge (cycle detected" in summary  # the warning names it


def test_when_no_run_converges_the_summary_says_so_first_and_prints_no_uncertainty(tmp_path, capsys):
    path = write_study(tmp_path / "cycle" / "study.toml", three_dof_chain_study(TARGETS, step_control="none"))
    out = tmp_path / "cycle" / "out"
    assert main(["update", str(path), "--out", str(out), "--quiet"]) == 0
    printed = capsys.readouterr().out.splitlines()
    assert printed[0].startswith(f"The updating run did not converge ({BOTH}: cycle detected")
    best = next(line for line in printed if line.startswith("best for the user weights"))
    assert best.startswith("best for the user weights: initial") or best.endswith("NOT converged)")
    report = (out / "report.md").read_text()
    summary = summary_section(report)
    first = summary.splitlines()[0]
    assert first.startswith(f"The updating run did not converge ({BOTH}: cycle detected: iteration")
    assert "(period 2)" in first and "not updated parameters" in first
    updated = next(line for line in summary.splitlines() if "No converged updated model" in line)
    assert "±" not in updated and "k2 = " in updated and "(not converged)" in updated
    table_row = next(line for line in report.splitlines() if line.startswith(f"| {BOTH} |"))
    assert "±" not in table_row and "not converged" in table_row


def test_a_best_model_that_predicts_worse_than_the_initial_one_is_the_first_warning(tmp_path, capsys):
    """The 2-DOF structure (m1 = 0.1, m2 = 0.5 kg, k = 1e6 N/m, ground–m1–m2–ground) has
    its m1 mode at 732 Hz; the model starts at k1 = 0.8e6, k2 = 1.2e6 N/m. A target of
    712 Hz — further from the structure than the initial model — pulls k1 down and
    makes every prediction worse; the target the identification finds does not."""
    def mode_hz(k1, k2, k3=1e6):
        stiffness = np.array([[k1 + k2, -k2], [-k2, k2 + k3]])
        return np.sqrt(scipy.linalg.eigh(stiffness, np.diag([0.1, 0.5]), eigvals_only=True)) / (2 * np.pi)
    structure, initial = mode_hz(1e6, 1e6)[1], mode_hz(0.8e6, 1.2e6)[1]
    assert abs(712.0 - structure) > abs(initial - structure)  # the premise: the wrong target is further off

    study = small_two_dof_study()
    study["targets"] = {"frequencies_hz": [712.0], "response_dof": "0", "input_dof": "0", "model_response_dof": "x1",
                        "model_input_dof": "x1", "model_modes": [2]}
    out = tmp_path / "worse" / "out"
    assert main(["update", str(write_study(tmp_path / "worse" / "study.toml", study)), "--out", str(out), "--quiet"]) == 0
    printed = capsys.readouterr().out.splitlines()
    assert printed[0].startswith("warning: prediction: the best updated model `eigensensitivity forward O(h) {k1}` "
                                 "predicts the measurements worse than the initial model: FRAC per level")
    summary = summary_section((out / "report.md").read_text())
    lines = [line for line in summary.splitlines() if line.strip()]
    assert lines[0].startswith("Warnings") and lines[1].startswith("* prediction: the best updated model")

    good = run_study(load_study(write_study(tmp_path / "good" / "study.toml", small_two_dof_study())))
    assert good.runs[0].converged and not [w for w in good.warnings if w.kind == "prediction_worse"]


class KinkAdapter(FEAdapter):
    """One mode at f = 10 Hz + |k − 1| Hz·m/N: its lowest frequency, 10 Hz at k = 1 N/m, is a kink."""

    name = "kink"

    def __init__(self) -> None:
        super().__init__(("k",))

    def model_fingerprint(self) -> str:
        return "kink"

    def _solve(self, parameters):
        return ModalResult(np.array([10.0 + abs(parameters["k"] - 1.0)]), np.ones((1, 1)), ("x",))


def test_a_trust_region_that_finds_no_lower_residual_stops_as_such():
    """A 5 Hz target is out of reach; the closest point, k = 1, is a kink where the forward
    difference promises a fall to 5 Hz that no step gives: the trust radius shrinks onto
    the kink and the run stops there, not converged, without ever raising the error."""
    result = inverse_eigensensitivity(KinkAdapter(), [Parameter("k", "N/m", 3.0, 0.0, 5.0, 1e-6)], UpdatingTargets([5.0]),
                                      EigensensitivityOptions(formula="forward"))
    assert not result.converged and result.stop == "no decrease" and "no step" in result.reason
    assert result.parameters["k"] == pytest.approx(1.0, abs=1e-4)
    assert np.all(np.diff(result.history["max_abs_error_pct"]) <= 0)
    assert result.iterations < 20


def test_a_contracting_oscillation_is_not_a_cycle_and_a_repeating_one_is():
    """Points x_n = x* + a(−c)^n, the path of a Gauss–Newton run on noisy targets (c = 0.65
    on a 3-mass chain, test_target_miss_warnings): the point two back comes within the
    tolerance before the step does, and was called a period-2 cycle; a path that returns
    with repeating steps is one."""
    from nlupdate.core.updating.stopping import cycle_period

    tolerance, limit = 1e-6, np.array([1.19, 0.84])
    direction = np.array([1.0, -0.7])
    for c in (0.5, 0.65, 0.9):
        path = [limit + 0.07 * (-c) ** n * direction for n in range(200)]
        at_rest = next(n for n in range(1, 200) if np.max(np.abs(path[n] - path[n - 1])) <= tolerance)
        assert all(cycle_period(path[:n + 1], tolerance) is None for n in range(at_rest + 1)), c
    a, b = limit, limit + 0.01 * direction
    assert cycle_period([limit + 0.03 * direction, a, b, a], tolerance) == 2
    assert cycle_period([a, b, a, b, a + 2e-7], tolerance) == 2  # within the tolerance
    assert cycle_period([a, b, limit + 0.02 * direction, a, b, limit + 0.02 * direction + 5e-7], tolerance) == 3
