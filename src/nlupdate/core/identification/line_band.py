"""The 95 % band of a modal joint backbone refined on a stepped sine's lines (``jenkins``/``iwan``).

The line refinement (:mod:`~nlupdate.core.identification.line_refine`) fits the lines at
their noise (rms misfit 2.01–2.05 % against 2 % noise on the Jenkins systems of
``benchmarks/test_type_truth.py``), so its linearised covariance
(:func:`~nlupdate.core.identification.joint_band.covariance_band`) is right about the noise;
it held the damping truth away from the stick–slip kink at only 35–50 % of the amplitudes
of the 2-DOF system (8 seeds; docs/ring-down.md, "Honest bands at the kink") for two things
it takes as known:

* **the linear-damping law.** The lines tell the viscous law (c = 2ζ₀ω₀Ω) from the
  structural one (2ζ₀ω₀²) by only 5–40 in χ² on the 2-DOF system; the band treated the law
  chosen as exact. Here the band's unknowns carry the law's **viscous share** w as well
  (:func:`~nlupdate.core.identification.joint_band.mixed_law_residual`: ζ_lin =
  ζ₀[(1 − w)ω₀²/ω² + wω₀/ω], w = 1 viscous, 0 structural; the lines' misfit is linear in w
  to within the square of a 10⁻⁴ change of the dynamic stiffness), so the covariance holds
  how far the lines leave the law open. Fitted freely, w lies at 0.37–0.98 over those seeds.
* **that one model fits every level.** What the single-mode model leaves out (the
  single-nonlinear-mode approximation of a system whose mode shape changes as the joint
  slips: noise-free, the 2-DOF's refinement is 0.3 % off in damping where the truth is stuck)
  is below the lines' noise line by line, but shows as the levels pulling the fit apart.
  The **leave-one-out spread**: the fit refitted with each stepped-sine level's lines left
  out in turn, then each other source's samples (``others_source``), its jackknife standard
  deviation ``σ_J² = (g−1)/g·Σ(c₍ⱼ₎ − c̄)²`` over the g refits times Student's t for g − 1
  degrees of freedom; the band is the larger of that and the covariance band at each
  amplitude (the jackknife estimates the whole scatter of the estimate, the noise's share
  included: added in quadrature it would count the noise twice).

Measured (``python benchmarks/kink_band_coverage.py``, seeds 0–15; docs/ring-down.md, "The
line refinement's law and band"), coverage of the damping truth off the kink, before (the
sample fit's law, the covariance band) → now: 2-DOF own refinement 49.3 → 88.4 %, joint fit
40.0 → 81.2 %; SDOF 87.9 → 99.1 % and 85.8 → 96.1 %.
"""
from __future__ import annotations

import numpy as np
import scipy.optimize
import scipy.stats
from numpy.typing import NDArray

from nlupdate.core.identification.modal_samples import ModalSamples
from nlupdate.core.identification.joint_band import (
    DRAWS, covariance_band, joint_unknowns, mixed_law_residual, model_from_unknowns,
)
from nlupdate.core.identification.line_refine import SteppedSineLines, refinement_residual
from nlupdate.core.model.amplitude_modal import AmplitudeModalModel


def leave_one_out(model: AmplitudeModalModel, lines: SteppedSineLines, noise: float, amplitude: NDArray,
                  others: ModalSamples | None = None, frequency_std: float | NDArray = 1e-3,
                  damping_std: float | NDArray = 0.05, others_source: NDArray | None = None
                  ) -> tuple[NDArray, NDArray]:
    """(natural frequencies (Hz), damping ratios) at ``amplitude`` of ``model`` — the line
    refinement of ``lines`` with ``others`` — refitted with each stepped-sine level's lines
    left out in turn, then each other source's samples (``others_source``: a label per sample
    of ``others``); one row per refit, at ``model``'s law, the lines at the full fit's relative
    ``noise``, each refit started from its unknowns. No rows when the lines' levels are not
    known."""
    amplitude = np.asarray(amplitude, dtype=float)
    if lines.level is None:
        return np.empty((0, amplitude.size)), np.empty((0, amplitude.size))
    n_others = 0 if others is None else others.amplitude.size
    source = np.zeros(n_others, int) if others_source is None else np.asarray(others_source)
    f_std, z_std = (np.broadcast_to(np.asarray(v, float), (n_others,)) for v in (frequency_std, damping_std))
    units = [(lines.level != level, np.ones(n_others, bool)) for level in np.unique(lines.level)]
    units += [(np.ones(lines.omega.size, bool), source != label) for label in np.unique(source)]
    unpack, theta = model_from_unknowns(model), joint_unknowns(model)
    f, z = [], []
    for kept, kept_others in units:
        subset = SteppedSineLines(lines.omega[kept], lines.force[kept], lines.receptance[kept], lines.input_shape,
                                  lines.level[kept])
        rest = None if others is None or not kept_others.any() else ModalSamples(
            others.amplitude[kept_others], others.frequency_hz[kept_others], others.damping_ratio[kept_others],
            others.force_n[kept_others], others.input_shape)
        residual = refinement_residual(model, subset, rest, f_std[kept_others], z_std[kept_others])
        refit = unpack(scipy.optimize.least_squares(residual, theta, args=(noise,), x_scale="jac", method="lm").x)
        w, zeta = refit.omega_zeta(amplitude)
        f.append(w / (2 * np.pi))
        z.append(zeta)
    return np.array(f), np.array(z)


def jackknife_halfwidth(refits: NDArray) -> NDArray:
    """Student's t (g − 1 degrees of freedom, 97.5 %) times the jackknife standard deviation of
    g leave-one-out ``refits`` (one row each); zeros below three refits."""
    g = refits.shape[0]
    if g < 3:
        return np.zeros(refits.shape[1:])
    return scipy.stats.t.ppf(0.975, g - 1) * np.sqrt((g - 1) / g * np.sum((refits - refits.mean(0))**2, axis=0))


def line_refinement_band(model: AmplitudeModalModel, lines: SteppedSineLines, noise: float, amplitude: NDArray,
                         others: ModalSamples | None = None, frequency_std: float | NDArray = 1e-3,
                         damping_std: float | NDArray = 0.05, others_source: NDArray | None = None,
                         noisy_amplitudes: tuple[ModalSamples, NDArray, NDArray, NDArray] | None = None,
                         seed: int = 0, draws: int = DRAWS) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """(frequency low, high (Hz), damping low, high) of the line refinement ``model`` of
    ``lines`` (their relative ``noise``) with ``others`` at ``amplitude`` (module docstring):
    the covariance band with the law's viscous share among the unknowns, widened at each
    amplitude to the leave-one-out spread where that is wider. ``noisy_amplitudes``: as
    :func:`~nlupdate.core.identification.joint_band.covariance_band` (the others' samples), as
    ``seed`` and ``draws``."""
    amplitude = np.asarray(amplitude, dtype=float)
    residual = mixed_law_residual(model, lambda law_model: _at_noise(
        refinement_residual(law_model, lines, others, frequency_std, damping_std), noise))
    f_low, f_high, z_low, z_high = covariance_band(model, residual, amplitude, draws, seed,
                                                   noisy_amplitudes=noisy_amplitudes, law_free=True)
    f_refits, z_refits = leave_one_out(model, lines, noise, amplitude, others, frequency_std, damping_std,
                                       others_source)
    w, zeta = model.omega_zeta(amplitude)
    f_spread, z_spread = jackknife_halfwidth(f_refits), jackknife_halfwidth(z_refits)
    f = w / (2 * np.pi)
    return (np.minimum(f_low, f - f_spread), np.maximum(f_high, f + f_spread),
            np.minimum(z_low, zeta - z_spread), np.maximum(z_high, zeta + z_spread))


def _at_noise(residual, noise: float):
    """θ → ``residual(θ, noise)``."""
    return lambda theta: residual(theta, noise)
