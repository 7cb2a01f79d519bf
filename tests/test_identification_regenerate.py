"""Regeneration of nonlinear FRFs on sampled linear FRFs, checked against the
continuation + stepped-sine solver (an independent algorithm for the same equations)."""
from __future__ import annotations

import numpy as np
import pytest

from nlupdate.core.response.continuation import trace_frequency_response
from nlupdate.core.model.elements import CubicStiffness, JenkinsFriction
from nlupdate.core.response.fixed_point import fixed_point_response
from nlupdate.core.correlation.metrics import frac
from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.dfmodels import PhysicalModel
from nlupdate.core.identification.prd import identify_prd
from nlupdate.core.identification.regenerate import SampledReceptance, regenerate_frf
from nlupdate.core.model.linear import LumpedModel
from nlupdate.core.measurement.frf_table import frf_table
from nlupdate.core.response.stepped_sine import stepped_sine
from nlupdate.core.model.system import NonlinearSystem

MODEL = LumpedModel.with_loss_factor([[0.1]], [[2e6]], 0.01)
ELEMENTS = (CubicStiffness((0,), 1e10), JenkinsFriction((0,), 3e5, 1.0))
GRID = np.arange(690.0, 800.0, 0.5)


def sweep(force: float, direction: str) -> np.ndarray:
    system = NonlinearSystem(MODEL, ELEMENTS)
    curve = trace_frequency_response(system, {0: force}, 2 * np.pi * 680, 2 * np.pi * 810)
    result = stepped_sine(curve, 2 * np.pi * GRID, direction)
    return result.response([0])[:, 0] / force, result.jumps_hz


def total_df(amplitude, omega):
    return sum(element.describing_function(amplitude, omega) for element in ELEMENTS)


@pytest.mark.parametrize("direction", ["up", "down"])
def test_regeneration_matches_stepped_sine_on_the_true_linear_frf(direction):
    h_linear = MODEL.receptance(2 * np.pi * GRID, [0], [0])[:, 0, 0]
    expected, jumps = sweep(130.0, direction)
    assert jumps  # the sweep crosses the fold region
    regenerated = regenerate_frf(GRID, h_linear, total_df, 130.0, direction)
    assert np.all(np.isfinite(regenerated))
    assert np.max(np.abs(regenerated - expected) / np.abs(expected)) < 1e-6


def test_regeneration_from_identified_prd_result():
    """Identify at 712 Hz from DF data, extract H^L, regenerate 280 N: same FRF."""
    system = NonlinearSystem(MODEL, ELEMENTS)
    levels = (0.01,) + tuple(np.arange(100.0, 401.0, 60.0))
    frequency, force, h = [], [], []
    for level in levels:
        x = fixed_point_response(system, {0: level}, 2 * np.pi * np.arange(700.0, 725.0)).response([0])[:, 0]
        frequency.append(np.arange(700.0, 725.0))
        force.append(np.full(x.size, level))
        h.append(x / level)
    data = FRFLevels.from_table(frf_table(np.concatenate(frequency), np.concatenate(force), "0", "0",
                                          np.concatenate(h)), "0", "0")
    result = identify_prd(data, 712.0, PhysicalModel(("cubic", "jenkins")))
    low = fixed_point_response(system, {0: 0.01}, 2 * np.pi * GRID).response([0])[:, 0] / 0.01
    h_linear = result.extract_linear_frf(GRID, low)
    expected, _ = sweep(280.0, "up")
    regenerated = regenerate_frf(GRID, h_linear, result.df_for_force(280.0), 280.0)
    assert frac(expected, regenerated) > 0.99999


def test_sampled_receptance_interpolates_and_drives_the_solvers():
    mass = np.diag([0.1, 0.5])
    stiffness = np.array([[2e6, -1e6], [-1e6, 2e6]])
    model = LumpedModel.with_loss_factor(mass, stiffness, 0.005)
    f = np.arange(700.0, 760.0, 0.25)
    sampled = SampledReceptance(f, model.receptance(2 * np.pi * f, [0, 1], [0, 1]))
    midpoints = 2 * np.pi * (f[:-1] + 0.125)
    exact, exact_derivative = model.receptance(midpoints, [0, 1], [1], derivative=True)
    interpolated, derivative = sampled.receptance(midpoints, [0, 1], [1], derivative=True)
    assert np.max(np.abs(interpolated - exact) / np.abs(exact)) < 1e-4
    assert np.max(np.abs(derivative - exact_derivative)) < 1e-2 * np.max(np.abs(exact_derivative))
    elements = (CubicStiffness((0,), 1e10),)
    omega = 2 * np.pi * np.arange(710.0, 725.0, 0.6)
    reference = fixed_point_response(NonlinearSystem(model, elements), {0: 30.0}, omega)
    on_samples = fixed_point_response(NonlinearSystem(sampled, elements), {0: 30.0}, omega)
    assert np.max(np.abs(on_samples.response([0, 1]) - reference.response([0, 1]))) < 1e-4 * np.max(
        np.abs(reference.response([0, 1])))
    with pytest.raises(ValueError, match="outside the sampled band"):
        sampled.receptance([2 * np.pi * 800.0], [0], [0])
