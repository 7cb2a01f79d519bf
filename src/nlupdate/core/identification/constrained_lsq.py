"""Linear least squares under linear inequality constraints, scaled to order one (the
polynomial backbone's fit: :mod:`nlupdate.core.identification.amplitude_modal_fit`)."""
from __future__ import annotations

import numpy as np
import scipy.optimize
from numpy.typing import NDArray


def constrained_lsq(design: NDArray, target: NDArray, weights: NDArray, constraints: NDArray,
                    bounds: NDArray) -> NDArray:
    """Coefficients c minimising ``Σ (w (design·c − target))²`` subject to
    ``constraints·c ≥ bounds``: SLSQP on the problem scaled to order one (the unconstrained
    solution's magnitudes, the misfit relative to the weighted target, the constraints in
    units of the largest target)."""
    matrix, rhs = design * weights[:, None], target * weights
    start = np.linalg.lstsq(matrix, rhs, rcond=None)[0]
    if np.all(constraints @ start >= bounds):
        return start
    unit = float(np.max(np.abs(target)))
    scale = np.maximum(np.abs(start), 1e-6 * unit)
    m, norm = matrix * scale[None, :], float(rhs @ rhs)
    g, h = constraints * scale[None, :] / unit, bounds / unit
    solution = scipy.optimize.minimize(
        lambda u: float(np.sum((m @ u - rhs) ** 2)) / norm, start / scale,
        jac=lambda u: 2 * (m.T @ (m @ u - rhs)) / norm, method="SLSQP",
        constraints=[{"type": "ineq", "fun": lambda u: g @ u - h, "jac": lambda u: g}],
        options={"maxiter": 1000, "ftol": 1e-15})
    return solution.x * scale
