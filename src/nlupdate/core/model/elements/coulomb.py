"""Coulomb friction ``f = Fs·sign(ẋ)``, its harmonics integrated exactly between the
zero crossings of the velocity (a sampled sign would give a zero Jacobian).

The crossings θ_c of ``u' = du/dθ`` are found on the samples and refined by Newton on the
trigonometric polynomial; the harmonics are differentiated through them,
``∂θ_c/∂c = −E'(θ_c)/u''(θ_c)``.
"""
from __future__ import annotations

from dataclasses import dataclass
from math import pi
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.model.elements.base import (
    CycleElement, EffectForm, ElementParameter, PeriodForces, amplitude_array, check_dofs, positive,
)


def _crossing_basis(theta: NDArray, fourier) -> tuple[NDArray, NDArray]:
    """Rows ``∂u'(θ)/∂c`` and ``∂u''(θ)/∂c`` at the angles θ."""
    k = np.arange(1, fourier.harmonics + 1)
    kt = np.outer(theta, k)
    d1 = np.zeros((theta.size, fourier.size))
    d2 = np.zeros_like(d1)
    d1[:, 1::2], d1[:, 2::2] = -k * np.sin(kt), -k * np.cos(kt)
    d2[:, 1::2], d2[:, 2::2] = -(k**2) * np.cos(kt), k**2 * np.sin(kt)
    return d1, d2


def velocity_crossings(c: NDArray, fourier) -> tuple[NDArray, NDArray, NDArray]:
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


@dataclass(frozen=True)
class CoulombFriction(CycleElement):
    """Coulomb friction ``f = Fs·sign(ẋ)``; ``ν = i·4Fs/(πA)``."""

    dofs: tuple[int, ...]
    type_name: ClassVar[str] = "coulomb"
    order: ClassVar[int] = 30
    parameters: ClassVar[tuple[ElementParameter, ...]] = (
        ElementParameter("slip_force", "N", meaning="Coulomb friction force, force = slip_force·sign(ẋ)"),
    )
    effects: ClassVar[tuple[EffectForm, ...]] = (EffectForm("coulomb_friction", order=30),)
    slip_force: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "dofs", check_dofs(self.dofs))
        positive("slip_force", self.slip_force)

    def describing_function(self, amplitude, omega=0.0):
        a = amplitude_array(amplitude)
        return 1j * 4 * self.slip_force / (pi * a)

    def describing_function_derivatives(self, amplitude, omega=0.0):
        a = amplitude_array(amplitude)
        d_da = -1j * 4 * self.slip_force / (pi * a**2)
        return d_da, np.zeros_like(d_da)

    def force(self, displacement, velocity, state, omega=0.0):
        return self.slip_force * np.sign(velocity), None

    def stiffness_bound(self, amplitude: float) -> float:
        return 0.0

    def one_period(self, c: NDArray, fourier) -> PeriodForces:
        fs = self.slip_force
        size = fourier.size
        theta, d1, slope = velocity_crossings(c, fourier)
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

    def damping_harmonics(self, c, omega, fourier):
        """``∂f/∂u̇ = 2Fs Σ_c δ(t − t_c)``, whose coefficients in θ are
        ``(1/2π) Σ_c 2Fs e^{−imθ_c} / |u̇'(θ_c)|``."""
        omega = np.asarray(omega, dtype=float)
        m = np.arange(-2 * fourier.harmonics, 2 * fourier.harmonics + 1)
        out = np.empty((omega.size, m.size), complex)
        for index, (ci, wi) in enumerate(zip(c, omega)):
            theta, _, slope = velocity_crossings(ci, fourier)
            weights = 2 * self.slip_force / (np.abs(slope) * wi)
            out[index] = np.exp(-1j * np.outer(m, theta)) @ weights / (2 * np.pi)
        return out
