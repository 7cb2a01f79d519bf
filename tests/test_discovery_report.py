"""Augmented models as model files: ``system_to_toml`` output read back by ``load_system``
gives the same receptances and elements (lumped dense and sparse, modal, every element type)."""
import numpy as np
import pytest
import scipy.sparse

from nlupdate.core.model.elements import (
    CoulombFriction, CubicStiffness, JenkinsFriction, PolynomialDF, QuadraticDamping, SymmetricGap,
)
from nlupdate.core.model.linear import LumpedModel, ModalModel
from nlupdate.core.model.model_file import load_system, write_system
from nlupdate.core.model.system import NonlinearSystem

ELEMENTS = (
    CubicStiffness((0,), -1.234567890123e11),
    JenkinsFriction((0, 2), kf=8e4, slip_force=1.0 / 3.0),
    CoulombFriction((1,), 0.1),
    QuadraticDamping((2, 1), 2.5),
    SymmetricGap((1,), gap=1e-5, kc=4e5),
    PolynomialDF((0,), real=(1e9, -2.48e6, -190.0), imag=(8e5, -109.0)),
)
MASS = np.diag([0.1, 0.5, 0.2])
STIFFNESS = 1e6 * np.array([[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.5]])


@pytest.mark.parametrize(
    "model",
    [
        LumpedModel(MASS, STIFFNESS, 0.3 * np.eye(3), 0.01 * STIFFNESS, ("m1", "m2", "tip:uz")),
        LumpedModel(scipy.sparse.csr_matrix(MASS), scipy.sparse.csr_matrix(STIFFNESS)),
        ModalModel([120.5, 480.25, 800.0], np.arange(9.0).reshape(3, 3) / 7 + 0.1, [0.01, 0.02, 0.0], 0.003, ("a", "b", "c")),
    ],
)
def test_written_model_reads_back_the_same(tmp_path, model):
    system = NonlinearSystem(model, ELEMENTS)
    reread = load_system(write_system(system, tmp_path / "augmented.toml"))
    assert reread.elements == system.elements
    assert reread.model.dof_names == model.dof_names
    w = 2 * np.pi * np.array([50.0, 300.0, 900.0])
    np.testing.assert_allclose(reread.model.receptance(w, [0, 1, 2], [0, 1, 2]), model.receptance(w, [0, 1, 2], [0, 1, 2]), rtol=1e-12)
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]
