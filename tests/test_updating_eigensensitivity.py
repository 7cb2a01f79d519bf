"""Inverse eigensensitivity updating on models with a known truth."""
from __future__ import annotations

import numpy as np
import pytest

from nlupdate.fe.adapters.base import Parameter
from nlupdate.fe.adapters.lumped import LumpedAdapter
from nlupdate.fe.adapters.surrogate import SurrogateAdapter
from nlupdate.core.updating.eigensensitivity import EigensensitivityOptions, inverse_eigensensitivity
from nlupdate.core.updating.pairing import pair_modes
from nlupdate.core.updating.sensitivity import FORMULAS
from nlupdate.core.updating.targets import UpdatingTargets

NEW_POINTS = {"forward": 1, "backward": 1, "central2": 2, "central4": 4}
MASSES = [0.1, 0.3, 0.2]
NOMINAL_K = [1e6, 1e6, 1e6, 1e6]
TRUTH_K = {"k1": 1.25e6, "k2": 0.8e6, "k3": 1.1e6}


class RecordingAdapter(LumpedAdapter):
    """Lumped chain that remembers every point it actually solved."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.solved = []

    def _solve(self, parameters):
        self.solved.append(self.key(parameters))
        return super()._solve(parameters)


def chain_parameters(start=(0.6e6, 1.5e6)):
    return [Parameter(name, "N/m", value, 0.4e6, 2.5e6, 1e-4) for name, value in zip(("k1", "k2"), start)]


def truth_result():
    return LumpedAdapter(MASSES, NOMINAL_K).evaluate(TRUTH_K)


@pytest.mark.parametrize("formula", list(FORMULAS))
def test_every_formula_recovers_the_truth_with_the_predicted_evaluation_counts(formula):
    """k1, k2 from three frequencies made with the truth (k3 known, k4 nominal).

    Three springs from three frequencies would not do: that inverse eigenproblem has
    other exact solutions (e.g. k = 1.196e6, 0.837e6, 1.105e6 N/m gives the same
    frequencies), so an overdetermined set is used.
    """
    truth = truth_result()
    targets = UpdatingTargets(truth.natural_frequencies_hz)
    adapter = RecordingAdapter(MASSES, NOMINAL_K)
    result = inverse_eigensensitivity(
        adapter, chain_parameters(), targets, EigensensitivityOptions(formula=formula, frequency_tolerance=1e-6),
        fixed={"k3": TRUTH_K["k3"]},
    )

    assert result.converged and result.reason == "frequency"
    for name in ("k1", "k2"):
        assert result.parameters[name] == pytest.approx(TRUTH_K[name], rel=5e-3)
    assert np.abs(result.history["max_abs_error_pct"].iloc[-1]) <= 1e-4

    n_parameters, iterations = 2, result.iterations
    # Gauss–Newton with the right Jacobian: 6 iterations from this start; the same run
    # with the sensitivities scaled by 2 (or 1.25) converges only linearly (19, or 10)
    assert 3 <= iterations <= 6
    assert result.counts["new"] == 1 + iterations * (n_parameters * NEW_POINTS[formula] + 1)
    one_sided = formula in ("forward", "backward")
    assert result.counts["cached"] == (iterations * n_parameters if one_sided else 0)
    # per-iteration bookkeeping in the history, and no point (base or other) solved twice
    history = result.history
    assert history["new_evaluations"].tolist() == [1] + [n_parameters * NEW_POINTS[formula] + 1] * iterations
    assert history["cached_evaluations"].tolist() == [0] + [n_parameters if one_sided else 0] * iterations
    assert len(adapter.solved) == len(set(adapter.solved)) == result.counts["new"]


def test_single_parameter_tbeam_update_follows_the_square_root_law():
    """All T-beam frequencies scale with √E, so the E that gives f1 = 40.75 Hz is known."""
    target = 40.75
    for formula in FORMULAS:
        adapter = SurrogateAdapter("tbeam", n_modes=2, global_modes_only=True, mesh_options={"elements_per_beam": 8})
        initial = adapter.evaluate({"E": 210e9}).natural_frequencies_hz
        expected_e = 210e9 * (target / initial[0]) ** 2
        parameter = Parameter("E", "Pa", 210e9, 100e9, 300e9, 1e-3)
        result = inverse_eigensensitivity(
            adapter, [parameter], UpdatingTargets([target]), EigensensitivityOptions(formula=formula, frequency_tolerance=1e-6)
        )
        assert result.converged
        assert result.iterations == 3  # Newton on f ∝ √E from 210 GPa (Jacobian ×2: 17)
        assert result.parameters["E"] == pytest.approx(expected_e, rel=1e-5)
        f2 = result.final.natural_frequencies_hz[1]
        assert f2 == pytest.approx(initial[1] * np.sqrt(result.parameters["E"] / 210e9), rel=1e-6)


def test_bounds_hold_when_the_truth_lies_outside_them():
    truth = truth_result()
    parameters = [Parameter("k1", "N/m", 1e6, 0.9e6, 1.1e6, 1e-4), Parameter("k2", "N/m", 1e6, 0.4e6, 2.5e6, 1e-4)]
    result = inverse_eigensensitivity(
        LumpedAdapter(MASSES, NOMINAL_K), parameters, UpdatingTargets(truth.natural_frequencies_hz[:2]),
        EigensensitivityOptions(formula="central2"), fixed={"k3": TRUTH_K["k3"]},
    )
    # it comes to rest on the bound: a stop, not convergence (the targets are out of reach)
    assert not result.converged and result.stop == "parameter at bound"
    assert result.reason == "parameter at bound (k1 on its upper bound 1.1e+06)"
    assert result.parameters["k1"] == pytest.approx(1.1e6, rel=1e-12)  # truth 1.25e6 is above the bound
    assert (result.history["p:k1"] <= 1.1e6).all() and (result.history["p:k1"] >= 0.9e6).all()


@pytest.mark.parametrize("regularisation", [0.0, 0.3, 1.0])
def test_tikhonov_step_matches_the_closed_form(regularisation):
    """One parameter: Δx = s·Δr / (s² + λ²) with s = ∂(f/f_t)/∂(k/k0) = f0 / (2 f_t) at k0."""
    m, k0, k_true = 0.2, 1e6, 1.3e6
    f_target = np.sqrt(k_true / m) / (2 * np.pi)
    f0 = np.sqrt(k0 / m) / (2 * np.pi)
    s = f0 / (2 * f_target)
    expected_step = s * (1 - f0 / f_target) / (s**2 + regularisation**2)
    result = inverse_eigensensitivity(
        LumpedAdapter([m], [k0]), [Parameter("k1", "N/m", k0, 0.5e6, 2e6, 1e-4)], UpdatingTargets([f_target]),
        EigensensitivityOptions(formula="central4", regularisation=regularisation, max_iterations=1),
    )
    assert result.history["p:k1"].iloc[1] / k0 - 1 == pytest.approx(expected_step, rel=1e-6)
    assert result.iterations == 1 and not result.converged


def test_mac_pairing_and_mode_shape_residual_with_shuffled_targets():
    truth = truth_result()
    order = [2, 0, 1]
    shapes = truth.mode_shapes[:, order] * np.array([2.0, -0.5, 3.0])  # any scaling and sign
    targets = UpdatingTargets(truth.natural_frequencies_hz[order], mode_shapes=shapes, coordinates=truth.coordinates)
    adapter = LumpedAdapter(MASSES, NOMINAL_K)
    assert pair_modes(adapter.evaluate({}), targets, "mac").model_indices == (2, 0, 1)
    parameters = chain_parameters() + [Parameter("k3", "N/m", 1e6, 0.4e6, 2.5e6, 1e-4)]
    result = inverse_eigensensitivity(
        adapter, parameters, targets,
        EigensensitivityOptions(formula="central2", pairing="mac", min_mac=0.9, use_mode_shapes=True, frequency_tolerance=1e-6),
    )
    assert result.converged
    for name, value in TRUTH_K.items():  # the shapes make all three springs identifiable
        assert result.parameters[name] == pytest.approx(value, rel=5e-3)
    assert min(result.final_pairing.mac) > 0.9999


def test_nearest_pairing_skips_unmeasured_modes():
    truth = truth_result()
    targets = UpdatingTargets(truth.natural_frequencies_hz[1:])
    initial = LumpedAdapter(MASSES, NOMINAL_K).evaluate({})
    assert pair_modes(initial, targets, "order").model_indices == (0, 1)
    assert pair_modes(initial, targets, "nearest").model_indices == (1, 2)
    with pytest.raises(ValueError, match="two or more coordinates"):
        pair_modes(initial, targets, "mac")


def test_options_are_checked():
    with pytest.raises(ValueError, match="formula"):
        EigensensitivityOptions(formula="secant")
    with pytest.raises(ValueError, match="pairing"):
        EigensensitivityOptions(pairing="closest")
    with pytest.raises(ValueError, match="lower < upper"):
        inverse_eigensensitivity(LumpedAdapter([1.0], [1.0]), [Parameter("k1", "N/m", 1.0, 1.0, 1.0)], UpdatingTargets([1.0]))


@pytest.mark.parametrize("formula", list(FORMULAS))
def test_tbeam_surrogate_recovers_e_and_h2_from_three_global_modes(formula):
    """Data made with E = 195 GPa, h2 = 1.45 mm (sensor masses on); start 210 GPa, 1.5 mm."""
    truth = {"E": 195e9, "h2": 1.45e-3}
    fixed = {"transducer_mass": 0.0302, "accelerometer_mass": 0.0048}

    def adapter():
        return SurrogateAdapter("tbeam", n_modes=3, global_modes_only=True, mesh_options={"elements_per_beam": 8})

    targets = UpdatingTargets(adapter().evaluate({**truth, **fixed}).natural_frequencies_hz)
    parameters = [Parameter("E", "Pa", 210e9, 150e9, 250e9, 1e-3), Parameter("h2", "m", 1.5e-3, 1.2e-3, 1.8e-3, 1e-3)]
    run = adapter()
    result = inverse_eigensensitivity(run, parameters, targets, EigensensitivityOptions(formula=formula, frequency_tolerance=1e-6), fixed)
    assert result.converged
    assert result.iterations <= 3  # quadratic convergence (Jacobian ×2: 17 iterations)
    for name, value in truth.items():
        assert result.parameters[name] == pytest.approx(value, rel=5e-3)
    assert result.counts["new"] == 1 + result.iterations * (2 * NEW_POINTS[formula] + 1)
