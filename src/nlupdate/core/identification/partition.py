"""The `aa`-partition form (docs/methods.md §4) for an element between two measured coordinates.

When the measured data hold both coordinates of the nonlinearity — an element between p
and q, the structure driven at q (a shaker at one end of the joint), the responses at p
and q measured — the balance of the first harmonic, ``X = H^L (F e_q − (e_p − e_q) ν u)``
with ``u = X_p − X_q``, reads at each level j and line (receptances H_rj = X_r/F_j)

    H_pj = a_p − b_p g_j,        H_qj = a_q − (a_p − a_q) g_j,       g_j = ν(|u_j|) (H_pj − H_qj),

with a_p = H^L_pq, a_q = H^L_qq, b_p = H^L_pp − H^L_pq (reciprocity: H^L_qp = a_p). At
a given ν these are linear in (a_p, a_q, b_p), two equations per level, so every line
with two or more levels gives the `aa` block of the linear receptance the structure is
driven through, and the residual says how well ν explains every level at once.
:func:`identify_between` fits the element parameters by minimising that residual over
every line (variable projection: the linear unknowns are solved for at each trial ν),
each equation weighted by its noise (relative noise: 1/|H_rj|).

A single input column cannot separate ν from the linear receptance across the element
in general (ν·b is what the data show); with the drive at one end of the element the
reciprocity above ties b_q to a and the scale is fixed. Other drive points are refused.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.optimize
from numpy.typing import NDArray

from nlupdate.core.identification.data import FRFLevels, match_frequencies
from nlupdate.core.identification.dfmodels import PhysicalModel
from nlupdate.core.identification.linear_frf import locate_linear_modes


@dataclass(frozen=True, eq=False)
class PartitionFit:
    """The element between p and q and the linear receptances it leaves (SI, Hz).

    model, p: the fitted physical model and its vector; frequency_hz: the lines;
    h_pq, h_qq: the extracted linear receptances H^L_pq, H^L_qq (m/N; NaN where fewer than
    two levels); residual_noise_fraction: the relative noise level (std/|H|) the weighted
    residuals imply, corrected for the unknowns — about the measurement's noise fraction
    when the model describes the data.
    """

    model: PhysicalModel
    p: NDArray[np.float64]
    frequency_hz: NDArray[np.float64]
    h_pq: NDArray[np.complex128]
    h_qq: NDArray[np.complex128]
    residual_noise_fraction: float

    def parameters(self) -> dict[str, float]:
        return self.model.parameters(self.p)


def _stacked(at_p: FRFLevels, at_q: FRFLevels) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """(lines Hz, H_p and H_q (levels, lines), forces (levels, lines)) on the q curve's
    lowest-level grid; NaN where a level lacks a line."""
    f = at_q.frequencies[0]
    shape = (at_q.levels.size, f.size)
    h_p, h_q, force = np.full(shape, np.nan + 0j), np.full(shape, np.nan + 0j), np.full(shape, np.nan)
    for j, level in enumerate(at_q.levels):
        for out, data in ((h_p, at_p), (h_q, at_q)):
            f_level, h = data.curve(float(level))
            at = match_frequencies(f_level, f)
            out[j, at >= 0] = h[at[at >= 0]]
        f_level = at_q.curve(float(level))[0]
        at = match_frequencies(f_level, f)
        force[j, at >= 0] = at_q.force_at(float(level), f_level)[at[at >= 0]]
    return f, h_p, h_q, force


def _solve(h_p: NDArray, h_q: NDArray, g: NDArray) -> tuple[NDArray, NDArray]:
    """Per line the weighted least-squares (a_p, a_q, b_p) and the weighted residuals
    (2·levels, lines)."""
    n_levels, n_lines = h_p.shape
    zero, one = np.zeros_like(g), np.ones_like(g)
    rows = np.concatenate([np.stack([one, zero, -g], axis=-1), np.stack([-g, 1 + g, zero], axis=-1)])
    rhs = np.concatenate([h_p, h_q])
    weight = 1.0 / np.abs(rhs)
    good = np.isfinite(rhs) & np.isfinite(weight) & np.all(np.isfinite(rows), axis=-1)
    weight = np.where(good, weight, 0.0)
    a = np.where(good[..., None], rows, 0.0) * weight[..., None]
    b = np.where(good, rhs, 0.0) * weight
    solution = np.full((n_lines, 3), np.nan + 0j)
    residual = np.zeros((2 * n_levels, n_lines))
    for line in range(n_lines):
        if np.sum(good[:n_levels, line] & good[n_levels:, line]) < 2:
            continue
        z, *_ = np.linalg.lstsq(a[:, line, :], b[:, line], rcond=None)
        solution[line] = z
        residual[:, line] = np.abs(a[:, line, :] @ z - b[:, line])
    return solution, residual


def identify_between(at_p: FRFLevels, at_q: FRFLevels, model: PhysicalModel) -> PartitionFit:
    """Fit ``model`` (an element between coordinates p and q) to the receptances of p
    (``at_p``) and q (``at_q``), both driven at q, at the same force levels (module
    docstring)."""
    if at_q.response_dof != at_q.input_dof or at_p.input_dof != at_q.input_dof:
        raise ValueError(f"the aa-partition form needs the drive at one end of the element: responses "
                         f"{at_p.response_dof!r} and {at_q.response_dof!r}, input {at_q.input_dof!r}")
    if not np.array_equal(at_p.levels, at_q.levels) or at_q.levels.size < 2:
        raise ValueError(f"the aa-partition form needs the same two or more levels at {at_p.response_dof!r} and "
                         f"{at_q.response_dof!r}, got {list(at_p.levels)} and {list(at_q.levels)}")
    f, h_p, h_q, force = _stacked(at_p, at_q)
    omega = 2 * np.pi * f[None, :]
    d = h_p - h_q
    amplitude = np.abs(d) * force

    def g_of(p: NDArray) -> NDArray:
        return model.nu(p, amplitude, omega) * d

    def residual(p: NDArray) -> NDArray:
        with np.errstate(all="ignore"):
            r = _solve(h_p, h_q, g_of(p))[1].ravel()
        return np.where(np.isfinite(r), r, 1e6)

    # starts: the ν each level implies at the line where the low level peaks, as the
    # PRD points of a driving-point element (g_j ≈ (H_q1 − H_qj)/(H_p1 − H_q1))
    line = int(np.nanargmax(np.abs(h_q[0])))
    implied_g = (h_q[0, line] - h_q[1:, line]) / (h_p[0, line] - h_q[0, line])
    implied_nu = implied_g / d[1:, line]
    starts = model.initial_guesses(amplitude[1:, line], implied_nu, float(amplitude[0, line]),
                                   float(omega[0, line]))
    best = min((scipy.optimize.least_squares(residual, start, x_scale=1.0) for start in starts),
               key=lambda fit: fit.cost)
    solution, r = _solve(h_p, h_q, g_of(best.x))
    used = int(np.sum(r != 0))
    ratio = float(np.sqrt(np.sum(r**2) / max(used - 3 * np.sum(np.isfinite(solution[:, 0])) - best.x.size, 1)))
    return PartitionFit(model, best.x, f, solution[:, 0], solution[:, 1], ratio)


@dataclass(frozen=True, eq=False)
class Placement:
    """The element placed between ``other_dof`` and the driven coordinate: its fit and the
    natural frequencies (Hz) of the driving-point linear receptance it leaves."""

    other_dof: str
    fit: PartitionFit
    modes_hz: tuple[float, ...]

    def as_dict(self, driven_dof: str, noise_fraction: float) -> dict:
        residual = self.fit.residual_noise_fraction
        return {"dofs": [self.other_dof, driven_dof], "parameters": self.fit.parameters(),
                "residual_noise_fraction": residual,
                "ratio_to_noise": residual / noise_fraction if noise_fraction > 0 else None,
                "linear_modes_hz": list(self.modes_hz)}


def placements(at_q: FRFLevels, others: dict[str, FRFLevels], model: PhysicalModel,
               modes_near_hz: tuple[float, ...] | None = None, band_fraction: float = 0.1) -> list[Placement]:
    """The element between each other measured coordinate and the driven one (``at_q``: the
    driving-point curves), best explained first (smallest residual). A coordinate whose fit
    fails (too few common lines or levels) is left out."""
    out = []
    for dof, at_p in others.items():
        try:
            with np.errstate(all="ignore"):
                fit = identify_between(at_p, at_q, model)
                finite = np.isfinite(fit.h_qq)
                modes = locate_linear_modes(fit.frequency_hz[finite], fit.h_qq[finite], np.abs(1 / fit.h_qq[finite]),
                                            modes_near_hz, band_fraction)
        except (ValueError, np.linalg.LinAlgError):
            continue
        out.append(Placement(str(dof), fit, tuple(float(m.natural_frequencies_hz[0]) for m in modes)))
    return sorted(out, key=lambda placement: placement.fit.residual_noise_fraction)
