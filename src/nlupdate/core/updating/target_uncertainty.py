"""Uncertainty of updated parameters from the uncertainty of their targets.

The targets of a study are natural frequencies extracted from measurements (by the PRD
identification: their standard deviations come from its Monte Carlo). An updating run
ends at parameters p* that minimise ``Σ_i w_i (f_i(p)/f_t,i − 1)²`` (plus mode-shape
terms); linearised about p*, a change δf_t of the targets moves the solution by

    δp = (Sᵀ W S)⁺ S_fᵀ W_f (δf_t / f_t),

with S the Jacobian of the response vector (``f/f_t`` per parameter unit, then mode-shape
terms; :attr:`UpdatingResult.sensitivity`) and W the residual weights. For independent
targets of standard deviation σ_i the parameter covariance is ``G diag(σ²/f_t²) Gᵀ``.
The pseudo-inverse keeps an under-determined set (more parameters than targets)
finite: its minimum-norm answer is then a lower bound, and is flagged. A parameter that
ends on a bound is flagged too: the linearisation does not see the bound.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from nlupdate.core.updating.eigensensitivity import UpdatingResult


@dataclass(frozen=True)
class ParameterUncertainty:
    """Standard deviation of each updated parameter (parameter units), and caveats."""

    std: dict[str, float]
    at_bound: tuple[str, ...]
    underdetermined: bool
    note: str


def propagate_target_uncertainty(
    result: UpdatingResult, target_std_hz: ArrayLike, lower: dict[str, float], upper: dict[str, float]
) -> ParameterUncertainty:
    """Parameter standard deviations of ``result`` for target standard deviations (Hz).

    ``lower``/``upper`` are the parameter bounds, to flag parameters that ended on one
    (within 1e-6 of the bound width).
    """
    sigma = np.atleast_1d(np.asarray(target_std_hz, dtype=float))
    targets = result.targets
    if sigma.shape != (targets.n_modes,) or np.any(~np.isfinite(sigma)) or np.any(sigma < 0):
        raise ValueError(f"target standard deviations must be {targets.n_modes} numbers ≥ 0 (Hz), got {sigma.tolist()}")
    names = list(result.parameters)
    if result.sensitivity is None:
        return ParameterUncertainty({n: float("nan") for n in names}, (), False,
                                    "no sensitivity: the start point already met the targets")
    # in parameters scaled by their values, so that the pseudo-inverse's cut-off compares
    # like with like (Pa and mm differ by 1e14)
    scale = np.array([abs(v) if v != 0 else upper[n] - lower[n] for n, v in result.parameters.items()])
    s = np.asarray(result.sensitivity, dtype=float) * scale[None, :]
    n_f = targets.n_modes
    root_w = np.sqrt(targets.weights)
    row_weights = np.concatenate([root_w, np.ones(s.shape[0] - n_f)])  # shape rows: weights do not matter here
    a = s * row_weights[:, None]
    normal_inverse = np.linalg.pinv(a.T @ a)
    gain = scale[:, None] * (normal_inverse @ (s[:n_f] * targets.weights[:, None]).T)  # δp per unit δf_t/f_t
    covariance = gain @ np.diag((sigma / targets.frequencies_hz) ** 2) @ gain.T
    underdetermined = np.linalg.matrix_rank(a) < len(names)
    at_bound = tuple(
        n for n in names
        if min(abs(result.parameters[n] - lower[n]), abs(upper[n] - result.parameters[n])) <= 1e-6 * (upper[n] - lower[n])
    )
    notes = []
    if underdetermined:
        notes.append("more parameters than independent targets: minimum-norm (lower-bound) spread")
    if at_bound:
        notes.append(f"{', '.join(at_bound)} ended on a bound: the linearised spread ignores the bound")
    std = {n: float(np.sqrt(max(covariance[j, j], 0.0))) for j, n in enumerate(names)}
    return ParameterUncertainty(std, at_bound, bool(underdetermined), "; ".join(notes))
