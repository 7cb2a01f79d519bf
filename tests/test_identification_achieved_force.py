"""Identification from lines measured at the force the controller achieved, not the level.

A stepped-sine controller rarely holds the force through a resonance: the public
Brake–Reuss beam runs (tests/data/brb) dip by up to 27 % there. The measured FRF of a line
is then ``X/F_line`` and its response amplitude ``|H|·F_line``; a method that takes
``|H|·level`` puts every point at the wrong amplitude. The table carries the per-line
force as ``level_achieved``; PRD (both estimators) and DDF must use it.

Reference: describing-function data of the source's §3.1 SDOF (cubic k3 = 1e10 N/m³,
Jenkins kf = 3e5 N/m, slip force 1 N), each line solved by the fixed-point method at its
own force — a force that dips by 25 % about 710 Hz and ripples by 5 %. With the per-line
force the physical-element fits recover the parameters to 1e-4, the polynomial to the
source's 1 %; read as if every line were at its level they are off by 25–65 % (k3).
"""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.ddf import identify_ddf
from nlupdate.core.identification.dfmodels import PhysicalModel, PolynomialModel
from nlupdate.core.identification.prd import identify_prd
from nlupdate.core.measurement.frf_table import frf_table
from nlupdate.core.model.elements import CubicStiffness, JenkinsFriction
from nlupdate.core.model.linear import LumpedModel
from nlupdate.core.model.system import NonlinearSystem
from nlupdate.core.response.fixed_point import fixed_point_response

LEVELS = (0.01,) + tuple(float(f) for f in np.arange(100.0, 401.0, 30.0))
GRID_HZ = np.arange(700.0, 717.0)
TRUTH = {"k3": 1e10, "kf": 3e5, "slip_force": 1.0}


def achieved_factor(frequency_hz: np.ndarray) -> np.ndarray:
    """Achieved force / level: a 25 % dip at the resonance and a 5 % ripple."""
    return 1 - 0.25 * np.exp(-(((frequency_hz - 710.0) / 4.0) ** 2)) + 0.05 * np.sin(frequency_hz)


@pytest.fixture(scope="module")
def table() -> pd.DataFrame:
    model = LumpedModel.with_loss_factor([[0.1]], [[2e6]], 0.01)
    system = NonlinearSystem(model, (CubicStiffness((0,), TRUTH["k3"]), JenkinsFriction((0,), TRUTH["kf"], 1.0)))
    curves = []
    for level in LEVELS:
        force = level * achieved_factor(GRID_HZ)
        x = []
        for frequency, f_line in zip(GRID_HZ, force):
            state = fixed_point_response(system, {0: f_line}, [2 * np.pi * frequency])
            assert state.converged.all()
            x.append(state.response([0])[0, 0])
        curve = frf_table(GRID_HZ, level, "0", "0", np.array(x) / force)
        curve["level_achieved"] = force
        curves.append(curve)
    return pd.concat(curves, ignore_index=True)


@pytest.mark.parametrize("estimator", ["naive", "improved"])
def test_prd_physical_elements_use_the_achieved_force(table, estimator):
    model = PhysicalModel(("cubic", "jenkins"))
    exact = identify_prd(FRFLevels.from_table(table, "0", "0"), 710.0, model, estimator=estimator).parameters()
    for name, value in TRUTH.items():
        assert exact[name] == pytest.approx(value, rel=1e-4), name
    nominal = identify_prd(FRFLevels.from_table(table.drop(columns="level_achieved"), "0", "0"), 710.0, model,
                           estimator=estimator).parameters()
    assert abs(nominal["k3"] / TRUTH["k3"] - 1) > 0.2  # the level in place of the achieved force


def test_prd_polynomial_uses_the_achieved_force(table):
    model = PolynomialModel.of_order(2)
    exact = identify_prd(FRFLevels.from_table(table, "0", "0"), 710.0, model).parameters()
    assert exact["k3"] == pytest.approx(TRUTH["k3"], rel=0.01)  # the source's accuracy on DF data
    assert exact["kf"] == pytest.approx(TRUTH["kf"], rel=0.01)
    nominal = identify_prd(FRFLevels.from_table(table.drop(columns="level_achieved"), "0", "0"), 710.0,
                           model).parameters()
    assert abs(nominal["k3"] / TRUTH["k3"] - 1) > 0.2


def test_ddf_uses_the_achieved_force(table):
    model = PhysicalModel(("cubic", "jenkins"))
    exact = identify_ddf(FRFLevels.from_table(table, "0", "0"), (0.01, 400.0), physical=model).parameters()
    for name, value in TRUTH.items():
        assert exact[name] == pytest.approx(value, rel=1e-4), name
    nominal = identify_ddf(FRFLevels.from_table(table.drop(columns="level_achieved"), "0", "0"), (0.01, 400.0),
                           physical=model).parameters()
    assert abs(nominal["k3"] / TRUTH["k3"] - 1) > 0.2


def test_force_at_interpolates_the_achieved_force_and_falls_back_to_the_level(table):
    data = FRFLevels.from_table(table, "0", "0")
    assert data.force_at(100.0, GRID_HZ) == pytest.approx(100.0 * achieved_factor(GRID_HZ), rel=1e-12)
    between = data.force_at(100.0, [700.5])[0]
    assert min(data.force_at(100.0, [700.0, 701.0])) <= between <= max(data.force_at(100.0, [700.0, 701.0]))
    without = FRFLevels.from_table(table.drop(columns="level_achieved"), "0", "0")
    assert np.all(without.force_at(100.0, GRID_HZ) == 100.0)
    # the achieved force follows the curves through subsets and band limits
    assert data.subset([100.0]).within((705.0, 710.0)).force_at(100.0, [708.0])[0] == pytest.approx(
        100.0 * achieved_factor(np.array([708.0]))[0])
