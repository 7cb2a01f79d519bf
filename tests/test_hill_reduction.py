"""Hill's method on the joint coordinates plus retained modes (core/response/hill_reduction.py).

References: the dense Hill computation on every dof of the same model (the method the
reduction replaces), a dense static solve, and the project's time integration.
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from nlupdate.core.model.elements import CubicStiffness, JenkinsFriction
from nlupdate.core.model.linear import LumpedModel
from nlupdate.core.model.system import NonlinearSystem
from nlupdate.core.response.harmonic_balance import HarmonicTruncationWarning, trace_harmonic_balance
from nlupdate.core.response.hill import HillModel, floquet_batch
from nlupdate.core.response.hill_reduction import element_directions, hill_model, residual_basis
from nlupdate.core.response.time_integration import steady_state_response

H = 3


def fixed_free_chain(n: int) -> LumpedModel:
    """Fixed–free chain, total mass 1 kg, tip stiffness 1e4 N/m, mass-proportional viscous
    damping 0.5 s⁻¹ and loss factor 0.002 (ω1 ≈ 157 rad/s)."""
    m, k = 1.0 / n, 1e4 * n
    main = np.full(n, 2 * k)
    main[-1] = k
    stiffness = np.diag(main) - np.diag(np.full(n - 1, k), 1) - np.diag(np.full(n - 1, k), -1)
    mass = np.eye(n) * m
    return LumpedModel(mass, stiffness, 0.5 * mass, 0.002 * stiffness)


def _jointed(n: int = 18, joints: int = 3) -> NonlinearSystem:
    """``joints`` cubic springs between node pairs spread along the chain, the first also with
    a Jenkins slider: a hardening curve with two folds."""
    stride = n // joints
    elements = [CubicStiffness((j * stride, j * stride + 1), 1e11) for j in range(joints)]
    elements.append(JenkinsFriction((0, 1), kf=0.3e4 * n, slip_force=3.0))
    return NonlinearSystem(fixed_free_chain(n), tuple(elements))


SYSTEM = _jointed()
W1 = float(SYSTEM.model.modes(1)[0][0])


@pytest.fixture(scope="module")
def curve():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HarmonicTruncationWarning)  # H = 3 leaves ~10 %: both computations see the same orbit
        return trace_harmonic_balance(SYSTEM, {17: 5.0}, 0.97 * W1, 1.08 * W1, harmonics=H, stability=True)


@pytest.fixture(scope="module")
def dense(curve):
    problem = curve.problem
    coefficients = problem.coefficients(curve.x_nonlinear)
    _, jacobians, _ = problem.forces_batch(coefficients, curve.omega, jacobian=True)
    return floquet_batch(HillModel.of(SYSTEM.model, problem.a), problem.element_index, coefficients, curve.omega,
                         problem.fourier, jacobians)


def test_the_harmonic_balance_reduces_this_model_automatically(curve):
    problem = curve.problem
    hill = hill_model(SYSTEM.model, problem.a, problem.element_index, curve.omega.max(), H)
    assert hill.mass.shape[0] < SYSTEM.model.n_dof / 2
    assert curve.floquet_multipliers.shape == (curve.omega.size, 2 * hill.mass.shape[0])


def test_reduced_verdicts_equal_the_dense_ones_at_every_point(curve, dense):
    _, multipliers = dense
    stable = np.abs(multipliers).max(axis=1) < 1.0 + 1e-7
    stable[curve.turning_point] = False
    folds = np.flatnonzero(curve.turning_point)
    assert folds.size == 2 and stable.sum() > 10 and (~stable).sum() > 10  # both verdicts occur
    assert np.array_equal(curve.stable, stable)
    inside = np.zeros(curve.omega.size, bool)
    inside[folds[0] : folds[1] + 1] = True
    assert np.array_equal(~curve.stable, inside)


def test_reduced_multipliers_and_exponents_match_the_dense_ones(curve, dense):
    exponents, multipliers = dense
    # the critical multiplier's modulus (measured ≤ 1.4e-4 apart)
    assert np.abs(np.abs(curve.floquet_multipliers).max(axis=1) - np.abs(multipliers).max(axis=1)).max() < 5e-4
    problem = curve.problem
    coefficients = problem.coefficients(curve.x_nonlinear)
    _, jacobians, _ = problem.forces_batch(coefficients, curve.omega, jacobian=True)
    hill = hill_model(SYSTEM.model, problem.a, problem.element_index, curve.omega.max(), H)
    reduced, _ = floquet_batch(hill, problem.element_index, coefficients, curve.omega, problem.fourier, jacobians)
    for p, omega in enumerate(curve.omega):
        # the four least damped exponents (those stability turns on) are dense ones, up to a copy
        # λ + imω (measured ≤ 2.2e-4·ω apart; the next family, the third mode at ~5ω, 2e-3·ω)
        light = reduced[p][np.argsort(-reduced[p].real)[:4]]
        shift = light[:, None] - exponents[p][None, :]
        distance = np.abs(shift.real) + np.abs((shift.imag / omega + 0.5) % 1.0 - 0.5) * omega
        assert distance.min(axis=1).max() < 5e-4 * omega, p


@pytest.mark.slow
def test_time_integration_leaves_an_unstable_orbit_and_settles_on_a_stable_one(curve):
    folds = np.flatnonzero(curve.turning_point)
    middle = (folds[0] + folds[1]) // 2
    stable = int(np.flatnonzero(curve.stable & (np.arange(curve.omega.size) > folds.max() + 5))[0])
    picks = [middle, stable]
    dofs = list(range(SYSTEM.model.n_dof))
    x = curve.harmonics(dofs)[picks, 1]
    result = steady_state_response(SYSTEM, {17: 5.0}, curve.omega[picks], initial=x, tolerance=1e-4, max_periods=600)
    change = np.abs(np.abs(result.x[:, 17]) - np.abs(x[:, 17])) / np.abs(x[:, 17])
    assert change[0] > 0.2  # unstable: leaves the middle branch
    assert result.converged[1] and change[1] < 0.05  # stable: stays (H = 3 truncation ≲ a few %)


def test_the_basis_is_exact_statically_for_any_joint_stiffness():
    """The static response to joint loads lies in the basis, so the Galerkin model is exact at
    ω = 0 whatever stiffness the joints have (stuck, slipping, stiffened)."""
    system = _jointed(40, 4)
    position = {dof: i for i, dof in enumerate(system.nonlinear_dofs)}
    index = [(e, position[e.dofs[0]], position[e.dofs[1]]) for e in system.elements]
    directions = element_directions(len(position), index)
    assert directions.shape[1] == 4  # four joints between node pairs: four directions, not eight
    basis = residual_basis(system.model, system.nonlinear_dofs, directions, 4 * W1)
    loads = np.zeros((40, 4))
    loads[list(system.nonlinear_dofs)] = directions
    k = system.model._dense_mkcd[1]
    for joint_stiffness in (0.0, 3e5, 1e8):
        stiffened = k + joint_stiffness * loads @ loads.T
        exact = loads.T @ np.linalg.solve(stiffened, loads)
        reduced = loads.T @ basis @ np.linalg.solve(basis.T @ stiffened @ basis, basis.T @ loads)
        assert np.abs(reduced - exact).max() < 1e-9 * np.abs(exact).max()


def test_small_and_modal_models_keep_their_coordinates():
    small = NonlinearSystem(fixed_free_chain(4), (CubicStiffness((0, 1), 1e9),))
    assert hill_model(small.model, [0, 1], [(small.elements[0], 0, 1)], 1.2 * W1, H).mass.shape == (4, 4)
    modal = fixed_free_chain(60).to_modal(8, [0, 1])
    assert hill_model(modal, [0, 1], [(small.elements[0], 0, 1)], 1.2 * W1, H).mass.shape == (8, 8)
