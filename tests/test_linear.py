"""Linear models: direct solve, modal superposition, sparse storage and dH/dω."""
import numpy as np
import pytest
import scipy.sparse

from nlupdate.core.model.linear import LumpedModel, ModalModel

M = np.diag([0.1, 0.5, 0.2])
K = 1e6 * np.array([[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.5]])
OMEGA = 2 * np.pi * np.array([100.0, 500.0, 732.0, 1400.0])


def test_direct_receptance_is_the_inverse_dynamic_stiffness():
    model = LumpedModel(M, K, damping=0.3 * np.eye(3), structural_damping=0.01 * K)
    h = model.receptance(OMEGA, [0, 2], [1])
    for w, block in zip(OMEGA, h):
        z = K - w**2 * M + 1j * w * 0.3 * np.eye(3) + 0.01j * K
        np.testing.assert_allclose(block, np.linalg.inv(z)[np.ix_([0, 2], [1])], rtol=1e-12)


def test_modal_superposition_equals_direct_solve_for_proportional_damping():
    lumped = LumpedModel.with_loss_factor(M, K, 0.02, damping=1e-5 * K)
    modal = lumped.to_modal()
    np.testing.assert_allclose(modal.receptance(OMEGA, [0, 1, 2], [0, 2]), lumped.receptance(OMEGA, [0, 1, 2], [0, 2]), rtol=1e-9)
    # analytical natural frequencies of the undamped problem
    expected = np.sqrt(np.sort(np.linalg.eigvals(np.linalg.solve(M, K)).real)) / (2 * np.pi)
    np.testing.assert_allclose(modal.natural_frequencies_hz, expected, rtol=1e-12)


def test_sparse_storage_gives_the_same_receptance_and_derivative():
    dense = LumpedModel.with_loss_factor(M, K, 0.01, damping=0.2 * np.eye(3))
    sparse = LumpedModel(scipy.sparse.csr_matrix(M), scipy.sparse.csr_matrix(K), scipy.sparse.csr_matrix(0.2 * np.eye(3)), scipy.sparse.csr_matrix(0.01 * K))
    h_d, dh_d = dense.receptance(OMEGA, [0, 1], [2, 0], derivative=True)
    h_s, dh_s = sparse.receptance(OMEGA, [0, 1], [2, 0], derivative=True)
    np.testing.assert_allclose(h_s, h_d, rtol=1e-10)
    np.testing.assert_allclose(dh_s, dh_d, rtol=1e-9)
    np.testing.assert_allclose(sparse.to_modal(n_modes=2).natural_frequencies_hz, dense.to_modal().natural_frequencies_hz[:2], rtol=1e-9)


@pytest.mark.parametrize("kind", ["lumped", "modal"])
def test_receptance_derivative_matches_finite_differences(kind):
    lumped = LumpedModel.with_loss_factor(M, K, 0.01, damping=0.2 * np.eye(3))
    model = lumped if kind == "lumped" else ModalModel([300.0, 800.0], [[1.0, 2.0], [0.5, -1.0]], damping_ratios=[0.01, 0.02], loss_factors=0.005)
    rows, cols = [0, 1], [1]
    _, dh = model.receptance(OMEGA, rows, cols, derivative=True)
    step = 1e-6 * OMEGA
    fd = (model.receptance(OMEGA + step, rows, cols) - model.receptance(OMEGA - step, rows, cols)) / (2 * step[:, None, None])
    np.testing.assert_allclose(dh, fd, rtol=1e-6)


def test_bad_matrices_are_rejected():
    with pytest.raises(ValueError, match="stiffness must be 3×3"):
        LumpedModel(M, np.eye(2))
    with pytest.raises(ValueError, match="NaN"):
        LumpedModel(M, K * np.nan)
    with pytest.raises(ValueError, match="columns"):
        ModalModel([10.0, 20.0], [[1.0, 2.0, 3.0]])
    with pytest.raises(ValueError, match="dof_names"):
        LumpedModel(M, K, dof_names=("a",))


@pytest.mark.parametrize("proportional", [True, False])
def test_dense_receptance_without_inverse_matches_the_inverse(proportional):
    # a 30-dof chain with structural damping γK, plus (not proportional) a local dashpot and
    # a joint's loss at one spring: the modal route is taken exactly when it is exact
    n = 30
    k = 1e4 * (2 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1))
    k[-1, -1] = 1e4
    m = np.eye(n) / n
    d = 0.01 * k
    c = np.zeros((n, n))
    if not proportional:
        c[n - 1, n - 1] = 0.3
        d[3:5, 3:5] += 50.0 * np.array([[1, -1], [-1, 1]])
    model = LumpedModel(m, k, c, d)
    assert (model._proportional_modes() is not None) == proportional
    omega = np.linspace(5.0, 900.0, 41)
    rows, cols = [n - 1, 4], [0, 3, n - 1]
    h, dh = model.receptance(omega, rows, cols, derivative=True)
    h_2, dh_2 = model.harmonic_receptance(omega, 2, rows, cols, derivative=True)
    for i, w in enumerate(omega):
        full = np.linalg.inv(model.dynamic_stiffness(w))
        d_full = -full @ (-2 * w * m + 1j * c) @ full
        np.testing.assert_allclose(h[i], full[np.ix_(rows, cols)], rtol=1e-9, atol=1e-12 * np.abs(full).max())
        np.testing.assert_allclose(dh[i], d_full[np.ix_(rows, cols)], rtol=1e-8, atol=1e-12 * np.abs(d_full).max())
        # harmonic 2: K − (2ω)²M + i(2ωC + 2D)
        z2 = k - (2 * w) ** 2 * m + 1j * (2 * w * c + 2 * d)
        full2 = np.linalg.inv(z2)
        np.testing.assert_allclose(h_2[i], full2[np.ix_(rows, cols)], rtol=1e-9, atol=1e-12 * np.abs(full2).max())
        d_full2 = -full2 @ (-2 * (2 * w) * m + 1j * c) @ full2 * 2
        np.testing.assert_allclose(dh_2[i], d_full2[np.ix_(rows, cols)], rtol=1e-8, atol=1e-12 * np.abs(d_full2).max())
