"""Weighted misfits of backbone samples about a model's curves ω(a), ζ(a): what the modal-joint
fits minimise (:mod:`~nlupdate.core.identification.amplitude_modal_fit`), and the errors in
the variables of samples whose modal amplitude is itself noisy.

:func:`sample_residual`: each sample's relative misfits ``ω(a)/ω_i − 1`` and ``ζ(a)/ζ_i − 1``
over their relative standard deviations, the amplitude a taken as exact.

A phase-resonance point's modal amplitude is its measured response over φ, ``a = x/φ``, and
its damping ratio the force over the response, ``ζ = φF/(2Ω²a)``
(:mod:`~nlupdate.core.identification.phase_resonance`). With relative noise e_x on the response
and e_F on the force, ``ln a = ln α + e_x`` and ``ln ζ = ln ζ(α) + e_F − e_x`` about the true
amplitude α: the amplitude is as noisy as the response, and its error moves the damping ratio
the opposite way. A fit that takes a as exact reads each point's damping at the wrong
amplitude, and near an Iwan joint's full-slip amplitude φ_max — where ζ(a) turns from flat to
steep — that error is several times the damping's own noise (∂ln ζ/∂ln a up to ~2 there, ~13
at a Jenkins joint's kink). The frequency, the locked excitation frequency Ω, is read far
more precisely than either (:data:`LOCKED_FREQUENCY_STD`), and the backbone ties it to the
amplitude: ``Ω = ω(α)`` places each point on the backbone, and so places the kink.

The fit (:func:`noisy_residual`) takes each noisy sample's true amplitude α_i as one more
unknown (as the Cramér–Rao bound of ``benchmarks/kink_information.py`` does) and its weighted
residuals are, per sample: the frequency ``(ω(α)/Ω − 1)/σ_f``, the force ``(ζ(α)α/(ζa) − 1)/σ_F``
(``ζa = φF/(2Ω²)`` holds the force's noise alone: ``σ_F² = σ_ζ² − σ_a²``) and the amplitude
``(α/a − 1)/σ_a``. Samples with σ_a = 0 keep α = a and the usual two residuals. The residual
count grows by one per noisy sample and the unknowns by one, so the degrees of freedom of the
F-tests on the fit's χ² (:func:`~nlupdate.core.identification.amplitude_modal_fit.microslip_test`)
are unchanged.

Which samples: :data:`NOISY_AMPLITUDE_SHARE` by test type (phase resonance, the force and the
response equally noisy: σ_a = σ_ζ/√2). Which fits: :data:`EIV_BACKBONES`, the modal-joint
sample fits (``iwan`` and ``jenkins``). A ``jenkins`` fit refined on a stepped sine's lines
(:mod:`~nlupdate.core.identification.line_refine`) takes the other sources' samples at their
amplitudes there, and its 95 % band carries their noise in its covariance; the band of a fit
made here is this residual's, the true amplitudes nuisance unknowns
(:func:`~nlupdate.core.identification.joint_band.noisy_fit_residual`). With the amplitudes
exact the phase-resonance points of the
Jenkins SDOF of tests/test_test_type_truth.py placed the slip amplitude with a scatter of
1.28 % over 24 seeds, twice the Cramér–Rao bound of those points (0.65 %,
``benchmarks/kink_information.py``); fitted, 0.64 % (docs/ring-down.md, "Efficient at the
kink"). Stepped-sine peaks also take
a and ζ from one height, but their amplitude is read from a fit over many lines
(:mod:`~nlupdate.core.identification.frf_peak`), not one reading; they are left as they were.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Callable, Sequence

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:  # the samples' module needs no residuals, but keep this one free of its imports
    from nlupdate.core.identification.modal_samples import ModalSamples

#: test types whose samples' modal amplitudes carry the response's noise, and the share of
#: their damping ratio's relative noise taken as that: a phase-resonance point's amplitude
#: is its response over φ, its damping ratio the force over the response, so with force and
#: response equally noisy the amplitude carries 1/√2 of the damping ratio's noise
NOISY_AMPLITUDE_SHARE = {"phase-resonance": 1 / np.sqrt(2)}
#: relative standard deviation of a phase-resonance point's frequency in the errors-in-variables
#: fit: the excitation frequency a phase-locked loop holds, read to about 1e-5 (the smallest
#: frequency noise a source is given, ``backbone_samples.NOISE_FLOOR``). Not the scatter of those
#: frequencies about a smooth curve in the *measured* amplitude: that is the amplitude's noise
#: times the backbone's slope (1.4–1.8e-3 about a quadratic, 0.8–3.9e-4 about the points' own
#: Iwan fit, for frequencies exact to 1e-6 on the Iwan truth of tests/test_test_type_truth.py),
#: which the fit carries as the amplitude's own residual instead; weighted by that scatter (1e-4)
#: the 2-DOF Iwan's six points kept φ_max 5–9 % off and the damping 6.2 % off on one seed of 8,
#: 4.8 % at 1e-5 (docs/ring-down.md, "The Iwan fits at φ_max")
LOCKED_FREQUENCY_STD = {"phase-resonance": 1e-5}
#: the backbones fitted with the noisy samples' true amplitudes unknown (module docstring; the
#: ``jenkins`` fits kept them exact until 2026-11-29, at twice the bound's scatter of a_s)
EIV_BACKBONES = ("iwan", "jenkins")


def sample_residual(model_omega_zeta, samples: ModalSamples, frequency_std: float, damping_std: float) -> NDArray:
    """Weighted relative misfits of ``samples`` (a
    :class:`~nlupdate.core.identification.modal_samples.ModalSamples`, which imports this
    module) about the curves ``model_omega_zeta(a) → (ω, ζ)``:
    frequencies over ``frequency_std``, then damping ratios over ``damping_std`` (non-finite: 1e6)."""
    omega, zeta = model_omega_zeta(samples.amplitude)
    r_f = (omega / (2 * np.pi * samples.frequency_hz) - 1) / frequency_std
    r_z = (zeta / samples.damping_ratio - 1) / damping_std
    out = np.concatenate([r_f, r_z])
    return np.where(np.isfinite(out), out, 1e6)


#: a model's curves at n amplitudes and their derivatives, for the residuals' Jacobians:
#: ω (rad/s), ζ, ∂ω/∂θ and ∂ζ/∂θ (n, p) in the model's p unknowns θ, then ∂ω/∂a and ∂ζ/∂a
Curves = tuple[NDArray, NDArray, NDArray, NDArray, NDArray, NDArray]


def _finite_rows(jacobian: NDArray, residual: NDArray) -> NDArray:
    """``jacobian`` with the rows of residuals that are not finite (set to 1e6, a constant) and
    any entry that is not finite at 0."""
    return np.where(np.isfinite(residual)[:, None] & np.isfinite(jacobian), jacobian, 0.0)


def sample_residual_jacobian(curves: Curves, samples: ModalSamples, frequency_std: float | NDArray, damping_std: float | NDArray,
                             shape: bool = False) -> NDArray:
    """∂/∂θ of :func:`sample_residual` (rows as its values), ``curves`` (:data:`Curves`) taken at
    the samples' amplitudes. With ``shape``, one more column: ∂/∂ln φ_f of samples from FRFs,
    whose a ∝ 1/φ_f and ζ_i ∝ φ_f²
    (:meth:`~nlupdate.core.identification.modal_samples.ModalSamples.with_shape`)."""
    omega, zeta, d_omega, d_zeta, omega_a, zeta_a = curves
    w_f = 1 / (2 * np.pi * samples.frequency_hz * frequency_std)
    w_z = 1 / (samples.damping_ratio * damping_std)
    if shape:
        a = samples.amplitude
        d_omega = np.column_stack([d_omega, -a * omega_a])
        d_zeta = np.column_stack([d_zeta, -a * zeta_a - 2 * zeta])
    residual = np.concatenate([omega * w_f, zeta * w_z])
    return _finite_rows(np.vstack([d_omega * w_f[:, None], d_zeta * w_z[:, None]]), residual)


def amplitude_std(kinds: Sequence[str], damping_std: NDArray) -> NDArray:
    """Each sample's relative amplitude noise from its test type ``kinds`` and its damping
    ratio's relative standard deviation (:data:`NOISY_AMPLITUDE_SHARE`; 0 for the others)."""
    share = np.array([NOISY_AMPLITUDE_SHARE.get(kind, 0.0) for kind in kinds])
    return share * np.broadcast_to(np.asarray(damping_std, float), share.shape)


def locked_frequency_std(kinds: Sequence[str], frequency_std: NDArray) -> NDArray:
    """Each sample's relative frequency noise for the errors-in-variables fit: the locked
    frequency's (:data:`LOCKED_FREQUENCY_STD`) where its type has one, else ``frequency_std``."""
    f_std = np.broadcast_to(np.asarray(frequency_std, float), (len(kinds),))
    locked = np.array([LOCKED_FREQUENCY_STD.get(kind, np.nan) for kind in kinds])
    return np.where(np.isfinite(locked), locked, f_std)


def noisy_residual(omega_zeta: Callable[[NDArray], tuple[NDArray, NDArray]], amplitude: NDArray,
                   frequency_hz: NDArray, damping_ratio: NDArray, log_true: NDArray, noisy: NDArray,
                   frequency_std: NDArray, damping_std: NDArray, amplitude_std: NDArray) -> NDArray:
    """Weighted misfits of samples (a, f Hz, ζ) about the curves ``omega_zeta(a) → (ω rad/s, ζ)``
    with the true amplitudes of the samples ``noisy`` (a boolean mask) at ``exp(log_true)``
    (module docstring): frequencies, then damping ratios (force over the response's share for
    the noisy ones), then the noisy samples' amplitudes; non-finite values 1e6."""
    at = amplitude.copy()
    at[noisy] = np.exp(log_true)
    omega, zeta = omega_zeta(at)
    r_f = (omega / (2 * np.pi * frequency_hz) - 1) / frequency_std
    force_std = np.sqrt(np.maximum(damping_std**2 - amplitude_std**2, 0.0))
    r_z = np.where(noisy, (zeta * at / (damping_ratio * amplitude) - 1) / np.where(noisy, force_std, 1.0),
                   (zeta / damping_ratio - 1) / damping_std)
    r_a = (at[noisy] / amplitude[noisy] - 1) / amplitude_std[noisy]
    out = np.concatenate([r_f, r_z, r_a])
    return np.where(np.isfinite(out), out, 1e6)


def noisy_residual_jacobian(curves: Curves, amplitude: NDArray, frequency_hz: NDArray, damping_ratio: NDArray,
                            log_true: NDArray, noisy: NDArray, frequency_std: NDArray, damping_std: NDArray,
                            amplitude_std: NDArray) -> NDArray:
    """∂/∂(θ, log_true) of :func:`noisy_residual` (rows as its values), ``curves``
    (:data:`Curves`) taken at the amplitudes it evaluates (the noisy samples' at ``exp(log_true)``)."""
    omega, zeta, d_omega, d_zeta, omega_a, zeta_a = curves
    at = amplitude.copy()
    at[noisy] = np.exp(log_true)
    n, m = amplitude.size, int(np.count_nonzero(noisy))
    w_f = 1 / (2 * np.pi * frequency_hz * frequency_std)
    force_std = np.sqrt(np.maximum(damping_std**2 - amplitude_std**2, 0.0))
    w_z = np.where(noisy, at / (damping_ratio * amplitude * np.where(noisy, force_std, 1.0)),
                   1 / (damping_ratio * damping_std))  # ∂r_z/∂ζ
    own = np.zeros((n, m))  # each noisy sample's column: its own rows only
    own[np.flatnonzero(noisy), np.arange(m)] = 1.0
    alpha = at[noisy]
    rows_f = np.hstack([d_omega * w_f[:, None], own * (omega_a * at * w_f)[:, None]])
    rows_z = np.hstack([d_zeta * w_z[:, None], own * ((zeta_a * at + zeta) * w_z)[:, None]])
    rows_a = np.hstack([np.zeros((m, d_omega.shape[1])), np.diag(alpha / (amplitude[noisy] * amplitude_std[noisy]))])
    residual = np.concatenate([omega * w_f, zeta * w_z, alpha])
    return _finite_rows(np.vstack([rows_f, rows_z, rows_a]), residual)


def sample_noise(kinds: Sequence[str], sizes: Sequence[int], noises: Sequence[tuple[float, float]],
                 errors_in_variables: bool) -> tuple[NDArray, NDArray, NDArray | None]:
    """Per-sample relative (frequency, damping ratio, amplitude) standard deviations of sources of
    test types ``kinds`` with ``sizes`` samples and (frequency, damping) noise ``noises`` each, in
    order; with ``errors_in_variables`` (the :data:`EIV_BACKBONES` fits) the noisy amplitudes
    and locked frequencies of the module docstring, else None for the amplitudes."""
    each = np.repeat(np.asarray(kinds, dtype=object), sizes)
    f_std, z_std = (np.repeat([n[k] for n in noises], sizes).astype(float) for k in (0, 1))
    if not errors_in_variables or not any(kind in NOISY_AMPLITUDE_SHARE for kind in kinds):
        return f_std, z_std, None
    return locked_frequency_std(list(each), f_std), z_std, amplitude_std(list(each), z_std)
