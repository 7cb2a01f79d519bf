"""An impact's pole below every other source's amplitudes: the consistency check cannot test
it, and the model's linear limit below it is an extrapolation (issue 37's review).

Truth: the describing-function backbone of the Iwan SDOF of tests/test_ring_down.py (10 Hz,
χ = −0.5, slip amplitude φ_max = 1 mm; its microslip softening grows as A^0.5 from A = 0),
sampled as a stepped sine would give it (A = 0.1–2 mm) and as an impact's pole at 1 % of
φ_max, ± 1e-5 of its frequency (the Brake–Reuss beam's hammer pole: 80.5797 ± 0.0006 Hz).
"""
from __future__ import annotations

import numpy as np
import pytest

from nlupdate.core.identification.amplitude_modal_fit import fit_amplitude_model
from nlupdate.core.identification.backbone_samples import _scores, consistency, join_samples
from nlupdate.core.identification.modal_samples import ModalSamples
from test_ring_down import IWAN, M, df_backbone

PHI = 1 / np.sqrt(M)
SHAPES = (("x", PHI),)
IMPACT_STD = (1e-5, 0.01)  # the impact's stated relative standard errors (frequency, damping ratio)


def truth(amplitude_m: np.ndarray, frequency_shift: float = 0.0) -> ModalSamples:
    """Samples of the DF truth at physical amplitudes A (m); modal a = A/φ."""
    f, z = df_backbone(IWAN, amplitude_m)
    return ModalSamples(amplitude_m / PHI, f * (1 + frequency_shift), z, np.zeros(amplitude_m.size), PHI)


def joint(parts, noises):
    def refit(chosen):
        stds = [np.concatenate([np.full(parts[i][1].amplitude.size, noises[i][k]) for i in chosen]) for k in (0, 1)]
        return fit_amplitude_model(join_samples([parts[i][1] for i in chosen]), SHAPES, "polynomial", 2, *stds)
    return refit(list(range(len(parts)))), refit


@pytest.mark.parametrize("shift_in_errors", [50.0, 0.0, -50.0])
def test_an_impact_below_every_other_source_is_not_checked(shift_in_errors):
    """Moved by ±50 of its standard errors or not, the joint fit follows the impact: scored
    against it (the check before) it agreed within 0.1 standard errors; it is now reported as
    not checked, and the linear limit above it as the backbone's extrapolation."""
    steps = truth(np.geomspace(1e-4, 2e-3, 8))
    tap = truth(np.array([1e-5]), shift_in_errors * IMPACT_STD[0])
    parts, noises = [("steps", steps, "stepped-sine"), ("tap", tap, "impact")], [(1e-3, 0.05), IMPACT_STD]
    model, refit = joint(parts, noises)
    before = _scores(model, parts, noises)[1]
    assert abs(before["frequency_score"]) < 0.1  # the check before: "consistent" whatever the shift
    row = consistency(model, parts, noises, refit).set_index("source").loc["tap"]
    assert row["compared_with"] == "none" and np.isnan(row["frequency_score"])
    assert model.warnings and "extrapolation below every sample" in model.warnings[0]


def test_the_linear_limit_of_a_microslip_joint_lies_above_its_impact_pole():
    """Why the fit does not pin the linear limit onto the impact: the Iwan joint still softens
    at 1 % of its slip amplitude, so the truth's f₀ lies 0.15 % (150 of the impact's standard
    errors) above the impact's pole; the polynomial in (a/a_ref)^0.5 through the impact
    extrapolates to within 1e-4 of the truth's f₀."""
    steps, tap = truth(np.geomspace(1e-4, 2e-3, 8)), truth(np.array([1e-5]))
    f0_truth = float(df_backbone(IWAN, np.array([1e-12]))[0][0])
    assert (f0_truth / tap.frequency_hz[0] - 1) / IMPACT_STD[0] > 100
    model, _ = joint([("steps", steps, "stepped-sine"), ("tap", tap, "impact")], [(1e-3, 0.05), IMPACT_STD])
    assert abs(model.natural_frequency_hz / f0_truth - 1) < 1e-4
    assert abs(model.frequency_hz(tap.amplitude)[0] / tap.frequency_hz[0] - 1) < 3 * IMPACT_STD[0]


def test_an_impact_among_the_other_samples_moved_by_50_errors_is_named():
    """Where the stepped sine brackets the impact's amplitude the check tests it: moved by 50 of
    its standard errors it is named, unmoved it agrees (the steps exact, at the noise floor
    1e-5 that source_noise gives them; with steps 100 × noisier the joint fit follows the
    impact and it scored 0.03 moved: the check cannot see what the other sources cannot pin)."""
    steps = truth(np.geomspace(3e-6, 2e-3, 12))
    for shift, named in ((50.0, True), (0.0, False)):
        tap = truth(np.array([1e-5]), shift * IMPACT_STD[0])
        parts, noises = [("steps", steps, "stepped-sine"), ("tap", tap, "impact")], [(1e-5, 0.05), IMPACT_STD]
        model, refit = joint(parts, noises)
        row = consistency(model, parts, noises, refit).set_index("source").loc["tap"]
        assert row["compared_with"] == "agreeing sources"
        assert (not row["consistent"]) == named, (shift, row)


def test_a_linear_damping_extrapolated_far_below_the_samples_is_stated():
    """The damping curve's ζ₀ is checked as the backbone's f₀ is. Truth: an SDOF (42.8 Hz, the
    transmitter beam's mode) with viscous ζ = 0.02 % and a power-law damper F = c|ẋ|^2.5 sgn ẋ,
    whose equivalent damping (the energy of one cycle, by quadrature) grows as A^1.5 and leaves
    the frequency alone; sampled over a factor 2.3 in amplitude as that beam's four levels are,
    its damping 0.034 → 0.068 %. The polynomial's ζ₀ misses the truth by 16 % (per sample 5 %)
    at 50 % of the lowest sample's damping: before, nothing said so (the frequency did not move,
    ζ₀ was above the 1 % floor)."""
    from scipy.integrate import quad

    f_n, z_lin, alpha = 42.8, 2e-4, 2.5
    w = 2 * np.pi * f_n

    def zeta(amplitude: float, c: float) -> float:  # m = 1 kg
        energy = quad(lambda t: c * abs(w * amplitude * np.sin(t)) ** (alpha + 1), 0, 2 * np.pi)[0] / w
        return z_lin + energy / (np.pi * w * amplitude**2) / (2 * w)

    amplitude = np.geomspace(5.4e-4, 1.25e-3, 4)
    c = (6.8e-4 - z_lin) / (zeta(amplitude[-1], 1.0) - z_lin)
    z = np.array([zeta(a, c) for a in amplitude])
    samples = ModalSamples(amplitude, np.full(amplitude.size, f_n), z, np.zeros(amplitude.size), 1.0)
    model = fit_amplitude_model(samples, (("x", 1.0),), "polynomial", 2, 1e-3, 0.05)
    assert abs(model.natural_frequency_hz / f_n - 1) < 1e-9  # no frequency extrapolation to warn about
    assert abs(model.damping_ratio / z_lin - 1) > 0.1  # not the linear damping the per-sample noise suggests
    assert model.damping_ratio > 0.01 * z[0]
    (warning,) = model.warnings
    assert "ζ₀" in warning and "extrapolation below every sample" in warning


def test_a_polynomial_backbone_with_too_few_samples_says_how_many_it_needs():
    """Order 2 on two samples: the error names the samples it needs and what to change (it
    read 'need 1 ≤ order < 2 samples')."""
    from nlupdate.core.model.amplitude_modal import AmplitudeModelError

    amplitude = np.array([1e-4, 2e-4])
    samples = ModalSamples(amplitude, np.array([80.0, 79.9]), np.array([1e-3, 1.2e-3]), np.zeros(2), 1.0)
    with pytest.raises(AmplitudeModelError, match="order 2 needs at least 3 samples, got 2: a lower order or more"):
        fit_amplitude_model(samples, (("x", 1.0),), "polynomial", 2, 1e-3, 0.05)
    with pytest.raises(AmplitudeModelError, match="order must be at least 1, got 0"):
        fit_amplitude_model(samples, (("x", 1.0),), "polynomial", 0, 1e-3, 0.05)
    assert fit_amplitude_model(samples, (("x", 1.0),), "polynomial", 1, 1e-3, 0.05).natural_frequency_hz > 0
