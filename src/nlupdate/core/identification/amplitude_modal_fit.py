"""Identify an amplitude-dependent modal model (:mod:`nlupdate.core.model.amplitude_modal`) of one mode
from samples of its backbone and damping curve (:mod:`~nlupdate.core.identification.modal_samples`:
from a modal table or from FRFs at several levels).

The backbone is fitted by weighted least squares of the relative errors of ω and ζ
(standard deviations ``frequency_std`` and ``damping_std``, relative). The linear limit is
held physical: the joint only softens, so f₀ lies at or above every sample (within
3 ``frequency_std``), and no higher above the lowest-amplitude sample f_ref than the
softening measured over all samples, ``f₀ ≤ f_ref(1 + max((f_max − f_min)/f_ref,
3·frequency_std))`` — an Iwan joint fitted with χ → −1 (it would slip at any amplitude)
otherwise puts f₀ anywhere above the data. An ``iwan`` fit that ends on that cap is refitted
without it (f₀ up to √2 × the highest sample's) and the refit kept where the capped one misses
the samples beyond their noise (:func:`microslip_test`, one constraint): samples all in
macroslip soften far more below the lowest of them than over them (the 2-DOF Iwan system of
tests/test_test_type_truth.py at 12–249 × its slip amplitude: 745 Hz stuck, 733.5 Hz at the
lowest sample, 0.1 Hz over the samples), and the capped fit missed its own phase-resonance
samples' damping by 11–13 %. Likewise the linear damping: a joint only adds
damping as it slips, so ζ₀ lies at or below the lowest-amplitude sample's damping ratio
(within 3 ``damping_std``: :func:`~nlupdate.core.identification.linear_limit.damping_cap`; the
BRB's polynomial put it at 5.8 × that). A fit on either bound, or with ζ₀ below 1 % of the
lowest sample's (the joint takes all the damping: ζ₀ undetermined), gets a warning.

* ``polynomial`` of ``order`` (linear least squares for f₀, c_k and ζ₀, d_k);
* ``iwan``: ω₀, ζ₀ and the modal joint (K_T < ω₀², F_S, χ, β), from several starts, with
  viscous and with structural linear damping (the better fit is kept; the note says). As for
  a PRD fit (:func:`~nlupdate.core.identification.dfmodels.iwan_identifiability`), amplitudes
  that stay below ``MACROSLIP_REACH × φ_max`` may show only χ and R' of the joint; the fit is
  then repeated with β = 0 and φ_max at the largest amplitude (the smallest joint that
  keeps every sample in microslip), and that fit is taken when it is as good within the
  noise (:func:`microslip_test`, or too few samples to test) — else the free fit (an Iwan SDOF's
  phase resonance to 1.7 φ_max: β = 0 missed ζ by 12 %, the free fit recovers χ, β); ``note`` says which;
* ``jenkins``: the same fit with β fixed at :data:`JENKINS_BETA` (the Iwan joint's Jenkins
  limit: stuck below φ_max = F_S/K_T, the closed hysteresis loop's energy above), for a
  joint that sticks and slips at one force, whose kink neither other form follows.

The Iwan least-squares problem itself (unknowns, starts, bounds):
:mod:`~nlupdate.core.identification.iwan_backbone_fit`.
"""
from __future__ import annotations

from dataclasses import replace
from typing import Sequence

import numpy as np
import pandas as pd
import scipy.stats
from numpy.typing import NDArray

from nlupdate.core.identification.constrained_lsq import constrained_lsq
from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.dfmodels import MACROSLIP_REACH
from nlupdate.core.identification.iwan_backbone_fit import JENKINS_BETA, JENKINS_CHI, SHAPE_RANGE, fit_iwan
from nlupdate.core.identification.linear_limit import damping_cap, linear_limit_range, linear_limit_warnings
from nlupdate.core.identification.modal_samples import ModalSamples, samples_from_frfs, samples_from_modal_table
from nlupdate.core.model.amplitude_modal import (
    BACKBONES, LINEAR_DAMPING, LOWER_BOUNDED, AmplitudeModalModel, AmplitudeModelError,
)

#: points of [0, a_ref] where the polynomial backbone is held monotone and its damping ≥ 0
_POLYNOMIAL_CHECKS = np.linspace(0.0, 1.0, 101)


#: exponents p of u = (a/a_ref)^p the polynomial backbone and damping curve are each tried
#: in (the best fit of each is kept)
POLYNOMIAL_EXPONENTS = (1.0, 0.5)


def _polynomial(samples: ModalSamples, shapes, order: int, frequency_std: float, damping_std: float,
                mode: int) -> AmplitudeModalModel:
    """Weighted least squares of f and of ζ, each against ``(a/a_ref)^p`` for the p of
    :data:`POLYNOMIAL_EXPONENTS` that fits it best, with the backbone monotone over the
    fitted range in the direction the samples trend (between samples spread over decades of
    a, a free polynomial in a swings hertz away from them), the linear limit inside
    :func:`linear_limit_range` (mirrored for a stiffening backbone), and ζ ≥ 0 over the range."""
    a_ref = float(np.max(samples.amplitude))
    powers = np.arange(order + 1)
    grid = _POLYNOMIAL_CHECKS[:, None]
    checks = grid ** powers[None, :]
    slope = np.where(powers[None, :] > 0, powers[None, :] * grid ** np.maximum(powers - 1, 0)[None, :], 0.0)
    softening = np.polyfit(np.log(samples.amplitude), samples.frequency_hz, 1)[0] <= 0
    low, high = (w / (2 * np.pi) for w in linear_limit_range(samples, frequency_std))
    f_ref = float(samples.frequency_hz[np.argmin(samples.amplitude)])
    first = np.eye(order + 1)[0]
    if softening:  # f₀ within linear_limit_range, falling with a
        limits = np.vstack([-slope, first, -first]), np.concatenate([np.zeros(len(slope)), [low, -high]])
    else:  # a stiffening backbone, mirrored: f₀ at or below every sample, rising with a
        top = float(samples.frequency_hz.min()) * (1 + 3 * float(np.median(frequency_std)))
        limits = np.vstack([slope, -first, first]), np.concatenate([np.zeros(len(slope)), [-top, 2 * f_ref - high]])
    # f_i = f₀ + Σ f₀c_k u^k: linear in (f₀, f₀c_k), weights 1/(σ_f f_i); ζ likewise
    wf = 1 / (frequency_std * samples.frequency_hz)
    wz = 1 / (damping_std * samples.damping_ratio)

    def best(target, weights, constraints):
        fits = []
        for exponent in POLYNOMIAL_EXPONENTS:
            design = (samples.amplitude / a_ref)[:, None] ** (exponent * powers)[None, :]
            c = constrained_lsq(design, target, weights, *constraints)
            fits.append((float(np.sum(((design @ c - target) * weights) ** 2)), exponent, c))
        return min(fits, key=lambda fit: fit[0])

    chi2_f, p_f, coefficients_f = best(samples.frequency_hz, wf, limits)
    z_cap = damping_cap(samples, damping_std)  # ζ₀ no higher than the lowest sample's damping
    chi2_z, p_z, coefficients_z = best(samples.damping_ratio, wz, (np.vstack([checks, -first]),
                                                                   np.concatenate([np.zeros(len(checks)), [-z_cap]])))
    f0, z0 = float(coefficients_f[0]), float(coefficients_z[0])
    model = AmplitudeModalModel(f0, max(z0, 0.0), shapes, frequency_coefficients=tuple(coefficients_f[1:] / f0),
                                damping_coefficients=tuple(coefficients_z[1:]), reference_amplitude=a_ref, mode=mode,
                                frequency_exponent=p_f, damping_exponent=p_z,
                                note=f"polynomial backbone of order {order} in (a/a_ref)^{p_f:g} and damping curve in "
                                     f"(a/a_ref)^{p_z:g} (chi² {chi2_f:.3g} and {chi2_z:.3g} for {samples.amplitude.size} "
                                     f"values each, {(d := samples.amplitude.size - order - 1)} degree{'s' * (d != 1)} of "
                                     f"freedom each), fitted to amplitudes up to a_ref = {a_ref:.4g} m·√kg and held at "
                                     f"their values there beyond")
    return replace(model, warnings=linear_limit_warnings(model, samples, frequency_std, z0, damping_std))



#: the backbones :func:`fit_amplitude_model` fits: the model's, and ``jenkins`` (an Iwan joint
#: in its Jenkins limit, stored as an ``iwan`` backbone)
FIT_BACKBONES = BACKBONES + ("jenkins",)
#: the backbones with a stick–slip kink (a Jenkins joint): refined on a driving-point stepped
#: sine's lines (:mod:`~nlupdate.core.identification.line_refine`), banded by that fit's covariance
#: (:mod:`~nlupdate.core.identification.joint_band`) rather than by bootstrap refits
KINKED_BACKBONES = ("jenkins",)


def default_resamples(backbone: str) -> int:
    """Bootstrap refits for a fitted model's 95 % bands when none are asked for: 200 for the
    polynomial backbone, none for Iwan's and Jenkins' (about a second per refit)."""
    return 200 if backbone == "polynomial" else 0

#: below this p-value of :func:`microslip_test` the free Iwan fit is kept
MICROSLIP_P = 0.05


#: what the β = 0 note adds when the free fit has one degree of freedom: its F-test then has little power
LITTLE_POWER = (" (the free fit has 1 degree of freedom: the F-test has little power, and β = 0 is kept unless the "
                "samples reject it strongly)")


def microslip_test(chi2_free: float, chi2_reduced: float, free_dof: int, constraints: int = 2) -> float:
    """p-value of the F-test of the Iwan fit with β = 0 and φ_max fixed (``constraints`` = 2
    parameters fewer; 1 for f₀ held on its softening cap) against the free fit:
    ``F = ((χ²_0 − χ²)/c)/(χ²/ν)``, ν the free fit's degrees of freedom
    (weighted residuals, so the noise level drops out). 1 where ν ≤ 0 (nothing to test: the
    simpler fit is kept); a small p says the constrained fit misses the samples beyond their noise."""
    if free_dof <= 0:
        return 1.0
    excess = max(chi2_reduced - chi2_free, 0.0) / constraints
    if excess == 0.0:
        return 1.0
    if chi2_free <= 0.0:
        return 0.0
    return float(scipy.stats.f.sf(excess / (chi2_free / free_dof), constraints, free_dof))



def fit_amplitude_model(samples: ModalSamples, shapes: Sequence[tuple[str, float]], backbone: str = "iwan",
                        order: int = 2, frequency_std: float | NDArray = 1e-3, damping_std: float | NDArray = 0.05,
                        mode: int = 1, amplitude_std: float | NDArray | None = None) -> AmplitudeModalModel:
    """The amplitude-dependent model of ``backbone`` fitted to ``samples`` (module docstring).

    ``frequency_std``, ``damping_std``: relative standard deviations of the samples' natural
    frequencies and damping ratios, one value for all or one per sample (samples of several
    sources each weighted by its own noise: :mod:`~nlupdate.core.identification.backbone_samples`).

    ``shapes``: the mode's mass-normalised shape (1/√kg) at named coordinates, the excited
    one included (its magnitude must be the samples' ``input_shape``).

    ``amplitude_std``: each sample's relative amplitude noise, below its damping ratio's; the
    Iwan fits then fit the true amplitudes where it is > 0 (:mod:`.sample_residuals`)."""
    if backbone not in FIT_BACKBONES:
        raise AmplitudeModelError(f"backbone must be one of {list(FIT_BACKBONES)}, got {backbone!r}")
    if np.any(np.asarray(frequency_std) <= 0) or np.any(np.asarray(damping_std) <= 0):
        raise AmplitudeModelError("frequency_std and damping_std must be > 0 (relative standard deviations)")
    if amplitude_std is not None and (np.any(np.asarray(amplitude_std) < 0) or samples.shape_free or
                                      np.any(np.asarray(amplitude_std) >= np.asarray(damping_std))):
        raise AmplitudeModelError("amplitude_std must be ≥ 0 and below damping_std (the amplitude's share of the "
                                  "damping ratio's noise), with the mode shape given")
    shapes = tuple((str(n), float(v)) for n, v in shapes)
    if backbone == "polynomial":
        if int(order) < 1:
            raise AmplitudeModelError(f"the polynomial order must be at least 1, got {order}")
        if int(order) >= samples.amplitude.size:
            raise AmplitudeModelError(f"a polynomial backbone of order {order} needs at least {int(order) + 1} samples, "
                                      f"got {samples.amplitude.size}: a lower order or more levels or runs")
        return _polynomial(samples, shapes, int(order), frequency_std, damping_std, mode)
    if samples.amplitude.size < 3:
        raise AmplitudeModelError(f"the {backbone} backbone needs at least 3 samples, got {samples.amplitude.size}")
    jenkins = {"beta": JENKINS_BETA, "chi": JENKINS_CHI} if backbone == "jenkins" else {}
    fits = [(*fit_iwan(samples, shapes, frequency_std, damping_std, mode, law, jenkins, amplitude_std=amplitude_std),
             law)
            for law in LINEAR_DAMPING]
    model, chi2, law = min(fits, key=lambda fit: fit[1])
    fitted_shape = samples.shape_free and samples.response_amplitude is not None
    n, capped, freed = 2 * samples.amplitude.size, True, ""
    free_dof = n - (6 + int(fitted_shape))  # ω₀, ζ₀, K_T, F_S, χ, β (and φ_f)
    dof = free_dof + 2 * bool(jenkins)  # the note's: two parameters fewer where β and χ (or φ_max) are fixed
    cap = linear_limit_range(samples, frequency_std)[1]
    if not jenkins and 2 * np.pi * model.natural_frequency_hz >= cap * (1 - 1e-6):  # on it: do the samples reject it?
        free = [(*fit_iwan(samples, shapes, frequency_std, damping_std, mode, other, None, False, amplitude_std), other)
                for other in LINEAR_DAMPING]
        best, chi2_capped = min(free, key=lambda fit: fit[1]), chi2
        if (p_cap := microslip_test(best[1], chi2, free_dof, constraints=1)) < MICROSLIP_P:
            (model, chi2, law), fits, capped = best, free, False
            freed = (f"; f0 not held under the softening cap (the capped fit misses the samples beyond the noise: "
                     f"chi² {chi2_capped:.3g}, F-test p = {p_cap:.2g})")
    stuck_shape = samples.input_shape  # √P, P the modal constant read from the levels (FRF samples)
    if fitted_shape:  # the fitted φ_f sets the amplitudes of every sample from here on
        samples = samples.with_shape(model.shapes[0][1])
        samples = ModalSamples(samples.amplitude, samples.frequency_hz, samples.damping_ratio, samples.force_n,
                               samples.input_shape, samples.response_amplitude, shape_free=False)
        shapes = model.shapes
    a_max, lower_bounds = float(np.max(samples.amplitude)), ()
    if jenkins:
        note = (f"modal Jenkins backbone: the Iwan joint in its Jenkins limit (beta = {JENKINS_BETA:g} fixed: stuck "
                f"below phi_max = slip_force/kt, the closed hysteresis loop above)")
    elif a_max < MACROSLIP_REACH * model.joint.phi_max or n <= 6:
        reach = a_max / model.joint.phi_max
        reduced, chi2_reduced = fit_iwan(samples, shapes, frequency_std, damping_std, mode, law,
                                         {"beta": 0.0, "phi_max": a_max}, capped, amplitude_std)
        p_value = microslip_test(chi2, chi2_reduced, free_dof)
        if p_value >= MICROSLIP_P:
            model, chi2, dof, lower_bounds = reduced, chi2_reduced, free_dof + 2, LOWER_BOUNDED
            why = ("too few samples to test it" if free_dof <= 0 else
                   f"the fit with beta = 0 is as good within the noise: F-test p = {p_value:.2g} ≥ {MICROSLIP_P:g}"
                   + (LITTLE_POWER if free_dof == 1 else ""))
            note = (f"no sample reaches the joint's macroslip (largest modal amplitude {a_max:.4g} m·√kg, {reach:.2g} × "
                    f"the φ_max of a free fit; {MACROSLIP_REACH:g} × needed) and {why}: the data determine chi and R' "
                    f"only; fixed beta = 0 and phi_max = the largest amplitude, so {' and '.join(lower_bounds)} are lower "
                    f"bounds")
        else:
            note = (f"modal Iwan backbone, all parameters fitted (the largest modal amplitude is {reach:.2g} × the "
                    f"fit's φ_max, below {MACROSLIP_REACH:g} ×, but the fit with beta = 0 is worse beyond the noise: "
                    f"chi² {chi2_reduced:.3g} against {chi2:.3g}, F-test p = {p_value:.2g}"
                    f"{LITTLE_POWER if free_dof == 1 else ''})")
    else:
        note = "modal Iwan backbone, all parameters fitted"
    chosen = ", ".join(f"{other} {c:.3g}" for _, c, other in sorted(fits, key=lambda fit: fit[2] != law))
    kept = "the kept fit with beta = 0" if lower_bounds else "the kept fit"
    note += (f"; {law} linear damping (the free fits' chi² {chosen}: the smaller's law is kept; {kept}: chi² "
             f"{chi2:.3g} for {n} values, {dof} degrees of freedom){freed}")
    if fitted_shape:
        note += (f"; the mode shape at the excited coordinate fitted with the backbone: {shapes[0][1]:.4g} 1/√kg "
                 f"(the Iwan joint ties its damping to its softening, which fixes the amplitude scale)")
    out = AmplitudeModalModel(model.natural_frequency_hz, model.damping_ratio, shapes, joint=model.joint, mode=mode,
                              linear_damping=law, note=note, lower_bounds=lower_bounds)
    warnings = linear_limit_warnings(out, samples, frequency_std, damping_std=damping_std)
    ratio = shapes[0][1] / stuck_shape
    if fitted_shape and abs(np.log(ratio)) >= 0.99 * np.log(SHAPE_RANGE):
        warnings += (f"the Iwan fit ends with the mode shape at the excited coordinate on its bound, {shapes[0][1]:.4g} "
                     f"1/√kg = {ratio:.3g} × the shape the levels' modal constant gives ({stuck_shape:.4g} 1/√kg; a joint that "
                     f"slips changes it by a few per cent): the joint cannot tie the measured damping to the measured "
                     f"softening; try the polynomial backbone",)
    return replace(out, warnings=warnings)


def amplitude_model_from_modal_table(table: pd.DataFrame, shapes: Sequence[tuple[str, float]], input_dof: str,
                                     backbone: str = "iwan", mode: int = 1, order: int = 2,
                                     source: str = "<modal table>") -> AmplitudeModalModel:
    """Fit the model of ``mode`` to a modal table measured with the force at ``input_dof``."""
    shapes = tuple((str(n), float(v)) for n, v in shapes)
    names = [n for n, _ in shapes]
    if str(input_dof) not in names:
        raise AmplitudeModelError(f"input_dof {input_dof!r}: give the mode shape there too (shapes at {names})")
    samples = samples_from_modal_table(table, dict(shapes)[str(input_dof)], mode, source)
    return fit_amplitude_model(samples, shapes, backbone, order, mode=mode)


def amplitude_model_from_frfs(data: FRFLevels, backbone: str = "iwan", input_shape: float | None = None,
                              order: int = 2, near_hz: float | None = None, mode: int = 1) -> AmplitudeModalModel:
    """Fit the model of the mode near ``near_hz`` (default: the lowest level's peak) to
    driving-point or transfer FRFs at several levels, one sample per level
    (:func:`samples_from_frfs`); the model's shapes are at the input and, for a transfer, the
    response.

    Without ``input_shape`` an Iwan backbone fits the shape φ_f too; a polynomial one takes
    the modal constant read with the other modes' share from every level (T-beam example,
    tests/test_bolted_beam_example.py, 1 % noise: 2.77 against the FE shape's 2.79 1/√kg; the
    lowest level's one-mode fit, the *stuck* mode's shape, gave 2.63). The samples' warnings
    (the other modes' share on its box: :func:`~nlupdate.core.identification.level_residual.bound_warning`)
    come first among the model's."""
    samples = samples_from_frfs(data, input_shape, near_hz)
    model = model_of_frf_samples(data, samples, backbone, order, mode)
    return replace(model, warnings=samples.warnings + model.warnings)  # the samples' own first: they are in question


def model_of_frf_samples(data: FRFLevels, samples: ModalSamples, backbone: str = "iwan", order: int = 2,
                         mode: int = 1) -> AmplitudeModalModel:
    """The model of :func:`amplitude_model_from_frfs` fitted to ``samples`` already read from
    ``data`` (:func:`samples_from_frfs`), without the samples' warnings: ``nlupdate amplitude``
    decides itself whether a band cut keeps them
    (:func:`~nlupdate.core.identification.amplitude_joint.measured_source`)."""
    shapes = ((data.input_dof, samples.input_shape),)
    if data.response_dof != data.input_dof:
        shapes += ((data.response_dof, samples.response_ratio * samples.input_shape),)
    model = fit_amplitude_model(samples, shapes, backbone, order, frequency_std=1e-3, damping_std=0.05, mode=mode)
    if data.response_dof == data.input_dof:
        return model
    split = ("the split taken equal, |φ_r| = |φ_f|, which sets the scale of the modal amplitude and of the joint's "
             "F_S and φ_max, not any prediction of these FRFs" if samples.shape_free else
             f"φ_f = {samples.input_shape:.4g} 1/√kg as given")
    return replace(model, note=model.note + f"; from transfer FRFs ({data.response_dof}/{data.input_dof}), which fix only "
                                            f"the product φ_rφ_f: {split}")
