"""Backbone samples from every measured line, not one per level (single-nonlinear-mode theory).

Near a well-separated resonance a force-controlled stepped-sine line at excitation Ω with
force F (the force achieved at that line) and receptance H at the driving point f obeys
(docs/methods.md §9, :mod:`nlupdate.core.model.single_mode`)

    (ω(a)² − Ω² + 2iζ(a)ω(a)²)·q = φ_f F,     X_f = φ_f q,     a = |q|,

after the other modes' share is removed from H. That share and the modal constant φ_f² are
found from every line of every level at once
(:func:`~nlupdate.core.identification.level_residual.frf_residual`, the amplitude models'
too: one owner), not from a linear one-mode fit of the lowest level, itself a nonlinear curve.
With ``D = φ_f²/H_mode`` each line gives one point of the backbone and of
the damping curve at its own amplitude:

    ω(a)² = Re D + Ω²,     ζ(a) = Im D / (2ω(a)²),     a = |H_mode|·F/|φ_f|

(:func:`~nlupdate.core.model.single_mode.natural_and_damping`: the damping hysteretic, a
friction joint's, whose dissipation per cycle does not depend on Ω; ζ is the viscous damping
ratio at resonance. A viscous share ζ_v of the damping, which the samples cannot tell apart,
reads as ζ + ζ_v(Ω − ω)/ω: on a flank at half the peak, Ω/ω ≈ 1 ± 1.7ζ, ζ off by ±1.7ζ_v of
itself, 0.85 % for ζ_v = 0.5 %.)

The peak alone gives one point per level; the lines around it give the curves over the
amplitudes each sweep passes through, so a few levels cover a decade of amplitude densely.
A line far from resonance carries little: D is large there and its noise (a fraction of
|D|) swamps ``Re D + Ω²``; only the lines where |H_mode| is at least :data:`PEAK_FRACTION`
of the level's peak are used (the half-power band and a little beyond). φ_f = √P, P the
modal constant of :func:`~nlupdate.core.identification.level_residual.frf_residual` (the
lowest level's one-mode fit, which the ``lines`` models took before, missed that curve by
15.9 % RMS on the Brake–Reuss beam and put φ_f² 2.4 % below P, the response-controlled runs'
own modal constants 1.04–1.13 × it; docs/validation.md, "Run 2's damping").

Response-controlled runs (``runs``: :class:`~nlupdate.core.identification.response_controlled.HeldRun`,
the same driving point) obey the same equation line by line with the force the controller
needed there, so their lines are samples of the same curves — at the run's held amplitude,
which a force-controlled sweep only passes through; a different test, added as evidence.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Sequence

import numpy as np
import scipy.optimize

from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.level_residual import LevelResidual, frf_residual
from nlupdate.core.identification.modal_samples import ModalSamples
from nlupdate.core.model.amplitude_modal import AmplitudeModelError
from nlupdate.core.model.single_mode import natural_and_damping

if TYPE_CHECKING:
    from nlupdate.core.identification.response_controlled import HeldRun

#: Lines whose modal |H| is below this fraction of their level's peak are left out.
PEAK_FRACTION = 0.5


def _curve_samples(f: np.ndarray, modal: np.ndarray, force: np.ndarray, phi: float) -> tuple[np.ndarray, ...]:
    """(a, natural frequency Hz, ζ, force, response amplitude) of the usable lines of one
    curve whose modal receptance is ``modal`` under ``force`` per line (module docstring)."""
    near = np.abs(modal) >= PEAK_FRACTION * np.max(np.abs(modal))
    w, zeta = natural_and_damping(phi**2 / modal[near], 2 * np.pi * f[near])
    good = np.isfinite(w)
    line_force = force[near]
    response = np.abs(modal[near]) * line_force
    return (response / phi)[good], (w / (2 * np.pi))[good], zeta[good], line_force[good], response[good]


def samples_from_lines(data: FRFLevels, share: LevelResidual | None = None, background: complex = 0.0,
                       runs: Sequence["HeldRun"] = ()) -> tuple[ModalSamples, LevelResidual]:
    """(one sample per usable line of every level and of every response-controlled run of
    ``runs``, the other modes' share and modal constant P they were read with: ``share``, by
    default :func:`~nlupdate.core.identification.level_residual.frf_residual` of ``data``)
    from driving-point FRFs (module docstring); ``background`` (m/N) is a constant receptance
    removed with the share (:func:`background_for_lines`)."""
    if data.response_dof != data.input_dof:
        raise AmplitudeModelError(f"FRFs of response {data.response_dof!r} / input {data.input_dof!r}: line samples "
                                  "need the driving-point FRF")
    share = share or frf_residual(data)[1]  # P > 0 at a driving point: frf_residual refuses another sign
    phi = float(np.sqrt(share.modal_constant))
    curves = [(f, h, data.force_at(float(level), f)) for level, f, h in
              zip(data.levels, data.frequencies, data.receptances)]
    for run in runs:
        if (run.response_dof, run.input_dof) != (data.response_dof, data.input_dof):
            raise AmplitudeModelError(f"response-controlled run {run.name}: at {run.response_dof}/{run.input_dof}, "
                                      f"not the driving point {data.input_dof} of the force-controlled curves")
        curves.append((run.frequency_hz, run.h, np.asarray(run.force_n, dtype=float)))
    parts = [_curve_samples(f, h - share.receptance(f) - background, force, phi) for f, h, force in curves]
    amplitude, frequency, damping, force, response = (np.concatenate(column) for column in zip(*parts))
    samples = ModalSamples(amplitude, frequency, damping, force, phi, response, shape_free=False)
    if samples.amplitude.size < 3 or not np.all(samples.damping_ratio > 0):
        bad = int(np.count_nonzero(samples.damping_ratio <= 0))
        raise AmplitudeModelError(f"{samples.amplitude.size} line samples, {bad} with zero or negative damping: "
                                  f"the curves do not show one resonance of the driving point")
    return samples, share


def background_for_lines(data: FRFLevels, order: int = 2, frequency_std: float = 2.5e-4,
                         damping_std: float = 0.05, runs: Sequence["HeldRun"] = ()) -> tuple[complex, LevelResidual]:
    """(the constant complex receptance B (m/N) beside the other modes' share of
    :func:`~nlupdate.core.identification.level_residual.frf_residual` that makes the line
    samples of every level one curve, that share).

    Single-mode theory gives every line the same ω(a), ζ(a) whichever flank of whichever
    level (or response-controlled run of ``runs``) it lies on; an error in the other modes'
    share shows as samples that disagree (the flanks of one level at equal amplitude). The
    share is found with each level on its own curves; B minimises the scatter of the samples
    about one set of polynomials of ``order`` in a/a_ref through every level (least squares
    of the relative misfits of the frequency over ``frequency_std`` and of the damping ratio
    over ``damping_std``), by Nelder–Mead from B = 0 in units of the share's size at the
    lowest level's peak."""
    share = frf_residual(data)[1]
    f_low, h_low = data.frequencies[0], data.receptances[0]
    peak = float(f_low[int(np.argmax(np.abs(h_low)))])
    unit = abs(complex(share.receptance(np.array([peak]))[0])) + 1e-3 * float(np.max(np.abs(h_low)))

    def scatter(x: np.ndarray) -> float:
        try:
            samples, _ = samples_from_lines(data, share, unit * complex(x[0], x[1]), runs)
        except AmplitudeModelError:
            return 1e12
        design = (samples.amplitude / samples.amplitude.max())[:, None] ** np.arange(order + 1)[None, :]
        total = 0.0
        for values, std in ((samples.frequency_hz, frequency_std), (samples.damping_ratio, damping_std)):
            misfit = values - design @ np.linalg.lstsq(design, values, rcond=None)[0]
            total += float(np.mean((misfit / (std * values)) ** 2))
        return total if np.isfinite(total) else 1e12

    best = scipy.optimize.minimize(scatter, np.zeros(2), method="Nelder-Mead",
                                   options={"xatol": 1e-4, "fatol": 1e-6, "maxiter": 600})
    x = best.x if best.fun < scatter(np.zeros(2)) else np.zeros(2)
    return unit * complex(x[0], x[1]), share
