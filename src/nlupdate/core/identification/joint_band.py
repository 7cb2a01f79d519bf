"""95 % bands of a modal-joint backbone (``iwan``/``jenkins``) from its fit's linearised covariance.

The residual bootstrap of :mod:`~nlupdate.core.identification.backbone_samples` (each
sample's misfit drawn onto the fitted curve and the samples refitted) is narrow where the
information is missing: six phase-resonance points leave 12 misfits for 4 unknowns, their
spread understates the noise by √(8/12), and no draw of them moves the stick–slip kink
further than the six points' own misfits do, while the damping just above the slip
amplitude a_s changes 12.7 × faster than a_s (docs/ring-down.md, "Honest bands at the
kink"). Here the band is that of the estimator itself:

* the weighted residual r(θ) the fit minimised (samples over their stated noise, or the
  stepped sine's lines by output error with the other sources' samples:
  :func:`~nlupdate.core.identification.line_refine.refinement_residual`) is differentiated
  at the fitted unknowns θ̂ (log ω₀, log ζ₀, logit(K_T/ω₀²), log F_S; χ and β too for Iwan)
  by central differences, J;
* the covariance is ``s²(JᵀJ)⁻¹`` with ``s² = Σr²/ν``, ν = m − p degrees of freedom (the
  residual's own scale: the stated noise need not be right);
* errors in the variables: a phase-resonance point's modal amplitude is its measured
  response over φ, as noisy as its damping ratio (:data:`~nlupdate.core.identification.sample_residuals.NOISY_AMPLITUDE_SHARE`), and the
  residual here takes it as exact (the line refinement does; a sample fit that fits the true
  amplitudes, :mod:`~nlupdate.core.identification.sample_residuals`, is banded by its own
  residual instead, those amplitudes nuisance unknowns: :func:`noisy_fit_residual`, its
  phase-resonance band holding the truth at 88 % of the kink band's amplitudes and 96.5 % over
  the range, tests/test_joint_band.py). A relative amplitude error δ moves the point's misfits by
  ``δ·(∂ln ω/∂ln a, ∂ln ζ/∂ln a)`` — next to the kink ∂ln ζ/∂ln a reaches ~13, so the point
  that places a_s carries several times its stated damping noise. That adds
  ``Jᵀ_s Σ_a J_s`` to the covariance's middle (the sandwich ``(JᵀJ)⁻¹(JᵀJ + Jᵀ_s Σ_a J_s)(JᵀJ)⁻¹``,
  scaled by s²; slopes as secants over ln a ± σ_a on the fitted curves). Without it the
  linearised band held the truth at 54 % of the kink band's amplitudes for six
  phase-resonance points (SDOF, 8 seeds), the fitted a_s's stated deviation 0.3–0.8 % against
  errors of 0.6–2.6 %;

* θ is drawn from the multivariate Student t of ν degrees of freedom about θ̂ (s² is itself
  estimated from ν values), each draw's curves ω(a), ζ(a) are evaluated, and the band is
  their 2.5–97.5 % points at each amplitude, widened to hold the fitted curve.

A draw of log F_S and logit(K_T/ω₀²) moves a_s = F_S/K_T, so the kink moves with it: the
band holds the damping of every slip amplitude the data allow, not only of the fitted one.

The linear-damping law (viscous or structural) is a choice, not an unknown, in this band.
With ``law_free`` the unknowns carry the law's viscous share w too, ζ_lin =
ζ₀[(1 − w)ω₀²/ω² + wω₀/ω] (w = 1 viscous, 0 structural: :data:`VISCOUS_SHARE`), the residual
that of :func:`mixed_law_residual` (the fit's residual at each law, mixed linearly in w) and
each draw's damping the same mixture of the two laws' curves: the line refinement's band
(:mod:`~nlupdate.core.identification.line_band`, which adds the leave-one-level-out spread).

What it does not hold: a bias of the estimator that no noise explains (the line
refinement's: docs/ring-down.md, "Honest bands at the kink").
"""
from __future__ import annotations

from dataclasses import replace
from typing import Callable

import numpy as np
import scipy.optimize
import scipy.special
from numpy.typing import NDArray

from nlupdate.core.identification.iwan_backbone_fit import (
    JENKINS_BETA, JENKINS_CHI, iwan_model, iwan_models_exist, iwan_parameters,
)
from nlupdate.core.identification.modal_samples import ModalSamples
from nlupdate.core.identification.sample_residuals import noisy_residual, sample_residual
from nlupdate.core.model.amplitude_modal import AmplitudeModalModel, AmplitudeModelError, joint_omega_zeta
from nlupdate.core.model.elements.iwan import iwan_describing_function

#: parameter draws per band
DRAWS = 4000
#: central-difference step in the unknowns (logs and logits)
_STEP = 1e-4
#: draws whose curves are evaluated together (a few MB per array for a few hundred amplitudes)
_CHUNK = 500
#: the viscous share w of the rest of the structure's damping at each linear-damping law
#: (the band's mixed law: ζ_lin = ζ₀[(1 − w)ω₀²/ω² + w ω₀/ω], module docstring)
VISCOUS_SHARE = {"viscous": 1.0, "structural": 0.0}


def joint_fixed(model: AmplitudeModalModel) -> dict[str, float]:
    """The parameters a ``jenkins`` backbone holds fixed (β, χ); none for an Iwan one."""
    if model.joint is None:
        raise AmplitudeModelError("a covariance band needs a modal joint (the jenkins or iwan backbone)")
    return {"beta": JENKINS_BETA, "chi": JENKINS_CHI} if model.joint.beta >= JENKINS_BETA * (1 - 1e-9) else {}


def joint_unknowns(model: AmplitudeModalModel) -> NDArray:
    """The unknowns of :func:`~nlupdate.core.identification.iwan_backbone_fit.iwan_model` for
    ``model``: log ω₀, log ζ₀, logit(K_T/ω₀²), log F_S (and logit(−χ), log β unless Jenkins)."""
    joint, w0 = model.joint, 2 * np.pi * model.natural_frequency_hz
    theta = [np.log(w0), np.log(model.damping_ratio), scipy.special.logit(joint.kt / w0**2), np.log(joint.slip_force)]
    if not joint_fixed(model):
        theta += [scipy.special.logit(-joint.chi), np.log(joint.beta)]
    return np.array(theta)


def model_from_unknowns(model: AmplitudeModalModel) -> Callable[[NDArray], AmplitudeModalModel]:
    """θ → the model of those unknowns, with ``model``'s shapes, mode and linear-damping law."""
    fixed = joint_fixed(model)
    return lambda theta: iwan_model(theta, model.shapes, fixed, model.mode, model.linear_damping)


def sample_fit_residual(model: AmplitudeModalModel, samples: ModalSamples, frequency_std: float | NDArray,
                        damping_std: float | NDArray) -> Callable[[NDArray], NDArray]:
    """θ → the weighted misfits the sample fit minimised
    (:func:`~nlupdate.core.identification.sample_residuals.sample_residual`)."""
    unpack = model_from_unknowns(model)
    return lambda theta: sample_residual(unpack(theta).omega_zeta, samples, frequency_std, damping_std)


def noisy_fit_residual(model: AmplitudeModalModel, samples: ModalSamples, frequency_std: NDArray,
                       damping_std: NDArray, amplitude_std: NDArray) -> tuple[Callable[[NDArray], NDArray], NDArray]:
    """(θ and the noisy samples' log true amplitudes → the weighted misfits the errors-in-variables
    sample fit minimised (:func:`~nlupdate.core.identification.sample_residuals.noisy_residual`),
    those log true amplitudes at ``model``'s θ: the fit's nuisance unknowns for
    :func:`covariance_band`). The standard deviations are the fit's own, per sample (the locked
    frequencies' of :func:`~nlupdate.core.identification.sample_residuals.sample_noise`)."""
    unpack, p = model_from_unknowns(model), joint_unknowns(model).size
    n = samples.amplitude.size
    stds = [np.broadcast_to(np.asarray(v, float), (n,)) for v in (frequency_std, damping_std, amplitude_std)]
    noisy = stds[2] > 0

    def residual(unknowns: NDArray) -> NDArray:
        return noisy_residual(unpack(unknowns[:p]).omega_zeta, samples.amplitude, samples.frequency_hz,
                              samples.damping_ratio, unknowns[p:], noisy, *stds)

    theta = joint_unknowns(model)
    start = np.log(samples.amplitude[noisy])
    with np.errstate(all="ignore"):
        true = scipy.optimize.least_squares(lambda u: residual(np.concatenate([theta, u])), start).x
    return residual, true


def mixed_law_residual(model: AmplitudeModalModel,
                       residual_at: Callable[[AmplitudeModalModel], Callable[[NDArray], NDArray]]
                       ) -> Callable[[NDArray], NDArray]:
    """(θ, w) → the weighted residual of ``model``'s fit at the mixed linear-damping law of
    viscous share w (module docstring), from ``residual_at``: a model → θ → the fit's residual
    at that model's law. Linear in w: ``r_s(θ) + w (r_v(θ) − r_s(θ))``."""
    structural = residual_at(replace(model, linear_damping="structural"))
    viscous = residual_at(replace(model, linear_damping="viscous"))

    def residual(unknowns: NDArray) -> NDArray:
        r_s = structural(unknowns[:-1])
        return r_s + unknowns[-1] * (viscous(unknowns[:-1]) - r_s)

    return residual


def _draw_curves(model: AmplitudeModalModel, unknowns: NDArray, amplitude: NDArray,
                 law_free: bool) -> tuple[NDArray, NDArray]:
    """ω (rad/s) and ζ at ``amplitude`` of the models of many ``unknowns`` at once (rows: θ, then
    with ``law_free`` the viscous share w: ζ the mixture of the two laws' curves, module
    docstring), all rows evaluated together
    (:func:`~nlupdate.core.model.elements.iwan.iwan_describing_function`); NaN rows where the
    unknowns make no model (:func:`~nlupdate.core.identification.iwan_backbone_fit.iwan_models_exist`)."""
    theta = unknowns[:, :-1] if law_free else unknowns
    with np.errstate(all="ignore"):
        w0, z0, kt, slip, chi, beta = iwan_parameters(theta, joint_fixed(model))
        exist = iwan_models_exist(w0, z0, kt, slip, beta)
        omega0 = 2 * np.pi * (w0 / (2 * np.pi))  # ω₀ as a model reads it back from its f₀
        column = [np.asarray(v)[:, None] if np.ndim(v) else v for v in (omega0, z0, kt, slip, chi, beta)]
        omega0, z0, kt, slip, chi, beta = column
        nu = iwan_describing_function(amplitude[None, :], kt, slip, chi, beta)
        if law_free:
            omega, z_s = joint_omega_zeta(omega0, z0, kt, nu, "structural")
            zeta = z_s + unknowns[:, -1:] * (joint_omega_zeta(omega0, z0, kt, nu, "viscous")[1] - z_s)
        else:
            omega, zeta = joint_omega_zeta(omega0, z0, kt, nu, model.linear_damping)
    return np.where(exist[:, None], omega, np.nan), np.where(exist[:, None], zeta, np.nan)


def _eiv_meat(model: AmplitudeModalModel, samples: ModalSamples, frequency_std: NDArray, damping_std: NDArray,
              amplitude_std: NDArray) -> NDArray:
    """The covariance, in the fit's weighted units, that noise in the samples' amplitudes adds
    to their (frequency, damping) misfits: per sample ``σ_a² s sᵀ`` with s the secant slopes
    of ln ω and ln ζ over ln a ± σ_a on the fitted curves, over the fit's standard deviations
    (frequencies first, then damping ratios, as the residual orders them)."""
    n = samples.amplitude.size
    sigma = np.maximum(np.broadcast_to(np.asarray(amplitude_std, float), (n,)), 1e-12)
    up, down = samples.amplitude * np.exp(sigma), samples.amplitude * np.exp(-sigma)
    (w_up, z_up), (w_down, z_down) = model.omega_zeta(up), model.omega_zeta(down)
    slope_f = np.log(w_up / w_down) / (2 * sigma) / np.broadcast_to(np.asarray(frequency_std, float), (n,))
    slope_z = np.log(z_up / z_down) / (2 * sigma) / np.broadcast_to(np.asarray(damping_std, float), (n,))
    meat = np.zeros((2 * n, 2 * n))
    index = np.arange(n)
    for rows, a_slope in ((index, slope_f), (index + n, slope_z)):
        for cols, b_slope in ((index, slope_f), (index + n, slope_z)):
            meat[rows, cols] = sigma**2 * a_slope * b_slope
    return meat


def covariance_band(model: AmplitudeModalModel, residual: Callable[[NDArray], NDArray], amplitude: NDArray,
                    draws: int = DRAWS, seed: int = 0,
                    noisy_amplitudes: tuple[ModalSamples, NDArray, NDArray, NDArray] | None = None,
                    law_free: bool = False, nuisance: NDArray | None = None) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """(frequency low, high (Hz), damping low, high) of ``model`` at ``amplitude`` (module
    docstring); ``residual``: θ → the weighted residual the fit minimised. ``noisy_amplitudes``:
    (samples, their frequency and damping standard deviations in the fit, their amplitudes'
    relative standard deviations) of the samples whose misfits end the residual, when their
    amplitudes are measured with noise (module docstring: errors in the variables). NaN where
    the covariance cannot be formed (no degrees of freedom, a singular Jacobian). ``law_free``:
    ``residual`` takes the viscous share w after θ (:func:`mixed_law_residual`) and the band
    holds the linear-damping law's uncertainty (module docstring). ``nuisance``: more unknowns
    ``residual`` takes after θ, at their fitted values (the errors-in-variables fit's log true
    amplitudes, :func:`noisy_fit_residual`): in the Jacobian and the degrees of freedom, not drawn
    (θ's covariance is its block of the whole)."""
    amplitude = np.asarray(amplitude, dtype=float)
    theta = joint_unknowns(model)
    if law_free:
        theta = np.append(theta, VISCOUS_SHARE[model.linear_damping])
    p = theta.size
    if nuisance is not None and noisy_amplitudes is not None:  # the amplitude rows would not end the residual
        raise ValueError("covariance_band: give the noisy amplitudes either as nuisance unknowns or as "
                         "noisy_amplitudes, not both")
    extra = np.zeros(0) if nuisance is None else np.asarray(nuisance, float)
    full = np.concatenate([theta, extra])
    r0 = residual(full)
    q, m = full.size, r0.size
    nan = np.full(amplitude.size, np.nan)
    if m <= q:
        return nan, nan, nan, nan
    jac = np.empty((m, q))
    for j in range(q):
        step = np.zeros(q)
        step[j] = _STEP
        jac[:, j] = (residual(full + step) - residual(full - step)) / (2 * _STEP)
    dof = m - q
    meat = jac.T @ jac
    if noisy_amplitudes is not None:
        tail = jac[m - 2 * noisy_amplitudes[0].amplitude.size:]
        meat = meat + tail.T @ _eiv_meat(model, *noisy_amplitudes) @ tail
    meat = float(r0 @ r0) / dof * meat
    try:
        bread = np.linalg.pinv(jac.T @ jac)
        cov = (bread @ meat @ bread)[:p, :p]
        root = np.linalg.cholesky(cov + 1e-12 * np.eye(p) * np.max(np.abs(np.diag(cov))))
    except np.linalg.LinAlgError:
        return nan, nan, nan, nan
    rng = np.random.default_rng(seed)
    shifts = (rng.standard_normal((draws, p)) @ root.T) / np.sqrt(rng.chisquare(dof, (draws, 1)) / dof)
    f, z = np.empty((draws, amplitude.size)), np.empty((draws, amplitude.size))
    for start in range(0, draws, _CHUNK):  # the draws' curves together, a chunk at a time
        w, z[start:start + _CHUNK] = _draw_curves(model, theta + shifts[start:start + _CHUNK], amplitude, law_free)
        f[start:start + _CHUNK] = w / (2 * np.pi)
    f_fit, z_fit = model.frequency_hz(amplitude), model.damping(amplitude)
    f_low, f_high = np.nanpercentile(f, [2.5, 97.5], axis=0)
    z_low, z_high = np.nanpercentile(z, [2.5, 97.5], axis=0)
    return np.minimum(f_low, f_fit), np.maximum(f_high, f_fit), np.minimum(z_low, z_fit), np.maximum(z_high, z_fit)
