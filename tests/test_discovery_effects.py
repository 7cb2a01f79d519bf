"""Discovery building blocks against independent references.

* every library DF against the docs/methods.md §2 formulas written out here;
* linear corrections against hand-assembled matrices, and the modal (Rayleigh–Ritz) form
  against the corrected lumped model;
* variable-projection starts recover noise-free parameters;
* the per-point output-error model (scalar condensation at a place, frozen background)
  against the project's continuation solver on the full system;
* the single-mode phase-resonance solution against closed forms;
* the noise level of the gap (1 − FRAC ≈ σ²) over many noise draws.
"""
import numpy as np
import pytest

from nlupdate.core.correlation.metrics import frac
from nlupdate.core.discovery.candidates import at_noise_level
from nlupdate.core.discovery.effects import (
    LIBRARY, Clearance, CoulombSlider, CubicHardening, CubicSoftening, DampingError, DFSamples, DryFriction, MassError,
    QuadraticDamper, StiffnessError, library,
)
from nlupdate.core.discovery.errors import DiscoveryError
from nlupdate.core.discovery.frf_fit import background_receptance, frf_context
from nlupdate.core.discovery.linear_edits import add_linear_correction
from nlupdate.core.discovery.backbone_fit import phase_resonance
from nlupdate.core.discovery.starts import joint_starts
from nlupdate.core.measurement.noise import add_frf_noise
from nlupdate.core.model.elements import CubicStiffness, JenkinsFriction, SymmetricGap
from nlupdate.core.model.linear import LumpedModel, ModalModel
from nlupdate.core.model.system import NonlinearSystem
from nlupdate.core.response.continuation import trace_frequency_response
from nlupdate.core.response.stepped_sine import stepped_sine

A = np.geomspace(1e-6, 1e-3, 40)
W = np.full(A.size, 2 * np.pi * 700.0)


def jenkins_formula(kf, fs, a):
    """docs/methods.md §2, written out independently of nlupdate.core.model.elements."""
    a0 = fs / kf
    beta = np.arccos(np.clip(1 - 2 * a0 / a, -1, 1))
    slipping = (kf / np.pi) * (beta - 0.5 * np.sin(2 * beta)) + 1j * 4 * fs / (np.pi * a) * (1 - a0 / a)
    return np.where(a <= a0, kf + 0j, slipping)


def gap_formula(g, kc, a):
    r = np.clip(g / a, 0, 1)
    return np.where(a <= g, 0.0, kc * (1 - 2 / np.pi * (np.arcsin(r) + r * np.sqrt(1 - r**2))))


@pytest.mark.parametrize(
    "effect,values,expected",
    [
        (CubicHardening(), [2e11], lambda a, w: 0.75 * 2e11 * a**2),
        (CubicSoftening(), [-1e11], lambda a, w: -0.75 * 1e11 * a**2),
        (DryFriction(), [1e5, 3.0], lambda a, w: jenkins_formula(1e5, 3.0, a)),
        (DryFriction(stuck_in_model=True), [1e5, 3.0], lambda a, w: jenkins_formula(1e5, 3.0, a) - 1e5),
        (CoulombSlider(), [0.7], lambda a, w: 4j * 0.7 / (np.pi * a)),
        (QuadraticDamper(), [2.5], lambda a, w: 8j * 2.5 * w**2 * a / (3 * np.pi)),
        (Clearance(), [1e-4, 5e4], lambda a, w: gap_formula(1e-4, 5e4, a)),
        (StiffnessError(), [-3e4], lambda a, w: -3e4 + 0 * a),
        (MassError(), [0.01], lambda a, w: -(w**2) * 0.01 + 0 * a),
        (DampingError(), [4.0], lambda a, w: 1j * w * 4.0 + 0 * a),
    ],
)
def test_library_describing_functions_follow_methods_formulas(effect, values, expected):
    np.testing.assert_allclose(effect.nu(np.array(values), A, W), expected(A, W), rtol=1e-12, atol=1e-9)
    # scale × shape form used for the starts
    shape = {DryFriction: values[-1] / values[0], Clearance: values[0]}.get(type(effect))
    scale = values[-1] if isinstance(effect, Clearance) else values[0]
    np.testing.assert_allclose(effect.values(scale, shape), values, rtol=1e-12)
    np.testing.assert_allclose(scale * effect.basis(shape, A, W), effect.nu(np.array(values), A, W), rtol=1e-12, atol=1e-9)


def test_library_selects_by_name_and_rejects_unknown_names():
    assert {e.name for e in LIBRARY} == {
        "cubic_stiffness", "softening_stiffness", "dry_friction", "microslip", "coulomb_friction", "quadratic_damping",
        "gap", "stiffness_error", "mass_error", "damping_error",
    }
    assert library(["dry_friction"]) == (DryFriction(), DryFriction(stuck_in_model=True))
    with pytest.raises(DiscoveryError, match="unknown effect 'glue'"):
        library(["glue"])


TWO_DOF = LumpedModel(np.diag([0.1, 0.5]), 1e6 * np.array([[2.0, -1.0], [-1.0, 2.0]]), 3.0 * np.eye(2), 0.01 * 1e6 * np.eye(2))


@pytest.mark.parametrize("dofs", [(0,), (1,), (0, 1)])
def test_linear_corrections_edit_the_matrices_at_the_place(dofs):
    s = np.zeros(2)
    s[dofs[0]] = 1
    if len(dofs) == 2:
        s[dofs[1]] = -1
    corrected = add_linear_correction(TWO_DOF, dofs, stiffness=-2e5, damping=1.5, mass=0.02 if len(dofs) == 1 else 0.0)
    mass = np.diag([0.1, 0.5]).copy()
    if len(dofs) == 1:
        mass[dofs[0], dofs[0]] += 0.02
    np.testing.assert_allclose(corrected.mass, mass)
    np.testing.assert_allclose(corrected.stiffness, 1e6 * np.array([[2.0, -1.0], [-1.0, 2.0]]) - 2e5 * np.outer(s, s))
    np.testing.assert_allclose(corrected.damping, 3.0 * np.eye(2) + 1.5 * np.outer(s, s))
    np.testing.assert_allclose(corrected.structural_damping, TWO_DOF.structural_damping)


@pytest.mark.parametrize("dofs,correction", [((1,), {"stiffness": -3e5}), ((0,), {"mass": 0.03}), ((0, 1), {"stiffness": 4e5})])
def test_modal_corrections_match_the_corrected_lumped_model(dofs, correction):
    lumped = LumpedModel(np.diag([0.1, 0.5]), 1e6 * np.array([[2.0, -1.0], [-1.0, 2.0]]))
    modal = lumped.to_modal()  # all modes: the Ritz basis is complete
    expected = add_linear_correction(lumped, dofs, **correction)
    got = add_linear_correction(modal, dofs, **correction)
    w = 2 * np.pi * np.linspace(100, 900, 9)
    np.testing.assert_allclose(got.receptance(w, [0, 1], [0, 1]), expected.receptance(w, [0, 1], [0, 1]), rtol=1e-9)


def test_stuck_friction_in_model_leaves_the_low_amplitude_model_unchanged():
    system = NonlinearSystem(TWO_DOF)
    augmented = DryFriction(stuck_in_model=True).apply(system, (0,), [2e5, 1.0])
    assert augmented.elements == (JenkinsFriction((0,), kf=2e5, slip_force=1.0),)
    stuck = add_linear_correction(augmented.model, (0,), stiffness=2e5)  # the Jenkins spring while stuck
    w = 2 * np.pi * np.linspace(100, 900, 9)
    np.testing.assert_allclose(stuck.receptance(w, [0, 1], [0, 1]), TWO_DOF.receptance(w, [0, 1], [0, 1]), rtol=1e-12)


@pytest.mark.parametrize(
    "effects,values",
    [
        ((DryFriction(),), ([1.2e5, 1.2e5 * A[15]],)),
        ((Clearance(),), ([A[30], 4e4],)),
        ((CubicHardening(), DryFriction()), ([3e11], [8e4, 8e4 * A[20]])),
    ],
)
def test_variable_projection_starts_recover_noise_free_parameters(effects, values):
    """With the true shape on the scan grid the start is the truth; the grid is log-spaced
    over [A_min/10, 3·A_max] (Jenkins) and [A_min/10, 0.95·A_max] (gap), 24 points."""
    a = np.geomspace(A.min(), A.max(), 24)
    grid = {DryFriction: np.geomspace(a.min() / 10, a.max() * 3, 24), Clearance: np.geomspace(a.min() / 10, a.max() * 0.95, 24)}
    on_grid = []
    for effect, v in zip(effects, values):
        v = np.array(v, dtype=float)
        if isinstance(effect, DryFriction):
            v[1] = v[0] * grid[DryFriction][12]
        if isinstance(effect, Clearance):
            v[0] = grid[Clearance][20]
        on_grid.append(v)
    w = np.full(a.size, 2 * np.pi * 700.0)
    nu = sum(e.nu(v, a, w) for e, v in zip(effects, on_grid))
    start = joint_starts(list(effects), DFSamples(a, w, nu, np.ones(a.size)))[0]
    for got, true in zip(start, on_grid):
        np.testing.assert_allclose(got, true, rtol=1e-8)


def test_frozen_background_receptance_is_the_inverse_of_z_plus_delta():
    element = JenkinsFriction((0, 1), kf=1e5, slip_force=2.0)
    system = NonlinearSystem(TWO_DOF, (element,))
    w = 2 * np.pi * np.array([250.0, 700.0])
    x = {0: np.array([3e-5 + 1e-5j, 1e-4j]), 1: np.array([1e-5, -2e-5 + 1e-6j])}
    got = background_receptance(system, w, [0, 1], x.__getitem__)
    for k in range(w.size):
        nu = complex(element.describing_function(abs(x[0][k] - x[1][k])))
        z = TWO_DOF.dynamic_stiffness(w[k]) + nu * np.array([[1, -1], [-1, 1]])
        np.testing.assert_allclose(got[k], np.linalg.inv(z), rtol=1e-10)


@pytest.mark.parametrize("place,element", [((0,), CubicStiffness((0,), 4e11)), ((0, 1), SymmetricGap((0, 1), 3e-5, 2e5)),
                                           ((1,), JenkinsFriction((1,), kf=1e5, slip_force=4.0))])
def test_per_point_prediction_matches_continuation_of_the_full_system(place, element):
    """The scalar condensation at a place (amplitude root nearest the measured one) gives the
    same responses as the continuation solver of the model with the element."""
    truth = NonlinearSystem(TWO_DOF, (element,))
    f = np.concatenate([np.linspace(230, 300, 15), np.linspace(650, 820, 15)])
    force = np.repeat([5.0, 40.0], f.size)
    w = np.tile(2 * np.pi * f, 2)
    x = np.empty((w.size, 2), complex)
    for level in (5.0, 40.0):
        mask = force == level
        curve = trace_frequency_response(truth, {0: level}, w[mask].min() * 0.99, w[mask].max() * 1.01)
        x[mask] = stepped_sine(curve, w[mask]).response([0, 1])
    measured = {0: x[:, 0], 1: x[:, 1]}
    context = frf_context(
        NonlinearSystem(TWO_DOF), (element,), (), place, 0, (0, 1), w, force, (force > 5).astype(int), x,
        measured.__getitem__, chi2_scale=1.0, penalty=1.0,
    )
    np.testing.assert_allclose(context.predict(), x, rtol=1e-7)
    assert context.localisation.explained == pytest.approx(1.0, abs=1e-9)


def test_phase_resonance_closed_forms():
    modal = ModalModel([10.0], [[0.5]], [0.02])
    wr, psi, force = 2 * np.pi * 10.0, np.full(3, 0.5), np.array([1.0, 3.0, 9.0])
    mode = np.zeros(3, int)
    # a spring: ω² = ω_r² + ψ²Δk, D = 2ζω_rω, Q = φF/D
    w, zeta, q = phase_resonance(modal, mode, 0, force, [(psi, lambda a, om: 2e3 + 0 * a * om)])
    w_expected = np.sqrt(wr**2 + 0.25 * 2e3)
    np.testing.assert_allclose(w, w_expected, rtol=1e-12)
    np.testing.assert_allclose(zeta, 2 * 0.02 * wr * w_expected / (2 * w_expected**2), rtol=1e-12)
    np.testing.assert_allclose(q, 0.5 * force / (2 * 0.02 * wr * w_expected), rtol=1e-10)
    # Coulomb friction: ω = ω_r, Q(2ζω_r² + ψ²·4Fs/(π|ψ|Q)) = φF
    fs = 0.1
    w, zeta, q = phase_resonance(modal, mode, 0, force, [(psi, lambda a, om: 4j * fs / (np.pi * a))])
    q_expected = (0.5 * force - 0.5 * 4 * fs / np.pi) / (2 * 0.02 * wr**2)
    np.testing.assert_allclose(w, wr, rtol=1e-12)
    np.testing.assert_allclose(q, q_expected, rtol=1e-9)
    np.testing.assert_allclose(zeta, 0.02 + 0.25 * 4 * fs / (np.pi * 0.5 * q_expected) / (2 * wr**2), rtol=1e-9)


def test_gap_of_a_perfect_model_is_the_noise_variance():
    """docs/methods.md §8 noise of relative std σ gives E[1 − FRAC] ≈ σ² (the gap's noise level)."""
    f = np.linspace(600, 830, 200)
    h = 1 / (2e6 * (1 + 0.04j) - 0.1 * (2 * np.pi * f) ** 2)
    gaps = [1 - frac(add_frf_noise(h, 0.02, seed), h) for seed in range(200)]
    assert np.mean(gaps) == pytest.approx(0.02**2, rel=0.05)


def test_noise_level_test_accepts_chi_square_draws_and_rejects_a_ten_percent_excess():
    rng = np.random.default_rng(0)
    n = 400
    draws = [float(np.sum(rng.standard_normal(n) ** 2)) for _ in range(500)]
    assert np.mean([at_noise_level(c, n) for c in draws]) > 0.99
    assert not at_noise_level(1.25 * n, n)
