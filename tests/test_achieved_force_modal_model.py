"""A stepped sine whose shaker's force dips at resonance (a voltage-driven shaker, as on the
Brake–Reuss beam, whose 0.1947 N level reaches 0.142 N at its peak): each level's backbone
sample sits at the amplitude the structure reached, |H|·F at the force achieved at the peak
line, not |H| times the level's mean force; and a held-out level is predicted line by line at
the force achieved there.

Reference: a closed-form single mode whose natural frequency and damping depend on its
amplitude, solved line by line at the force of each line (tests/single_mode_reference.py),
so the amplitude of each line and the backbone at it are known exactly.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from nlupdate.core.identification.amplitude_modal_fit import samples_from_frfs
from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.model.amplitude_modal import AmplitudeModalModel
from nlupdate.core.validation.held_type import stepped_sine_levels
from nlupdate.core.measurement.frf_table import frf_table
from single_mode_reference import amplitude

F0, Z0 = 80.0, 0.002          # linear limit: Hz, damping ratio
A1 = 1e-4                     # m: the amplitude at which the mode has softened by 0.05 % and damps 1.5 × ζ₀
LINES = np.linspace(79.0, 81.0, 201)
GRID = np.geomspace(1e-8, 1e-2, 4000)
LEVELS = (0.2, 0.5, 1.0)      # N: each level's mean force over its lines


def natural(a):
    return 2 * np.pi * F0 * (1 - 0.0005 * np.asarray(a) / A1)


def damping(a):
    return Z0 * (1 + 0.5 * np.asarray(a) / A1)


def denominator(a, omega):
    """The amplitude-dependent modal model's (hysteretic damping: 2iζω², a polynomial
    backbone's form, docs/ring-down.md)."""
    w = natural(a)
    return w**2 - omega**2 + 2j * damping(a) * w**2


def shaker_force(level: float, f_hz: np.ndarray, dip: float) -> np.ndarray:
    """A force that dips by ``dip`` (a share) over the resonance, scaled so its mean over the
    lines is ``level``."""
    shape = 1 - dip * np.exp(-(((f_hz - F0) / 0.3) ** 2))
    return level * shape / shape.mean()


def measured(dip: float) -> tuple[FRFLevels, np.ndarray]:
    """The three levels' FRFs, and the amplitude each reached at its largest line."""
    rows, reached = [], []
    for level in LEVELS:
        force = shaker_force(level, LINES, dip)
        a = np.array([amplitude(denominator, F, 2 * np.pi * f, GRID) for F, f in zip(force, LINES)])
        h = 1 / denominator(a, 2 * np.pi * LINES)
        table = frf_table(LINES, level, "0", "0", h)
        table["level_achieved"] = force
        rows.append(table)
        reached.append(a[np.argmax(np.abs(h))])
    return FRFLevels.from_table(pd.concat(rows, ignore_index=True), "0", "0"), np.array(reached)


def readings(dip: float):
    """(samples, the amplitude each level reached at its largest line) of the three levels."""
    data, reached = measured(dip)
    return samples_from_frfs(data, input_shape=1.0), reached


def test_each_sample_sits_at_the_amplitude_the_force_achieved_at_the_peak_drove():
    steady, steady_reached = readings(dip=0.0)
    dipped, dipped_reached = readings(dip=0.3)
    # unit mass, φ = 1: the modal amplitude is the displacement at the driving point. The peak
    # reader's own error on this mode (the lowest level's one-mode fit takes part of the
    # curve's amplitude dependence for residual terms) is a few per cent at constant force.
    steady_error = steady.amplitude / steady_reached - 1
    dipped_error = dipped.amplitude / dipped_reached - 1
    assert np.all(np.abs(steady_error) < 0.06)
    # the dipping shaker's levels read as well as the steady one's (the level's mean force
    # would put them 30-40 % too high)
    assert np.all(np.abs(dipped_error) < np.abs(steady_error) + 0.01)
    steady_damping = np.abs(steady.damping_ratio / damping(steady.amplitude) - 1)
    dipped_damping = np.abs(dipped.damping_ratio / damping(dipped.amplitude) - 1)
    assert np.all(dipped_damping < steady_damping + 0.02)
    np.testing.assert_allclose(dipped.level, LEVELS)
    assert np.all(dipped.force_n < 0.8 * np.array(LEVELS))  # the force at each peak, in the dip


def test_a_held_out_level_is_predicted_at_the_force_each_line_achieved():
    """The exact model of the mode (its polynomial backbone and damping curve are the
    reference's, unit mass) predicts each level of the dipping shaker: read by the same
    estimator, the predicted resonance, damping ratio and peak equal the measured ones. At
    each level's mean force the prediction reached 15-30 % more amplitude at its peak, so it
    was more damped than the test."""
    data, _ = measured(dip=0.3)
    a_ref = 10 * A1
    exact = AmplitudeModalModel(F0, Z0, (("0", 1.0),), frequency_coefficients=(-0.0005 * a_ref / A1,),
                                damping_coefficients=(0.5 * Z0 * a_ref / A1,), reference_amplitude=a_ref)
    levels = stepped_sine_levels(exact, data, (0.0, a_ref))
    np.testing.assert_allclose(levels.resonance_hz_predicted, levels.resonance_hz_measured, atol=0.002)
    np.testing.assert_allclose(levels.damping_ratio_predicted, levels.damping_ratio_measured, rtol=0.01)
    np.testing.assert_allclose(levels.peak_abs_predicted, levels.peak_abs_measured, rtol=0.01)
