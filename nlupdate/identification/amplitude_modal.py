"""Identify an amplitude-dependent modal model (:mod:`nlupdate.model.amplitude_modal`) of one mode.

Two kinds of data give samples ``(a_i, ω_i, ζ_i)`` of the backbone and damping curve, with
the mass-normalised shape φ_f (1/√kg) of the mode at the excited coordinate:

* a **modal table** (:mod:`nlupdate.measurement.modal_table`: natural frequency and damping
  ratio of the mode per force level, as a phase-resonance or one-mode analysis gives them):
  at phase resonance ``2ζω² a = |φ_f| F``, so ``a_i = |φ_f| F_i / (2ζ_i ω_i²)``;
* **FRFs at several levels** (driving point): every point near the resonance inverts the
  single-mode relation, ``φ_f²/H = ω(a)² − Ω² + 2iζ(a)ω(a)Ω`` with ``a = |H|F/|φ_f|``::

      ω_i² = Re(φ_f²/H_i) + Ω_i²,    ζ_i = Im(φ_f²/H_i) / (2ω_iΩ_i).

  Points whose |H| is at least ``peak_share`` of their level's peak are used (off
  resonance the other modes and the noise dominate). Without a given φ_f, φ_f² is the
  modal constant of a one-mode fit of the lowest level
  (:func:`~nlupdate.identification.modal_fit.fit_mode_near`), where the joint barely moves.

The backbone is then fitted by weighted least squares of the relative errors of ω and ζ
(standard deviations ``frequency_std`` and ``damping_std``, relative):

* ``polynomial`` of ``order`` (linear least squares for f₀, c_k and ζ₀, d_k);
* ``iwan``: ω₀, ζ₀ and the modal joint (K_T < ω₀², F_S, χ, β), from several starts. As for
  a PRD fit (:func:`~nlupdate.identification.dfmodels.iwan_identifiability`), amplitudes
  that stay below ``MACROSLIP_REACH × φ_max`` show only χ and R' of the joint; the fit is
  then repeated with β = 0 and φ_max at the largest amplitude (the smallest joint that
  keeps every sample in microslip) and the model's ``note`` says so.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
import pandas as pd
import scipy.optimize
import scipy.special
from numpy.typing import NDArray

from nlupdate.identification.data import FRFLevels
from nlupdate.identification.dfmodels import MACROSLIP_REACH
from nlupdate.identification.modal_fit import fit_mode_near
from nlupdate.measurement.modal_table import validate_modal_table
from nlupdate.model.amplitude_modal import BACKBONES, AmplitudeModalModel, AmplitudeModelError
from nlupdate.model.elements import IwanJoint


@dataclass(frozen=True, eq=False)
class ModalSamples:
    """Samples of one mode's backbone: modal amplitude a (m·√kg), natural frequency (Hz),
    damping ratio and the force level (N) each came from; ``input_shape`` φ_f (1/√kg)."""

    amplitude: NDArray[np.float64]
    frequency_hz: NDArray[np.float64]
    damping_ratio: NDArray[np.float64]
    force_n: NDArray[np.float64]
    input_shape: float


def samples_from_modal_table(table: pd.DataFrame, input_shape: float, mode: int = 1,
                             source: str = "<modal table>") -> ModalSamples:
    """Backbone samples of ``mode`` from a modal table (phase resonance: module docstring)."""
    clean = validate_modal_table(table, source)
    rows = clean[clean["mode"] == int(mode)]
    if len(rows) < 2:
        raise AmplitudeModelError(f"{source}: mode {mode} appears at {len(rows)} force level(s); an amplitude-dependent "
                                  "model needs two or more")
    if not (np.isfinite(input_shape) and input_shape != 0):
        raise AmplitudeModelError(f"input_shape: the mass-normalised mode shape at the excited coordinate (1/√kg, ≠ 0), "
                                  f"got {input_shape}")
    force = rows["force_level_n"].to_numpy(dtype=float)
    frequency = rows["natural_frequency_hz"].to_numpy(dtype=float)
    zeta = rows["damping_ratio"].to_numpy(dtype=float)
    if np.any(zeta <= 0):
        raise AmplitudeModelError(f"{source}: mode {mode} has a damping ratio of 0; the phase-resonance amplitude "
                                  "|φ_f|F/(2ζω²) needs ζ > 0")
    amplitude = abs(input_shape) * force / (2 * zeta * (2 * np.pi * frequency) ** 2)
    return ModalSamples(amplitude, frequency, zeta, force, abs(float(input_shape)))


def samples_from_frfs(data: FRFLevels, input_shape: float | None = None, near_hz: float | None = None,
                      peak_share: float = 0.5) -> ModalSamples:
    """Backbone samples from driving-point FRFs at several levels (module docstring)."""
    if data.response_dof != data.input_dof:
        raise AmplitudeModelError(f"FRFs of response {data.response_dof!r} / input {data.input_dof!r}: the samples "
                                  "need the driving-point FRF")
    if not 0 < peak_share < 1:
        raise AmplitudeModelError(f"peak_share must be in (0, 1), got {peak_share}")
    f_low, h_low = data.frequencies[0], data.receptances[0]
    if input_shape is None:
        start = float(f_low[np.argmax(np.abs(h_low))]) if near_hz is None else float(near_hz)
        fit = fit_mode_near(f_low, h_low, start, band_fraction=0.1)
        constant = complex(fit.modal_constants[0])
        if not constant.real > 0:
            raise AmplitudeModelError(f"the one-mode fit of the {data.levels[0]:g} N FRF gives a modal constant "
                                      f"{constant:.4g}; give input_shape")
        input_shape = float(np.sqrt(constant.real))
    phi2 = float(input_shape) ** 2
    samples = []
    for level, f, h in zip(data.levels, data.frequencies, data.receptances):
        use = np.abs(h) >= peak_share * np.max(np.abs(h))
        omega = 2 * np.pi * f[use]
        z = phi2 / h[use]
        w2 = z.real + omega**2
        ok = w2 > 0
        w = np.sqrt(np.where(ok, w2, 1.0))
        zeta = z.imag / (2 * w * omega)
        amplitude = np.abs(h[use]) * float(level) / abs(float(input_shape))
        keep = ok & (zeta > 0)
        samples.append(np.column_stack([amplitude[keep], w[keep] / (2 * np.pi), zeta[keep], np.full(keep.sum(), level)]))
    stacked = np.concatenate(samples)
    if stacked.shape[0] < 4:
        raise AmplitudeModelError("fewer than 4 FRF points near the resonance; measure closer to it")
    return ModalSamples(stacked[:, 0], stacked[:, 1], stacked[:, 2], stacked[:, 3], abs(float(input_shape)))


# ---------------------------------------------------------------------------------- fitting
def _residual(model_omega_zeta, samples: ModalSamples, frequency_std: float, damping_std: float) -> NDArray:
    omega, zeta = model_omega_zeta(samples.amplitude)
    r_f = (omega / (2 * np.pi * samples.frequency_hz) - 1) / frequency_std
    r_z = (zeta / samples.damping_ratio - 1) / damping_std
    out = np.concatenate([r_f, r_z])
    return np.where(np.isfinite(out), out, 1e6)


def _polynomial(samples: ModalSamples, shapes, order: int, frequency_std: float, damping_std: float,
                mode: int) -> AmplitudeModalModel:
    a_ref = float(np.max(samples.amplitude))
    x = samples.amplitude / a_ref
    design = x[:, None] ** np.arange(order + 1)[None, :]
    # f_i = f₀ + Σ f₀c_k x^k: linear in (f₀, f₀c_k), weights 1/(σ_f f_i); ζ likewise
    wf = 1 / (frequency_std * samples.frequency_hz)
    coefficients_f = np.linalg.lstsq(design * wf[:, None], samples.frequency_hz * wf, rcond=None)[0]
    wz = 1 / (damping_std * samples.damping_ratio)
    coefficients_z = np.linalg.lstsq(design * wz[:, None], samples.damping_ratio * wz, rcond=None)[0]
    f0, z0 = float(coefficients_f[0]), float(coefficients_z[0])
    return AmplitudeModalModel(f0, max(z0, 0.0), shapes, frequency_coefficients=tuple(coefficients_f[1:] / f0),
                               damping_coefficients=tuple(coefficients_z[1:]), reference_amplitude=a_ref, mode=mode,
                               note=f"polynomial backbone of order {order} fitted to amplitudes up to {a_ref:.4g} m·√kg")


def _iwan_model(theta: NDArray, shapes, fixed: dict[str, float], mode: int) -> AmplitudeModalModel:
    """Model from unknowns: log ω₀, log ζ₀, logit(K_T/ω₀²), then (log F_S or fixed φ_max),
    logit(−χ) (χ ∈ (−1, 0)), log β (or fixed)."""
    values = iter(theta)
    w0 = float(np.exp(next(values)))
    z0 = float(np.exp(next(values)))
    kt = float(scipy.special.expit(next(values))) * w0**2
    slip = None if "phi_max" in fixed else float(np.exp(next(values)))
    chi = -float(np.clip(scipy.special.expit(next(values)), 1e-9, 1 - 1e-9))
    beta = fixed["beta"] if "beta" in fixed else float(np.exp(next(values)))
    if slip is None:
        slip = fixed["phi_max"] * kt * (beta + (chi + 1) / (chi + 2)) / (1 + beta)
    joint = IwanJoint((0,), slip_force=slip, kt=kt, chi=chi, beta=beta)
    return AmplitudeModalModel(w0 / (2 * np.pi), z0, shapes, joint=joint, mode=mode)


def _iwan(samples: ModalSamples, shapes, frequency_std: float, damping_std: float, mode: int,
          fixed: dict[str, float] | None = None) -> tuple[AmplitudeModalModel, float]:
    fixed = fixed or {}
    z_low = float(samples.damping_ratio[np.argmin(samples.amplitude)])
    a_max = float(np.max(samples.amplitude))
    w0 = 2 * np.pi * float(np.max(samples.frequency_hz)) * 1.001
    best = None
    for share in (0.05, 0.3):
        for reach in (1.0, 4.0):
            for chi in (-0.3, -0.7):
                for beta in ((0.1, 1.0) if "beta" not in fixed else (fixed["beta"],)):
                    kt = share * w0**2
                    phi_max = fixed.get("phi_max", reach * a_max)
                    slip = phi_max * kt * (beta + (chi + 1) / (chi + 2)) / (1 + beta)
                    theta = [np.log(w0), np.log(max(min(z_low, 0.5), 1e-5)), scipy.special.logit(share)]
                    if "phi_max" not in fixed:
                        theta.append(np.log(slip))
                    theta.append(scipy.special.logit(-chi))
                    if "beta" not in fixed:
                        theta.append(np.log(beta))

                    def residual(t):
                        try:
                            model = _iwan_model(t, shapes, fixed, mode)
                        except (ValueError, OverflowError):
                            return np.full(2 * samples.amplitude.size, 1e6)
                        with np.errstate(all="ignore"):
                            return _residual(model.omega_zeta, samples, frequency_std, damping_std)

                    solution = scipy.optimize.least_squares(residual, np.array(theta), method="trf", max_nfev=400)
                    if best is None or solution.cost < best.cost:
                        best = solution
    return _iwan_model(best.x, shapes, fixed, mode), float(2 * best.cost)


def fit_amplitude_model(samples: ModalSamples, shapes: Sequence[tuple[str, float]], backbone: str = "iwan",
                        order: int = 2, frequency_std: float = 1e-3, damping_std: float = 0.05,
                        mode: int = 1) -> AmplitudeModalModel:
    """The amplitude-dependent model of ``backbone`` fitted to ``samples`` (module docstring).

    ``shapes``: the mode's mass-normalised shape (1/√kg) at named coordinates, the excited
    one included (its magnitude must be the samples' ``input_shape``)."""
    if backbone not in BACKBONES:
        raise AmplitudeModelError(f"backbone must be one of {list(BACKBONES)}, got {backbone!r}")
    if frequency_std <= 0 or damping_std <= 0:
        raise AmplitudeModelError("frequency_std and damping_std must be > 0 (relative standard deviations)")
    shapes = tuple((str(n), float(v)) for n, v in shapes)
    if backbone == "polynomial":
        if not 1 <= int(order) < samples.amplitude.size:
            raise AmplitudeModelError(f"polynomial order {order}: need 1 ≤ order < {samples.amplitude.size} samples")
        return _polynomial(samples, shapes, int(order), frequency_std, damping_std, mode)
    if samples.amplitude.size < 3:
        raise AmplitudeModelError(f"an Iwan backbone needs at least 3 samples, got {samples.amplitude.size}")
    model, chi2 = _iwan(samples, shapes, frequency_std, damping_std, mode)
    a_max = float(np.max(samples.amplitude))
    n = 2 * samples.amplitude.size
    if a_max < MACROSLIP_REACH * model.joint.phi_max or n <= 6:
        reach = a_max / model.joint.phi_max
        model, chi2 = _iwan(samples, shapes, frequency_std, damping_std, mode, {"beta": 0.0, "phi_max": a_max})
        note = (f"no sample reaches the joint's macroslip (largest modal amplitude {a_max:.4g} m·√kg, {reach:.2g} × "
                f"the φ_max of a free fit; {MACROSLIP_REACH:g} × needed) or too few samples: the data determine chi "
                f"and R' only; fixed beta = 0 and phi_max = the largest amplitude, so kt and slip_force are lower "
                f"bounds; chi² = {chi2:.3g} for {n} values")
    else:
        note = f"modal Iwan backbone, all parameters fitted; chi² = {chi2:.3g} for {n} values"
    return AmplitudeModalModel(model.natural_frequency_hz, model.damping_ratio, shapes, joint=model.joint, mode=mode,
                               note=note)


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
                              order: int = 2, near_hz: float | None = None, peak_share: float = 0.5,
                              mode: int = 1) -> AmplitudeModalModel:
    """Fit the model of the mode near ``near_hz`` (default: the lowest level's peak) to
    driving-point FRFs at several levels."""
    samples = samples_from_frfs(data, input_shape, near_hz, peak_share)
    return fit_amplitude_model(samples, ((data.input_dof, samples.input_shape),), backbone, order,
                               frequency_std=1e-3, damping_std=0.05, mode=mode)


def modal_amplitude_table(samples: ModalSamples) -> pd.DataFrame:
    """The samples as a table (for plots and reports)."""
    return pd.DataFrame({"modal_amplitude": samples.amplitude, "natural_frequency_hz": samples.frequency_hz,
                         "damping_ratio": samples.damping_ratio, "force_level_n": samples.force_n})
