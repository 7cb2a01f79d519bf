"""SurrogateAdapter: caching, parameter overrides, metadata and input checks."""
from __future__ import annotations

import numpy as np
import pytest

from nlupdate.core.updating.evaluation import MemoisedEvaluator
from nlupdate.fe.adapters.surrogate import SurrogateAdapter
from nlupdate.fe.models.gunbarrel import GunBarrelParameters
from nlupdate.fe.models.tbeam import TBEAM_COORDINATES, TBeamParameters


@pytest.fixture
def tbeam_adapter():
    return SurrogateAdapter(
        "tbeam",
        TBeamParameters().with_sensor_masses(),
        n_modes=3,
        mesh_options={"elements_per_beam": 16},
        global_modes_only=True,
        parameter_names=["E", "h1", "h2", "w1"],
    )


def test_same_parameters_are_solved_once(tbeam_adapter):
    evaluator = MemoisedEvaluator(tbeam_adapter)
    first, second = evaluator([{"E": 200e9, "h2": 1.5e-3}, {"h2": 1.5e-3, "E": 200e9}])
    assert second is first
    assert evaluator.counts() == {"new": 1, "cached": 1}
    evaluator([{"E": 201e9, "h2": 1.5e-3}])
    assert evaluator.counts() == {"new": 2, "cached": 1}


def test_point_keys_name_the_model_set_up_not_the_instance():
    options = dict(model="gunbarrel", n_modes=2, parameter_names=["motor_stiffness"])
    point = {"motor_stiffness": 3e8}
    # two instances of one set-up share keys (what a persistent cache across runs relies on) …
    assert SurrogateAdapter(**options).key(point) == SurrogateAdapter(**options).key(point)
    # … while another mesh is another model
    assert SurrogateAdapter(**options, mesh_options={"elements": 96}).key(point) != SurrogateAdapter(**options).key(point)


def test_result_metadata_and_shapes(tbeam_adapter):
    result = tbeam_adapter.evaluate({})
    assert result.metadata["solver"] == "surrogate"
    assert result.metadata["log_path"] is None
    assert result.metadata["mesh_size"] > 0 and result.metadata["wall_time_s"] >= 0
    assert result.coordinates == TBEAM_COORDINATES
    assert result.mode_shapes.shape == (len(TBEAM_COORDINATES), 3)
    assert np.all(result.mode_shapes[0] > 0)  # drive-point entry positive
    np.testing.assert_allclose(result.natural_frequencies_hz, [41.4, 193.3, 266.0], rtol=0.03)


def test_modulus_scaling_follows_dimensional_analysis(tbeam_adapter):
    """Changing only E scales every frequency by √(E2/E1) and leaves the
    mass-normalised shapes unchanged (K ∝ E, M independent of E)."""
    base = tbeam_adapter.evaluate({"E": 210e9})
    updated = tbeam_adapter.evaluate({"E": 161.5e9})
    np.testing.assert_allclose(
        updated.natural_frequencies_hz / base.natural_frequencies_hz, np.sqrt(161.5 / 210), rtol=1e-9
    )
    np.testing.assert_allclose(updated.mode_shapes, base.mode_shapes, rtol=1e-6, atol=1e-9)


def test_global_modes_only_skips_local_modes():
    common = dict(model="tbeam", n_modes=3, mesh_options={"elements_per_beam": 16})
    every = SurrogateAdapter(**common).evaluate({})
    global_only = SurrogateAdapter(**common, global_modes_only=True).evaluate({})
    tip_every = np.abs(every.mode_shapes[0])
    assert tip_every[2] < 1e-6 * tip_every.max()  # mode 3 is a local thin-beam mode
    assert np.all(np.abs(global_only.mode_shapes[0]) > 0.1)
    np.testing.assert_allclose(global_only.natural_frequencies_hz[:2], every.natural_frequencies_hz[:2])
    assert global_only.natural_frequencies_hz[2] > every.natural_frequencies_hz[2]


def test_gunbarrel_motor_stiffness_update():
    """Source: updated motor stiffness 499e6 N/m gives 7.469 Hz (initial 140e6: 6.375 Hz)."""
    adapter = SurrogateAdapter("gunbarrel", GunBarrelParameters(), n_modes=1, parameter_names=["motor_stiffness"])
    initial = adapter.evaluate({"motor_stiffness": 140e6}).natural_frequencies_hz[0]
    updated = adapter.evaluate({"motor_stiffness": 499e6}).natural_frequencies_hz[0]
    assert initial == pytest.approx(6.375, rel=0.02)
    assert updated == pytest.approx(7.46875, rel=0.025)


def test_bad_input_raises_value_error(tbeam_adapter):
    with pytest.raises(ValueError, match="unknown parameter"):
        tbeam_adapter.evaluate({"L1": 0.4})
    with pytest.raises(ValueError, match="h1"):
        tbeam_adapter.evaluate({"h1": -1.0})
    with pytest.raises(ValueError, match="model"):
        SurrogateAdapter("plate")
    with pytest.raises(ValueError, match="coordinate"):
        SurrogateAdapter("tbeam", coordinates=["nowhere:uz"])
    with pytest.raises(ValueError, match="global_modes_only"):
        SurrogateAdapter("gunbarrel", global_modes_only=True)
    with pytest.raises(ValueError, match="mesh_options"):
        SurrogateAdapter("tbeam", mesh_options={"elements": 10})
    with pytest.raises(ValueError, match="base_parameters"):
        SurrogateAdapter("tbeam", GunBarrelParameters())
