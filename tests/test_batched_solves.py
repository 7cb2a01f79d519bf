"""The batched single-harmonic solves against independent references.

* The batched residual's Jacobians against central differences of the batched residual,
  for every element (cubic, gap, quadratic damping, polynomial, Coulomb, Jenkins, Iwan),
  between two coordinates and to ground.
* Batched Newton from perturbed starts reaches the roots of the uncondensed balance
  ``(Z + Δ(X)) X = F`` (solved independently by scipy's ``fsolve`` per point).
* Stepped-sine sweeps (closed form, fold-free batch, trace + batched polish) against the
  exact single-harmonic Duffing relation (the cubic in A² solved by ``numpy.roots``): every
  grid point on a root, on the stable one the sweep direction implies, jumps at the first
  grid frequency past the exact folds — including the grid points within 0.005 rad/s of a
  fold, where an unchecked Newton lands on the unstable root.
* The fold-free batch on a friction system equals the traced route.
"""
from __future__ import annotations

import numpy as np
import pytest
import scipy.optimize

from nlupdate.core.model.elements import (
    CoulombFriction, CubicStiffness, IwanJoint, JenkinsFriction, PolynomialDF, QuadraticDamping, SymmetricGap,
)
from nlupdate.core.model.linear import LumpedModel
from nlupdate.core.model.system import CondensedProblem, NonlinearSystem, newton_batch
from nlupdate.core.response.continuation import ContinuationOptions, trace_frequency_response
from nlupdate.core.response.stepped_sine import stepped_sine
from nlupdate.core.response.sweep import fold_free_branch, frequency_sweep

M, C, K, K3, F = 1.0, 0.05, 1.0, 1.0, 0.5
DUFFING = NonlinearSystem(LumpedModel([[M]], [[K]], [[C]]), (CubicStiffness((0,), K3),))
TWO_DOF = LumpedModel.with_loss_factor(np.diag([1.0, 0.5]), np.array([[2.0, -1.0], [-1.0, 1.5]]), 0.02)
ELEMENTS = {
    "cubic": lambda dofs: CubicStiffness(dofs, 0.4),
    "gap": lambda dofs: SymmetricGap(dofs, gap=0.05, kc=0.8),
    "quadratic damping": lambda dofs: QuadraticDamping(dofs, 0.05),
    "polynomial": lambda dofs: PolynomialDF(dofs, (0.3, 0.0, 0.1), (0.02, 0.01)),
    "coulomb": lambda dofs: CoulombFriction(dofs, 0.01),
    "jenkins": lambda dofs: JenkinsFriction(dofs, kf=0.5, slip_force=0.03),
    "iwan": lambda dofs: IwanJoint(dofs, slip_force=0.03, kt=0.5, chi=-0.5, beta=0.5),
}


def exact_roots(omega: float) -> np.ndarray:
    """Amplitudes A of every single-harmonic Duffing solution at ω: A²[(k − mω² + ¾k3A²)² + (cω)²] = F²."""
    p = K - M * omega**2
    u = np.roots([(0.75 * K3) ** 2, 1.5 * K3 * p, p**2 + (C * omega) ** 2, -(F**2)])
    u = u.real[(np.abs(u.imag) <= 1e-9 * np.abs(u)) & (u.real > 0)]
    return np.sqrt(np.sort(u))


def exact_folds() -> np.ndarray:
    scan = np.linspace(0.5, 3.5, 3001)
    counts = np.array([exact_roots(w).size for w in scan])
    change = np.flatnonzero(np.diff(counts))
    return np.array([_bisect_count(scan[i], scan[i + 1]) for i in change])


def _bisect_count(low: float, high: float) -> float:
    """Where the number of roots changes between ``low`` and ``high`` (rad/s), to 1e-15."""
    n_low = exact_roots(low).size
    for _ in range(60):
        mid = 0.5 * (low + high)
        if exact_roots(mid).size == n_low:
            low = mid
        else:
            high = mid
    return 0.5 * (low + high)


def assert_jacobian_is_central_differences(problem, y, linear, jac):
    """``jac`` (points, rows, unknowns) against central differences (step 1e-6) of the batch's
    residual at ``y`` (points, unknowns) with the points' ``linear`` parts."""
    h = 1e-6
    for i in range(problem.size):
        step = np.zeros(problem.size)
        step[i] = h
        central = (problem.residual_batch(y + step, linear, jacobian=False)
                   - problem.residual_batch(y - step, linear, jacobian=False)) / (2 * h)
        np.testing.assert_allclose(jac[:, :, i], central, rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("name", list(ELEMENTS))
def test_batched_jacobians_match_central_differences(name):
    system = NonlinearSystem(TWO_DOF, (ELEMENTS[name]((0, 1)), ELEMENTS[name]((1,))))
    problem = CondensedProblem(system, {0: 0.1}, x_scale=0.1)
    rng = np.random.default_rng(3)
    omega = np.array([0.6, 0.9, 1.3, 1.7])
    y = rng.uniform(-1.5, 1.5, (omega.size, problem.size))
    linear = problem.linear_batch(omega)
    r, jac, jac_w = problem.residual_batch(y, linear)
    for p, w in enumerate(omega):  # the single-point methods are the batch of one
        r1, j1, jw1 = problem.residual_and_jacobians(y[p], w)
        np.testing.assert_allclose(r1, r[p], rtol=1e-13, atol=1e-15)
        np.testing.assert_allclose(j1, jac[p], rtol=1e-13, atol=1e-15)
    assert_jacobian_is_central_differences(problem, y, linear, jac)
    dw = 1e-6
    central_w = (problem.residual_batch(y, problem.linear_batch(omega + dw), jacobian=False)
                 - problem.residual_batch(y, problem.linear_batch(omega - dw), jacobian=False)) / (2 * dw)
    np.testing.assert_allclose(jac_w, central_w, rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("name", ["cubic", "jenkins", "iwan", "coulomb"])
def test_batched_newton_solves_the_uncondensed_balance(name):
    system = NonlinearSystem(TWO_DOF, (ELEMENTS[name]((0, 1)), CubicStiffness((1,), 0.2)))
    problem = CondensedProblem(system, {0: 0.1}, x_scale=0.1)
    omega = np.linspace(0.4, 2.0, 9)
    linear = problem.linear_batch(omega)
    start = problem.to_real(linear.x_lin)
    y, converged, _ = newton_batch(problem, linear, start)
    assert converged.all()
    x = problem.to_complex(y)
    for w, x_p in zip(omega, x):  # (Z + Δ(X)) X = F, solved by fsolve from the batched solution ± 1 %
        def balance(v, w=w):
            xx = v[:2] + 1j * v[2:]
            g = problem.forces(xx, w)
            out = TWO_DOF.dynamic_stiffness(w) @ xx + g - np.array([0.1, 0.0])
            return np.concatenate([out.real, out.imag])
        guess = np.concatenate([x_p.real, x_p.imag]) * 1.01
        reference = scipy.optimize.fsolve(balance, guess, xtol=1e-13)
        np.testing.assert_allclose(np.concatenate([x_p.real, x_p.imag]), reference, rtol=1e-7, atol=1e-10)


@pytest.mark.parametrize("route", ["closed form", "traced"])
def test_sweeps_follow_the_exact_stable_branches(route):
    folds = exact_folds()
    low, high = folds.min(), folds.max()
    # a grid with points within 0.005 rad/s of both folds
    grid = np.sort(np.concatenate([np.linspace(0.5, 3.5, 400), low + [-0.004, 0.001, 0.004], high + [-0.004, -0.0003, 0.003]]))
    for direction in ("up", "down"):
        sweep = frequency_sweep(DUFFING, {0: F}, grid, direction, closed_form_roots=route == "closed form")
        assert sweep.route == route
        amplitude = np.abs(sweep.x_nonlinear[:, 0])
        for w, a in zip(grid, amplitude):
            roots = exact_roots(w)
            # the sweep's branch: up stays on the resonant (largest) root until the upper fold,
            # down on the smallest until the lower fold
            if direction == "up":
                expected = roots[-1] if w < high else roots[0]
            else:
                expected = roots[0] if w > low else roots[-1]
            away = min(abs(w - low), abs(w - high)) > 0.01
            # Newton stops at a scaled residual of 1e-10 (scale: the largest linear response, ~10)
            assert abs(a - expected) <= (1e-8 if away else 1e-6) * max(expected, 1.0), (direction, w, a, roots)
        jump = grid[grid > high][0] if direction == "up" else grid[grid < low][-1]
        assert sweep.jumps_hz == pytest.approx((jump / (2 * np.pi),), rel=1e-12)


def test_polish_near_a_fold_keeps_the_stable_root():
    curve = trace_frequency_response(DUFFING, {0: F}, 0.5, 3.5)
    high = exact_folds().max()
    grid = high - np.array([0.004, 0.002, 0.001, 0.0005, 0.0002])
    sweep = stepped_sine(curve, grid, "up")
    np.testing.assert_allclose(np.abs(sweep.x_nonlinear[:, 0]), [exact_roots(w)[-1] for w in grid], rtol=1e-6)


def test_fold_free_batch_equals_the_traced_route():
    model = LumpedModel.with_loss_factor(np.diag([0.1, 0.5]), np.array([[2e6, -1e6], [-1e6, 2e6]]), 0.005)
    system = NonlinearSystem(model, (CubicStiffness((0,), 1e10), JenkinsFriction((0,), 8e4, 1.0)))
    omega = 2 * np.pi * np.linspace(500, 900, 801)
    problem = CondensedProblem(system, {0: 0.5})  # low force: stuck and slipping, no fold
    x = fold_free_branch(problem, omega, ContinuationOptions())
    assert x is not None
    traced = frequency_sweep(system, {0: 0.5}, omega, "up", fold_free=False)
    assert traced.route == "traced"
    np.testing.assert_allclose(x, traced.x_nonlinear, rtol=1e-7)
    # with folds (100 N) the batch is refused and the trace answers
    assert fold_free_branch(CondensedProblem(system, {0: 100.0}), omega, ContinuationOptions()) is None
    assert frequency_sweep(system, {0: 100.0}, omega, "up").route == "traced"


def test_levels_traced_in_lockstep_are_the_curves_traced_one_by_one():
    from nlupdate.core.response.continuation import trace_frequency_responses

    model = LumpedModel.with_loss_factor(np.diag([0.1, 0.5]), np.array([[2e6, -1e6], [-1e6, 2e6]]), 0.005)
    system = NonlinearSystem(model, (CubicStiffness((0,), 1e10), JenkinsFriction((0,), 8e4, 1.0)))
    band = (2 * np.pi * 500, 2 * np.pi * 900)
    forcings = [{0: level} for level in (20.0, 60.0, 100.0)]
    together = trace_frequency_responses(system, forcings, *band)
    for curve, forcing in zip(together, forcings):
        alone = trace_frequency_response(system, forcing, *band)
        assert curve.omega.size == alone.omega.size
        np.testing.assert_allclose(curve.omega, alone.omega, rtol=1e-12)
        np.testing.assert_allclose(curve.x_nonlinear, alone.x_nonlinear, rtol=1e-9, atol=1e-12 * np.abs(alone.x_nonlinear).max())
        np.testing.assert_array_equal(curve.stable, alone.stable)
        assert curve.turning_point.sum() == 2


@pytest.mark.parametrize("name", list(ELEMENTS))
def test_multi_harmonic_batch_equals_points_and_central_differences(name):
    from nlupdate.core.response.harmonic_balance import HarmonicBalanceProblem

    system = NonlinearSystem(TWO_DOF, (ELEMENTS[name]((0, 1)), ELEMENTS[name]((1,))))
    problem = HarmonicBalanceProblem(system, {0: 0.1}, harmonics=3, samples=64, x_scale=0.1)
    rng = np.random.default_rng(5)
    omega = np.array([0.6, 1.1, 1.7])
    y = rng.uniform(-1.0, 1.0, (omega.size, problem.size))
    y[:, problem.n * 3 :] *= 0.2  # higher harmonics smaller, as in a response
    linear = problem.linear_batch(omega)
    r, jac, jac_w = problem.residual_batch(y, linear)
    for p, w in enumerate(omega):  # one batch = the points one by one
        r1, j1, jw1 = problem.residual_and_jacobians(y[p], w)
        np.testing.assert_allclose(r[p], r1, rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(jac[p], j1, rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(jac_w[p], jw1, rtol=1e-12, atol=1e-14)
    if name in ("coulomb", "jenkins", "iwan", "gap"):
        return  # non-smooth laws: their Jacobians are checked against differences in test_harmonic_balance.py
    assert_jacobian_is_central_differences(problem, y, linear, jac)
