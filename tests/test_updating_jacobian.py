"""The Jacobian the updating methods use, against references computed here.

The end-to-end updating tests reach the truth whatever the scale of the sensitivities
(a Gauss–Newton iteration with S scaled by 2 still converges, only linearly), so they
cannot tell a right Jacobian from a wrong one. These tests can:

* 3-mass chain: every finite-difference formula, through the path the updating
  methods take (:meth:`ModalResponse.jacobian`, and the ``sensitivity`` an updating
  run returns), against the analytical eigenvalue derivative
  ``dλ/dp = φᵀ(dK/dp − λ dM/dp)φ`` (mass-normalised φ), ``df/dp = (dλ/dp)/(8π² f)``,
  with K, M and their derivatives built in this file.
* T-beam surrogate: the E column against ``f/(2E)`` and against the closed-form value
  of each difference formula applied to ``f ∝ √E`` (every frequency of the surrogate
  scales exactly with √E); the h1 and h2 columns against a Richardson-extrapolated
  central difference computed in this file with its own steps.
* The iteration: with an exact Jacobian, inverse eigensensitivity is Newton's method.
  For one parameter on the √E law its iterates follow the Newton map
  ``e → 2√(1+e) − 2 − e`` (e = E/E_true − 1) and it needs 3 iterations to 1e-6; a
  Jacobian scaled by 2 halves the error per step, a sign error walks away.
"""
from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from nlupdate.fe.adapters.base import Parameter
from nlupdate.fe.adapters.lumped import LumpedAdapter
from nlupdate.fe.adapters.surrogate import SurrogateAdapter
from nlupdate.core.updating.eigensensitivity import EigensensitivityOptions, inverse_eigensensitivity
from nlupdate.core.updating.evaluation import MemoisedEvaluator
from nlupdate.core.updating.optimisation import OptimisationOptions, optimise_frequencies
from nlupdate.core.updating.residuals import ModalResponse, ResponseOptions
from nlupdate.core.updating.sensitivity import FORMULAS, jacobian
from nlupdate.core.updating.targets import UpdatingTargets

# ------------------------------------------------------------------ 3-mass chain
MASSES = [0.1, 0.3, 0.2]
NOMINAL_K = [1e6, 1e6, 1e6, 1e6]
POINT = {"m1": 0.1, "m2": 0.3, "m3": 0.2, "k1": 1.25e6, "k2": 0.8e6, "k3": 1.1e6, "k4": 1.0e6}
#: stiffnesses and a mass: dλ/dm is negative, so a sign error cannot hide
UPDATED = ("k1", "k2", "m2", "k4")
RELATIVE_STEP = 1e-3
#: largest error of a column (relative to the column's largest entry) at 0.1 % steps;
#: measured on the chain 5.2e-4 (one-sided), 6.6e-7 (central O(h²)), 4e-12 (central O(h⁴))
#: and on the T-beam 6.1e-4, 1.3e-6, 4e-10
TOLERANCE = {"forward": 1.5e-3, "backward": 1.5e-3, "central2": 5e-6, "central4": 5e-9}


def chain_matrices(values):
    """M and K of ground –k1– m1 –k2– m2 –k3– m3 –k4– ground (written out, not the adapter's)."""
    m1, m2, m3 = values["m1"], values["m2"], values["m3"]
    k1, k2, k3, k4 = values["k1"], values["k2"], values["k3"], values["k4"]
    mass = np.diag([m1, m2, m3])
    stiffness = np.array([[k1 + k2, -k2, 0.0], [-k2, k2 + k3, -k3], [0.0, -k3, k3 + k4]])
    return mass, stiffness


def analytical_frequency_jacobian(values, names):
    """∂f_r/∂p (Hz per parameter unit), shape (3, len(names)). M and K are linear in every
    parameter, so ∂M/∂p and ∂K/∂p are the matrices of a unit value of p alone."""
    mass, stiffness = chain_matrices(values)
    lam, phi = scipy.linalg.eigh(stiffness, mass)  # φᵀMφ = I
    f = np.sqrt(lam) / (2 * np.pi)
    columns = []
    for name in names:
        d_mass, d_stiffness = chain_matrices({key: float(key == name) for key in values})
        d_lam = np.einsum("ir,ij,jr->r", phi, d_stiffness, phi) - lam * np.einsum("ir,ij,jr->r", phi, d_mass, phi)
        columns.append(d_lam / (8 * np.pi**2 * f))
    return np.column_stack(columns)


def column_errors(s, reference):
    """Largest error of each column relative to that column's largest reference entry."""
    return np.max(np.abs(s - reference), axis=0) / np.max(np.abs(reference), axis=0)


def chain_parameters(relative_step=RELATIVE_STEP):
    return [Parameter(name, "-", POINT[name], POINT[name] / 4, POINT[name] * 4, relative_step) for name in UPDATED]


def chain_response(formula):
    """The updating methods' response (f/f_target) of the chain at POINT, the other
    parameters fixed; targets 1 % off the chain's frequencies."""
    f_chain = LumpedAdapter(MASSES, NOMINAL_K).evaluate(POINT).natural_frequencies_hz
    targets = UpdatingTargets(1.01 * f_chain)
    fixed = {name: value for name, value in POINT.items() if name not in UPDATED}
    evaluator = MemoisedEvaluator(LumpedAdapter(MASSES, NOMINAL_K))
    return ModalResponse(evaluator, chain_parameters(), targets, fixed, ResponseOptions(formula=formula)), targets


def test_analytical_reference_is_right():
    """The reference itself, on a case with a closed form: scaling every spring by s
    scales every frequency by √s, so Σ_k k ∂f/∂k = f/2, and Σ_m m ∂f/∂m = −f/2."""
    names = ["k1", "k2", "k3", "k4", "m1", "m2", "m3"]
    s = analytical_frequency_jacobian(POINT, names)
    f = np.sqrt(scipy.linalg.eigh(*chain_matrices(POINT)[::-1], eigvals_only=True)) / (2 * np.pi)
    weights = np.array([POINT[n] for n in names])
    np.testing.assert_allclose(s[:, :4] @ weights[:4], f / 2, rtol=1e-12)
    np.testing.assert_allclose(s[:, 4:] @ weights[4:], -f / 2, rtol=1e-12)


@pytest.mark.parametrize("formula", list(FORMULAS))
def test_chain_jacobian_of_the_updating_response_matches_the_eigenvalue_derivative(formula):
    response, targets = chain_response(formula)
    values = {name: POINT[name] for name in UPDATED}
    base = response.evaluate(values)
    s = response.jacobian(values, base, response.pair(base), formula)  # ∂(f/f_target)/∂p
    reference = analytical_frequency_jacobian(POINT, UPDATED) / targets.frequencies_hz[:, None]
    assert np.all(column_errors(s, reference) < TOLERANCE[formula]), column_errors(s, reference)


@pytest.mark.parametrize("formula", list(FORMULAS))
def test_chain_jacobian_of_a_plain_response_matches_the_eigenvalue_derivative(formula):
    adapter = LumpedAdapter(MASSES, NOMINAL_K)
    values = {name: POINT[name] for name in UPDATED}
    s = jacobian(lambda p: adapter.evaluate({**POINT, **p}).natural_frequencies_hz, values, chain_parameters(), formula)
    reference = analytical_frequency_jacobian(POINT, UPDATED)
    assert np.all(column_errors(s, reference) < TOLERANCE[formula]), column_errors(s, reference)


def test_one_sided_formulas_step_to_opposite_sides():
    """Forward and backward truncation errors are ±(h/2)·f'' to first order: equal and
    opposite, and their mean is the central O(h²) value. A swapped or one-sided stencil,
    or a step of the wrong length, breaks this."""
    adapter = LumpedAdapter(MASSES, NOMINAL_K)
    values = {name: POINT[name] for name in UPDATED}

    def s(formula):
        return jacobian(lambda p: adapter.evaluate({**POINT, **p}).natural_frequencies_hz, values, chain_parameters(), formula)

    reference = analytical_frequency_jacobian(POINT, UPDATED)
    forward, backward = s("forward") - reference, s("backward") - reference
    scale = np.max(np.abs(forward), axis=0)
    assert np.all(scale > 1e-5 * np.max(np.abs(reference), axis=0))  # a real O(h) error to compare
    np.testing.assert_allclose(forward / scale, -backward / scale, atol=0.01)
    np.testing.assert_allclose((s("forward") + s("backward")) / 2, s("central2"), rtol=0, atol=1e-9 * np.abs(reference).max())


@pytest.mark.parametrize("method", ["eigensensitivity", "optimisation"])
def test_the_jacobian_an_updating_run_used_is_the_eigenvalue_derivative(method):
    """The last sensitivity of a real run (k1, k2 from three frequencies of the truth),
    at the point where it was formed, against the analytical derivative there."""
    truth = LumpedAdapter(MASSES, NOMINAL_K).evaluate(POINT).natural_frequencies_hz
    targets = UpdatingTargets(truth)
    parameters = [Parameter(name, "N/m", start, 0.4e6, 2.5e6, RELATIVE_STEP) for name, start in (("k1", 1.1e6), ("k2", 0.9e6))]
    fixed = {"k3": POINT["k3"]}
    if method == "eigensensitivity":
        result = inverse_eigensensitivity(LumpedAdapter(MASSES, NOMINAL_K), parameters, targets,
                                          EigensensitivityOptions(formula="central2", frequency_tolerance=1e-6), fixed)
    else:
        result = optimise_frequencies(LumpedAdapter(MASSES, NOMINAL_K), parameters, targets,
                                      OptimisationOptions(formula="central2"), fixed)
    assert result.sensitivity is not None
    point = {**POINT, **result.sensitivity_point}
    reference = analytical_frequency_jacobian(point, ("k1", "k2")) / truth[:, None]
    assert np.all(column_errors(result.sensitivity, reference) < TOLERANCE["central2"])


# ------------------------------------------------------------------ T-beam surrogate
BEAM_FIXED = {"transducer_mass": 0.0302, "accelerometer_mass": 0.0048}
BEAM_POINT = {"E": 195e9, "h2": 1.45e-3, "h1": 8.0e-3}

#: each formula applied to g(E) = √E at E with step δE, divided by g'(E) = 1/(2√E)
DISCRETE_SQRT = {
    "forward": lambda d: 2 * (np.sqrt(1 + d) - 1) / d,
    "backward": lambda d: 2 * (1 - np.sqrt(1 - d)) / d,
    "central2": lambda d: (np.sqrt(1 + d) - np.sqrt(1 - d)) / d,
    "central4": lambda d: (-np.sqrt(1 + 2 * d) + 8 * np.sqrt(1 + d) - 8 * np.sqrt(1 - d) + np.sqrt(1 - 2 * d)) / (6 * d),
}


def beam_adapter():
    return SurrogateAdapter("tbeam", n_modes=3, global_modes_only=True, mesh_options={"elements_per_beam": 8})


@pytest.fixture(scope="module")
def beam_reference():
    """Frequencies at BEAM_POINT and ∂f/∂p: E analytical; h2, h1 by Richardson-extrapolated
    central differences with 0.4 % and 0.2 % steps (error ~1e-10 of the column)."""
    adapter = beam_adapter()

    def f(**change):
        return adapter.evaluate({**BEAM_FIXED, **BEAM_POINT, **change}).natural_frequencies_hz

    f0 = f()
    columns = [f0 / (2 * BEAM_POINT["E"])]
    for name in ("h2", "h1"):
        value = BEAM_POINT[name]
        central = [(f(**{name: value + r * value}) - f(**{name: value - r * value})) / (2 * r * value) for r in (4e-3, 2e-3)]
        columns.append((4 * central[1] - central[0]) / 3)
    return f0, np.column_stack(columns)


@pytest.mark.parametrize("formula", list(FORMULAS))
def test_tbeam_jacobian_matches_independent_references(formula, beam_reference):
    f0, reference = beam_reference
    targets = UpdatingTargets(f0)  # response f/f0
    parameters = [Parameter(name, "-", value, value / 2, 2 * value, RELATIVE_STEP) for name, value in BEAM_POINT.items()]
    response = ModalResponse(MemoisedEvaluator(beam_adapter()), parameters, targets, BEAM_FIXED, ResponseOptions(formula=formula))
    base = response.evaluate(BEAM_POINT)
    s = response.jacobian(BEAM_POINT, base, response.pair(base), formula) * f0[:, None]
    assert np.all(column_errors(s, reference) < TOLERANCE[formula]), column_errors(s, reference)
    # the E column is the formula's exact value on f ∝ √E: any other step or weight shows
    np.testing.assert_allclose(s[:, 0], reference[:, 0] * DISCRETE_SQRT[formula](RELATIVE_STEP), rtol=1e-7)


# ------------------------------------------------------------------ the iteration
def newton_errors(e0, n):
    """Relative errors e_k = E_k/E_true − 1 of Newton's method on f ∝ √E, from e0."""
    errors = [e0]
    for _ in range(n):
        e = errors[-1]
        errors.append(2 * np.sqrt(1 + e) - 2 - e)
    return np.array(errors)


@pytest.mark.parametrize("formula", list(FORMULAS))
def test_single_parameter_update_follows_the_newton_map(formula):
    """E alone for f1 = 40.75 Hz (thesis §4.1): 3 iterations to 1e-6, each iterate where
    an exact Newton step puts it (up to the O(h) Jacobian error of the one-sided formulas).
    With the Jacobian ×2 the errors go 0.30, 0.14, 0.07 …; with its sign flipped, up."""
    adapter = SurrogateAdapter("tbeam", n_modes=2, global_modes_only=True, mesh_options={"elements_per_beam": 8})
    f_initial = adapter.evaluate({"E": 210e9}).natural_frequencies_hz[0]
    e_true = 210e9 * (40.75 / f_initial) ** 2
    result = inverse_eigensensitivity(
        adapter, [Parameter("E", "Pa", 210e9, 100e9, 300e9, RELATIVE_STEP)], UpdatingTargets([40.75]),
        EigensensitivityOptions(formula=formula, frequency_tolerance=1e-6),
    )
    errors = result.history["p:E"].to_numpy() / e_true - 1
    expected = newton_errors(210e9 / e_true - 1, 3)
    assert result.converged and result.reason == "frequency"
    assert result.iterations == 3
    # a one-sided Jacobian is off by ~h/4 = 2.5e-4 relative: the step is off by that fraction
    allowed = 1e-3 * np.abs(np.r_[0.0, expected[:-1]]) + 1e-8
    assert np.all(np.abs(errors - expected) <= allowed), (errors, expected)
    assert abs(errors[-1]) < 1e-6


@pytest.mark.parametrize("formula", list(FORMULAS))
def test_two_parameter_update_converges_quadratically(formula):
    """E and h2 from three global modes (sensor masses on), truth 195 GPa / 1.45 mm from
    210 GPa / 1.5 mm: the parameter error falls 7.7e-2 → 2.4e-3 → ~6e-6 → ~1e-9 (an
    exact-Jacobian Newton step squares it); three iterations, each ≥ 20× smaller.
    A Jacobian ×2 only halves it per iteration."""
    truth = {"E": 195e9, "h2": 1.45e-3}
    targets = UpdatingTargets(beam_adapter().evaluate({**truth, **BEAM_FIXED}).natural_frequencies_hz)
    parameters = [Parameter("E", "Pa", 210e9, 150e9, 250e9, RELATIVE_STEP), Parameter("h2", "m", 1.5e-3, 1.2e-3, 1.8e-3, RELATIVE_STEP)]
    result = inverse_eigensensitivity(beam_adapter(), parameters, targets,
                                      EigensensitivityOptions(formula=formula, frequency_tolerance=1e-6), BEAM_FIXED)
    history = result.history
    errors = np.max([np.abs(history[f"p:{name}"].to_numpy() / value - 1) for name, value in truth.items()], axis=0)
    assert result.converged and result.iterations <= 3, errors
    assert np.all(errors[1:] <= 0.05 * errors[:-1]), errors
    assert errors[-1] < 1e-6
