"""One level's misfits about its weighted polynomials (core/identification/level_residual.py),
both curves solved in one least-squares call, against numpy's weighted polynomial fit."""
from __future__ import annotations

import numpy as np

from nlupdate.core.identification.level_residual import ORDER, _level_misfits


def test_a_levels_misfits_are_those_of_its_two_weighted_polynomial_fits():
    """``Re D + Ω²`` and ``Im D`` each fitted by ``numpy.polynomial.polynomial.polyfit`` in a/a_max
    with weights 1/|D|: the misfits over |D|, frequencies' first, to 1e-9 of the largest."""
    rng = np.random.default_rng(4)
    a = np.geomspace(1e-4, 1e-3, 40)
    omega = 2 * np.pi * np.linspace(79, 81, 40)
    stiffness = (2 * np.pi * 80) ** 2 * (1 - 0.02 * a / a.max()) - omega**2 + 1e3 * rng.standard_normal(40) \
        + 1j * (2 * 0.004 * (2 * np.pi * 80) ** 2 * (1 + a / a.max()) + 1e2 * rng.standard_normal(40))
    weight = 1 / np.abs(stiffness)
    x = a / a.max()
    expected = []
    for values in (stiffness.real + omega**2, stiffness.imag):
        coefficients = np.polynomial.polynomial.polyfit(x, values, ORDER, w=weight)
        expected.append((values - np.polynomial.polynomial.polyval(x, coefficients)) * weight)
    expected = np.concatenate(expected)
    misfits = _level_misfits(a, stiffness, omega, ORDER)
    assert misfits.shape == (80,)
    assert np.max(np.abs(misfits - expected)) <= 1e-9 * np.max(np.abs(expected))
