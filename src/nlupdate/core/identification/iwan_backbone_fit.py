"""The least-squares problem of an Iwan (or Jenkins-limit) modal backbone
(:mod:`~nlupdate.core.identification.amplitude_modal_fit` decides which fits to make and
keep): the model's unknowns (:func:`iwan_model`), the starts, the bounds on ω₀ (the linear limit
of :func:`~nlupdate.core.identification.linear_limit.linear_limit_range`) and on a fitted mode
shape (:data:`SHAPE_RANGE`), and the weighted residuals of
:mod:`~nlupdate.core.identification.sample_residuals` (errors in variables where the amplitudes
are noisy).
"""
from __future__ import annotations

import numpy as np
import scipy.optimize
import scipy.special
from numpy.typing import NDArray

from nlupdate.core.identification.linear_limit import linear_limit_range
from nlupdate.core.identification.modal_samples import ModalSamples
from nlupdate.core.identification.sample_residuals import noisy_residual, sample_residual
from nlupdate.core.model.amplitude_modal import AmplitudeModalModel
from nlupdate.core.model.elements import IwanJoint

#: β of the ``jenkins`` backbone: the Iwan joint's continuous part is K_T/(1+β), so its
#: describing function is a Jenkins element's (k_f = K_T, F_s = F_S) within ~1/β
JENKINS_BETA = 1e6
#: χ of the ``jenkins`` backbone (it only shapes the continuous part, which β makes negligible)
JENKINS_CHI = -0.5

#: how far (a factor either way) an Iwan fit's mode shape may stray from the modal constant
#: read from the levels (a one-mode fit of the lowest level before issue 34; the bolted-beam example: 2.78–2.85 against 2.63 1/√kg). The bound is the
#: physics, not a convenience: a free shape let the fit shrink φ_f, which scales every
#: damping ratio by φ_f² and keeps each peak, so a joint that cannot tie the measured damping
#: to the measured softening (the BRB; a quadratic damper) fitted with ζ₀ → 0 and predicted
#: curves 5–15 × too narrow (held-out damping −80 … −95 %)
SHAPE_RANGE = 1.1


def iwan_model(theta: NDArray, shapes, fixed: dict[str, float], mode: int, damping: str) -> AmplitudeModalModel:
    """Model from unknowns: log ω₀, log ζ₀, logit(K_T/ω₀²), then (log F_S or fixed φ_max),
    logit(−χ) (χ ∈ (−1, 0), or fixed), log β (or fixed)."""
    values = iter(theta)
    w0 = float(np.exp(next(values)))
    z0 = float(np.exp(next(values)))
    kt = float(scipy.special.expit(next(values))) * w0**2
    slip = None if "phi_max" in fixed else float(np.exp(next(values)))
    chi = fixed["chi"] if "chi" in fixed else -float(np.clip(scipy.special.expit(next(values)), 1e-9, 1 - 1e-9))
    beta = fixed["beta"] if "beta" in fixed else float(np.exp(next(values)))
    if slip is None:
        slip = fixed["phi_max"] * kt * (beta + (chi + 1) / (chi + 2)) / (1 + beta)
    joint = IwanJoint((0,), slip_force=slip, kt=kt, chi=chi, beta=beta)
    return AmplitudeModalModel(w0 / (2 * np.pi), z0, shapes, joint=joint, mode=mode, linear_damping=damping)


def fit_iwan(samples: ModalSamples, shapes, frequency_std: float, damping_std: float, mode: int, damping: str,
          fixed: dict[str, float] | None = None, capped: bool = True,
          amplitude_std: NDArray | None = None) -> tuple[AmplitudeModalModel, float]:
    """Best Iwan backbone over the starts; with ``samples.shape_free`` the shape φ_f (the last
    unknown, as a log) is fitted too and the model's shapes carry it. ``capped``: f₀ under
    the softening cap of :func:`linear_limit_range` (the ``jenkins`` backbone never);
    ``amplitude_std``: the samples' relative amplitude noise (:mod:`.sample_residuals`)."""
    fixed, free_shape, n = fixed or {}, samples.shape_free and samples.response_amplitude is not None, samples.amplitude.size
    a_std = np.zeros(n) if amplitude_std is None else np.broadcast_to(np.asarray(amplitude_std, float), (n,))
    noisy, stds = a_std > 0, [np.broadcast_to(np.asarray(std, float), (n,)) for std in (frequency_std, damping_std)]
    omega_range = linear_limit_range(samples, frequency_std, fixed.get("beta") == JENKINS_BETA or not capped)
    if free_shape:
        def unpack(t):
            phi = float(np.exp(t[-1]))
            scaled = ((shapes[0][0], phi),) + tuple((n, v * phi / shapes[0][1]) for n, v in shapes[1:])
            return iwan_model(t[:-1], scaled, fixed, mode, damping), samples.with_shape(phi)
    else:
        def unpack(t):
            return iwan_model(t, shapes, fixed, mode, damping), samples
    z_low = float(samples.damping_ratio[np.argmin(samples.amplitude)])
    a_max = float(np.max(samples.amplitude))
    # log ω₀ is held in linear_limit_range by the trust region's own bounds: a logistic map
    # onto that narrow range (1.5 Hz for a Jenkins SDOF at 81 Hz) made ω₀'s column ~300 × weaker
    # than under log ω₀, the first step went into ζ₀ and φ_f instead (ζ₀ 0.0074 → 0.35), and the
    # fit stalled at ζ₀ → 1 with φ_f 22.7 × the truth
    log_range = np.log(omega_range)
    inside = log_range + np.array([0.02, -0.02]) * (log_range[1] - log_range[0])
    w0 = float(np.exp(np.clip(np.log(2 * np.pi * float(np.max(samples.frequency_hz)) * 1.001), *inside)))
    best = None
    for share in (0.05, 0.3):
        # φ_max from a tenth of the largest amplitude (FRFs into gross slip: a Jenkins SDOF
        # measured up to 0.08 N has it at 1.4 %) to four times it; one start where it is fixed
        for reach in ((0.1, 1.0, 4.0) if "phi_max" not in fixed else (1.0,)):
            for chi in ((-0.3, -0.7) if "chi" not in fixed else (fixed["chi"],)):
                for beta in ((0.1, 1.0) if "beta" not in fixed else (fixed["beta"],)):
                    kt = share * w0**2
                    phi_max = fixed.get("phi_max", reach * a_max)
                    slip = phi_max * kt * (beta + (chi + 1) / (chi + 2)) / (1 + beta)
                    theta = [np.log(w0), np.log(max(min(z_low, 0.5), 1e-5)),
                             scipy.special.logit(share)]
                    if "phi_max" not in fixed:
                        theta.append(np.log(slip))
                    if "chi" not in fixed:
                        theta.append(scipy.special.logit(-chi))
                    if "beta" not in fixed:
                        theta.append(np.log(beta))
                    if free_shape:
                        theta.append(np.log(samples.input_shape))
                    unknowns = len(theta)  # then the noisy samples' log true amplitudes (iwan_model ignores them)
                    theta.extend(np.log(samples.amplitude[noisy]))

                    def residual(t):
                        with np.errstate(all="ignore"):
                            try:
                                model, data = unpack(t)
                            except (ValueError, OverflowError):
                                return np.full(2 * n + int(noisy.sum()), 1e6)
                            if noisy.any():
                                return noisy_residual(model.omega_zeta, data.amplitude, data.frequency_hz,
                                                      data.damping_ratio, t[unknowns:], noisy, *stds, a_std)
                            return sample_residual(model.omega_zeta, data, frequency_std, damping_std)

                    lower, upper = np.full(len(theta), -np.inf), np.full(len(theta), np.inf)
                    lower[0], upper[0] = log_range
                    if free_shape:  # the shape a slipping joint gives: a few per cent from the stuck one
                        lower[unknowns - 1], upper[unknowns - 1] = np.log(samples.input_shape) + np.log(SHAPE_RANGE) * np.array([-1, 1])
                    solution = scipy.optimize.least_squares(residual, np.array(theta), method="trf", max_nfev=400,
                                                            bounds=(lower, upper))
                    if best is None or solution.cost < best.cost:
                        best = solution
    return unpack(best.x)[0], float(2 * best.cost)

