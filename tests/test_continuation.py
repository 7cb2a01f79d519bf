"""Continuation, fixed-point and stepped-sine solvers against independent references.

References used here: the analytical single-harmonic frequency–amplitude relation of
the Duffing oscillator (an implicit equation independent of the solver), finite
differences for Jacobians, and the full (uncondensed) harmonic balance residual
``(Z + Δ) X − F`` assembled directly from docs/methods.md §1.
"""
import warnings

import numpy as np
import pytest
import scipy.sparse

from nlupdate.core.response.continuation import trace_frequency_response
from delta_reference import assemble_delta
from nlupdate.core.model.elements import CubicStiffness, JenkinsFriction, QuadraticDamping, SymmetricGap
from nlupdate.core.response.fixed_point import fixed_point_response
from nlupdate.core.model.linear import LumpedModel
from nlupdate.core.response.stepped_sine import stepped_sine
from nlupdate.core.model.system import CondensedProblem, NonlinearSystem

M, C, K, K3, F = 1.0, 0.05, 1.0, 1.0, 0.5
DUFFING = NonlinearSystem(LumpedModel([[M]], [[K]], [[C]]), (CubicStiffness((0,), K3),))


def duffing_amplitude_equation(amplitude, omega):
    """[(k − mω² + ¾k3A²)² + (cω)²]·A² − F² (zero on the single-harmonic curve)."""
    return ((K - M * omega**2 + 0.75 * K3 * amplitude**2) ** 2 + (C * omega) ** 2) * amplitude**2 - F**2


def duffing_roots(omega):
    """All positive amplitudes at ω: cubic in s = A² of the relation above."""
    a = K - M * omega**2
    coefficients = [(0.75 * K3) ** 2, 2 * a * 0.75 * K3, a**2 + (C * omega) ** 2, -(F**2)]
    s = np.roots(coefficients)
    s = np.real(s[(np.abs(s.imag) < 1e-9) & (s.real > 0)])
    return np.sort(np.sqrt(s))


def duffing_folds():
    """Fold frequencies: where the number of real roots changes (bisection on a fine grid)."""
    grid = np.linspace(0.5, 3.5, 30001)
    counts = np.array([duffing_roots(w).size for w in grid])
    change = np.nonzero(np.diff(counts))[0]
    return np.sort(0.5 * (grid[change] + grid[change + 1]))


@pytest.fixture(scope="module")
def duffing_curve():
    return trace_frequency_response(DUFFING, {0: F}, 0.5, 3.5)


def test_duffing_curve_satisfies_the_analytical_amplitude_relation(duffing_curve):
    amplitude = np.abs(duffing_curve.x_nonlinear[:, 0])
    residual = duffing_amplitude_equation(amplitude, duffing_curve.omega) / F**2
    assert np.max(np.abs(residual)) < 1e-7
    assert duffing_curve.omega[0] == pytest.approx(0.5) and duffing_curve.omega[-1] == pytest.approx(3.5)


def test_duffing_folds_match_the_analytical_folds(duffing_curve):
    expected = duffing_folds()
    found = np.sort(duffing_curve.omega[duffing_curve.turning_point])
    assert expected.size == 2 and found.size == 2
    np.testing.assert_allclose(found, expected, atol=2e-4)
    np.testing.assert_allclose(found, [1.4416, 3.0290], atol=2e-4)  # values quoted in the issue


def test_only_the_middle_of_three_solutions_is_unstable(duffing_curve):
    for omega, x, stable, turning in zip(
        duffing_curve.omega, duffing_curve.x_nonlinear[:, 0], duffing_curve.stable, duffing_curve.turning_point
    ):
        if turning:
            continue
        roots = duffing_roots(omega)
        if roots.size == 3 and min(abs(roots[1] - roots[0]), abs(roots[2] - roots[1])) > 1e-3:
            is_middle = abs(abs(x) - roots[1]) < 1e-6
            assert stable != is_middle, (omega, abs(x), roots)
        elif roots.size == 1:
            assert stable


def test_stepped_sine_jumps_at_the_reported_folds(duffing_curve):
    grid = np.linspace(0.5, 3.5, 301)
    spacing = grid[1] - grid[0]
    low_fold, high_fold = np.sort(duffing_curve.omega[duffing_curve.turning_point])
    up = stepped_sine(duffing_curve, grid, "up")
    down = stepped_sine(duffing_curve, grid, "down")
    assert len(up.jumps_hz) == 1 and len(down.jumps_hz) == 1
    assert 0 < 2 * np.pi * up.jumps_hz[0] - high_fold <= spacing
    assert 0 < low_fold - 2 * np.pi * down.jumps_hz[0] <= spacing
    # sweep up rides the upper (largest) solution until the fold, sweep down the lowest
    for omega, x_up, x_down in zip(grid, up.x_nonlinear[:, 0], down.x_nonlinear[:, 0]):
        roots = duffing_roots(omega)
        assert abs(abs(x_up) - roots[-1] if omega < high_fold else abs(x_up) - roots[0]) < 1e-8
        assert abs(abs(x_down) - roots[0] if omega > low_fold else abs(x_down) - roots[-1]) < 1e-8


def two_dof_system(elements):
    k = 1e6
    model = LumpedModel.with_loss_factor([[0.1, 0.0], [0.0, 0.5]], [[2 * k, -k], [-k, 2 * k]], 0.005)
    return NonlinearSystem(model, elements)


def test_condensed_jacobians_match_finite_differences():
    system = two_dof_system(
        (
            CubicStiffness((0,), 1e10),
            JenkinsFriction((0, 1), kf=8e4, slip_force=1.0),
            QuadraticDamping((1,), cq=3.0),
            SymmetricGap((1,), gap=2e-5, kc=2e5),
        )
    )
    problem = CondensedProblem(system, {0: 30.0}, x_scale=1e-4)
    rng = np.random.default_rng(3)
    y = rng.normal(size=4)
    omega = 2 * np.pi * 700.0
    r, jac, jac_w = problem.residual_and_jacobians(y, omega)
    h = 1e-7
    fd = np.column_stack([(problem.residual(y + h * e, omega) - problem.residual(y - h * e, omega)) / (2 * h) for e in np.eye(4)])
    np.testing.assert_allclose(jac, fd, rtol=1e-5, atol=1e-7 * np.abs(jac).max())
    hw = 1e-6 * omega
    fd_w = (problem.residual(y, omega + hw) - problem.residual(y, omega - hw)) / (2 * hw)
    np.testing.assert_allclose(jac_w, fd_w, rtol=1e-5, atol=1e-7 * np.abs(jac_w).max())
    np.testing.assert_allclose(r, problem.residual(y, omega))


def full_harmonic_balance_residual(system, omega, x_full, force_full):
    """|(Z(ω) + Δ(X)) X − F| / |F| on the uncondensed model."""
    z = system.model.dynamic_stiffness(omega)
    delta = assemble_delta(system.elements, x_full, omega, dofs=range(system.model.n_dof))
    return np.linalg.norm((z + delta) @ x_full - force_full) / np.linalg.norm(force_full)


def test_two_dof_cubic_and_jenkins_curve_solves_the_full_balance():
    system = two_dof_system((CubicStiffness((0,), 1e10), JenkinsFriction((0,), kf=8e4, slip_force=1.0)))
    curve = trace_frequency_response(system, {0: 100.0}, 2 * np.pi * 600, 2 * np.pi * 1100)
    x_full = curve.response([0, 1])
    worst = max(
        full_harmonic_balance_residual(system, w, x, np.array([100.0, 0.0])) for w, x in zip(curve.omega, x_full)
    )
    assert worst < 1e-8
    assert curve.turning_point.sum() == 2  # hardening jump of the m1 mode


def test_element_between_two_dofs_and_large_sparse_model():
    """A 400-dof sparse chain with a cubic link between dofs 10 and 11: full balance holds."""
    n = 400
    k = 1e5 * (2 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1))
    model = LumpedModel(
        scipy.sparse.identity(n, format="csr") * 0.01,
        scipy.sparse.csr_matrix(k),
        structural_damping=scipy.sparse.csr_matrix(0.01 * k),
    )
    system = NonlinearSystem(model, (CubicStiffness((10, 11), 5e11),))
    curve = trace_frequency_response(system, {10: 1.0}, 2 * np.pi * 5.0, 2 * np.pi * 12.0)
    force = np.zeros(n)
    force[10] = 1.0
    x_full = curve.response(range(n))
    for index in range(0, curve.omega.size, max(1, curve.omega.size // 5)):
        assert full_harmonic_balance_residual(system, curve.omega[index], x_full[index], force) < 1e-8


METHODS_SDOF = NonlinearSystem(
    LumpedModel.with_loss_factor([[0.1]], [[2e6]], 0.01),
    (CubicStiffness((0,), 1e10), JenkinsFriction((0,), kf=3e5, slip_force=1.0)),
)


def test_methods_sdof_traced_at_eleven_force_levels_without_tuning():
    """docs/methods.md §8 SDOF, 100…400 N in 30 N steps, 600–1300 Hz: default settings only."""
    for force in np.arange(100.0, 401.0, 30.0):
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # a stalled continuation warns: fail on it
            curve = trace_frequency_response(METHODS_SDOF, {0: force}, 2 * np.pi * 600, 2 * np.pi * 1300)
        assert curve.frequency_hz[-1] == pytest.approx(1300.0)
        x = curve.x_nonlinear[:, 0]
        nu = sum(complex(0) + e.describing_function(np.abs(x), curve.omega) for e in METHODS_SDOF.elements)
        z = 2e6 * (1 + 0.01j) - 0.1 * curve.omega**2
        assert np.max(np.abs((z + nu) * x - force)) / force < 1e-8
        assert curve.turning_point.sum() % 2 == 0
        assert curve.turning_point.sum() >= 2  # every level above 100 N jumps in this band


def test_fixed_point_matches_continuation_where_the_response_is_single_valued():
    curve = trace_frequency_response(METHODS_SDOF, {0: 0.01}, 2 * np.pi * 600, 2 * np.pi * 900)
    grid = 2 * np.pi * np.linspace(600, 900, 61)
    fixed = fixed_point_response(METHODS_SDOF, {0: 0.01}, grid)
    assert fixed.converged.all()
    swept = stepped_sine(curve, grid, "up")
    np.testing.assert_allclose(fixed.x_nonlinear, swept.x_nonlinear, rtol=1e-6)


def test_linear_system_without_elements_returns_the_receptance():
    system = NonlinearSystem(LumpedModel([[1.0]], [[4.0]], [[0.1]]), ())
    curve = trace_frequency_response(system, {0: 2.0}, 0.5, 3.0)
    expected = 2.0 / (4.0 - curve.omega**2 + 0.1j * curve.omega)
    np.testing.assert_allclose(curve.response([0])[:, 0], expected, rtol=1e-12)


def test_bad_requests_raise_clear_errors():
    with pytest.raises(ValueError, match="omega_start < omega_end"):
        trace_frequency_response(DUFFING, {0: F}, 3.0, 1.0)
    with pytest.raises(ValueError, match="unknown dof"):
        trace_frequency_response(DUFFING, {5: F}, 1.0, 2.0)
    with pytest.raises(ValueError, match="does not exist"):
        NonlinearSystem(LumpedModel([[1.0]], [[1.0]]), (CubicStiffness((3,), 1.0),))


@pytest.mark.parametrize("force", [0.3, 1.0, 2.0, 5.0, 20.0])
def test_stick_slip_kinks_are_passed_without_stalling(force):
    """At these levels the Jenkins element goes from stuck to slipping inside the band."""
    system = two_dof_system((CubicStiffness((0,), 1e10), JenkinsFriction((0,), kf=8e4, slip_force=1.0)))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        curve = trace_frequency_response(system, {0: force}, 2 * np.pi * 600, 2 * np.pi * 850)
    assert curve.frequency_hz[-1] == pytest.approx(850.0)
    amplitude = np.abs(curve.x_nonlinear[:, 0])
    if 1.0 <= force <= 5.0:
        assert amplitude.max() > 1.0 / 8e4 > amplitude.min()  # the transition is inside the band
    x_full = curve.response([0, 1])
    worst = max(full_harmonic_balance_residual(system, w, x, np.array([force, 0.0])) for w, x in zip(curve.omega, x_full))
    assert worst < 1e-8


def test_continuation_options_in_one_place():
    from nlupdate.core.response.continuation import ContinuationOptions

    system = NonlinearSystem(LumpedModel([[1.0]], [[1.0]], [[0.05]]), (CubicStiffness((0,), 1.0),))
    default = trace_frequency_response(system, {0: 0.5}, 0.5, 3.5)
    options = ContinuationOptions(max_step=0.01)
    finer = trace_frequency_response(system, {0: 0.5}, 0.5, 3.5, options=options)
    same = trace_frequency_response(system, {0: 0.5}, 0.5, 3.5, max_step=0.01)  # keyword override
    assert finer.omega.size > 2 * default.omega.size
    np.testing.assert_array_equal(finer.omega, same.omega)
    np.testing.assert_allclose(np.sort(finer.omega[finer.turning_point]), np.sort(default.omega[default.turning_point]),
                               rtol=1e-7)
    with pytest.raises(ValueError, match="min_step ≤ step"):
        ContinuationOptions(step=1e-8)
    with pytest.raises(ValueError, match="corrector_iterations: expected an integer"):
        ContinuationOptions(corrector_iterations=0)
    with pytest.raises(TypeError, match="unknown continuation option"):
        trace_frequency_response(system, {0: 0.5}, 0.5, 3.5, max_stepp=0.01)


def test_a_large_step_never_carries_the_trace_over_a_fold_onto_the_other_branch():
    """The demo's T-beam at 40 N (stiffening cubic + Jenkins at the tip) has two folds. The
    second-order predictor once landed past the lower fold on the lower stable branch, whose
    tangent is nearly parallel there, and the trace walked down it out of the band: the
    stepped sine then had no response above the upper fold (733 of 1801 points). A chord that
    turns from either tangent by more than the angle limit is now refused."""
    from pathlib import Path

    from nlupdate.app.cli.demo import demo_study_text
    from nlupdate.core.model.linear import dof_index
    from nlupdate.study import study_from_text
    from nlupdate.study.steps.measured import truth_system

    study = study_from_text(demo_study_text(1), Path("demo.toml"))
    system = truth_system(study, study.measured.simulate)
    tip = dof_index(system.model, "tip:uz")
    band = (2 * np.pi * 30.0, 2 * np.pi * 210.0)
    curve = trace_frequency_response(system, {tip: 40.0}, *band)
    fine = trace_frequency_response(system, {tip: 40.0}, *band, max_step=0.005)
    assert curve.omega[-1] == pytest.approx(band[1])  # it leaves through the far edge
    np.testing.assert_allclose(curve.omega[curve.turning_point], fine.omega[fine.turning_point], rtol=1e-6)
    grid = np.linspace(*band, 1801)
    assert np.isfinite(stepped_sine(curve, grid, "up").x_nonlinear).all()
