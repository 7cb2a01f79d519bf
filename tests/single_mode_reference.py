"""A force-controlled stepped sine of one mode whose natural frequency and damping ratio
depend on its amplitude, solved in closed form line by line — the independent reference of
the validate tests that choose their own ω(a), ζ(a).

``denominator(a, Ω)`` is ω(a)² − Ω² + 2iζ(a)ω(a)Ω (rad²/s², a in m, Ω in rad/s); a line at
force F (N) responds with the amplitude a solving a·|denominator(a, Ω)| = F (single-harmonic
balance), found by interpolation on a log grid of amplitudes on which that product is
asserted to rise, so the root is unique; its receptance is 1/denominator(a, Ω) (m/N).
"""
from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import pandas as pd

from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.impact import LinearLimit
from nlupdate.core.measurement.frf_table import frf_table

Denominator = Callable[[np.ndarray | float, float], np.ndarray | complex]


def amplitude(denominator: Denominator, force: float, omega: float, grid: np.ndarray) -> float:
    """The amplitude a (m) on ``grid`` at which a·|denominator(a, Ω)| equals ``force`` (N)."""
    g = grid * np.abs(denominator(grid, omega))
    assert np.all(np.diff(g) > 0)
    return float(np.interp(np.log(force), np.log(g), grid))


def stepped_sine(denominator: Denominator, levels: Sequence[float], frequencies_hz: np.ndarray,
                 grid: np.ndarray) -> FRFLevels:
    """The driving-point FRFs (coordinate ``"0"``) at each force level (N), line by line."""
    rows = []
    for level in levels:
        h = [1 / denominator(amplitude(denominator, level, 2 * np.pi * f, grid), 2 * np.pi * f)
             for f in frequencies_hz]
        rows.append(frf_table(frequencies_hz, level, "0", "0", np.array(h)))
    return FRFLevels.from_table(pd.concat(rows, ignore_index=True), "0", "0")


def exact_linear_limit(omega0: float, zeta0: float) -> LinearLimit:
    """The mode's linear limit as an impact would state it, exact: natural frequency
    ω₀/2π (Hz, ω₀ in rad/s) and damping ratio ζ₀ with negligible standard errors."""
    return LinearLimit(omega0 / (2 * np.pi), zeta0, 1e-4, 1e-6, 1e-8, (1e-9, 1e-8), (0.0, 1.0), (60.0, 100.0),
                       ("0",), 1, "exact")
