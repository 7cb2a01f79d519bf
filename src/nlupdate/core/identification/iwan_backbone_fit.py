"""The least-squares problem of an Iwan (or Jenkins-limit) modal backbone
(:mod:`~nlupdate.core.identification.amplitude_modal_fit` decides which fits to make and
keep): the model's unknowns (:func:`iwan_model`), the starts, the bounds on ω₀ (the linear limit
of :func:`~nlupdate.core.identification.linear_limit.linear_limit_range`) and on a fitted mode
shape (:data:`SHAPE_RANGE`), and the weighted residuals of
:mod:`~nlupdate.core.identification.sample_residuals` (errors in variables where the amplitudes
are noisy) with their Jacobian in closed form (:func:`iwan_curves`: the joint's describing
function differentiated in its parameters,
:meth:`~nlupdate.core.model.elements.IwanJoint.describing_function_gradient`). The Jacobian by
2-point differences took 60 % of the fits' time (one residual per unknown per step); the
closed form costs about one residual (benchmarks/iwan_fit_jacobian.py).
"""
from __future__ import annotations

from typing import Callable, NamedTuple, Sequence

import numpy as np
import scipy.optimize
import scipy.special
from numpy.typing import ArrayLike, NDArray

from nlupdate.core.identification.linear_limit import linear_limit_range
from nlupdate.core.identification.modal_samples import ModalSamples
from nlupdate.core.identification.sample_residuals import (
    Curves, noisy_residual, noisy_residual_jacobian, sample_residual, sample_residual_jacobian,
)
from nlupdate.core.model.amplitude_modal import AmplitudeModalModel
from nlupdate.core.model.elements import IwanJoint
from nlupdate.core.model.elements.iwan import slip_force_at

#: β of the ``jenkins`` backbone: the Iwan joint's continuous part is K_T/(1+β), so its
#: describing function is a Jenkins element's (k_f = K_T, F_s = F_S) within ~1/β
JENKINS_BETA = 1e6
#: χ of the ``jenkins`` backbone (it only shapes the continuous part, which β makes negligible)
JENKINS_CHI = -0.5

#: how far (a factor either way) an Iwan fit's mode shape may stray from √P, P the modal
#: constant read from every level at once (level_residual; a one-mode fit of the lowest level
#: before issue 34; the bolted-beam example: 2.78–2.85 against 2.63 1/√kg). The bound is the
#: physics, not a convenience: a free shape let the fit shrink φ_f, which scales every
#: damping ratio by φ_f² and keeps each peak, so a joint that cannot tie the measured damping
#: to the measured softening (the BRB; a quadratic damper) fitted with ζ₀ → 0 and predicted
#: curves 5–15 × too narrow (held-out damping −80 … −95 %)
SHAPE_RANGE = 1.1


def iwan_parameters(theta: ArrayLike, fixed: dict[str, float]) -> tuple[NDArray, ...]:
    """(ω₀ rad/s, ζ₀, K_T, F_S, χ, β) of unknowns θ on the last axis (leading axes: many θ at
    once): log ω₀, log ζ₀, logit(K_T/ω₀²), then (log F_S or fixed φ_max), logit(−χ) (χ ∈ (−1,
    0), or fixed), log β (or fixed)."""
    theta = np.asarray(theta, dtype=float)
    values = iter(theta if theta.ndim == 1 else np.moveaxis(theta, -1, 0))  # one θ (a fit's step): its scalars
    w0 = np.exp(next(values))
    z0 = np.exp(next(values))
    kt = scipy.special.expit(next(values)) * w0**2
    slip = None if "phi_max" in fixed else np.exp(next(values))
    chi = fixed["chi"] if "chi" in fixed else -_clip(scipy.special.expit(next(values)), 1e-9, 1 - 1e-9)
    beta = fixed["beta"] if "beta" in fixed else np.exp(next(values))
    if slip is None:
        slip = slip_force_at(fixed["phi_max"], kt, chi, beta)
    return w0, z0, kt, slip, chi, beta


def _clip(value, low: float, high: float):
    """np.clip of ``value``; of one number, without its dispatch (a fit takes one θ per step)."""
    if np.ndim(value) == 0:
        return min(max(value, low), high)
    return np.clip(value, low, high)


def iwan_models_exist(w0: NDArray, z0: NDArray, kt: NDArray, slip: NDArray, beta: NDArray) -> NDArray:
    """Where :func:`iwan_parameters`' values make a model (:func:`iwan_model` refuses the others):
    the checks of :class:`~nlupdate.core.model.amplitude_modal.AmplitudeModalModel` and
    :class:`~nlupdate.core.model.elements.IwanJoint` that those values can fail (f₀ finite and
    > 0, 0 ≤ ζ₀ < 1, 0 < K_T < ω₀² as the model reads ω₀ back from f₀, F_S finite and > 0, β finite;
    the χ of the map is always inside (−1, 0])."""
    f0 = w0 / (2 * np.pi)
    with np.errstate(invalid="ignore", over="ignore"):
        return (np.isfinite(f0) & (f0 > 0) & np.isfinite(z0) & (z0 < 1) & np.isfinite(kt) & (kt > 0)
                & (kt < (2 * np.pi * f0) ** 2) & np.isfinite(slip) & (slip > 0) & np.isfinite(beta))


def iwan_model(theta: NDArray, shapes: Sequence[tuple[str, float]], fixed: dict[str, float], mode: int, damping: str) -> AmplitudeModalModel:
    """Model from unknowns θ (:func:`iwan_parameters`)."""
    w0, z0, kt, slip, chi, beta = (float(v) for v in iwan_parameters(theta, fixed))
    joint = IwanJoint((0,), slip_force=slip, kt=kt, chi=chi, beta=beta)
    return AmplitudeModalModel(w0 / (2 * np.pi), z0, shapes, joint=joint, mode=mode, linear_damping=damping)


def iwan_curves(model: AmplitudeModalModel, theta: NDArray, fixed: dict[str, float], amplitude: NDArray,
                known: tuple | None = None) -> Curves:
    """The curves ω(a), ζ(a) of ``model`` = :func:`iwan_model` (``theta``, ``fixed``) at
    ``amplitude`` (m·√kg) with their derivatives in ``theta`` and in a
    (:data:`~nlupdate.core.identification.sample_residuals.Curves`): ω² = ω₀² − K_T + Re ν,
    ζ = ζ₀(ω₀/ω)^k + Im ν/(2ω²) (k = 1 viscous, 2 structural), ν's derivatives from the joint
    (:meth:`~nlupdate.core.model.elements.IwanJoint.describing_function_gradient`) through the
    maps of :func:`iwan_model` (a χ on its clip has no derivative). ``known``: (ν, its pieces,
    ω, ζ) at ``amplitude`` — the joint's
    :meth:`~nlupdate.core.model.elements.IwanJoint.describing_function_and_parts` and the
    model's curves from them —, if at hand."""
    joint, w0, z0, a = model.joint, model.omega0, model.damping_ratio, np.asarray(amplitude, float)
    kt, slip, chi, beta = joint.kt, joint.slip_force, joint.chi, joint.beta
    p = len(theta)
    d = np.zeros((6, p))  # ∂/∂θ of ln ω₀, ln ζ₀, K_T, F_S, χ, β
    d[0, 0], d[1, 1], d[2, 0], d[2, 2] = 1.0, 1.0, 2 * kt, kt * (1 - kt / w0**2)
    k = 3
    if "phi_max" not in fixed:
        d[3, k], k = slip, k + 1
    if "chi" not in fixed:
        e = float(scipy.special.expit(theta[k]))
        d[4, k], k = (-e * (1 - e) if 1e-9 < e < 1 - 1e-9 else 0.0), k + 1
    if "beta" not in fixed:
        d[5, k] = beta
    if "phi_max" in fixed:  # F_S = φ_max K_T (β + c)/(1 + β), c = (χ+1)/(χ+2)
        c, phi = (chi + 1) / (chi + 2), fixed["phi_max"]
        d[3] = (slip / kt * d[2] + phi * kt / ((1 + beta) * (chi + 2) ** 2) * d[4]
                + phi * kt * (1 - c) / np.square(1 + beta) * d[5])
    names = ("kt", "slip_force", "beta") + ("chi",) * ("chi" not in fixed)  # a fixed χ's row of d is 0
    nu, nu_a, gradient = joint.describing_function_gradient(a, names, None if known is None else known[:2])
    d_nu = np.column_stack([gradient[name] for name in names]) @ d[[2, 3, 5, 4][:len(names)]]
    omega, zeta = (model.joint_curves(nu) if known is None  # the model's own curves
                   else known[2:])
    power = 1 if model.linear_damping == "viscous" else 2
    with np.errstate(divide="ignore", invalid="ignore"):
        d_omega = (2 * w0**2 * d[0] - d[2] + d_nu.real) / (2 * omega[:, None])
        linear = z0 * (w0 / omega) ** power  # ζ's linear part
        d_zeta = (linear[:, None] * (d[1] + power * d[0]) + d_nu.imag / (2 * omega[:, None] ** 2)
                  - (power * linear + nu.imag / omega**2)[:, None] * d_omega / omega[:, None])
        omega_a = nu_a.real / (2 * omega)
        zeta_a = nu_a.imag / (2 * omega**2) - (power * linear + nu.imag / omega**2) * omega_a / omega
    return omega, zeta, d_omega, d_zeta, omega_a, zeta_a


class IwanProblem(NamedTuple):
    """One Iwan backbone's least-squares problem (:func:`iwan_problem`): ``unpack(θ)`` → (model,
    samples: with a fitted shape, the samples at it), the weighted ``residual(θ)`` and its
    ``jacobian(θ)``, how many unknowns are the model's (the last of them ln φ_f where
    ``shape``), then one log true amplitude for each of the samples ``noisy`` (a mask)."""

    unpack: Callable[[NDArray], tuple[AmplitudeModalModel, ModalSamples]]
    residual: Callable[[NDArray], NDArray]
    jacobian: Callable[[NDArray], NDArray]
    unknowns: int
    shape: bool
    noisy: NDArray


def iwan_problem(samples: ModalSamples, shapes: Sequence[tuple[str, float]], frequency_std: float | NDArray, damping_std: float | NDArray,
                 mode: int, damping: str, fixed: dict[str, float] | None = None,
                 amplitude_std: NDArray | None = None) -> IwanProblem:
    """The residuals of an Iwan backbone with ``damping`` linear damping and the parameters
    ``fixed`` (``beta``, ``chi``, ``phi_max``) about ``samples``, and their Jacobian; with
    ``samples.shape_free`` (FRF samples) the shape φ_f is the last of the model's unknowns (as
    a log) and the model's shapes carry it; ``amplitude_std``: the samples' relative amplitude
    noise (:mod:`.sample_residuals`: their log true amplitudes are unknowns too)."""
    fixed, free_shape, n = fixed or {}, samples.shape_free and samples.response_amplitude is not None, samples.amplitude.size
    a_std = np.zeros(n) if amplitude_std is None else np.broadcast_to(np.asarray(amplitude_std, float), (n,))
    noisy, stds = a_std > 0, [np.broadcast_to(np.asarray(std, float), (n,)) for std in (frequency_std, damping_std)]
    unknowns = 3 + sum(name not in fixed for name in ("phi_max", "chi", "beta")) + int(free_shape)
    rows = 2 * n + int(noisy.sum())
    if free_shape:
        def unpack(t):
            phi = float(np.exp(t[unknowns - 1]))
            scaled = ((shapes[0][0], phi),) + tuple((name, v * phi / shapes[0][1]) for name, v in shapes[1:])
            return iwan_model(t[:unknowns - 1], scaled, fixed, mode, damping), samples.with_shape(phi)
    else:
        def unpack(t):
            return iwan_model(t[:unknowns], shapes, fixed, mode, damping), samples

    last: dict = {}

    def cached(t):
        """``unpack(t)``, None where the unknowns give no model; the last one kept (scipy asks
        for the Jacobian where it has just evaluated the residuals), with the joint's describing
        function at the samples' amplitudes once the residuals have computed it (``df``)."""
        if last.get("t") is None or not np.array_equal(last["t"], t):
            try:
                last["model"] = unpack(t)
            except (ValueError, OverflowError):
                last["model"] = None
            last["t"], last["df"] = np.array(t), None
        return last["model"]

    def omega_zeta(model: AmplitudeModalModel, amplitude: NDArray) -> tuple[NDArray, NDArray]:
        """``model.omega_zeta(amplitude)`` (through the model's own
        :meth:`~nlupdate.core.model.amplitude_modal.AmplitudeModalModel.joint_curves`), keeping the describing function and its pieces for the
        Jacobian at the same unknowns."""
        nu, parts = model.joint.describing_function_and_parts(np.asarray(amplitude, dtype=float))
        omega, zeta = model.joint_curves(nu)
        last["df"] = (amplitude, nu, parts, omega, zeta)
        return omega, zeta

    def known_df(amplitude: NDArray) -> tuple | None:
        """(ν, its pieces, ω, ζ) as the residuals computed them at ``amplitude``, if they did."""
        df = last.get("df")
        return df[1:] if df is not None and df[0] is amplitude else None

    def residual(t):
        with np.errstate(all="ignore"):
            if (unpacked := cached(t)) is None:
                return np.full(rows, 1e6)
            model, data = unpacked
            if noisy.any():
                return noisy_residual(model.omega_zeta, data.amplitude, data.frequency_hz, data.damping_ratio,
                                      t[unknowns:], noisy, *stds, a_std)
            return sample_residual(lambda a: omega_zeta(model, a), data, frequency_std, damping_std)

    def jacobian(t):
        with np.errstate(all="ignore"):
            if (unpacked := cached(t)) is None:
                return np.zeros((rows, len(t)))
            model, data = unpacked
            theta = t[:unknowns - int(free_shape)]
            if noisy.any():
                at = data.amplitude.copy()
                at[noisy] = np.exp(t[unknowns:])
                return noisy_residual_jacobian(iwan_curves(model, theta, fixed, at), data.amplitude, data.frequency_hz,
                                               data.damping_ratio, t[unknowns:], noisy, *stds, a_std)
            return sample_residual_jacobian(iwan_curves(model, theta, fixed, data.amplitude, known_df(data.amplitude)),
                                            data, *stds, shape=free_shape)

    return IwanProblem(unpack, residual, jacobian, unknowns, free_shape, noisy)


def fit_iwan(samples: ModalSamples, shapes: Sequence[tuple[str, float]], frequency_std: float, damping_std: float, mode: int, damping: str,
             fixed: dict[str, float] | None = None, capped: bool = True,
             amplitude_std: NDArray | None = None) -> tuple[AmplitudeModalModel, float]:
    """Best Iwan backbone over the starts (the problem: :func:`iwan_problem`). ``capped``: f₀
    under the softening cap of :func:`linear_limit_range` (the ``jenkins`` backbone never)."""
    fixed = fixed or {}
    problem = iwan_problem(samples, shapes, frequency_std, damping_std, mode, damping, fixed, amplitude_std)
    omega_range = linear_limit_range(samples, frequency_std, fixed.get("beta") == JENKINS_BETA or not capped)
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
                    slip = slip_force_at(phi_max, kt, chi, beta)
                    theta = [np.log(w0), np.log(max(min(z_low, 0.5), 1e-5)),
                             scipy.special.logit(share)]
                    if "phi_max" not in fixed:
                        theta.append(np.log(slip))
                    if "chi" not in fixed:
                        theta.append(scipy.special.logit(-chi))
                    if "beta" not in fixed:
                        theta.append(np.log(beta))
                    if problem.shape:
                        theta.append(np.log(samples.input_shape))
                    theta.extend(np.log(samples.amplitude[problem.noisy]))  # the noisy samples' log true amplitudes

                    lower, upper = np.full(len(theta), -np.inf), np.full(len(theta), np.inf)
                    lower[0], upper[0] = log_range
                    if problem.shape:  # the shape a slipping joint gives: a few per cent from the stuck one
                        lower[problem.unknowns - 1], upper[problem.unknowns - 1] = (
                            np.log(samples.input_shape) + np.log(SHAPE_RANGE) * np.array([-1, 1]))
                    # a χ on its clip or β → 0 leaves a Jacobian column exactly 0, which scipy's
                    # trust-region step may divide by (test_validate's Jenkins SDOF: a losing start
                    # that ends on xtol): its floating-point warnings are not the fit's
                    with np.errstate(divide="ignore", invalid="ignore"):
                        solution = scipy.optimize.least_squares(problem.residual, np.array(theta), problem.jacobian,
                                                                method="trf", max_nfev=400, bounds=(lower, upper))
                    if best is None or solution.cost < best.cost:
                        best = solution
    return problem.unpack(best.x)[0], float(2 * best.cost)

