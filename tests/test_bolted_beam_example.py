"""The bolted-beam example (examples/bolted_beam/study.toml): a T-beam whose clamped tip is an
Iwan joint. Its simulated test identified, updated and predicted end to end (slow), and an
amplitude-dependent modal model of its first mode from the same FRFs (fast)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from nlupdate.identification.amplitude_modal import amplitude_model_from_frfs
from nlupdate.identification.data import FRFLevels
from nlupdate.study import load_study
from nlupdate.study.steps import measured_table
from nlupdate.updating.adapter_factory import AdapterSpec, build_adapter

STUDY = Path(__file__).resolve().parents[1] / "examples" / "bolted_beam" / "study.toml"


@pytest.fixture(scope="module")
def study():
    return load_study(STUDY)


@pytest.fixture(scope="module")
def measured(study):
    return measured_table(study)


def test_amplitude_model_from_the_example_frfs_follows_every_level(study, measured):
    data = FRFLevels.from_table(measured, "tip:uz", "tip:uz")
    model = amplitude_model_from_frfs(data, "iwan")
    # the FE shape of mode 1 at the tip, at the truth (the joint slips in this shape)
    truth = study.measured.simulate
    modes = build_adapter(AdapterSpec("surrogate", "tbeam", {"coordinates": ["tip:uz"], "n_modes": 2})).evaluate(
        truth.parameters)
    assert model.shape("tip:uz") == pytest.approx(abs(modes.mode_shapes[0, 0]), rel=0.02)
    for level, f, h in zip(data.levels, data.frequencies, data.receptances):
        first = f < 70.0
        fine = np.linspace(30.0, 70.0, 4001)
        predicted = model.frf(fine, level, "tip:uz", "tip:uz")
        f_peak, f_model = f[first][np.argmax(np.abs(h[first]))], fine[np.argmax(np.abs(predicted))]
        assert abs(f_model / f_peak - 1) < 0.005  # measured ≤ 0.42 %
        assert abs(np.abs(predicted).max() / np.abs(h[first]).max() - 1) < 0.08  # measured ≤ 5.2 %


@pytest.mark.slow
def test_the_example_identifies_updates_and_predicts(study, measured):
    from nlupdate.study.run import run_study

    result = run_study(study)
    p = result.identification.parameters()
    stats = result.identification.uncertainty.parameters
    for name, truth in (("slip_force", 0.5), ("kt", 5e3), ("chi", -0.4), ("beta", 0.3)):
        assert abs(p[name] - truth) <= 3 * stats[name].std + 1e-3 * abs(truth), name
    best = result.ranking["candidate"].iloc[0]
    run = next(r for r in result.runs if r.name == best)
    assert run.parameters["E"] == pytest.approx(195e9, rel=5e-3) and run.parameters["h2"] == pytest.approx(1.45e-3, rel=5e-3)
    updated = next(prediction for prediction in result.predictions if prediction.name == best)
    assert updated.correlation["frac"].min() > 0.99
