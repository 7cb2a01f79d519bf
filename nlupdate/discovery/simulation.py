"""The model's response at the measured points (force level, frequency), as a test would see it.

Per force level the nonlinear frequency response is traced by continuation over the measured
band — describing function by default, or multi-harmonic balance with given
:class:`~nlupdate.response.harmonic_balance.HarmonicSettings` (its first harmonic) — and
read as a stepped-sine sweep (:mod:`nlupdate.response.stepped_sine`); a model without
nonlinear elements is evaluated directly, ``X = H(ω)·F``. Points that no stable branch
reaches are NaN. Any failure is a :class:`ModelSolveError` naming the force level.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np
from numpy.typing import NDArray

from nlupdate.discovery.errors import ModelSolveError
from nlupdate.model.system import NonlinearSystem
from nlupdate.response.continuation import ContinuationError, trace_frequency_response
from nlupdate.response.harmonic_balance import HarmonicSettings, trace_harmonic_balance
from nlupdate.response.stepped_sine import stepped_sine

_BAND_MARGIN = 0.005


def simulate_points(
    system: NonlinearSystem,
    input_dof: int,
    force: NDArray[np.float64],
    omega: NDArray[np.float64],
    dofs: Sequence[int],
    sweep: str = "up",
    harmonic_balance: HarmonicSettings | None = None,
) -> NDArray[np.complex128]:
    """Complex amplitudes (m) at ``dofs`` for a harmonic force ``force`` (N) at ``input_dof``
    and frequency ``omega`` (rad/s) per point; shape (n_points, len(dofs)). With
    ``harmonic_balance`` the first harmonic of the multi-harmonic balance, else the
    describing function's."""
    dofs = list(dofs)
    out = np.full((force.size, len(dofs)), np.nan + 0j)
    for level in np.unique(force):
        points = np.flatnonzero(force == level)
        points = points[np.argsort(omega[points], kind="stable")]
        w = omega[points]
        band = f"{w.min() / (2 * np.pi):g}–{w.max() / (2 * np.pi):g} Hz"
        try:
            with np.errstate(all="ignore"):
                if not system.elements:
                    x = system.model.receptance(w, dofs, [input_dof])[:, :, 0] * level
                else:
                    band_rad = (w.min() * (1 - _BAND_MARGIN), w.max() * (1 + _BAND_MARGIN))
                    if harmonic_balance is None:
                        curve = trace_frequency_response(system, {input_dof: level}, *band_rad)
                    else:
                        settings = harmonic_balance
                        curve = trace_harmonic_balance(
                            system, {input_dof: level}, *band_rad, harmonics=settings.harmonics,
                            samples=settings.samples, stability=settings.stability, share_limit=settings.share_limit,
                        )
                    x = stepped_sine(curve, w, sweep).response(dofs)
        except (ContinuationError, np.linalg.LinAlgError, ValueError, ArithmeticError) as error:
            raise ModelSolveError(f"the model cannot be solved at {level:g} N, {band} ({error})") from None
        if not np.any(np.isfinite(x)):
            raise ModelSolveError(f"the model has no finite response at {level:g} N, {band} (singular or unstable)")
        out[points] = x
    return out
