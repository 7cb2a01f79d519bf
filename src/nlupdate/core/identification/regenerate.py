"""Nonlinear FRFs regenerated from an extracted linear FRF and an identified nonlinearity.

Single nonlinear coordinate (driving point): at every frequency of the extracted linear
receptance ``H^L(ω)`` the scalar balance ``(1/H^L + ν(A, ω))·X = F`` is solved for all
its amplitude roots (:func:`nlupdate.core.identification.scalar_balance.all_amplitudes`), and read
as a stepped-sine test by the response package's rule for roots found per frequency
(:func:`nlupdate.core.response.steady_state.sweep_stable_roots`: the sweep stays on the stable root
nearest in log A to the previous frequency's, and jumps to the nearest remaining stable root when
its branch ends at a fold). This works directly on noisy samples (no interpolation; a continuation
over the interpolated samples stalls at the spurious folds noise makes).

Several nonlinear coordinates: :class:`SampledReceptance` turns a sampled receptance
matrix (e.g. an extracted ``H^L_aa``) into a linear model for the project's solvers
(:mod:`nlupdate.core.response.fixed_point`, :mod:`nlupdate.core.response.continuation`), by cubic-spline
interpolation in ω of every entry.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np
import scipy.interpolate
from numpy.typing import ArrayLike, NDArray

from nlupdate.fingerprints import fingerprint
from nlupdate.core.identification.scalar_balance import all_amplitudes
from nlupdate.core.response.steady_state import sweep_stable_roots


def regenerate_frf(
    frequency_hz: ArrayLike,
    h_linear: ArrayLike,
    nu: Callable[[NDArray, NDArray], NDArray],
    force: float,
    direction: str = "up",
    amplitude_span: tuple[float, float] = (1e-6, 1e3),
    grid_points: int = 800,
) -> NDArray[np.complex128]:
    """Nonlinear receptance X/F (m/N) at ``force`` (N) on the grid of ``h_linear``.

    ``nu(A, ω)`` is the describing function (N/m) of the amplitude A (m) and ω (rad/s).
    Roots are searched for ``A`` in ``amplitude_span × F·|H^L(ω)|``. Frequencies with no
    stable root are NaN.
    """
    if direction not in ("up", "down"):
        raise ValueError(f"direction must be 'up' or 'down', got {direction!r}")
    f = np.asarray(frequency_hz, dtype=float)
    h = np.asarray(h_linear, dtype=complex)
    if f.shape != h.shape or f.ndim != 1:
        raise ValueError(f"frequency ({f.shape}) and linear receptance ({h.shape}) must be 1-D of equal length")
    if not np.isfinite(force) or force <= 0:
        raise ValueError(f"force must be a positive amplitude in N, got {force}")
    omega = 2 * np.pi * f
    w = 1.0 / h
    linear_amplitude = float(force) * np.abs(h)
    roots = all_amplitudes(
        w, nu, float(force), omega, amplitude_span[0] * linear_amplitude, amplitude_span[1] * linear_amplitude,
        grid_points=grid_points,
    )
    amplitude = sweep_stable_roots(roots, direction)
    out = np.full(f.size, np.nan + 0j)
    read = np.flatnonzero(np.isfinite(amplitude))
    out[read] = 1.0 / (w[read] + nu(amplitude[read], omega[read]))
    return out


@dataclass(frozen=True, eq=False)
class SampledReceptance:
    """A linear model given by receptance samples ``h[k, i, j]`` at ``frequency_hz[k]``.

    Implements the :class:`nlupdate.core.model.linear.LinearModel` protocol by cubic-spline
    interpolation in ω (rad/s) of each entry (real and imaginary parts); asking outside
    the sampled band raises ValueError.
    """

    frequency_hz: NDArray[np.float64]
    h: NDArray[np.complex128]
    dof_names: tuple[str, ...] = field(default=())
    _spline: object = field(init=False, repr=False)

    def __post_init__(self) -> None:
        f = np.asarray(self.frequency_hz, dtype=float)
        h = np.asarray(self.h, dtype=complex)
        if h.ndim == 1:
            h = h[:, None, None]
        if h.ndim != 3 or h.shape[0] != f.size or h.shape[1] != h.shape[2]:
            raise ValueError(f"receptance samples must have shape (n_freq, n, n), got {h.shape} for {f.size} frequencies")
        if f.size < 4 or np.any(np.diff(f) <= 0) or not np.all(np.isfinite(h)):
            raise ValueError("need at least 4 strictly increasing frequencies and finite receptances")
        names = tuple(self.dof_names) or tuple(str(i) for i in range(h.shape[1]))
        object.__setattr__(self, "frequency_hz", f)
        object.__setattr__(self, "h", h)
        object.__setattr__(self, "dof_names", names)
        object.__setattr__(self, "_spline", scipy.interpolate.CubicSpline(2 * np.pi * f, h, axis=0))

    @property
    def n_dof(self) -> int:
        return self.h.shape[1]

    def fingerprint(self) -> str:
        return fingerprint("sampled", self.frequency_hz, self.h, length=16)

    def receptance(
        self, omega: ArrayLike, rows: Sequence[int], cols: Sequence[int], derivative: bool = False
    ):
        w = np.atleast_1d(np.asarray(omega, dtype=float))
        low, high = 2 * np.pi * self.frequency_hz[0], 2 * np.pi * self.frequency_hz[-1]
        if np.any(w < low * (1 - 1e-12)) or np.any(w > high * (1 + 1e-12)):
            raise ValueError(
                f"SampledReceptance: frequency outside the sampled band {self.frequency_hz[0]:g}–"
                f"{self.frequency_hz[-1]:g} Hz"
            )
        rows, cols = list(rows), list(cols)
        values = self._spline(w)[:, rows][:, :, cols]
        if not derivative:
            return values
        return values, self._spline(w, 1)[:, rows][:, :, cols]
