"""Linear models: direct solve, modal superposition, sparse storage and dH/dω."""
import numpy as np
import pytest
import scipy.sparse

from nlupdate.model.linear import LumpedModel, ModalModel

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
