"""DDF method on the §3.5 SDOF with cubic stiffness only (describing-function data, as in
the source): noise-free it recovers k* and the linear FRF (analytical receptance)."""
from __future__ import annotations

import numpy as np
import pytest

from nlupdate.core.response.continuation import trace_frequency_response
from nlupdate.core.model.elements import CubicStiffness
from nlupdate.core.correlation.metrics import frac
from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.ddf import identify_ddf
from nlupdate.core.identification.dfmodels import PhysicalModel
from nlupdate.core.identification.prd import IdentificationError
from nlupdate.core.model.linear import LumpedModel
from nlupdate.core.measurement.frf_table import frf_table
from nlupdate.core.response.stepped_sine import stepped_sine
from nlupdate.core.model.system import NonlinearSystem

MODEL = LumpedModel.with_loss_factor([[0.1]], [[2e6]], 0.01)


@pytest.fixture(scope="module")
def cubic_data() -> FRFLevels:
    system = NonlinearSystem(MODEL, (CubicStiffness((0,), 1e10),))
    grid = np.arange(600.0, 951.0, 2.0)
    frequency, force, h = [], [], []
    for level in (100.0, 150.0, 350.0, 450.0):
        curve = trace_frequency_response(system, {0: level}, 2 * np.pi * 590, 2 * np.pi * 960)
        sweep = stepped_sine(curve, 2 * np.pi * grid, "up")
        frequency.append(grid)
        force.append(np.full(grid.size, level))
        h.append(sweep.response([0])[:, 0] / level)
    table = frf_table(np.concatenate(frequency), np.concatenate(force), "0", "0", np.concatenate(h))
    return FRFLevels.from_table(table, "0", "0")


@pytest.mark.parametrize("pair", [(100.0, 350.0), (150.0, 450.0), (100.0, 450.0)])
@pytest.mark.parametrize("estimator", ["naive", "weighted"])
def test_ddf_recovers_cubic_stiffness_noise_free(cubic_data, pair, estimator):
    result = identify_ddf(cubic_data, pair, (600.0, 850.0), order=2, estimator=estimator)
    assert result.parameters()["k3"] == pytest.approx(1e10, rel=1e-6)
    x = 1e-3  # a typical amplitude (m): the linear term is negligible there
    assert abs(result.coefficients[0]) * x < 1e-6 * abs(result.coefficients[1]) * x**2


def test_ddf_linear_frf_from_either_level(cubic_data):
    result = identify_ddf(cubic_data, (100.0, 450.0), order=3)
    for level in (100.0, 450.0):
        f, h = cubic_data.curve(level)
        linear = MODEL.receptance(2 * np.pi * f, [0], [0])[:, 0, 0]
        assert frac(linear, result.extract_linear_frf(f, h, level)) > 0.999999


def test_ddf_with_physical_element(cubic_data):
    result = identify_ddf(cubic_data, (150.0, 450.0), physical=PhysicalModel(("cubic",)))
    assert result.parameters()["k3"] == pytest.approx(1e10, rel=1e-6)


def test_ddf_errors(cubic_data):
    with pytest.raises(IdentificationError, match="two different"):
        identify_ddf(cubic_data, (100.0, 100.0))
    with pytest.raises(ValueError, match="not measured"):
        identify_ddf(cubic_data, (100.0, 200.0))
    with pytest.raises(IdentificationError, match="frequencies in"):
        identify_ddf(cubic_data, (100.0, 450.0), (700.0, 702.0), order=3)
    with pytest.raises(IdentificationError, match="only 1"):
        identify_ddf(cubic_data.subset([100.0]))
