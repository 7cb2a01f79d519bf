"""The other modes' share of a mode's stepped-sine FRFs, and its modal constant, from every
force level at once (single-nonlinear-mode theory).

A force-controlled stepped-sine curve near a well-separated resonance is the mode plus the
other modes' share: ``H = P/(ω(a)² − Ω² + 2iζ(a)ω(a)²) + R`` (P = φ_rφ_f, the modal
constant; the damping hysteretic, :mod:`nlupdate.core.model.single_mode`). The other modes
are far and linear, so R is the same at every level; the mode is not linear, and a linear
one-mode fit of one level — the lowest, as the peak samples took it before — takes part of
that curve's amplitude dependence for residual terms and modal constant. On a closed-form
single mode (no other mode at all) whose damping grows 1.5 × across three levels
(tests/test_achieved_force_modal_model.py) that fit put R at 2.9 % of the lowest peak, and
the peak samples read 2.8–4.9 % high in amplitude and 3.8–7.5 % low in damping; with R
constant (no residual mass) 2.8–4.7 % and 3.7–7.3 %; a linear fit of every level with one
shared R was worse still (4.0–6.9 %, 5.2–10.3 %: every level's curve is nonlinear).

What single-mode theory says instead: with the right R and P every line is a sample of the
mode's two curves, ``D = P/(H − R)``, ``ω(a)² = Re D + Ω²``, ``ζ(a) = Im D/(2ω²)`` at
``a ∝ |H − R|·F`` (F the force achieved at that line,
:func:`~nlupdate.core.model.single_mode.natural_and_damping`), and a level's two flanks pass
through the same amplitudes, so they must give the same ω(a) and ζ(a). A wrong P splits
them (``ω²`` reads ``cω² + (1 − c)Ω²`` for P off by c), a wrong R bends them apart, and by
as much at every level. :func:`level_residual` takes the R (one complex constant) and P that
make each level's samples — of its lines near the top, |H − R| at least
:data:`PEAK_FRACTION` of its peak, chosen with the start's R and kept while R and P move —
scatter least about that level's own polynomials of ``order`` in a/a_max (frequency misfits
over ``frequency_std``, damping over ``damping_std``, relative), summed over the levels. The
curves are each level's own because one polynomial through all levels cannot follow a
backbone over decades of amplitude: on the 2-DOF Iwan system of
tests/test_amplitude_limits.py (stuck to macroslip, 97.6 → 93.4 Hz) one such curve put R at
20 % of the lowest peak and P at 2.4 × the truth; per level, P = 0.253 between the stuck and
the slipped shapes' 0.248 and 0.276, R 0.7 % of the peak.

Measured (tests/test_achieved_force_modal_model.py): on the closed-form mode R is found 0
and P exact, the peak samples within 0.25 % in amplitude and 0.41 % in damping (the peak
reader's own error); with a linear mode at 100 Hz beside it (its share 11 % of the lowest
peak) within 0.02 % with φ_f given, and, read without a shape, φ_f 0.998 for 1, the samples
0.25 % high in amplitude and 0.61 % low in damping. On the Brake–Reuss beam (tests/data/brb)
P gives φ_f = 0.704 1/√kg, nearer the response-controlled runs' modal constants (0.727) than
the lowest level's one-mode fit (0.628 with R − R_m/Ω², 0.688 with R alone).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.optimize
from numpy.typing import NDArray

from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.modal_fit import fit_mode_near
from nlupdate.core.model.amplitude_modal import AmplitudeModelError
from nlupdate.core.model.single_mode import natural_and_damping

#: Lines whose modal |H| is below this fraction of their level's peak are left out (the
#: half-power band and a little beyond: far from resonance D is large and its noise swamps
#: ``Re D + Ω²``).
PEAK_FRACTION = 0.5


@dataclass(frozen=True)
class LevelResidual:
    """The other modes' share ``residual`` (complex, receptance units, the same at every
    level and line), the mode's real modal constant ``modal_constant`` P = φ_rφ_f
    (receptance × rad²/s²) and the weighted scatter (sum of squares) of the line samples
    about their polynomials at that R and P."""

    residual: complex
    modal_constant: float
    scatter: float


def polynomial_misfits(amplitude: NDArray, frequency: NDArray, damping: NDArray, order: int,
                       frequency_std: float, damping_std: float) -> NDArray[np.float64]:
    """Relative misfits of the samples' frequencies (over ``frequency_std``) then damping
    ratios (over ``damping_std``) about their least-squares polynomials of ``order`` in
    a/a_max (non-finite: 1e6)."""
    design = (amplitude / np.max(amplitude))[:, None] ** np.arange(order + 1)[None, :]
    out = []
    for values, std in ((frequency, frequency_std), (damping, damping_std)):
        out.append((values - design @ np.linalg.lstsq(design, values, rcond=None)[0]) / (std * values))
    misfit = np.concatenate(out)
    return np.where(np.isfinite(misfit), misfit, 1e6)


def level_residual(data: FRFLevels, modal_constant: float, start_residual: complex, centre_hz: float,
                   half_band: float, order: int = 2, frequency_std: float = 2.5e-4,
                   damping_std: float = 0.05) -> LevelResidual:
    """R and P of ``data``'s mode (module docstring) from the lines within ``centre_hz·(1 ±
    half_band)`` of every level, started from R = 0 and from ``start_residual`` (a one-mode
    fit's share at the centre), each with P = ``modal_constant`` (the sign of P is kept);
    the better end is taken."""
    curves = []
    for level, f, h in zip(data.levels, data.frequencies, data.receptances):
        band = np.abs(f - centre_hz) <= half_band * centre_hz
        curves.append((2 * np.pi * f[band], h[band], np.asarray(data.force_at(float(level), f[band]), dtype=float)))
    unit = 1e-2 * max(float(np.max(np.abs(h))) for _, h, _ in curves if h.size)

    def unpack(x: NDArray) -> tuple[complex, float]:
        return unit * complex(x[0], x[1]), modal_constant * float(np.exp(x[2]))

    def misfits(x: NDArray, masks: list[NDArray]) -> NDArray[np.float64]:
        residual, constant = unpack(x)
        out = []
        for (omega, h, force), near in zip(curves, masks):
            modal = h[near] - residual
            natural, zeta = natural_and_damping(constant / modal, omega[near])
            out.append(polynomial_misfits(np.abs(modal) * force[near], natural, zeta, order, frequency_std,
                                          damping_std))
        return np.concatenate(out)

    ends = []
    for start in (0j, complex(start_residual)):
        # the lines near each level's top with the start's R, kept while R and P move
        masks = [np.abs(h - start) >= PEAK_FRACTION * np.max(np.abs(h - start), initial=0.0) for _, h, _ in curves]
        x0 = np.array([start.real / unit, start.imag / unit, 0.0])
        fit = scipy.optimize.least_squares(misfits, x0, args=(masks,))
        ends.append((2 * float(fit.cost), fit.x))
    scatter, x = min(ends, key=lambda end: end[0])
    residual, constant = unpack(x)
    return LevelResidual(residual, constant, scatter)


def frf_residual(data: FRFLevels, near_hz: float | None = None, band_fraction: float = 0.1) -> tuple[float, LevelResidual]:
    """(the mode's centre (Hz), its other modes' share and modal constant from every level:
    :func:`level_residual`) for the mode near
    ``near_hz`` (default: the lowest level's peak), started from a one-mode fit of the
    lowest level over ``near_hz·(1 ± band_fraction)``, which also gives the centre."""
    f_low, h_low = data.frequencies[0], data.receptances[0]
    start = float(f_low[np.argmax(np.abs(h_low))]) if near_hz is None else float(near_hz)
    fit = fit_mode_near(f_low, h_low, start, band_fraction=band_fraction)
    centre = float(fit.natural_frequencies_hz[0])
    driving = data.response_dof == data.input_dof
    constant = complex(fit.modal_constants[0])
    if not (constant.real > 0 if driving else constant.real != 0):
        raise AmplitudeModelError(f"the one-mode fit of the {data.levels[0]:g} {data.reference_unit} FRF "
                                  f"({data.response_dof}/{data.input_dof}) gives a modal constant {constant:.4g}"
                                  + ("; give input_shape" if driving else ": no resonance of this mode to sample"))
    start_residual = complex(fit.residual_receptance(np.array([centre]))[0])
    return centre, level_residual(data, constant.real, start_residual, centre, 2.5 * band_fraction)
