"""Where the disagreement sits: the place (coordinate or pair) and the mode band.

Place. For one extra element at place u (relative coordinate ``x_u = x_r − x_j``, or
``x_r`` to ground) the responses at the measured coordinates m are exactly
``X_m = H_mf F − H_mu g`` at every point, with g the element's first-harmonic force and H
the receptances of the model (docs/methods.md §3, receptance form). Fitting one free complex g per
point by least squares (weights ``1/|X̃_m|``, the noise model) tells

* ``explained`` — the fraction of the current model's misfit that *any* element at u removes
  (the element replaces what was found at u before, so this is what u explains beyond what
  the current model already explains): the right place explains all of it up to noise, a
  wrong one leaves the part it cannot reach;
* the apparent describing function ``ν̃ = g / X̃_u`` against the measured amplitude
  ``|X̃_u|`` — the generalisation of PRD's ``1/H_measured − 1/H_model`` (docs/methods.md §4) to any
  place; a linear model error gives a ν̃ that does not change with the force level, a
  missing nonlinearity one that does (``force_dependence``).

Band. Each measured point belongs to the nearest natural frequency of the model; the
share of the misfit per mode says which mode carries the disagreement.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.discovery.effects import DFSamples


@dataclass(frozen=True)
class Localisation:
    """How well one place explains the disagreement (see module docstring).

    explained: fraction of the misfit a free element force at the place removes;
    amplitude_by_level: median measured amplitude of the place's (relative) displacement
    per force level (m); df_by_level: weighted mean apparent DF per level (N/m);
    force_dependence: ``|ν̄_highest − ν̄_lowest| / max|ν̄|`` over the two extreme levels.
    """

    dofs: tuple[int, ...]
    explained: float
    amplitude_by_level: tuple[float, ...]
    df_by_level: tuple[complex, ...]
    force_dependence: float

    def to_dict(self) -> dict:
        return {
            "dofs": list(self.dofs),
            "explained": self.explained,
            "amplitude_by_level_m": list(self.amplitude_by_level),
            "describing_function_by_level": [{"real": v.real, "imag": v.imag} for v in self.df_by_level],
            "force_dependence": self.force_dependence,
        }


def free_element_force(
    h_mf: NDArray, h_mu: NDArray, x_measured: NDArray, force: NDArray, scale: NDArray | float = 1.0,
    current_misfit: float | None = None,
) -> tuple[NDArray[np.complex128], float]:
    """Per-point LS element force g (N) and the fraction of the misfit it explains.

    ``h_mf`` (n, m) and ``h_mu`` (n, m) are receptances (m/N) from the force and from the
    place to the measured coordinates, ``x_measured`` (n, m) the measured amplitudes (m);
    residuals are ``scale·(X − X̃)/|X̃|`` (``scale`` = 1/noise std per value, so their sum of
    squares is χ²). The fraction is of ``current_misfit`` when given (the χ² of the current
    model: what the place explains beyond what is already explained), else of the misfit
    of the background alone; it is clipped to [0, 1].
    """
    weight = scale / np.abs(x_measured)
    a = h_mu * weight
    b = (h_mf * force[:, None] - x_measured) * weight
    g = np.sum(np.conj(a) * b, axis=1) / np.sum(np.abs(a) ** 2, axis=1)  # b ≈ a·g
    before = float(np.sum(np.abs(b) ** 2)) if current_misfit is None else float(current_misfit)
    after = float(np.sum(np.abs(b - a * g[:, None]) ** 2))
    return g, float(np.clip(1.0 - after / before, 0.0, 1.0)) if before > 0 else 0.0


def summarise(
    dofs: tuple[int, ...], explained: float, level_index: NDArray[np.int64], samples: DFSamples
) -> Localisation:
    """Per-level amplitude and apparent-DF summary of one place."""
    levels = np.unique(level_index)
    weight = 1.0 / samples.std**2
    amplitude = tuple(float(np.median(samples.amplitude[level_index == k])) for k in levels)
    df = tuple(
        complex(np.sum(weight[level_index == k] * samples.nu[level_index == k]) / np.sum(weight[level_index == k]))
        for k in levels
    )
    scale = max(abs(df[0]), abs(df[-1]), 1e-300)
    return Localisation(dofs, float(explained), amplitude, df, float(abs(df[-1] - df[0]) / scale))


def band_shares(omega: NDArray, misfit: NDArray, natural_omega: NDArray) -> list[tuple[float, float]]:
    """``(mode frequency in Hz, share of the misfit)`` for the modes nearest the points."""
    natural = np.sort(np.asarray(natural_omega, dtype=float))
    natural = natural[(natural > omega.min() / 2) & (natural < omega.max() * 2)]
    if natural.size == 0:
        return []
    nearest = np.argmin(np.abs(omega[:, None] - natural[None, :]), axis=1)
    total = float(np.sum(misfit)) or 1.0
    return [
        (float(natural[k] / (2 * np.pi)), float(np.sum(misfit[nearest == k]) / total))
        for k in range(natural.size) if np.any(nearest == k)
    ]
