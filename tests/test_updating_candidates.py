"""Optimisation-based updating, candidate sweeps, comparison and ranking; targets from FRFs."""
from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
import scipy.optimize

from nlupdate.fe.adapters.base import Parameter
from nlupdate.fe.adapters.lumped import LumpedAdapter
from nlupdate.core.model.linear import LumpedModel, ModalModel
from nlupdate.core.measurement.frf_table import frf_table
from nlupdate.core.measurement.frf_files import write_frf_table
from nlupdate.fe.adapters.registry import AdapterSpec
from nlupdate.fe.adapters.registry import build_adapter
from nlupdate.core.updating.evaluation import MemoisedEvaluator
from nlupdate.core.updating.runs import UpdatingRun, compare_candidates, rank_candidates, update
from nlupdate.core.updating.eigensensitivity import EigensensitivityOptions
from nlupdate.core.updating.optimisation import OptimisationOptions, optimise_frequencies
from nlupdate.core.updating.targets import UpdatingTargets, frf_natural_frequencies, peak_frequencies, read_linear_frf

MASSES = [0.1, 0.3, 0.2]
NOMINAL_K = [1e6, 1e6, 1e6, 1e6]
TRUTH_K = {"k1": 1.25e6, "k2": 0.8e6, "k3": 1.1e6}
SPEC = AdapterSpec("lumped", options={"masses": MASSES, "stiffnesses": NOMINAL_K})


def run_in_order(runs: list[UpdatingRun]):
    """The runs in order, one memoised evaluator for all (they share one model)."""
    evaluator = MemoisedEvaluator(build_adapter(runs[0].adapter))
    return [update(run, evaluator) for run in runs]


def truth_frequencies():
    return LumpedAdapter(MASSES, NOMINAL_K).evaluate(TRUTH_K).natural_frequencies_hz


def spring(name, start=1e6, lower=0.4e6, upper=2.5e6):
    return Parameter(name, "N/m", start, lower, upper, 1e-4)


def test_optimisation_recovers_the_truth():
    result = optimise_frequencies(
        LumpedAdapter(MASSES, NOMINAL_K), [spring("k1", 0.6e6), spring("k2", 1.5e6)], UpdatingTargets(truth_frequencies()),
        OptimisationOptions(formula="central2"), fixed={"k3": TRUTH_K["k3"]},
    )
    assert result.converged
    for name in ("k1", "k2"):
        assert result.parameters[name] == pytest.approx(TRUTH_K[name], rel=5e-3)
    assert np.abs(result.history["max_abs_error_pct"].iloc[-1]) < 1e-3


@pytest.mark.parametrize("weights", [(1.0, 1.0, 1.0), (10.0, 1.0, 0.1), (0.1, 1.0, 10.0)])
def test_weighted_fit_matches_an_independent_scalar_minimisation(weights):
    """Only k2 is updated while k3 keeps a wrong value, so the targets cannot all be met;
    the weighted optimum must equal the one found by a bounded scalar search."""
    targets = UpdatingTargets(truth_frequencies(), weights)
    fixed = {"k1": TRUTH_K["k1"], "k3": 1e6}
    w = np.asarray(weights)

    def objective(k2):
        mass = np.diag(MASSES)
        k = [TRUTH_K["k1"], k2, 1e6, 1e6]
        stiffness = np.array([[k[0] + k[1], -k[1], 0], [-k[1], k[1] + k[2], -k[2]], [0, -k[2], k[2] + k[3]]])
        f = LumpedModel(mass, stiffness).modes()[0] / (2 * np.pi)
        return np.sum(w * (f / targets.frequencies_hz - 1) ** 2)

    reference = scipy.optimize.minimize_scalar(objective, bounds=(0.4e6, 2.5e6), method="bounded", options={"xatol": 1.0}).x
    result = optimise_frequencies(
        LumpedAdapter(MASSES, NOMINAL_K), [spring("k2")], targets, OptimisationOptions(formula="central4"), fixed
    )
    assert result.parameters["k2"] == pytest.approx(reference, rel=1e-4)


def test_optimisation_stays_within_bounds():
    result = optimise_frequencies(
        LumpedAdapter(MASSES, NOMINAL_K), [spring("k1", 1e6, 0.9e6, 1.1e6), spring("k2")],
        UpdatingTargets(truth_frequencies()), fixed={"k3": TRUTH_K["k3"]},
    )
    assert result.parameters["k1"] == pytest.approx(1.1e6, rel=1e-6)
    assert result.history["p:k1"].between(0.9e6, 1.1e6).all()


def sweep():
    targets = UpdatingTargets(truth_frequencies())
    fixed = {"k3": TRUTH_K["k3"]}
    tasks = [
        UpdatingRun(f"eig {formula}", SPEC, (spring("k1"), spring("k2")), targets, "eigensensitivity",
                     EigensensitivityOptions(formula=formula), fixed)
        for formula in ("forward", "central4")
    ]
    tasks += [
        UpdatingRun("opt k1", SPEC, (spring("k1"),), targets, "optimisation", OptimisationOptions(), fixed),
        UpdatingRun("opt k1 k2", SPEC, (spring("k1"), spring("k2")), targets.with_weights([1, 2, 3]), "optimisation",
                     OptimisationOptions(), fixed),
    ]
    return tasks


def test_a_sweep_solves_a_point_shared_by_its_runs_once():
    """Every run of the sweep starts at the same point of the same model: only the first
    run computes it, and each run still reaches the truth on its own."""
    results = run_in_order(sweep())
    assert [r.name for r in results] == [t.name for t in sweep()]
    first_rows = [r.history.iloc[0] for r in results]
    assert (first_rows[0]["new_evaluations"], first_rows[0]["cached_evaluations"]) == (1, 0)
    assert (first_rows[1]["new_evaluations"], first_rows[1]["cached_evaluations"]) == (0, 1)
    assert first_rows[3]["new_evaluations"] == 0  # "opt k1 k2" starts there too
    for result in (results[0], results[1], results[3]):  # the {k1, k2} runs meet every target
        for name in ("k1", "k2"):
            assert result.parameters[name] == pytest.approx(TRUTH_K[name], rel=5e-3), result.name
    # "opt k1" cannot (k2 stays at its nominal 1e6 N/m): its k1 is the least-squares optimum,
    # found here by a bounded scalar search
    assert results[2].parameters["k1"] == pytest.approx(k1_only_optimum(), rel=1e-5)
    assert "k2" not in results[2].parameters


def k1_only_optimum():
    """argmin over k1 of Σ (f_i/f_i^truth − 1)² with k2 = 1e6, k3 = 1.1e6, k4 = 1e6 N/m."""
    target = truth_frequencies()

    def objective(k1):
        stiffness = np.array([[k1 + 1e6, -1e6, 0], [-1e6, 1e6 + 1.1e6, -1.1e6], [0, -1.1e6, 1.1e6 + 1e6]])
        f = LumpedModel(np.diag(MASSES), stiffness).modes()[0] / (2 * np.pi)
        return np.sum((f / target - 1) ** 2)

    return scipy.optimize.minimize_scalar(objective, bounds=(0.4e6, 2.5e6), method="bounded", options={"xatol": 1.0}).x


def test_candidate_frf_comparison_identifies_the_truth():
    """The truth candidate's modal-superposition FRF equals the direct-solve FRF of the
    truth model with structural damping D = γK (modal loss factor γ): FRAC = 1."""
    gamma = 0.01
    truth = dict(TRUTH_K, k4=1e6)
    adapter = LumpedAdapter(MASSES, NOMINAL_K)
    mass, stiffness = adapter.matrices(truth)
    frequencies = np.linspace(150, 900, 1501)
    h_reference = LumpedModel.with_loss_factor(mass, stiffness, gamma).receptance(2 * np.pi * frequencies, [0], [0])[:, 0, 0]
    results = run_in_order(sweep())
    comparison = compare_candidates(results, (frequencies, h_reference), "x1", "x1", loss_factors=gamma)

    assert list(comparison["candidate"].unique()) == ["initial"] + [t.name for t in sweep()]
    truth_like = comparison[comparison["candidate"] == "eig central4"]
    assert truth_like["frac"].min() > 0.9999
    assert truth_like["error_pct"].abs().max() < 1e-2
    initial = comparison[comparison["candidate"] == "initial"]
    assert (initial["frac"].to_numpy() < truth_like["frac"].to_numpy()).all()
    expected_error = 100 * (LumpedAdapter(MASSES, NOMINAL_K).evaluate({"k3": 1.1e6}).natural_frequencies_hz / truth_frequencies() - 1)
    np.testing.assert_allclose(initial["error_pct"], expected_error, rtol=1e-12)

    ranking = rank_candidates(comparison, [1, 1, 1])
    assert ranking["candidate"].iloc[-1] == "initial"
    assert ranking.loc[ranking["candidate"] == "eig central4", "rank_frac"].item() <= 2


def test_ranking_follows_the_user_weights():
    comparison = pd.DataFrame({
        "candidate": ["A", "A", "B", "B"],
        "mode": ["mode1", "mode2", "mode1", "mode2"],
        "error_pct": [0.1, -3.0, -1.0, 0.5],
        "frac": [0.99, 0.80, 0.95, 0.97],
    })
    by_mode1 = rank_candidates(comparison, {"mode1": 1.0})
    assert by_mode1["candidate"].tolist() == ["A", "B"]
    assert by_mode1["weighted_abs_error_pct"].tolist() == pytest.approx([0.1, 1.0])
    both = rank_candidates(comparison, [1.0, 1.0])
    assert both["candidate"].tolist() == ["B", "A"]
    assert both["weighted_abs_error_pct"].tolist() == pytest.approx([0.75, 1.55])
    assert both.set_index("candidate")["rank_frac"].to_dict() == {"B": 1, "A": 2}
    with pytest.raises(ValueError, match="unknown mode"):
        rank_candidates(comparison, {"mode3": 1.0})


def test_peak_picking_finds_the_natural_frequencies():
    f_r = np.array([52.3, 141.7, 305.2])
    zeta = 0.005
    modal = ModalModel(f_r, np.array([[1.0, -0.8, 0.6]]), damping_ratios=zeta)
    frequencies = np.arange(20.0, 400.0, 0.25)
    h = modal.receptance(2 * np.pi * frequencies, [0], [0])[:, 0, 0]
    peaks = peak_frequencies(frequencies, h, 3)
    np.testing.assert_allclose(peaks, f_r * np.sqrt(1 - 2 * zeta**2), rtol=3e-4)
    np.testing.assert_allclose(peak_frequencies(frequencies, h, 1, band_hz=(100, 200)), [f_r[1]], rtol=3e-4)
    np.testing.assert_allclose(frf_natural_frequencies(frequencies, h, 3, method="line_fit"), f_r, rtol=2e-4)
    with pytest.raises(ValueError, match="expected 4"):
        peak_frequencies(frequencies, h, 4)
    with pytest.raises(ValueError, match="expected one of"):
        frf_natural_frequencies(frequencies, h, 3, method="circle_fit")


def test_linear_frf_is_found_from_a_directory_a_json_file_or_the_table(tmp_path):
    frequencies = np.linspace(10, 100, 50)
    h = 1e-6 / (1 - (frequencies / 60) ** 2 + 0.02j)
    table = frf_table(frequencies, 1.0, "tip:uz", "tip:uz", h)
    result_dir = tmp_path / "ident"
    result_dir.mkdir()
    write_frf_table(table, result_dir / "linear_frf.parquet")
    (tmp_path / "result.json").write_text(json.dumps({"linear_frf": "ident/linear_frf.parquet"}))
    for path in (result_dir, tmp_path / "result.json", result_dir / "linear_frf.parquet"):
        f, hh = read_linear_frf(path, "tip:uz", "tip:uz")
        np.testing.assert_allclose(f, frequencies)
        np.testing.assert_allclose(hh, h)
    with pytest.raises(ValueError, match="available"):
        read_linear_frf(result_dir, "tip:uy", "tip:uz")
    with pytest.raises(FileNotFoundError, match="linear_frf.parquet"):
        read_linear_frf(tmp_path, "tip:uz", "tip:uz")
