"""Whether a held-out test type's 95 % bands test anything (``validate --hold-out-type``):
the rule of ``--hold-out LEVELS`` (nlupdate.core.validation.compared) applied to the held type.

Truth, known in closed form: a mode whose natural frequency and damping ratio are linear in
the modal amplitude a (m·√kg), f(a) = 10 Hz · (1 − 0.02 a/A), ζ(a) = 0.5 % · (1 + 2 a/A),
A = 1 mm·√kg — inside the ``polynomial`` backbone's family, so the model of the right form
fitted to the kept samples predicts the held ones exactly but for the kept samples' noise.
The held "ring-down" samples are the truth at 0.40–0.45 A with 1e-5 (frequency) and 0.5 %
(damping) relative scatter: over them the frequency moves by 0.1 % and the damping by 3 %.
The kept "response-controlled" samples cover 0.1–1 A:

* measured to 1e-5 and 0.5 %: the bootstrap band of the prediction is about as narrow as the
  held samples' own scatter allows, and holds the truth — informative, no flag;
* frequencies measured to 2 % (damping still to 0.5 %): the frequency band (about ±0.8 %)
  holds every frequency the held ring-down measured eight times over (its whole movement is
  0.1 %, 0.01 Hz), so a prediction that ignored the amplitude dependence would pass as
  well — each in-band frequency flagged, the damping bands (about ±2 %, against the held
  test's 3 % movement) not, and the verdict a warning.
"""
from __future__ import annotations

import numpy as np
import pytest

from nlupdate.core.identification.modal_samples import ModalSamples
from nlupdate.core.validation.held_type import hold_out_type
from nlupdate.core.validation.verdict import held_type_said
from nlupdate.reporting.validation_text import held_type_rows, said_line

A = 1e-3
PHI = 1 / np.sqrt(2.0)


def held_type_lines(summary: dict, unit: str = "N") -> list[str]:
    """What ``validate --hold-out-type`` prints of validation.json's ``held_out_type`` entry: what
    it says before its table (the verdict, the model's warnings), then the table."""
    return [said_line(line) for line in held_type_said(summary, unit)] + held_type_rows(summary, unit)


def truth(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return 10.0 * (1 - 0.02 * a / A), 0.005 * (1 + 2 * a / A)


def samples(a: np.ndarray, noise: tuple[float, float], seed: int) -> ModalSamples:
    rng = np.random.default_rng(seed)
    f, z = truth(a)
    f = f * (1 + noise[0] * rng.standard_normal(a.size))
    z = z * (1 + noise[1] * rng.standard_normal(a.size))
    force = 2 * z * (2 * np.pi * f) ** 2 * a / PHI  # the force holding a at resonance: 2ζω²a = φ_f F
    return ModalSamples(a, f, z, force, PHI)


def held_out(kept_noise: tuple[float, float]) -> dict:
    held = ("ring", samples(np.linspace(0.40, 0.45, 12) * A, (1e-5, 0.005), 1), (1e-5, 0.005), "ring-down")
    kept = ("runs", samples(np.geomspace(0.1, 1.0, 16) * A, kept_noise, 2), kept_noise, "response-controlled")
    return hold_out_type([kept, held], "ring-down", (("0", PHI),), backbone="polynomial", order=1,
                         resamples=60).summary()


@pytest.fixture(scope="module")
def tight() -> dict:
    return held_out((1e-5, 0.005))


@pytest.fixture(scope="module")
def wide() -> dict:
    return held_out((0.02, 0.005))


def compared(summary: dict) -> list[dict]:
    return [entry[name] for entry in summary["samples"] for name in ("natural_frequency_hz", "damping_ratio")]


def test_a_tight_band_that_holds_the_truth_is_informative(tight):
    values = compared(tight)
    assert len(values) == 24 and all(c["inside"] for c in values)
    assert all(c["informative"] is True for c in values)
    lines = held_type_lines(tight, "N")
    assert not lines[0].startswith("warning:") and "band uninformative" not in "\n".join(lines)
    assert "they test nothing" not in lines[0]


def test_a_band_wide_enough_to_hold_any_value_of_the_held_test_is_flagged(wide):
    values = compared(wide)
    assert all(c["inside"] for c in values)
    frequency = [entry["natural_frequency_hz"] for entry in wide["samples"]]
    measured = [c["measured"] for c in frequency]
    for c in frequency:  # the band holds every frequency the held test measured, centred anywhere among them
        assert c["low"] < min(measured) - (max(measured) - min(measured)) and c["high"] > 2 * max(measured) - min(measured)
        assert c["informative"] is False and c["band_width_scale"] == "high - low"
    assert all(entry["damping_ratio"]["informative"] is True for entry in wide["samples"])
    verdict = held_type_lines(wide, "N")[0]
    assert verdict.startswith("warning: ring-down held out: every measured value within the fitted amplitudes lies "
                              "within the prediction's 95 % band, but 24 of 24 values in band, 12 of them in bands "
                              "wider than twice the test's own spread")
    assert verdict.endswith("they test nothing")


def held_impact(kept_a: np.ndarray, kept_noise: tuple[float, float], order: int) -> dict:
    """A single impact (the truth at 1e-6 A: its linear limit, 10 Hz and 0.5 %, to 1e-5 and
    0.5 %) held out of response-controlled runs at ``kept_a``."""
    impact = ("tap", samples(np.array([1e-6 * A]), (1e-5, 0.005), 5), (1e-5, 0.005), "impact")
    kept = ("runs", samples(kept_a, kept_noise, 2), kept_noise, "response-controlled")
    return hold_out_type([kept, impact], "impact", (("0", PHI),), backbone="polynomial", order=order,
                         resamples=60).summary()


def test_a_single_held_value_is_judged_against_the_kept_sources_spread():
    """One value has no spread of its own: its band is judged against twice the kept runs' spread
    (module docstring of held_type). Runs over 0.1–1 A measured to 1e-5: the linear limit's band
    (±0.0002 Hz) holds the truth and is informative. Runs over 0.5–1 A only, to 0.3 %, extrapolated
    to a = 0 by a quadratic: a 0.8 Hz band against the runs' 0.13 Hz spread — it holds any linear
    limit the runs make plausible — flagged, and the damping band reaching 0 too (before: not judged)."""
    (tight,) = held_impact(np.geomspace(0.1, 1.0, 16) * A, (1e-5, 0.005), 1)["samples"]
    for name in ("natural_frequency_hz", "damping_ratio"):
        assert tight[name]["inside"] and tight[name]["informative"] is True, tight[name]
    summary = held_impact(np.geomspace(0.5, 1.0, 6) * A, (3e-3, 0.005), 2)
    (wide,) = summary["samples"]
    first = held_type_lines(summary, "N")[0]
    assert first.startswith("warning:") and "the kept sources' spread" in first and "test nothing" in first, first
    f = wide["natural_frequency_hz"]
    kept_f = truth(np.geomspace(0.5, 1.0, 6) * A)[0]
    assert f["inside"] and f["high"] - f["low"] > 2 * np.ptp(kept_f), f
    assert f["informative"] is False and wide["damping_ratio"]["informative"] is False, wide
