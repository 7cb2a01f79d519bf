"""The describing-function closed form (src/nlupdate/core/response/closed_form.py) against independent
references: its cubic's roots against 40-digit roots (mpmath) over the whole physical family of
the cubic and on the reference Duffing grid through both folds (coefficients from m, c, k),
its stability against the sign of the continuation's Jacobian determinant, and its responses
against the harmonic-balance residual."""
from __future__ import annotations

import mpmath
import numpy as np
import pytest
from scipy.optimize import brentq

from nlupdate.core.model.elements import CubicStiffness
from nlupdate.core.model.linear import LumpedModel
from nlupdate.core.model.system import CondensedProblem, NonlinearSystem
from nlupdate.core.response import closed_form

M, C, K, K3, F = 1.0, 0.05, 1.0, 1.0, 0.5  # the reference Duffing (benchmarks/frf)


def reference_roots(a: float, b: float, c: float, d: float) -> list[float]:
    """Positive real roots of a u³ + b u² + c u + d at 40 digits, ascending."""
    with mpmath.workdps(40):
        roots = mpmath.polyroots([mpmath.mpf(float(v)) for v in (a, b, c, d)], maxsteps=400, extraprec=300)
        return sorted(float(mpmath.re(r)) for r in roots
                      if abs(mpmath.im(r)) <= mpmath.mpf(10) ** -30 * abs(r) and mpmath.re(r) > 0)


def assert_roots(u: np.ndarray, expected: list[float], rtol: float, where) -> None:
    found = u[np.isfinite(u)]
    assert found.size == len(expected), (where, found, expected)
    assert np.all(np.isnan(u[found.size:])), (where, u)  # NaN last
    np.testing.assert_allclose(found, expected, rtol=rtol, atol=0, err_msg=str(where))


def test_roots_of_the_physical_family_to_high_precision():
    # The closed form's cubic ε²v³ + 2ε cos φ v² + v − 1 = 0 in v = u/|X_lin|², ε = c|h||X_lin|²,
    # φ = arg h: weak (ε = 1e-8: the shift back from the depressed cubic cancels 8 digits) to
    # strong nonlinearity, light damping (φ → π) and every scale of |X_lin|².
    rng = np.random.default_rng(7)
    n = 300
    eps = 10 ** rng.uniform(-8, 8, n)
    phi = np.where(rng.random(n) < 0.5, rng.uniform(0, np.pi, n), np.pi - 10 ** rng.uniform(-8, -1, n))
    scale = 10 ** rng.uniform(-12, 6, n)
    a, b, c, d = eps**2 / scale**2, 2 * eps * np.cos(phi) / scale, np.ones(n), -scale
    u = closed_form._positive_cubic_roots(a, b, c, d)
    three = 0
    for i in range(n):
        expected = reference_roots(a[i], b[i], c[i], d[i])
        three += len(expected) == 3
        assert_roots(u[i], expected, 1e-10, (eps[i], phi[i], scale[i]))
    assert three > 20  # the sample has three-root cases


def test_roots_on_the_duffing_grid_through_both_folds():
    def discriminant(w):
        a, b, c, d = duffing_cubic(w)
        return 18 * a * b * c * d - 4 * b**3 * d + b**2 * c**2 - 4 * a * c**3 - 27 * a**2 * d**2

    def duffing_cubic(w):
        p = K - M * w**2
        return (0.75 * K3) ** 2, 1.5 * K3 * p, p**2 + (C * w) ** 2, -(F**2)

    folds = np.array([brentq(discriminant, 1.3, 1.6, xtol=1e-15), brentq(discriminant, 2.9, 3.1, xtol=1e-15)])
    offsets = 10.0 ** -np.arange(1, 8)
    grid = np.sort(np.concatenate([np.linspace(0.5, 3.5, 121), (folds[:, None] + offsets).ravel(),
                                   (folds[:, None] - offsets).ravel()]))
    system = NonlinearSystem(LumpedModel([[M]], [[K]], [[C]]), (CubicStiffness((0,), K3),))
    roots = closed_form.cubic_roots(CondensedProblem(system, {0: F}), grid)
    for w, u, count in zip(grid, roots.u, roots.count):
        expected = reference_roots(*duffing_cubic(w))
        near = np.min(np.abs(w - folds)) < 0.01  # within 1e-7 of a fold the roots are still found
        assert_roots(u, expected, 1e-9 if near else 1e-12, w)
        assert count == len(expected)
    assert set(roots.count) == {1, 3}


def test_a_triple_root_and_the_order_of_the_roots():
    u = closed_form._positive_cubic_roots(*(np.array([v]) for v in (1.0, -3.0, 3.0, -1.0)))  # (u − 1)³
    np.testing.assert_array_equal(u, [[1.0, np.nan, np.nan]])
    # three positive roots given in every order of the coefficients' construction: ascending out
    r = np.array([[0.3, 2.0, 7.0], [7.0, 0.3, 2.0], [1e-6, 1.0, 1e6]])
    a = np.ones(3)
    b, c, d = -r.sum(1), r[:, 0] * r[:, 1] + r[:, 1] * r[:, 2] + r[:, 0] * r[:, 2], -r.prod(1)
    np.testing.assert_allclose(closed_form._positive_cubic_roots(a, b, c, d), np.sort(r, axis=1), rtol=1e-12)
    # two negative roots, one positive: the positive one first, NaN after
    u = closed_form._positive_cubic_roots(np.ones(1), np.array([3.0 - 0.5]), np.array([2.0 - 1.5]), np.array([-1.0]))
    np.testing.assert_allclose(u, [[0.5, np.nan, np.nan]], rtol=1e-14)  # (u + 1)(u + 2)(u − 0.5)


@pytest.fixture(scope="module")
def two_dof():
    """Cubic springs of opposite sign summing to 0.8 N/m³ on dof 0, force on dof 1: X_lin ≠ H_aa F."""
    model = LumpedModel(np.diag([1.0, 0.5]), np.array([[2.0, -1.0], [-1.0, 1.5]]), np.array([[0.04, 0.0], [0.0, 0.02]]))
    system = NonlinearSystem(model, (CubicStiffness((0,), 1.3), CubicStiffness((0,), -0.5)))
    problem = CondensedProblem(system, {1: 0.3})
    omega = np.linspace(0.3, 2.5, 2001)
    return problem, omega, closed_form.cubic_roots(problem, omega)


def test_stability_is_the_sign_of_the_jacobian_determinant(two_dof):
    problem, omega, roots = two_dof
    assert closed_form.applies(problem) and (roots.count == 3).sum() > 50
    rows, cols = np.nonzero(np.isfinite(roots.u))
    x = roots.x[rows, cols]
    residual, jac, _ = problem.residual_batch(problem.to_real(x[:, None]), problem.linear_batch(omega[rows], False))
    det = np.linalg.det(jac)
    assert np.max(np.abs(residual)) < 1e-10  # every root solves the balance
    clear = np.abs(det) > 1e-6
    np.testing.assert_array_equal(roots.stable[rows, cols][clear], det[clear] > 0)
    assert (~roots.stable[rows, cols][clear]).sum() > 50  # unstable roots are in the sample
    assert not roots.stable[~np.isfinite(roots.u)].any()


def test_response_is_the_chosen_root(two_dof):
    problem, omega, roots = two_dof
    index = np.where(roots.count == 3, 2, 0)
    x = roots.response(index)
    np.testing.assert_array_equal(x, roots.x[np.arange(omega.size), index])
    np.testing.assert_allclose(np.abs(x) ** 2, roots.u[np.arange(omega.size), index], rtol=1e-12)
