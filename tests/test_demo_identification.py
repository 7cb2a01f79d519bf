"""The demo's identification over eight noise seeds: both linear modes found, near the truth.

The demo study (``nlupdate demo``) simulates the T-beam whose underlying linear system has
its first two modes at 43.76 and 185.19 Hz (the hidden truth's modal model). Stuck friction
lifts the low-force resonance of mode 1 to ~85 Hz, so the PRD frequency search starts
there and walks down to the linear mode on the extracted linear FRF, which is noisiest
around that mode. Two faults did this wrong for some seeds (the slow eight-seed check of
``tests/test_demo.py`` found them): the resonance test lost the noisy mode 1 (seeds 7, 8:
the targets then had one mode), and the search jumped to mode 2 when one extracted FRF
showed no crossing below the reference, where PRD's k3 came out 4–5 % off with a 0.7 %
standard deviation (seeds 1, 3, 8). A third put the modes beside the truth: the linear
FRF came from the 0.01 N level alone, where the stuck joint's stiffness (3e4 N/m) swamps
the structure's own at mode 1 and the level carries 12× the noise of the 1 N level there
(mode 1 up to 0.95 Hz off, seed 5); and a one-mode fit with a constant upper residual put
mode 2 0.02 Hz high (modes at 215 and 219 Hz, just above its band). The linear FRF now
comes from every level, weighted by its noise, and the fit bends its residual (S ω²).
The Monte-Carlo part is left to the slow test.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from nlupdate.app.cli.demo import demo_study_text
from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.pipeline import identify
from nlupdate.study import study_from_text
from nlupdate.study.steps.measured import measured_table, truth_system


@pytest.mark.parametrize("seed", range(1, 9))
def test_both_linear_modes_found_and_the_frequency_search_stays_on_mode_one(seed):
    study = study_from_text(demo_study_text(seed), Path("demo.toml"))
    omega_sq, _, _ = truth_system(study, study.measured.simulate).model.modal_damping()
    truth_hz = np.sqrt(np.sort(omega_sq)[:2]) / (2 * np.pi)
    settings = dataclasses.replace(study.identification, samples=2)
    table = measured_table(study)
    identification = identify(FRFLevels.from_table(table, settings.response_dof, settings.input_dof), settings)
    found = identification.natural_frequencies_hz
    assert found.size == 2, found
    np.testing.assert_allclose(found, truth_hz, rtol=0.03)
    # seeds 1-12: mode 1 within 0.12 Hz, mode 2 within 0.01 Hz (from the 0.01 N level
    # alone: 0.95 Hz and 0.045 Hz)
    assert abs(found[0] - truth_hz[0]) < 0.2 and abs(found[1] - truth_hz[1]) < 0.015, (found, truth_hz)
    assert identification.frequency_choice.frequency_hz < 1.1 * truth_hz[0], identification.frequency_choice
    found = identification.result.parameters()
    # with levels through the stick-slip transition every parameter is determined (within
    # 1.5 % for seeds 1-8; the source's 10...50 N alone gave slip forces of 0.01-0.8 N)
    assert abs(found["k3"] / 3e9 - 1) < 0.05 and abs(found["kf"] / 3e4 - 1) < 0.05
    assert abs(found["slip_force"] / 0.5 - 1) < 0.1, found
