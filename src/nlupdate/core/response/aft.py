"""Alternating frequency–time (AFT) evaluation of element forces over one period.

Conventions
-----------
A periodic relative motion with H harmonics and a constant term, ``θ = ωt``,
``u(θ) = U₀ + Σ_{k=1}^{H} Re(U_k e^{ikθ})``, is held as the real coefficient vector
``c = [U₀, Re U₁, Im U₁, …, Re U_H, Im U_H]`` (length 2H + 1, metres). The element
force goes back to the same layout, ``G = [G₀, Re G₁, Im G₁, …]`` with ``G₀`` the mean
force and ``G_k = (1/π)∫₀^{2π} f(θ) e^{−ikθ} dθ`` (N) — for H = 1 and ``U₀ = 0`` this is
the describing-function convention ``G₁ = ν(|U₁|)·U₁`` of :mod:`nlupdate.core.model.elements`.

The scheme: N samples per period at ``θ_j = 2πj/N`` by an inverse real FFT of ``c``, the
time-domain force law at each sample, a real FFT back to ``G``. The Jacobian ``∂G/∂c``
goes through the same transform: the force tangents in time (``∂f/∂u`` and ``∂f/∂u'``,
``u' = du/dθ = u̇/ω``) times the synthesis matrices ``E = ∂u(θ_j)/∂c`` and ``E' = ∂u'(θ_j)/∂c``,
transformed column by column. Two elements need more than a pointwise law:

* Jenkins: the force is the steady-state hysteresis cycle of the return mapping over the
  period (passes repeated until the cycle closes); in stick
  ``f(θ) = ±Fs + kf (u(θ) − u(θ_a))`` with θ_a the last slip sample, so
  ``∂f(θ)/∂c = kf (E(θ) − E(θ_a))``, zero in slip. A cycle whose peak-to-peak motion stays
  below ``2Fs/kf`` sticks with the slider centred (the limit of the slipping cycle).
* Iwan: Masing's rules with memory on the samples (:func:`_iwan_branches`): every sample
  lies on a branch from a turning point o, ``f = F_o + 2 sgn(u − u_o) F_bb(|u − u_o|/2)``
  with the joint's backbone F_bb, and a turning point's force is built the same way from
  the one before it, down to the outer loop's ``±F_bb(a)`` at the global extremes
  (a = half the peak-to-peak motion; the sliders that never slip are centred, as for
  Jenkins). So ``∂f/∂c = ∂F_o/∂c + F_bb'(|u − u_o|/2)(E(θ) − E(θ_o))``, recursively.
  Exact for the continuous distribution (not the time-domain sliders); turning points
  are taken on the samples.
* Coulomb: ``Fs·sign(u̇)`` is piecewise constant, so samples would give a zero Jacobian.
  Its harmonics are integrated exactly between the zero crossings θ_c of u' (found on
  the samples, refined by Newton on the trigonometric polynomial) and differentiated
  through them, ``∂θ_c/∂c = −E'(θ_c)/u''(θ_c)``.

Aliasing: a force law with powers up to p needs ``N > (p + 1)·H`` for exact low harmonics;
non-smooth laws (gap, Jenkins, Iwan) converge with N. :func:`aliasing_change` measures it.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.model.elements import (
    CoulombFriction,
    CubicStiffness,
    IwanJoint,
    JenkinsFriction,
    PolynomialDF,
    QuadraticDamping,
    SymmetricGap,
    _cos_power_mean,
)


class Fourier:
    """Synthesis and analysis between ``2H + 1`` real coefficients and N time samples.

    Two equal routes: matrix products with the synthesis matrices ``E``, ``E'`` and the
    analysis matrix ``A`` (``c = A^T f``: ``A = E·diag(1/N, 2/N, …, 2/N)``), used for up to
    ``MATRIX_SIZE`` coefficients, where a few small products cost less than the FFT's
    set-up; real FFTs for more.
    """

    MATRIX_SIZE = 16

    def __init__(self, harmonics: int, samples: int) -> None:
        harmonics, samples = int(harmonics), int(samples)
        if harmonics < 1:
            raise ValueError(f"harmonics: expected an integer ≥ 1, got {harmonics}")
        if samples <= 2 * harmonics:
            raise ValueError(
                f"samples per period: {samples} cannot carry {harmonics} harmonics; need more than "
                f"2·H = {2 * harmonics} (and ≥ 4·H for cubic laws)"
            )
        self.harmonics, self.samples = harmonics, samples
        self.theta = 2 * np.pi * np.arange(samples) / samples
        k = np.arange(1, harmonics + 1)
        kt = np.outer(self.theta, k)
        self.E = np.empty((samples, 2 * harmonics + 1))
        self.E[:, 0] = 1.0
        self.E[:, 1::2], self.E[:, 2::2] = np.cos(kt), -np.sin(kt)
        self.dE = np.zeros_like(self.E)  # ∂/∂θ
        self.dE[:, 1::2], self.dE[:, 2::2] = -k * np.sin(kt), -k * np.cos(kt)
        self.A = self.E * np.r_[1.0, np.full(2 * harmonics, 2.0)] / samples
        self._matrices = self.size <= self.MATRIX_SIZE
        self._motion_synthesis = np.concatenate([self.E.T, self.dE.T], axis=1)  # (2H+1, 2N)

    @property
    def size(self) -> int:
        return 2 * self.harmonics + 1

    def to_time(self, c: NDArray) -> NDArray:
        """Samples (N, …) of the motion with coefficients ``c`` (2H+1, …)."""
        if self._matrices:
            return np.tensordot(self.E, c, axes=1)
        spectrum = np.zeros((self.samples // 2 + 1,) + c.shape[1:], dtype=complex)
        spectrum[0] = c[0] * self.samples
        spectrum[1 : self.harmonics + 1] = (c[1::2] + 1j * c[2::2]) * (self.samples / 2)
        return np.fft.irfft(spectrum, n=self.samples, axis=0)

    def motions(self, c: NDArray) -> tuple[NDArray, NDArray]:
        """Samples (P, N) of ``u`` and ``du/dθ`` for P coefficient vectors ``c`` (P, 2H+1)."""
        if self._matrices:
            both = c @ self._motion_synthesis
            return both[:, : self.samples], both[:, self.samples :]
        h = self.harmonics
        spectrum = np.zeros((c.shape[0], 2, self.samples // 2 + 1), dtype=complex)
        spectrum[:, 0, 0] = c[:, 0] * self.samples
        first = (c[:, 1::2] + 1j * c[:, 2::2]) * (self.samples / 2)
        spectrum[:, 0, 1 : h + 1] = first
        spectrum[:, 1, 1 : h + 1] = 1j * np.arange(1, h + 1) * first  # d/dθ: ik per harmonic
        samples = np.fft.irfft(spectrum, n=self.samples, axis=-1)
        return samples[:, 0], samples[:, 1]

    def harmonics_of(self, f: NDArray) -> NDArray:
        """Coefficients (…, 2H+1) of samples ``f`` (…, N) (the transform along the last axis)."""
        if self._matrices:
            return f @ self.A
        spectrum = np.fft.rfft(f, axis=-1)[..., : self.harmonics + 1] * (2.0 / self.samples)
        out = np.empty(f.shape[:-1] + (self.size,))
        out[..., 0] = spectrum[..., 0].real / 2
        out[..., 1::2], out[..., 2::2] = spectrum[..., 1:].real, spectrum[..., 1:].imag
        return out

    def to_harmonics(self, f: NDArray) -> NDArray:
        """Coefficients (2H+1, …) of samples ``f`` (N, …)."""
        if self._matrices:
            return np.tensordot(self.A.T, f, axes=1)
        spectrum = np.fft.rfft(f, axis=0)[: self.harmonics + 1] * (2.0 / self.samples)
        out = np.empty((self.size,) + f.shape[1:])
        out[0] = spectrum[0].real / 2
        out[1::2], out[2::2] = spectrum[1:].real, spectrum[1:].imag
        return out


@dataclass(frozen=True)
class PeriodForces:
    """One element over one period: harmonics G (2H+1,) (N), ∂G/∂c (2H+1, 2H+1) (N/m),
    ∂G/∂ω (2H+1,) (N·s/rad)."""

    g: NDArray
    dg_dc: NDArray
    dg_domega: NDArray


# -- pointwise laws: (u, u', ω) → (f, ∂f/∂u, ∂f/∂u', ∂f/∂ω); None for a part that is zero ----
def _cubic(e: CubicStiffness, u, up, w):
    u_sq = u * u
    return e.k3 * u_sq * u, 3 * e.k3 * u_sq, None, None


def _gap(e: SymmetricGap, u, up, w):
    engaged = np.abs(u) > e.gap
    return np.where(engaged, e.kc * (u - e.gap * np.sign(u)), 0.0), np.where(engaged, e.kc, 0.0), None, None


def _quadratic_damping(e: QuadraticDamping, u, up, w):
    law = up * np.abs(up)
    return e.cq * w**2 * law, None, 2 * e.cq * w**2 * np.abs(up), 2 * e.cq * w * law


def _polynomial_law(coefficients: tuple[float, ...], x: NDArray) -> tuple[NDArray, NDArray]:
    order = len(coefficients) - 1
    f, df = np.zeros_like(x), np.zeros_like(x)
    for index, coefficient in enumerate(coefficients):
        power = order - index
        if coefficient != 0.0:
            gain = coefficient / _cos_power_mean(power)
            f = f + gain * x * np.abs(x) ** power
            df = df + gain * (power + 1) * np.abs(x) ** power
    return f, df


def _polynomial(e: PolynomialDF, u, up, w):
    f_real, k_real = _polynomial_law(e.real, u)
    f_imag, k_imag = _polynomial_law(e.imag, up)
    return f_real + f_imag, k_real, k_imag, None


_POINTWISE: dict[type, Callable] = {
    CubicStiffness: _cubic,
    SymmetricGap: _gap,
    QuadraticDamping: _quadratic_damping,
    PolynomialDF: _polynomial,
}


def _pointwise_forces(law, element, c, omega, fourier: Fourier) -> PeriodForces:
    """Pointwise laws for P motions at once: ``c`` (P, 2H+1), ``omega`` (P,); results (P, …)."""
    u, up = fourier.motions(c)
    w = np.asarray(omega, dtype=float)[:, None]
    f, f_u, f_up, f_w = law(element, u, up, w)
    points = c.shape[0]
    signals = np.zeros((points, fourier.size + 2, fourier.samples))  # one transform for all columns
    signals[:, 0] = f
    if f_w is not None:
        signals[:, 1] = f_w
    if f_u is not None:
        signals[:, 2:] = f_u[:, None, :] * fourier.E.T
    if f_up is not None:
        signals[:, 2:] += f_up[:, None, :] * fourier.dE.T
    harmonics = fourier.harmonics_of(signals)  # (P, size+2, 2H+1)
    return PeriodForces(harmonics[:, 0], np.swapaxes(harmonics[:, 2:], 1, 2), harmonics[:, 1])


# -- Jenkins: steady hysteresis cycle ---------------------------------------------------------
def _jenkins_cycle(element: JenkinsFriction, u: NDArray) -> tuple[NDArray, NDArray]:
    """Force samples of the steady cycle and, per sample, the index of the last slip sample
    (−1 while slipping; −2 for a cycle that sticks throughout, centred)."""
    kf, fs = element.kf, element.slip_force
    n = u.size
    if np.ptp(u) <= 2 * fs / kf:
        return kf * (u - 0.5 * (u.max() + u.min())), np.full(n, -2)
    start = int(np.argmax(u))
    values = u.tolist()
    force, anchor = [0.0] * n, [-1] * n
    f_prev, u_prev, last = fs, values[start], start
    for _ in range(4):
        f_start = f_prev
        for step in range(1, n + 1):
            j = (start + step) % n
            trial = f_prev + kf * (values[j] - u_prev)
            if trial >= fs or trial <= -fs:
                f_prev, last, anchor[j] = (fs if trial > 0 else -fs), j, -1
            else:
                f_prev, anchor[j] = trial, last
            force[j], u_prev = f_prev, values[j]
        if abs(f_prev - f_start) <= 1e-12 * fs:
            break
    return np.array(force), np.array(anchor)


def _jenkins_forces(element: JenkinsFriction, c, omega, fourier: Fourier) -> PeriodForces:
    u = fourier.to_time(c)
    force, anchor = _jenkins_cycle(element, u)
    if anchor[0] == -2:
        centre = 0.5 * (fourier.E[np.argmax(u)] + fourier.E[np.argmin(u)])
        tangent = element.kf * (fourier.E - centre)
    else:
        stick = anchor >= 0
        tangent = np.zeros_like(fourier.E)
        tangent[stick] = element.kf * (fourier.E[stick] - fourier.E[anchor[stick]])
    return PeriodForces(fourier.to_harmonics(force), fourier.to_harmonics(tangent), np.zeros(fourier.size))


# -- Iwan: Masing hysteresis with memory ------------------------------------------------------
def _iwan_branches(element: IwanJoint, u: NDArray, fourier: Fourier):
    """The steady cycle of an Iwan joint on the samples ``u`` by Masing's rules.

    Returns, per sample, the index of its branch's turning point (the origin), and the
    force (N) and force gradient ``∂F/∂c`` (2H+1) at every turning point, keyed by sample.
    The cycle starts at the global maximum on the outer loop, whose turning points carry
    ``±F_bb(a)``, a = half the peak-to-peak motion; every later turning point j on a branch
    from origin o carries ``F_j = F_o + 2 sgn(u_j − u_o) F_bb(|u_j − u_o|/2)``; a branch that
    runs past the turning point before its origin closes that inner loop (both are dropped)
    and continues on the branch they interrupted."""
    n = u.size
    top, bottom = int(np.argmax(u)), int(np.argmin(u))
    half = 0.5 * (u[top] - u[bottom])
    f_half, t_half = (float(v) for v in element.backbone(half))
    outer = 0.5 * t_half * (fourier.E[top] - fourier.E[bottom])
    force = {bottom: -f_half, top: f_half}
    gradient = {bottom: -outer, top: outer}
    stack = [bottom, top]
    values = u.tolist()
    origin = np.empty(n, dtype=np.int64)
    origin[top] = top
    direction = -1.0
    previous = top
    for step in range(1, n):
        j = (top + step) % n
        value = values[j]
        if (value - values[previous]) * direction < 0:  # the previous sample is a turning point
            o = stack[-1]
            stretch = values[previous] - values[o]
            f_bb, t_bb = (float(v) for v in element.backbone(0.5 * abs(stretch)))
            force[previous] = force[o] + 2.0 * np.copysign(f_bb, stretch)
            gradient[previous] = gradient[o] + t_bb * (fourier.E[previous] - fourier.E[o])
            stack.append(previous)
            direction = -direction
        while len(stack) > 2 and (value - values[stack[-2]]) * direction > 0:  # an inner loop closes
            del stack[-2:]
        origin[j] = stack[-1]
        previous = j
    return origin, force, gradient


def _iwan_forces(element: IwanJoint, c, omega, fourier: Fourier) -> PeriodForces:
    u = fourier.to_time(c)
    origin, force_at, gradient_at = _iwan_branches(element, u, fourier)
    keys = np.array(sorted(force_at))
    slot = np.searchsorted(keys, origin)
    turning_force = np.array([force_at[k] for k in keys])
    turning_gradient = np.array([gradient_at[k] for k in keys])
    stretch = u - u[origin]
    f_bb, t_bb = element.backbone(0.5 * stretch)
    force = turning_force[slot] + 2.0 * f_bb
    tangent = turning_gradient[slot] + t_bb[:, None] * (fourier.E - fourier.E[origin])
    return PeriodForces(fourier.to_harmonics(force), fourier.to_harmonics(tangent), np.zeros(fourier.size))


# -- Coulomb: exact integration between velocity zero crossings -------------------------------
def _crossing_basis(theta: NDArray, fourier: Fourier) -> tuple[NDArray, NDArray]:
    """Rows ``∂u'(θ)/∂c`` and ``∂u''(θ)/∂c`` at the angles θ."""
    k = np.arange(1, fourier.harmonics + 1)
    kt = np.outer(theta, k)
    d1 = np.zeros((theta.size, fourier.size))
    d2 = np.zeros_like(d1)
    d1[:, 1::2], d1[:, 2::2] = -k * np.sin(kt), -k * np.cos(kt)
    d2[:, 1::2], d2[:, 2::2] = -(k**2) * np.cos(kt), k**2 * np.sin(kt)
    return d1, d2


def _velocity_crossings(c: NDArray, fourier: Fourier) -> tuple[NDArray, NDArray, NDArray]:
    """Zero crossings θ_c of u' = du/dθ (sorted), ``∂u'(θ_c)/∂c`` and u''(θ_c)."""
    none = (np.empty(0), np.empty((0, fourier.size)), np.empty(0))
    up = fourier.dE @ c
    if np.max(np.abs(up)) == 0.0:
        return none
    nxt = np.roll(up, -1)
    change = np.flatnonzero((up > 0) != (nxt > 0))
    if change.size == 0:
        return none
    h = 2 * np.pi / fourier.samples
    low = fourier.theta[change]
    theta = low + h * up[change] / (up[change] - nxt[change])
    for _ in range(8):  # Newton on the trigonometric polynomial, kept inside its bracket
        d1, d2 = _crossing_basis(theta, fourier)
        value, slope = d1 @ c, d2 @ c
        step = np.where(slope != 0, value / np.where(slope != 0, slope, 1.0), 0.0)
        theta = np.clip(theta - step, low, low + h)
        if np.max(np.abs(step)) < 1e-14:
            break
    d1, d2 = _crossing_basis(theta, fourier)
    return theta, d1, d2 @ c


def _coulomb_forces(element: CoulombFriction, c, omega, fourier: Fourier) -> PeriodForces:
    fs = element.slip_force
    size = fourier.size
    theta, d1, slope = _velocity_crossings(c, fourier)
    g, dg = np.zeros(size), np.zeros((size, size))
    if theta.size == 0:
        return PeriodForces(g, dg, np.zeros(size))
    sign_after = np.sign(slope)
    jump = 2 * sign_after  # s_after − s_before
    length = (np.roll(theta, -1) - theta) % (2 * np.pi)
    g[0] = fs / (2 * np.pi) * np.sum(sign_after * length)
    k = np.arange(1, fourier.harmonics + 1)
    phase = np.exp(-1j * np.outer(k, theta))  # (H, n_c)
    gk = fs / (1j * np.pi * k) * (phase @ jump)
    g[1::2], g[2::2] = gk.real, gk.imag
    dg_dtheta = np.zeros((size, theta.size))
    dg_dtheta[0] = -fs / (2 * np.pi) * jump
    d = -fs / np.pi * jump * phase
    dg_dtheta[1::2], dg_dtheta[2::2] = d.real, d.imag
    dtheta_dc = -d1 / slope[:, None]
    return PeriodForces(g, dg_dtheta @ dtheta_dc, np.zeros(size))


def period_forces(element, c: NDArray, omega: float, fourier: Fourier) -> PeriodForces:
    """Harmonics of one element's force for relative-motion coefficients ``c`` (m) at ω (rad/s)."""
    result = period_forces_batch(element, np.asarray(c, dtype=float)[None], np.array([omega], dtype=float), fourier)
    return PeriodForces(result.g[0], result.dg_dc[0], result.dg_domega[0])


_HYSTERETIC: dict[type, Callable] = {}  # filled below: laws evaluated one motion at a time


def period_forces_batch(element, c: NDArray, omega: NDArray, fourier: Fourier) -> PeriodForces:
    """:func:`period_forces` for P motions at once: ``c`` (P, 2H+1) (m), ``omega`` (P,) (rad/s);
    G (P, 2H+1), ∂G/∂c (P, 2H+1, 2H+1), ∂G/∂ω (P, 2H+1). Pointwise laws share every transform;
    the hysteresis cycles (Jenkins, Iwan) and Coulomb's crossings are followed motion by motion."""
    single = _HYSTERETIC.get(type(element))
    if single is not None:
        parts = [single(element, ci, wi, fourier) for ci, wi in zip(c, omega)]
        if not parts:
            empty = np.zeros((0, fourier.size))
            return PeriodForces(empty, np.zeros((0, fourier.size, fourier.size)), empty)
        return PeriodForces(np.array([p.g for p in parts]), np.array([p.dg_dc for p in parts]),
                            np.array([p.dg_domega for p in parts]))
    law = _POINTWISE.get(type(element))
    if law is None:
        raise TypeError(f"{type(element).__name__}: no time-domain law for harmonic balance")
    return _pointwise_forces(law, element, c, omega, fourier)


def damping_coefficients_batch(element, c: NDArray, omega: NDArray, fourier: Fourier) -> NDArray[np.complex128]:
    """Fourier coefficients (P, 4H+1; m = −2H … 2H) of an element's tangent damping ``∂f/∂u̇``
    (N·s/m) along P motions ``c`` (P, 2H+1), for Hill's method. Coulomb: ``∂f/∂u̇ = 2Fs Σ_c δ(t − t_c)``,
    whose coefficients in θ are ``(1/2π) Σ_c 2Fs e^{−imθ_c} / |u̇'(θ_c)|``; Jenkins and Iwan: none
    (rate-independent)."""
    omega = np.asarray(omega, dtype=float)
    m = np.arange(-2 * fourier.harmonics, 2 * fourier.harmonics + 1)
    if isinstance(element, (JenkinsFriction, IwanJoint)):
        return np.zeros((omega.size, m.size), complex)
    if isinstance(element, CoulombFriction):
        out = np.empty((omega.size, m.size), complex)
        for index, (ci, wi) in enumerate(zip(c, omega)):
            theta, _, slope = _velocity_crossings(ci, fourier)
            weights = 2 * element.slip_force / (np.abs(slope) * wi)
            out[index] = np.exp(-1j * np.outer(m, theta)) @ weights / (2 * np.pi)
        return out
    law = _POINTWISE[type(element)]
    u, up = fourier.motions(c)
    w = omega[:, None]
    _, _, f_up, _ = law(element, u, up, w)
    if f_up is None:
        return np.zeros((omega.size, m.size), complex)
    spectrum = np.fft.fft(np.broadcast_to(f_up / w, u.shape), axis=-1) / fourier.samples
    return spectrum[:, m % fourier.samples]


def aliasing_change(element, c: NDArray, omega: float, fourier: Fourier, factor: int = 8) -> float:
    """Relative change of the element's force harmonics when the samples are ``factor`` × N."""
    fine = Fourier(fourier.harmonics, fourier.samples * factor)
    coarse_g = period_forces(element, c, omega, fourier).g
    fine_g = period_forces(element, c, omega, fine).g
    scale = np.linalg.norm(fine_g)
    return float(np.linalg.norm(coarse_g - fine_g) / scale) if scale > 0 else 0.0


_HYSTERETIC.update({JenkinsFriction: _jenkins_forces, IwanJoint: _iwan_forces, CoulombFriction: _coulomb_forces})
