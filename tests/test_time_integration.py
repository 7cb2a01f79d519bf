"""Time integration against independent references: analytical receptances, the analytical
Jenkins loop energy, a perturbation solution for the third harmonic, stiff models."""
import numpy as np
import pytest
import scipy.sparse

from nlupdate.core.model.elements import CubicStiffness, JenkinsFriction
from nlupdate.core.model.linear import LumpedModel
from nlupdate.core.model.system import NonlinearSystem
from nlupdate.core.response.time_integration import TimeIntegrationError, steady_state_response, time_sweep
from nlupdate.core.response.time_operators import Operators


def chain_matrices(n: int, k: float = 1.0, m: float = 1.0):
    """Fixed–free spring chain: n masses m, springs k from ground to dof 0 and between neighbours."""
    stiffness = k * (2 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1))
    stiffness[n - 1, n - 1] = k
    return m * np.eye(n), stiffness


def relative_error(x: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Largest error over dofs relative to the largest reference amplitude, per case."""
    return np.max(np.abs(x - reference), axis=1) / np.max(np.abs(reference), axis=1)


def test_linear_response_matches_receptance_with_viscous_and_structural_damping():
    mass = np.diag([1.0, 2.0, 0.5])
    stiffness = np.array([[3.0, -1.0, 0.0], [-1.0, 2.5, -1.5], [0.0, -1.5, 1.5]])
    viscous = np.array([[0.03, -0.01, 0.0], [-0.01, 0.01, 0.0], [0.0, 0.0, 0.02]])  # non-proportional
    structural = 0.04 * np.diag([3.0, 0.5, 1.0])  # non-proportional ``iD``
    model = LumpedModel(mass, stiffness, viscous, structural)
    natural = np.sqrt(np.sort(np.linalg.eigvals(np.linalg.solve(mass, stiffness)).real))
    omega = np.concatenate([[0.3], natural * 1.002, [1.2, 3.0]])
    force = np.array([1.0, 0.0, 0.4 - 0.3j])
    result = steady_state_response(NonlinearSystem(model, ()), {0: 1.0, 2: 0.4 - 0.3j}, omega, tolerance=1e-9)
    reference = model.receptance(omega, range(3), range(3)) @ force
    assert result.converged.all()
    assert np.max(relative_error(result.x, reference)) < 1e-3
    assert np.max(result.harmonic_ratio) < 1e-6  # a linear system responds at one frequency


def test_modal_model_matches_its_modal_receptance():
    mass, stiffness = chain_matrices(6)
    lumped = LumpedModel.with_loss_factor(mass, stiffness, 0.03, damping=0.01 * stiffness)
    modal = lumped.to_modal(4, coordinates=[1, 3, 5])
    omega = np.array([0.2, 0.5, 1.0, 1.6])
    result = steady_state_response(NonlinearSystem(modal, ()), {"5": 2.0}, omega, tolerance=1e-9)
    reference = modal.receptance(omega, range(3), [2])[:, :, 0] * 2.0
    assert result.converged.all()
    assert np.max(relative_error(result.x, reference)) < 1e-3


def test_the_steps_motion_at_the_nonlinear_dofs_is_their_coordinates_of_each_half_of_the_state():
    """``Operators.nonlinear_motion`` (the time step's one indexing) gives exactly what
    ``nonlinear_coordinates`` gives for the displacements and the velocities, lumped and modal."""
    mass, stiffness = chain_matrices(6)
    lumped = LumpedModel.with_loss_factor(mass, stiffness, 0.03)
    for model, dofs in ((lumped, (1, 4)), (lumped.to_modal(4, coordinates=[1, 3, 5]), (0, 2))):
        ops = Operators(NonlinearSystem(model, (CubicStiffness(dofs, k3=1.0), JenkinsFriction((dofs[0],), kf=1.0,
                                                                                              slip_force=1.0))))
        y = np.random.default_rng(0).standard_normal((2 * ops.n_q, 5))
        x, v = ops.nonlinear_motion(y)
        assert np.array_equal(x, ops.nonlinear_coordinates(y[:ops.n_q]))
        assert np.array_equal(v, ops.nonlinear_coordinates(y[ops.n_q:]))


def test_sparse_model_with_diagonal_mass_matches_receptance():
    mass, stiffness = chain_matrices(20)
    model = LumpedModel.with_loss_factor(scipy.sparse.csr_matrix(mass), scipy.sparse.csr_matrix(stiffness), 0.05)
    omega = np.array([0.1, 0.35, 0.8])
    result = steady_state_response(NonlinearSystem(model, ()), {19: 1.0}, omega, tolerance=1e-9, max_periods=4000)
    reference = model.receptance(omega, range(20), [19])[:, :, 0]
    assert result.converged.all()
    assert np.max(relative_error(result.x, reference)) < 1e-3


def test_time_step_follows_the_highest_natural_frequency_and_element_stiffness_bound():
    # A stiff second dof (ω ≈ 141 rad/s) forced at 1 rad/s: 64 steps per period would be
    # 100× beyond the RK4 stability limit, so the step must come from the model.
    model = LumpedModel.with_loss_factor(np.diag([1.0, 1.0]), np.array([[2.0, -1.0], [-1.0, 2e4]]), 0.05)
    omega = np.array([1.0, 1.3])
    result = steady_state_response(NonlinearSystem(model, ()), {0: 1.0}, omega, tolerance=1e-9)
    reference = model.receptance(omega, range(2), [0])[:, :, 0]
    assert result.converged.all()
    assert np.all(result.steps_per_period >= 2 * np.pi * np.sqrt(2e4) / omega.min() * 0.99)
    assert np.max(relative_error(result.x, reference)) < 1e-3
    # The same through an element: a stiff Jenkins spring (stuck) on a soft oscillator.
    stiff = NonlinearSystem(
        LumpedModel.with_loss_factor([[1.0]], [[1.0]], 0.05), (JenkinsFriction((0,), kf=1e4, slip_force=1e3),)
    )
    stuck = steady_state_response(stiff, {0: 1.0}, [1.0], tolerance=1e-9)
    linear = LumpedModel.with_loss_factor([[1.0]], [[1.0 + 1e4]], 0.05 / (1.0 + 1e4)).receptance([1.0], [0], [0])[0, 0, 0]
    assert stuck.converged.all() and stuck.steps_per_period[0] >= 2 * np.pi * 100 * 0.99
    assert abs(stuck.x[0, 0] - linear) < 1e-3 * abs(linear)


def test_jenkins_dissipates_the_analytical_loop_energy_per_cycle():
    # Energy balance over one steady period: the work of the force π·Im(F·X̄) (exact: the force
    # is a pure first harmonic) = viscous work c∮ẋ²dt + Jenkins loop area 4Fs(A − Fs/kf),
    # with A the displacement amplitude (half peak-to-peak) of the slipping element.
    c, kf, fs, force = 0.02, 1.0, 0.1, 0.3
    system = NonlinearSystem(LumpedModel([[1.0]], [[1.0]], [[c]]), (JenkinsFriction((0,), kf, fs),))
    omega = np.array([0.5, 0.7, 1.8])
    result = steady_state_response(system, {0: force}, omega, tolerance=1e-10, keep_history=True)
    assert result.converged.all()
    work_in = np.pi * np.imag(force * np.conj(result.x[:, 0]))
    viscous = np.array([c * np.mean(h[1, 0] ** 2) * 2 * np.pi / w for h, w in zip(result.history, omega)])
    amplitude = np.array([(h[0, 0].max() - h[0, 0].min()) / 2 for h in result.history])
    assert np.all(amplitude > 1.5 * fs / kf)  # slipping every half cycle
    loop = 4 * fs * (amplitude - fs / kf)
    np.testing.assert_allclose(work_in - viscous, loop, rtol=1e-3)


def test_third_harmonic_ratio_of_a_weak_duffing_oscillator_matches_perturbation_theory():
    # x ≈ Re(X₁e^{iωt}) gives k3·x³ ⊃ (k3/4)·Re(X₁³e^{3iωt}), so to first order
    # X₃ = −(k3/4)X₁³ / (k − 9ω²m + 3iωc) and the harmonic ratio is |X₃|/|X₁|.
    k3, c = 0.05, 0.1  # weak: second-order corrections ≈ (3/4)k3|X₁|²·2/|k − 9ω²m| ≈ 1.5 %
    system = NonlinearSystem(LumpedModel([[1.0]], [[1.0]], [[c]]), (CubicStiffness((0,), k3),))
    omega = np.array([0.5, 2.0])
    result = steady_state_response(system, {0: 0.4}, omega, tolerance=1e-10, steps_per_period=128)
    x1 = result.x[:, 0]
    x3 = -(k3 / 4) * x1**3 / (1.0 - 9 * omega**2 + 3j * omega * c)
    assert result.converged.all()
    np.testing.assert_allclose(result.harmonic_ratio[:, 0], np.abs(x3 / x1), rtol=0.03)
    assert result.harmonic_ratio[0, 0] > 1e-3  # the check is not vacuous


def test_linear_time_sweep_has_no_jumps_and_matches_receptance():
    model = LumpedModel.with_loss_factor([[1.0]], [[1.0]], 0.1)
    grid = np.array([0.8, 0.95, 1.0, 1.05, 1.2])
    reference = model.receptance(grid, [0], [0])[:, 0, 0]
    for direction in ("up", "down"):
        sweep = time_sweep(NonlinearSystem(model, ()), {0: 1.0}, grid, direction, tolerance=1e-9)
        assert sweep.jumps_hz == ()
        assert sweep.converged.all()
        np.testing.assert_allclose(sweep.x[:, 0], reference, rtol=1e-3)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"omega": [-1.0]}, "omega"),
        ({"forcing": {0: [1.0, 2.0, 3.0]}}, "forcing"),
        ({"forcing": {}}, "forcing"),
        ({"initial": np.zeros((3, 1))}, "initial"),
        ({"steps_per_period": 4}, "steps_per_period"),
        ({"tolerance": 0.0}, "tolerance"),
    ],
)
def test_bad_input_raises_value_error_naming_the_argument(kwargs, message):
    system = NonlinearSystem(LumpedModel([[1.0]], [[1.0]], [[0.1]]), ())
    arguments = {"forcing": {0: 1.0}, "omega": [1.0, 2.0]} | kwargs
    with pytest.raises(TimeIntegrationError, match=message):
        steady_state_response(system, arguments.pop("forcing"), arguments.pop("omega"), **arguments)
    assert issubclass(TimeIntegrationError, ValueError)
