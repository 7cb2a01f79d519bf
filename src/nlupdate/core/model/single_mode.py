"""The forced response of one nonlinear mode: the one form every caller uses.

Single-nonlinear-mode theory (docs/methods.md §9, :mod:`nlupdate.core.model.amplitude_modal`):
the mass-normalised mode (shape φ in 1/√kg, modal amplitude a = |q| in m·√kg) forced at
coordinate f by ``Re(F e^{iΩt})`` (F in N, Ω in rad/s) obeys ``D(a, Ω)·q = φ_f F`` with ::

    D(a, Ω) = ω(a)² − Ω² + 2i[ζ(a)ω(a)² + ζ_v(a)ω(a)(Ω − ω(a))]        (rad²/s²)

and the receptance between coordinates j and k is ``H_jk = φ_jφ_k/D + R_jk`` (m/N), R the
other modes' share (residual terms, m/N).

Convention. ω(a) (rad/s) is the natural frequency and ζ(a) (fraction) the damping ratio at
amplitude a, defined so that at resonance (Ω = ω(a)) the imaginary part is ``2ζω²`` whatever
the damping's kind — there ζ is the viscous damping ratio. Away from resonance the damping is
hysteretic (a damping force proportional to the amplitude, in phase with the velocity,
dissipating the same energy per cycle at any Ω) except the share ζ_v(a) ≤ ζ(a) that is
viscous (a damping force proportional to the velocity, growing with Ω). A friction joint's
describing function is hysteretic (its dissipation per cycle depends on the amplitude alone),
so ζ_v is zero unless the model declares a viscous part of the rest of the structure's
damping (:meth:`~nlupdate.core.model.amplitude_modal.AmplitudeModalModel.viscous_damping`);
``ζ_v = ζ`` is the all-viscous form ``2iζωΩ``, which on a flank at half the peak
(Ω/ω ≈ 1 ± 1.7ζ) puts the joint's damping term about ±1.7ζ (relative) off.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: fixed-point steps of :func:`excitation_frequencies` for a viscous share
_VISCOUS_STEPS = 8


def dynamic_stiffness(omega: ArrayLike, natural: ArrayLike, zeta: ArrayLike,
                      viscous: ArrayLike = 0.0) -> NDArray[np.complex128]:
    """``D = ω² − Ω² + 2i[ζω² + ζ_v ω(Ω − ω)]`` (rad²/s², per unit modal mass; module
    docstring) at excitation ``omega`` Ω (rad/s) for the mode's ``natural`` frequency ω
    (rad/s), damping ratio ``zeta`` ζ and its viscous share ``viscous`` ζ_v (fractions),
    broadcast against each other."""
    w, z, v = (np.asarray(x, dtype=float) for x in (natural, zeta, viscous))
    big = np.asarray(omega, dtype=float)
    return w**2 - big**2 + 2j * (z * w**2 + v * w * (big - w))


def receptance(omega: ArrayLike, natural: ArrayLike, zeta: ArrayLike, shape_response: float, shape_input: float,
               residual: ArrayLike = 0.0, viscous: ArrayLike = 0.0) -> NDArray[np.complex128]:
    """The single-nonlinear-mode receptance ``φ_jφ_k/D + R`` (m/N; module docstring):
    ``shape_response`` φ_j and ``shape_input`` φ_k (1/√kg), ``residual`` R (m/N, the other
    modes' share at each Ω), ω, ζ, ζ_v at the modal amplitude of each line (see
    :func:`dynamic_stiffness`)."""
    return float(shape_response) * float(shape_input) / dynamic_stiffness(omega, natural, zeta, viscous) + residual


def natural_and_damping(stiffness: ArrayLike, omega: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The inverse of :func:`dynamic_stiffness` with no viscous share: (ω rad/s, ζ) from a
    measured ``D = φ_f²/H_mode`` at excitation Ω (rad/s): ``ω² = Re D + Ω²``,
    ``ζ = Im D/(2ω²)``; NaN where ``Re D + Ω² ≤ 0``."""
    d, big = np.asarray(stiffness, dtype=complex), np.asarray(omega, dtype=float)
    w_sq = d.real + big**2
    w_sq = np.where(w_sq > 0, w_sq, np.nan)
    return np.sqrt(w_sq), d.imag / (2 * w_sq)


def resonance_discriminant(modal_force: float, amplitude: ArrayLike, natural: ArrayLike,
                           zeta: ArrayLike) -> NDArray[np.float64]:
    """``P² − 4ζ²ω⁴`` with ``P = |φ_f F|/a`` (rad⁴/s⁴): ≥ 0 where the amplitude a (m·√kg) is
    reached at some Ω — the peak of a hysteretic mode is at Ω = ω, where |D| = 2ζω²."""
    a, w, z = (np.asarray(x, dtype=float) for x in (amplitude, natural, zeta))
    return (modal_force / a) ** 2 - 4 * z**2 * w**4


def excitation_frequencies(modal_force: float, amplitude: ArrayLike, natural: ArrayLike, zeta: ArrayLike,
                           viscous: ArrayLike = 0.0) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(below, above): the excitation frequencies Ω (rad/s) at which the modal force
    ``|φ_f F|`` (N/√kg) holds the modal amplitude a (m·√kg), ``a·|D(a, Ω)| = |φ_f F|``, on
    either side of resonance; NaN where there is none (above the peak). Without a viscous
    share ``Ω² = ω² ∓ √(P² − 4ζ²ω⁴)``; with one, that form with the imaginary part taken at
    the current Ω, iterated (a contraction of factor about ζ_v away from the peak; a point
    that does not settle to 1e-9 is NaN: within about ζζ_v of the peak's amplitude)."""
    a, w, z, v = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (amplitude, natural, zeta, viscous)))
    p_sq = (modal_force / a) ** 2
    out = []
    for sign in (-1.0, 1.0):
        big = w.copy()
        for _ in range(_VISCOUS_STEPS if np.any(v) else 1):
            imag = 2 * (z * w**2 + v * w * (big - w))
            root = np.sqrt(np.where(p_sq >= imag**2, p_sq - imag**2, np.nan))
            square = w**2 + sign * root
            big = np.sqrt(np.where(square > 0, square, np.nan))
        if np.any(v):
            settled = np.abs(a * np.abs(dynamic_stiffness(big, w, z, v)) / modal_force - 1) < 1e-9
            big = np.where(settled, big, np.nan)
        out.append(big)
    return out[0], out[1]
