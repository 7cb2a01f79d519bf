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
transformed column by column. That is every element's default (its ``harmonic_law`` gives
the force and tangents at the samples: :class:`~nlupdate.core.model.elements.base.ElementBase`);
an element whose force is not a function of the sample — a hysteresis cycle (Jenkins,
Iwan: Masing's rules), a discontinuity integrated exactly (Coulomb) — computes its own
harmonics in its module. This module holds the transforms and asks each element.

Aliasing: a force law with powers up to p needs ``N > (p + 1)·H`` for exact low harmonics;
non-smooth laws (gap, Jenkins, Iwan) converge with N. :func:`aliasing_change` measures it.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.model.elements import NonlinearElement, PeriodForces


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


def period_forces(element, c: NDArray, omega: float, fourier: Fourier) -> PeriodForces:
    """Harmonics of one element's force for relative-motion coefficients ``c`` (m) at ω (rad/s)."""
    result = period_forces_batch(element, np.asarray(c, dtype=float)[None], np.array([omega], dtype=float), fourier)
    return PeriodForces(result.g[0], result.dg_dc[0], result.dg_domega[0])


def period_forces_batch(element: NonlinearElement, c: NDArray, omega: NDArray, fourier: Fourier) -> PeriodForces:
    """:func:`period_forces` for P motions at once: ``c`` (P, 2H+1) (m), ``omega`` (P,) (rad/s);
    G (P, 2H+1), ∂G/∂c (P, 2H+1, 2H+1), ∂G/∂ω (P, 2H+1). Pointwise laws share every transform;
    hysteresis cycles and exact crossings are followed motion by motion (the element's ``period_forces``)."""
    return element.period_forces(c, omega, fourier)


def damping_coefficients_batch(element: NonlinearElement, c: NDArray, omega: NDArray, fourier: Fourier) -> NDArray[np.complex128]:
    """Fourier coefficients (P, 4H+1; m = −2H … 2H) of an element's tangent damping ``∂f/∂u̇``
    (N·s/m) along P motions ``c`` (P, 2H+1), for Hill's method (the element's ``damping_harmonics``)."""
    return element.damping_harmonics(c, np.asarray(omega, dtype=float), fourier)


def aliasing_change(element, c: NDArray, omega: float, fourier: Fourier, factor: int = 8) -> float:
    """Relative change of the element's force harmonics when the samples are ``factor`` × N."""
    fine = Fourier(fourier.harmonics, fourier.samples * factor)
    coarse_g = period_forces(element, c, omega, fourier).g
    fine_g = period_forces(element, c, omega, fine).g
    scale = np.linalg.norm(fine_g)
    return float(np.linalg.norm(coarse_g - fine_g) / scale) if scale > 0 else 0.0

