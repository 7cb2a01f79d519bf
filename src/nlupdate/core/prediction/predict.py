"""Predictions of the updated nonlinear model: updated linear model + identified elements.

The source's last step (docs/methods.md §6): the updated linear FE model (its modes at the
measured coordinates, from an adapter evaluated at the updated parameters) and the
identified nonlinear elements form the updated nonlinear model, which is simulated at
every measured force level and frequency and compared with the measurements.

Damping. Natural frequencies and mode shapes come from the FE model, damping does not.
Two sources: the loss factor of the extracted linear FRF's first mode (identification),
or — default, :func:`fit_loss_factor` — the one modal loss factor η for which the
updated nonlinear model best reproduces the lowest measured force level. At that level
the friction sticks and the response is well above the noise at its (stiffened)
resonance, while the extracted linear FRF is noisiest at its own resonance (see
:mod:`nlupdate.core.identification.modal_fit`), so the low-force fit is the better-conditioned
estimate. The fit minimises the relative FRF error ``Σ |H_model − H̃|²/|H̃|²`` over η by a
bounded scalar search.

Solver. By default every response is the describing-function continuation read as a
stepped-sine test; with ``harmonic_balance`` (a
:class:`~nlupdate.core.response.harmonic_balance.HarmonicSettings`) it is the first harmonic of
the multi-harmonic balance instead (a model without elements is linear: the continuation).
"""
from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Sequence

import numpy as np
import pandas as pd
import scipy.optimize
from numpy.typing import ArrayLike

from nlupdate.fe.adapters.base import ModalResult
from nlupdate.core.correlation.levels import correlate_levels
from nlupdate.core.measurement.frf_table import select_frf
from nlupdate.core.measurement.units import table_reference_unit
from nlupdate.core.model.system import NonlinearSystem
from nlupdate.core.response.harmonic_balance import HarmonicSettings
from nlupdate.core.model.linear import dof_index
from nlupdate.core.response.simulate import simulate_frf_table
from nlupdate.core.response.sweep import frequency_sweep

if TYPE_CHECKING:
    from nlupdate.core.identification.pipeline import Identification

LOSS_FACTOR_BOUNDS = (1e-4, 0.2)
#: how close (relative) a fitted η must be to a bound to count as on it: twice the search's
#: tolerance in log η (:func:`fit_loss_factor`'s ``xatol``)
_ON_BOUND = 2e-3


def loss_factor_bound(eta: float) -> str | None:
    """``"lower"`` or ``"upper"`` when the low-force fit's η ended on that end of its search
    (:data:`LOSS_FACTOR_BOUNDS`): no loss factor in the range reproduces the curve, so η is the
    search's, not the structure's; None inside."""
    for name, bound in zip(("lower", "upper"), LOSS_FACTOR_BOUNDS):
        if abs(np.log(eta / bound)) < _ON_BOUND:
            return name
    return None


def on_bound_note(eta: float) -> str:
    """The words a fitted η on a bound of its search carries ("" inside)."""
    bound = loss_factor_bound(eta)
    return "" if bound is None else (f", on the {bound} bound of its search ({LOSS_FACTOR_BOUNDS[0]:g}–"
                                     f"{LOSS_FACTOR_BOUNDS[1]:g}): no loss factor in that range reproduces it")


def updated_model(modes: ModalResult, elements: Sequence, loss_factor: float) -> NonlinearSystem:
    """Nonlinear system of the FE modes (at their coordinates, modal loss factor η) and the
    identified ``elements`` (whose ``dofs`` index those coordinates)."""
    return NonlinearSystem(modes.to_modal_model(loss_factors=float(loss_factor)), tuple(elements))


def predict(
    system: NonlinearSystem, input_dof: str, frequency_hz: ArrayLike, force_levels_n: Sequence[float], sweep: str = "up",
    harmonic_balance: HarmonicSettings | None = None,
) -> pd.DataFrame:
    """Predicted measured-FRF table (every coordinate of the model) at each force level,
    read as a stepped-sine test sweeping ``sweep``; by harmonic balance with these settings
    if ``harmonic_balance`` is given (see the module docstring)."""
    if harmonic_balance is None or not system.elements:
        table, _ = simulate_frf_table(system, input_dof, frequency_hz, force_levels_n, sweep=sweep)
    else:
        table, _ = simulate_frf_table(system, input_dof, frequency_hz, force_levels_n, sweep=sweep, method="hb",
                                      harmonic_balance=harmonic_balance)
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
    harmonic_balance: HarmonicSettings | None = None,
) -> float:
    """The modal loss factor η (all modes) that best reproduces one measured curve
    (``frequency_hz`` Hz, ``h_measured`` m/N at ``force_n`` N) with the solver of
    ``harmonic_balance`` (None: describing function); see the module docstring.

    The trial models of the search do not warn about harmonic truncation (a fixed number of
    harmonics is checked with the limit at 1); the prediction at the fitted η does."""
    f = np.asarray(frequency_hz, dtype=float)
    h = np.asarray(h_measured, dtype=complex)
    if harmonic_balance is None or not elements:
        misfit = _describing_function_misfit(modes, elements, response_dof, input_dof, f, h, force_n, sweep)
    else:
        misfit = _harmonic_balance_misfit(modes, elements, response_dof, input_dof, f, h, force_n, sweep,
                                          harmonic_balance)
    low, high = np.log(LOSS_FACTOR_BOUNDS)
    solution = scipy.optimize.minimize_scalar(misfit, bounds=(low, high), method="bounded", options={"xatol": 1e-3})
    return float(np.exp(solution.x))


def _describing_function_misfit(modes, elements, response_dof, input_dof, f, h, force_n, sweep):
    """Misfit of log η by the describing function. What does not change between the trials
    is set up once (coordinates, grid, measured points), and each trial's Newton starts from
    the previous trial's responses (:func:`~nlupdate.core.response.sweep.frequency_sweep`)."""
    grid = np.unique(f)
    if grid.size < 2 or grid[0] <= 0:
        raise ValueError("the frequency grid needs at least two frequencies, all > 0 Hz")
    omega = 2 * np.pi * grid
    probe = updated_model(modes, elements, LOSS_FACTOR_BOUNDS[0])
    response, forcing = dof_index(probe.model, response_dof), {dof_index(probe.model, input_dof): float(force_n)}
    measured = np.searchsorted(grid, f)
    previous: list = []

    def misfit(log_eta: float) -> float:
        system = updated_model(modes, elements, float(np.exp(log_eta)))
        start = previous[-1].x_nonlinear if previous and previous[-1].route == "fold-free" else None
        result = frequency_sweep(system, forcing, omega, sweep, start=start)
        previous[:] = [result]
        h_model = result.response([response])[:, 0] / float(force_n)
        valid = np.isfinite(h_model)[measured]
        if not valid.any():
            return np.inf
        return float(np.mean(np.abs(h_model[measured][valid] - h[valid]) ** 2 / np.abs(h[valid]) ** 2))

    return misfit


def _harmonic_balance_misfit(modes, elements, response_dof, input_dof, f, h, force_n, sweep, harmonic_balance):
    """Misfit of log η by the multi-harmonic balance (the trials do not warn about truncation:
    a fixed number of harmonics is checked with the limit at 1)."""
    trials = harmonic_balance
    if harmonic_balance.harmonics != "auto":
        trials = dataclasses.replace(harmonic_balance, share_limit=float(np.nextafter(1.0, 0.0)))

    def misfit(log_eta: float) -> float:
        system = updated_model(modes, elements, float(np.exp(log_eta)))
        predicted = predict(system, input_dof, f, [force_n], sweep, trials)
        f_model, h_model = select_frf(predicted, response_dof, input_dof, force_n)
        measured = np.isin(f, f_model)
        if not measured.any():
            return np.inf
        return float(np.mean(np.abs(h_model[np.isin(f_model, f)] - h[measured]) ** 2 / np.abs(h[measured]) ** 2))

    return misfit


@dataclasses.dataclass(frozen=True, eq=False)
class LevelPredictions:
    """The updated nonlinear model against one measured curve at every force level.

    loss_factor: the modal loss factor η used, and loss_factor_source: where it came from;
    table: the predicted measured-FRF table of that curve (receptance, m/N; the measured
    coordinate names); correlation: one row per force level
    (:func:`nlupdate.core.correlation.levels.correlate_levels`: FRAC, normalised FRF error,
    peak frequency error in %, peak amplitude ratio).
    """

    loss_factor: float
    loss_factor_source: str
    table: pd.DataFrame
    correlation: pd.DataFrame

    def __repr__(self) -> str:
        """One line: the levels and their FRAC (``summary()``: every metric per level)."""
        levels = " ".join(f"{v:g}" for v in self.correlation["force_level_n"])
        frac = " ".join(f"{v:.3f}" for v in self.correlation["frac"])
        return f"<LevelPredictions at {levels} N: FRAC {frac}; loss factor {self.loss_factor:.4g}>"

    def summary(self) -> str:
        """The loss factor and its source, then one line per force level: FRAC, normalised
        FRF error, peak frequency error (%) and peak amplitude ratio."""
        lines = [f"loss factor {self.loss_factor:.4g} ({self.loss_factor_source})"]
        for row in self.correlation.itertuples():
            lines.append(f"{row.force_level_n:>8g} N: FRAC {row.frac:.3f}, FRF error {row.normalised_error:.3g}, "
                         f"peak shift {row.peak_frequency_error_pct:+.2f} %, peak ratio {row.peak_amplitude_ratio:.3f}")
        return "\n".join(lines)


#: the loss-factor settings a prediction takes by name (else a number): fitted to the lowest level, or the
#: identification's extracted modes
LOSS_FACTOR_SOURCES = ("low_force_fit", "identified")


def model_dofs(response_dof: str, input_dof: str, model_response_dof: str | None = None,
               model_input_dof: str | None = None) -> tuple[str, str]:
    """The FE model's names of a measured curve's (response, input): as given, else the measured
    names — but a driving point renamed in the model (``model_response_dof`` alone) names its
    input too."""
    response, inp = str(response_dof), str(input_dof)
    model_response = response if model_response_dof is None else str(model_response_dof)
    if model_input_dof is None:
        model_input_dof = model_response if response == inp else inp
    return model_response, str(model_input_dof)


def chosen_loss_factor(setting: float | str, identification: Identification) -> float | str:
    """The ``loss_factor`` :func:`predict_measured` takes for a setting: ``"identified"``, the mean
    loss factor of ``identification``'s extracted linear modes; a number or ``"low_force_fit"`` as given."""
    return float(np.mean(identification.loss_factors)) if setting == "identified" else setting


def predict_measured(
    modes: ModalResult,
    elements: Sequence,
    measured: pd.DataFrame,
    response_dof: str,
    input_dof: str,
    *,
    model_response_dof: str | None = None,
    model_input_dof: str | None = None,
    loss_factor: float | str = "low_force_fit",
    force_levels_n: Sequence[float] | None = None,
    sweep: str = "up",
    harmonic_balance: HarmonicSettings | None = None,
) -> LevelPredictions:
    """Predict one measured curve (``response_dof`` / ``input_dof`` of ``measured``) at every
    force level (default: every level of that curve; N) and frequency (Hz) of the
    measurement with the FE ``modes`` and the identified ``elements`` (whose dofs index
    ``modes.coordinates``), then correlate it with the measurement level by level.

    ``model_response_dof``/``model_input_dof`` name the same coordinates in the model
    (default: the measured names). ``loss_factor``: a number (the modal η of every mode)
    or ``"low_force_fit"`` (:func:`fit_loss_factor` on the lowest level; see the module
    docstring). Solver: describing function, or harmonic balance with ``harmonic_balance``.
    """
    response, inp = str(response_dof), str(input_dof)
    model_response, model_input = model_dofs(response, inp, model_response_dof, model_input_dof)
    curve = measured[(measured["response_dof"].astype(str) == response) & (measured["input_dof"].astype(str) == inp)]
    levels = tuple(float(v) for v in (np.unique(curve["force_level_n"].to_numpy(dtype=float))
                                      if force_levels_n is None else force_levels_n))
    if loss_factor == "low_force_fit":
        level = min(levels)
        f_low, h_low = select_frf(measured, response, inp, level)
        eta = fit_loss_factor(modes, elements, model_response, model_input, f_low, h_low, level, sweep,
                              harmonic_balance)
        source = f"fitted to the {level:g} {table_reference_unit(measured)} measurement" + on_bound_note(eta)
    elif isinstance(loss_factor, str):
        raise ValueError(f"loss_factor must be a number or 'low_force_fit', got {loss_factor!r}")
    else:
        eta, source = float(loss_factor), "given"
    frequency = np.unique(measured["frequency_hz"].to_numpy(dtype=float))
    predicted = predict(updated_model(modes, elements, eta), model_input, frequency, levels, sweep, harmonic_balance)
    predicted = predicted[(predicted["response_dof"] == model_response) & (predicted["input_dof"] == model_input)]
    predicted = predicted.assign(response_dof=response, input_dof=inp).reset_index(drop=True)
    return LevelPredictions(eta, source, predicted, correlate_levels(measured, predicted, response, inp))
