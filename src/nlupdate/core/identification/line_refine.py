"""A modal joint backbone refined on every line of a force-controlled stepped sine (output error).

One sample per level (the peak, :func:`~nlupdate.core.identification.modal_samples.samples_from_frfs`)
sees a Jenkins joint's stick–slip kink only where a level happens to peak, and its damping
just above the slip amplitude a_s changes 12.7 × faster than a_s (docs/ring-down.md, "Near
the stick–slip kink"): six levels at 2 % noise placed a_s within about ±3 %, the damping up
to 21 % off next to it. Every line of a curve whose peak lies above a_s passes through the
kink on its flanks, so the lines see it densely. Each line at excitation Ω (rad/s) with force
F (N) and modal receptance H (the driving point's, the other modes' share removed by the
lowest level's one-mode fit with its residual mass, :func:`_lowest_level_residual`)
obeys single-nonlinear-mode theory at its modal amplitude a = |H|F/φ_f::

    D = φ_f²/H = ω(a)² − Ω² + i(c(Ω) + Im ν(a)),    c = 2ζ₀ω₀Ω (viscous) or 2ζ₀ω₀² (structural),

ν the modal joint's describing function: the joint's dissipation does not scale with Ω. That
is the model's own dynamic stiffness (:meth:`~nlupdate.core.model.amplitude_modal.AmplitudeModalModel.dynamic_stiffness`,
:mod:`nlupdate.core.model.single_mode`: hysteretic but for the viscous share ζ₀ω₀/ω(a)).
(Written all as 2ζ(a)ω(a)Ω, viscous — as the model's forced response was before — a flank at
half the peak, Ω/ω ≈ 1 ± 1.7ζ, reads the joint's damping ±2 % off, above the peak low and
below it high; fitted in that form, the refinement put a_s +0.4 % high on noise-free curves of
the Jenkins SDOF and its damping next to a_s 5 % off.)

Per-line samples (a_i, ω_i, ζ_i) fitted as points would put the noise of H into a as well
as into ω and ζ — errors in the variables, which next to the kink bias a_s (+0.5 % on average
over 8 seeds of the Jenkins SDOF at 2 % noise, ζ up to 10 % off next to a_s). The refinement
is instead an output-error fit: for trial joint parameters each line's amplitude solves
``a·|D(a, Ω)| = φ_f F`` (Newton in ln a from the measured amplitude: the branch the line was
measured on), and the misfit is ``(D_measured − D(a))/|D_measured|`` (real and imaginary
parts), the relative noise of H. Lines where |H| is at least
:data:`~nlupdate.core.identification.line_samples.PEAK_FRACTION` of their level's peak are
used. Other sources' samples (ring-down, phase resonance, impact) join the same least
squares with their own relative standard deviations; the lines' noise is their rms misfit
after a first pass. The linear-damping law (viscous or structural, c above) is chosen on the
lines: the fit is made at each and the smaller residual kept. The sample fit that starts it
picks the law from six peaks, by noise: on the 2-DOF Jenkins system it picked the structural
law on 3 of 8 seeds (the truth is viscous), and the refinement, keeping it, was 0.9–1 % off in
damping away from the kink; the lines pick the viscous law on 7 of 8 (docs/ring-down.md,
"Honest bands at the kink"; the band holds the law's uncertainty:
:mod:`~nlupdate.core.identification.line_band`).

Measured on the Jenkins systems of ``benchmarks/test_type_truth.py`` (six levels, 301 lines,
2 % noise, 8 seeds; docs/ring-down.md, "The kink from the stepped sine's lines"): the
stepped sine's own fit places a_s within +0.003 … +0.16 % (SDOF) and −0.14 … +0.27 % (2-DOF), against −0.06 …
+2.5 % and −1.3 … +2.0 % from the peaks, and its damping within 1.2 % and 1.0 % of the truth
over 0.5–15 a_s, the kink included (the peaks: 19 % and 7.1 %; tests/test_stepped_sine_truth.py).
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Callable

import numpy as np
import scipy.optimize
from numpy.typing import NDArray

from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.joint_band import joint_unknowns, model_from_unknowns
from nlupdate.core.identification.line_samples import PEAK_FRACTION
from nlupdate.core.identification.modal_fit import ModalFit, fit_mode_over_band
from nlupdate.core.identification.modal_samples import ModalSamples
from nlupdate.core.identification.sample_residuals import sample_residual
from nlupdate.core.model.amplitude_modal import LINEAR_DAMPING, AmplitudeModalModel, AmplitudeModelError

#: Newton steps in ln a per line (each at most :data:`_STEP` in ln a)
_NEWTON = 30
_STEP = 0.1
#: the lines' relative noise assumed for the first pass (its scale only weighs them against
#: other sources; the second pass takes their rms misfit)
_FIRST_NOISE = 0.02


@dataclass(frozen=True, eq=False)
class SteppedSineLines:
    """The usable lines of a driving-point stepped sine: ``omega`` (rad/s), ``force`` (N, the
    force achieved at the line), ``receptance`` (complex m/N, the mode's share: the other modes'
    residual terms removed), the shape φ_f (1/√kg) at the driving point and each line's
    ``level`` (its index in the stepped sine's levels; None: not known)."""

    omega: NDArray[np.float64]
    force: NDArray[np.float64]
    receptance: NDArray[np.complex128]
    input_shape: float
    level: NDArray[np.int_] | None = None

    @property
    def amplitude(self) -> NDArray[np.float64]:
        """Each line's modal amplitude a = |H|F/|φ_f| (m·√kg)."""
        return np.abs(self.receptance) * self.force / abs(self.input_shape)


def _lowest_level_residual(data: FRFLevels) -> ModalFit:
    """The one-mode fit of the lowest level over its whole band with R and R_m/ω², whose
    residual terms alone the refinement takes (φ_f is given to it). The ``lines`` models and
    the amplitude samples take the other modes' share from every level at once instead
    (:func:`~nlupdate.core.identification.level_residual.frf_residual`); here the residual
    mass is kept because the refinement's band held the truth with it: with a constant alone
    the 2-DOF's seed 3 (tests/test_line_band.py, a true second mode above) held it at 71 % of
    the amplitudes off the kink instead of 100 % (measured)."""
    return fit_mode_over_band(data.frequencies[0], data.receptances[0], lower_residual=True)


def stepped_sine_lines(data: FRFLevels, input_shape: float) -> SteppedSineLines:
    """The lines of every level of driving-point FRFs ``data`` within
    :data:`~nlupdate.core.identification.line_samples.PEAK_FRACTION` of their level's peak,
    with the shape φ_f given (1/√kg)."""
    if data.response_dof != data.input_dof:
        raise AmplitudeModelError(f"FRFs of response {data.response_dof!r} / input {data.input_dof!r}: the line "
                                  "refinement needs the driving-point FRF")
    if not (np.isfinite(input_shape) and input_shape != 0):
        raise AmplitudeModelError(f"input_shape: the mass-normalised shape at {data.input_dof} (1/√kg, ≠ 0), "
                                  f"got {input_shape}")
    fit = _lowest_level_residual(data)  # its residual only: φ_f is given
    omega, force, receptance, index = [], [], [], []
    for k, (level, f, h) in enumerate(zip(data.levels, data.frequencies, data.receptances)):
        modal = h - fit.residual_receptance(f)
        near = np.abs(modal) >= PEAK_FRACTION * np.max(np.abs(modal))
        omega.append(2 * np.pi * f[near])
        force.append(np.asarray(data.force_at(float(level), f), dtype=float)[near])
        receptance.append(modal[near])
        index.append(np.full(int(near.sum()), k))
    return SteppedSineLines(np.concatenate(omega), np.concatenate(force), np.concatenate(receptance),
                            abs(float(input_shape)), np.concatenate(index))


def line_amplitudes(model: AmplitudeModalModel, lines: SteppedSineLines) -> NDArray[np.float64]:
    """The amplitude each line holds on ``model``: ``a·|D(a, Ω)| = φ_f F`` solved by Newton in
    ln a from the measured amplitude (module docstring)."""
    target = np.log(lines.input_shape * lines.force)
    log_a = np.log(lines.amplitude)
    step = 1e-5

    def g(x):
        return x + np.log(np.abs(model.dynamic_stiffness(np.exp(x), lines.omega)))

    for _ in range(_NEWTON):
        value = g(log_a) - target
        slope = (g(log_a + step) - g(log_a - step)) / (2 * step)
        slope = np.where(np.abs(slope) < 0.05, np.copysign(0.05, slope), slope)  # near a fold
        change = np.clip(-value / slope, -_STEP, _STEP)
        log_a = log_a + change
        if np.all(np.abs(change) < 1e-10):
            break
    return np.exp(log_a)


def line_misfit(model: AmplitudeModalModel, lines: SteppedSineLines) -> NDArray[np.float64]:
    """Relative misfits ``(D_measured − D(a))/|D_measured|`` of every line, real parts then
    imaginary parts (module docstring)."""
    measured = lines.input_shape**2 / lines.receptance
    r = (measured - model.dynamic_stiffness(line_amplitudes(model, lines), lines.omega)) / np.abs(measured)
    return np.concatenate([r.real, r.imag])


def refinement_residual(model: AmplitudeModalModel, lines: SteppedSineLines, others: ModalSamples | None = None,
                        frequency_std: float | NDArray = 1e-3,
                        damping_std: float | NDArray = 0.05) -> Callable[[NDArray, float], NDArray]:
    """(θ, the lines' relative noise) → the weighted residual :func:`refine_on_lines` minimises
    (θ: :func:`~nlupdate.core.identification.joint_band.joint_unknowns`; the lines' misfits over
    their noise, then ``others``' samples over their standard deviations; 1e6 where a trial
    model cannot be formed)."""
    if model.joint is None:
        raise AmplitudeModelError("the line refinement fits a modal joint (the jenkins or iwan backbone)")
    unpack = model_from_unknowns(model)

    def residual(theta: NDArray, noise: float) -> NDArray:
        with np.errstate(all="ignore"):
            try:
                trial = unpack(theta)
            except (ValueError, OverflowError):
                trial = None
            size = 2 * lines.omega.size + (0 if others is None else 2 * others.amplitude.size)
            if trial is None:
                return np.full(size, 1e6)
            parts = [line_misfit(trial, lines) / (noise / np.sqrt(2))]
            if others is not None:
                parts.append(sample_residual(trial.omega_zeta, others, frequency_std, damping_std))
            out = np.concatenate(parts)
        return np.where(np.isfinite(out), out, 1e6)

    return residual


def refine_on_lines(model: AmplitudeModalModel, lines: SteppedSineLines, others: ModalSamples | None = None,
                    frequency_std: float | NDArray = 1e-3,
                    damping_std: float | NDArray = 0.05) -> tuple[AmplitudeModalModel, float]:
    """(``model`` — a modal Jenkins or Iwan backbone — refitted to the stepped sine's ``lines``
    by output error, with ``others`` (samples of other sources, their relative standard
    deviations ``frequency_std``, ``damping_std``) in the same least squares; the lines'
    relative noise, their rms misfit). Module docstring: the linear-damping law is the one of
    the smaller residual (the lines weighed at the smaller of the two laws' noises); the mode
    shapes are kept (``model`` is the start: the sample fit)."""
    if model.joint is None:
        raise AmplitudeModelError("the line refinement fits a modal joint (the jenkins or iwan backbone)")
    if abs(abs(model.shape(0)) / lines.input_shape - 1) > 1e-9:
        raise AmplitudeModelError(f"the model's shape at its first coordinate, {abs(model.shape(0)):.6g} 1/√kg, is not "
                                  f"the lines' φ_f = {lines.input_shape:.6g}: their amplitudes have no common scale")
    fits = [refine_at_law(replace(model, linear_damping=law), lines, others, frequency_std, damping_std)
            for law in LINEAR_DAMPING]
    common = min(noise for _, noise in fits)
    costs = [float(np.sum(refinement_residual(refined, lines, others, frequency_std, damping_std)(
        joint_unknowns(refined), common)**2)) for refined, _ in fits]
    refined, noise = fits[int(np.argmin(costs))]
    note = (f"{model.note}; refined on {lines.omega.size} stepped-sine lines by output error (each line's amplitude "
            f"solved on the model, the joint's dissipation hysteretic; {refined.linear_damping} linear damping, the "
            f"lines' choice: residual " + ", ".join(f"{law} {c:.4g}" for law, c in zip(LINEAR_DAMPING, costs))
            + f"; lines' rms misfit {noise:.2g})")
    return replace(model, natural_frequency_hz=refined.natural_frequency_hz, damping_ratio=refined.damping_ratio,
                   joint=refined.joint, linear_damping=refined.linear_damping, note=note), noise


def refine_at_law(model: AmplitudeModalModel, lines: SteppedSineLines, others: ModalSamples | None = None,
                  frequency_std: float | NDArray = 1e-3, damping_std: float | NDArray = 0.05,
                  ) -> tuple[AmplitudeModalModel, float]:
    """(``model`` refined on ``lines`` with ``others`` as :func:`refine_on_lines` does, but at
    ``model``'s own linear-damping law; the lines' relative noise, their rms misfit)."""
    residual = refinement_residual(model, lines, others, frequency_std, damping_std)
    unpack = model_from_unknowns(model)
    theta, noise = joint_unknowns(model), _FIRST_NOISE
    for _ in range(2 if others is not None else 1):
        solution = scipy.optimize.least_squares(residual, theta, args=(noise,), x_scale="jac", method="lm")
        theta = solution.x
        misfit = line_misfit(unpack(theta), lines)
        noise = float(np.sqrt(2 * np.sum(misfit**2) / max(misfit.size - theta.size, 1)))
    return unpack(theta), noise
