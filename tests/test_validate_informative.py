"""An uninformative 95 % band says so (issue 34, "Honest bands"): ``Compared.informative``
(nlupdate.core.validation.compared), its mark in the table and its count in the verdict.

References, independent of the rule's code:

* an SDOF with a Jenkins joint, stuck at the lowest level and in gross slip at the top
  (simulated by describing-function continuation, 0.5 % noise): its resonance moves by
  ~2 Hz over the levels; a held-out level's band that is narrower than that spread — it
  does not hold every level's measured resonance — discriminates, and must not be flagged;
* the public Brake–Reuss beam's four force-controlled levels (tests/data/brb): their
  measured resonances span 0.32 Hz, and each held-out level's ``lines`` resonance band holds
  every one of them — a prediction of *any* level's value, or of none changing with
  amplitude, passes: provably uninformative.
"""
from __future__ import annotations

import numpy as np

from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.model.elements import JenkinsFriction
from nlupdate.core.model.linear import LumpedModel
from nlupdate.core.model.system import NonlinearSystem
from nlupdate.core.response.simulate import simulate_frf_table
from nlupdate.core.validation.held_out import validate
from nlupdate.core.validation.resonance import resonance
from nlupdate.reporting.validation_text import in_band_cell, verdict_lines


def _measured_resonances(data: FRFLevels) -> np.ndarray:
    return np.array([resonance(f, h).resonance_hz for f, h in zip(data.frequencies, data.receptances)])


def _holds_all(c, values: np.ndarray) -> bool:
    return bool(c.low <= values.min() and c.high >= values.max())


def test_a_band_that_could_fail_is_informative():
    """Jenkins SDOF (1 kg, 80 Hz, kf = 5 % of k, slip 0.02 N), five levels from stuck to
    gross slip, predicted by the model of the right form (``amplitude-jenkins``): each
    held-out level's resonance band leaves out a measured resonance (it could fail), its
    measured value lies in it, it is not flagged, and the verdict counts no uninformative band."""
    k = (2 * np.pi * 80.0) ** 2
    system = NonlinearSystem(LumpedModel.with_loss_factor([[1.0]], [[k]], 0.002),
                             (JenkinsFriction((0,), 0.05 * k, 0.02),))
    table, _ = simulate_frf_table(system, 0, np.linspace(76.0, 84.0, 161), (0.01, 0.02, 0.04, 0.08, 0.16),
                                  noise=0.005, seed=1)
    data = FRFLevels.from_table(table, "0", "0")
    measured = _measured_resonances(data)
    assert np.ptp(measured) > 1.0  # the joint moves the resonance by far more than the noise
    validation = validate(data, [0.04, 0.08], ["amplitude-jenkins"])
    for result in validation.held_out:
        c = result.compared["resonance_hz"]
        assert c.inside and not _holds_all(c, measured), (result.level, c.low, c.high)
        for name, q in result.compared.items():
            assert q.inside and q.informative is True, (result.level, name, q)
        assert "uninformative" not in in_band_cell(result.compared)
    assert "uninformative" not in " ".join(verdict_lines(validation, "N"))


def test_a_band_that_holds_every_measured_resonance_is_flagged():
    """BRB, each level held out by ``lines``: every resonance band holds all four measured
    resonances, so it is flagged, the table says so, and the verdict opens with a warning
    counting the in-band values whose band tests nothing."""
    from test_real_measurements import brb_levels

    data = brb_levels()
    measured = _measured_resonances(data)
    validation = validate(data, "each", ["lines"])
    for result in validation.held_out:
        c = result.compared["resonance_hz"]
        assert c.inside and _holds_all(c, measured), (result.level, c.low, c.high, measured)
        assert c.informative is False
        assert result.as_dict()["resonance_hz"]["informative"] is False
        assert in_band_cell(result.compared).startswith("yes (band uninformative)")
    inside = sum(bool(c.inside) for r in validation.held_out for c in r.compared.values())
    idle = sum(c.inside is True and c.informative is False for r in validation.held_out for c in r.compared.values())
    assert idle >= len(validation.held_out)
    first = verdict_lines(validation, "N")[0]
    assert first.startswith("warning: "), first
    assert f"{inside} of {inside} values in band, {idle} of them in bands wider" in first, first
    assert "they test nothing" in first
