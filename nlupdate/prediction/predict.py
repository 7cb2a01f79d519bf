"""Predictions of the updated nonlinear model: updated linear model + identified elements.

The source's last step (METHODS §6): the updated linear FE model (its modes at the
measured coordinates, from an adapter evaluated at the updated parameters) and the
identified nonlinear elements form the updated nonlinear model, which is simulated at
every measured force level and frequency and compared with the measurements.

Damping. Natural frequencies and mode shapes come from the FE model, damping does not.
Two sources: the loss factor of the extracted linear FRF's first mode (identification),
or — default, :func:`fit_loss_factor` — the one modal loss factor η for which the
updated nonlinear model best reproduces the lowest measured force level. At that level
the friction sticks and the response is well above the noise at its (stiffened)
resonance, while the extracted linear FRF is noisiest at its own resonance (see
:mod:`nlupdate.identification.modal_fit`), so the low-force fit is the better-conditioned
estimate. The fit minimises the relative FRF error ``Σ |H_model − H̃|²/|H̃|²`` over η by a
bounded scalar search.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np
import pandas as pd
import scipy.optimize
from numpy.typing import ArrayLike

from nlupdate.adapters.base import ModalResult
from nlupdate.measurement.frf_table import select_frf
from nlupdate.model.system import NonlinearSystem
from nlupdate.response.simulate import simulate_frf_table

LOSS_FACTOR_BOUNDS = (1e-4, 0.2)


def updated_model(modes: ModalResult, elements: Sequence, loss_factor: float) -> NonlinearSystem:
    """Nonlinear system of the FE modes (at their coordinates, modal loss factor η) and the
    identified ``elements`` (whose ``dofs`` index those coordinates)."""
    return NonlinearSystem(modes.to_modal_model(loss_factors=float(loss_factor)), tuple(elements))


def predict(
    system: NonlinearSystem, input_dof: str, frequency_hz: ArrayLike, force_levels_n: Sequence[float], sweep: str = "up"
) -> pd.DataFrame:
    """Predicted measured-FRF table (every coordinate of the model) at each force level,
    read as a stepped-sine test sweeping ``sweep``."""
    table, _ = simulate_frf_table(system, input_dof, frequency_hz, force_levels_n, sweep=sweep)
    return table


def fit_loss_factor(
    modes: ModalResult,
    elements: Sequence,
    response_dof: str,
    input_dof: str,
    frequency_hz: ArrayLike,
    h_measured: ArrayLike,
    force_n: float,
    sweep: str = "up",
) -> float:
    """The modal loss factor η (all modes) that best reproduces one measured curve
    (``frequency_hz`` Hz, ``h_measured`` m/N at ``force_n`` N); see the module docstring."""
    f = np.asarray(frequency_hz, dtype=float)
    h = np.asarray(h_measured, dtype=complex)

    def misfit(log_eta: float) -> float:
        system = updated_model(modes, elements, float(np.exp(log_eta)))
        f_model, h_model = select_frf(predict(system, input_dof, f, [force_n], sweep), response_dof, input_dof, force_n)
        measured = np.isin(f, f_model)
        if not measured.any():
            return np.inf
        return float(np.mean(np.abs(h_model[np.isin(f_model, f)] - h[measured]) ** 2 / np.abs(h[measured]) ** 2))

    low, high = np.log(LOSS_FACTOR_BOUNDS)
    solution = scipy.optimize.minimize_scalar(misfit, bounds=(low, high), method="bounded", options={"xatol": 1e-3})
    return float(np.exp(solution.x))
