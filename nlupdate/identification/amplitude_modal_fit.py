"""Identify an amplitude-dependent modal model (:mod:`nlupdate.model.amplitude_modal`) of one mode.

Two kinds of data give samples ``(a_i, ω_i, ζ_i)`` of the backbone and damping curve, with
the mass-normalised shape φ_f (1/√kg) of the mode at the excited coordinate:

* a **modal table** (:mod:`nlupdate.measurement.modal_table`: natural frequency and damping
  ratio of the mode per force level, as a phase-resonance or one-mode analysis gives them):
  at phase resonance ``2ζω² a = |φ_f| F``, so ``a_i = |φ_f| F_i / (2ζ_i ω_i²)``;
* **FRFs at several levels** (driving point): each level's resonance — the peak of |H|
  after removing the other modes' share ``R − R_m/Ω²`` found by a one-mode fit of the
  lowest level (:func:`~nlupdate.identification.modal_fit.fit_mode_near`) — gives one
  sample: ω_i the peak frequency, x_i = |H_peak|F_i the amplitude there, ``a_i = x_i/|φ_f|``
  and ``ζ_i = φ_f²F_i/(2ω_i²x_i)`` (at resonance |H| = φ_f²/(2ζω²)). The points off the peak
  are not used: where a stiff joint changes the mode's shape between stuck and slipping,
  single-mode theory holds at the resonance but not on the flanks (the bolted-beam example's
  exact modal model misses its flanks by 21 % rms, its peaks by ≤ 1.1 %). Without a given
  φ_f an Iwan fit fits φ_f with the backbone (the joint's damping is tied to its softening,
  which fixes the scale of a); a polynomial one uses the lowest level's modal constant.

The backbone is then fitted by weighted least squares of the relative errors of ω and ζ
(standard deviations ``frequency_std`` and ``damping_std``, relative):

* ``polynomial`` of ``order`` (linear least squares for f₀, c_k and ζ₀, d_k);
* ``iwan``: ω₀, ζ₀ and the modal joint (K_T < ω₀², F_S, χ, β), from several starts, with
  viscous and with structural linear damping (the better fit is kept; the note says). As for
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
from nlupdate.model.amplitude_modal import BACKBONES, LINEAR_DAMPING, AmplitudeModalModel, AmplitudeModelError
from nlupdate.model.elements import IwanJoint


@dataclass(frozen=True, eq=False)
class ModalSamples:
    """Samples of one mode's backbone: modal amplitude a (m·√kg), natural frequency (Hz),
    damping ratio and the force level (N) each came from; ``input_shape`` φ_f (1/√kg).

    From FRFs, ``response_amplitude`` holds the resonance amplitude x (m) at the excited
    coordinate, so that a = x/φ_f and ζ = φ_f²F/(2ω²x) follow for any φ_f (:meth:`with_shape`),
    and ``shape_free`` says φ_f was not given (an Iwan fit then fits it)."""

    amplitude: NDArray[np.float64]
    frequency_hz: NDArray[np.float64]
    damping_ratio: NDArray[np.float64]
    force_n: NDArray[np.float64]
    input_shape: float
    response_amplitude: NDArray[np.float64] | None = None
    shape_free: bool = False

    def with_shape(self, input_shape: float) -> "ModalSamples":
        """The same FRF samples for another φ_f (1/√kg)."""
        if self.response_amplitude is None:
            raise AmplitudeModelError("only samples from FRFs (with their response amplitudes) can change their shape")
        phi, x, omega = abs(float(input_shape)), self.response_amplitude, 2 * np.pi * self.frequency_hz
        return ModalSamples(x / phi, self.frequency_hz, phi**2 * self.force_n / (2 * omega**2 * x), self.force_n, phi,
                            x, self.shape_free)


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
                      band_fraction: float = 0.1) -> ModalSamples:
    """One backbone sample per force level from driving-point FRFs (module docstring): the
    resonance of each level (peak of |H| within ``band_fraction`` of the lowest level's
    resonance near ``near_hz``, refined by a parabola), after removing the other modes' share."""
    if data.response_dof != data.input_dof:
        raise AmplitudeModelError(f"FRFs of response {data.response_dof!r} / input {data.input_dof!r}: the samples "
                                  "need the driving-point FRF")
    f_low, h_low = data.frequencies[0], data.receptances[0]
    start = float(f_low[np.argmax(np.abs(h_low))]) if near_hz is None else float(near_hz)
    fit = fit_mode_near(f_low, h_low, start, band_fraction=band_fraction)
    centre = float(fit.natural_frequencies_hz[0])
    shape_free = input_shape is None
    if shape_free:
        constant = complex(fit.modal_constants[0])
        if not constant.real > 0:
            raise AmplitudeModelError(f"the one-mode fit of the {data.levels[0]:g} N FRF gives a modal constant "
                                      f"{constant:.4g}; give input_shape")
        input_shape = float(np.sqrt(constant.real))
    peak_hz, peak_x, forces = [], [], []
    for level, f, h in zip(data.levels, data.frequencies, data.receptances):
        band = np.abs(f - centre) <= 2.5 * band_fraction * centre
        fb = f[band]
        hb = np.abs(h[band] - fit.residual_receptance(fb))
        if fb.size < 3:
            continue
        i = int(np.clip(np.argmax(hb), 1, fb.size - 2))
        y0, y1, y2 = hb[i - 1 : i + 2]
        curvature = y0 - 2 * y1 + y2
        shift = float(np.clip(0.5 * (y0 - y2) / curvature, -1, 1)) if curvature < 0 else 0.0
        peak_hz.append(fb[i] + shift * 0.5 * (fb[i + 1] - fb[i - 1]))
        peak_x.append((y1 - 0.25 * (y0 - y2) * shift) * float(level))
        forces.append(float(level))
    if len(forces) < 2:
        raise AmplitudeModelError("fewer than two force levels show the resonance; measure around it at two or more levels")
    x, frequency, force = np.array(peak_x), np.array(peak_hz), np.array(forces)
    phi = abs(float(input_shape))
    omega = 2 * np.pi * frequency
    return ModalSamples(x / phi, frequency, phi**2 * force / (2 * omega**2 * x), force, phi, x, shape_free)


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


def _iwan_model(theta: NDArray, shapes, fixed: dict[str, float], mode: int, damping: str) -> AmplitudeModalModel:
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
    return AmplitudeModalModel(w0 / (2 * np.pi), z0, shapes, joint=joint, mode=mode, linear_damping=damping)


def _iwan(samples: ModalSamples, shapes, frequency_std: float, damping_std: float, mode: int, damping: str,
          fixed: dict[str, float] | None = None) -> tuple[AmplitudeModalModel, float]:
    """Best Iwan backbone over the starts; with ``samples.shape_free`` the shape φ_f (the last
    unknown, as a log) is fitted too and the model's shapes carry it."""
    fixed = fixed or {}
    free_shape = samples.shape_free and samples.response_amplitude is not None
    if free_shape:
        def unpack(t):
            phi = float(np.exp(t[-1]))
            return _iwan_model(t[:-1], ((shapes[0][0], phi),), fixed, mode, damping), samples.with_shape(phi)
    else:
        def unpack(t):
            return _iwan_model(t, shapes, fixed, mode, damping), samples
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
                    if free_shape:
                        theta.append(np.log(samples.input_shape))

                    def residual(t):
                        try:
                            model, data = unpack(t)
                        except (ValueError, OverflowError):
                            return np.full(2 * samples.amplitude.size, 1e6)
                        with np.errstate(all="ignore"):
                            return _residual(model.omega_zeta, data, frequency_std, damping_std)

                    solution = scipy.optimize.least_squares(residual, np.array(theta), method="trf", max_nfev=400)
                    if best is None or solution.cost < best.cost:
                        best = solution
    return unpack(best.x)[0], float(2 * best.cost)


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
    fits = [(*_iwan(samples, shapes, frequency_std, damping_std, mode, law), law) for law in LINEAR_DAMPING]
    model, chi2, law = min(fits, key=lambda fit: fit[1])
    fitted_shape = samples.shape_free and samples.response_amplitude is not None
    if fitted_shape:  # the fitted φ_f sets the amplitudes of every sample from here on
        samples = samples.with_shape(model.shapes[0][1])
        samples = ModalSamples(samples.amplitude, samples.frequency_hz, samples.damping_ratio, samples.force_n,
                               samples.input_shape, samples.response_amplitude, shape_free=False)
        shapes = model.shapes
    a_max = float(np.max(samples.amplitude))
    n = 2 * samples.amplitude.size
    if a_max < MACROSLIP_REACH * model.joint.phi_max or n <= 6:
        reach = a_max / model.joint.phi_max
        model, chi2 = _iwan(samples, shapes, frequency_std, damping_std, mode, law, {"beta": 0.0, "phi_max": a_max})
        note = (f"no sample reaches the joint's macroslip (largest modal amplitude {a_max:.4g} m·√kg, {reach:.2g} × "
                f"the φ_max of a free fit; {MACROSLIP_REACH:g} × needed) or too few samples: the data determine chi "
                f"and R' only; fixed beta = 0 and phi_max = the largest amplitude, so kt and slip_force are lower "
                f"bounds")
    else:
        note = "modal Iwan backbone, all parameters fitted"
    others = ", ".join(f"{other} {c:.3g}" for _, c, other in fits if other != law)
    note += f"; {law} linear damping (chi² {chi2:.3g} for {n} values; {others})"
    if fitted_shape:
        note += (f"; the mode shape at the excited coordinate fitted with the backbone: {shapes[0][1]:.4g} 1/√kg "
                 f"(the Iwan joint ties its damping to its softening, which fixes the amplitude scale)")
    return AmplitudeModalModel(model.natural_frequency_hz, model.damping_ratio, shapes, joint=model.joint, mode=mode,
                               linear_damping=law, note=note)


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
    driving-point FRFs at several levels, one sample per level (:func:`samples_from_frfs`).

    Without ``input_shape`` an Iwan backbone fits the shape φ_f too; a polynomial one takes
    the lowest level's one-mode fit, which is the *stuck* mode's shape — with a stiff joint it
    differs from the shape the joint slips in (T-beam example: 2.63 against 2.79 1/√kg)."""
    samples = samples_from_frfs(data, input_shape, near_hz)
    return fit_amplitude_model(samples, ((data.input_dof, samples.input_shape),), backbone, order,
                               frequency_std=1e-3, damping_std=0.05, mode=mode)
