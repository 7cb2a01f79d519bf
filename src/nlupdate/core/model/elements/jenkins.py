"""Jenkins element: a spring in series with a Coulomb slider.

Harmonic balance: the force is the steady-state hysteresis cycle of the return mapping
over the period (passes repeated until the cycle closes); in stick
``f(θ) = ±Fs + kf (u(θ) − u(θ_a))`` with θ_a the last slip sample, so
``∂f(θ)/∂c = kf (E(θ) − E(θ_a))``, zero in slip. A cycle whose peak-to-peak motion stays
below ``2Fs/kf`` sticks with the slider centred (the limit of the slipping cycle).
"""
from __future__ import annotations

from dataclasses import dataclass
from math import pi
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.model.elements.base import (
    SHAPE_POINTS, CycleElement, EffectForm, ElementParameter, PeriodForces, amplitude_array, check_dofs,
    positive,
)


@dataclass(frozen=True)
class JenkinsFriction(CycleElement):
    """Jenkins element: spring kf (N/m) in series with a Coulomb slider of slip force Fs (N).

    Stuck below ``A = Fs/kf`` (ν = kf); above, with ``β = arccos(1 − 2Fs/(kf A))``:
    ``Re ν = (kf/π)(β − ½ sin 2β)``, ``Im ν = (4Fs/(πA))(1 − Fs/(kf A))``.
    The time-domain state is the slider position (m). Discovery (``dry_friction``): kf the
    scale, the slip amplitude ``Fs/kf`` the shape.
    """

    dofs: tuple[int, ...]
    type_name: ClassVar[str] = "jenkins"
    order: ClassVar[int] = 20
    parameters: ClassVar[tuple[ElementParameter, ...]] = (
        ElementParameter("kf", "N/m", meaning="stuck stiffness of the Jenkins element (spring in series with the slider)"),
        ElementParameter("slip_force", "N", meaning="force at which the Jenkins slider slips"),
    )
    stick_slip: ClassVar[tuple[str, str]] = ("kf", "slip_force")
    effects: ClassVar[tuple[EffectForm, ...]] = (EffectForm("dry_friction", joint=True, order=20),)
    kf: float
    slip_force: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "dofs", check_dofs(self.dofs))
        positive("kf", self.kf)
        positive("slip_force", self.slip_force)

    @property
    def slip_amplitude(self) -> float:
        """Amplitude (m) at which the slider starts to slip."""
        return self.slip_force / self.kf

    def _beta(self, a: NDArray) -> NDArray:
        ratio = np.clip(1.0 - 2.0 * self.slip_amplitude / a, -1.0, 1.0)
        return np.arccos(ratio)

    def describing_function(self, amplitude, omega=0.0):
        a = amplitude_array(amplitude)
        stuck = a <= self.slip_amplitude
        beta = self._beta(a)
        real = self.kf / pi * (beta - 0.5 * np.sin(2 * beta))
        imag = 4 * self.slip_force / (pi * a) * (1 - self.slip_amplitude / a)
        return np.where(stuck, self.kf + 0j, real + 1j * imag)

    def describing_function_derivatives(self, amplitude, omega=0.0):
        a = amplitude_array(amplitude)
        a0 = self.slip_amplitude
        stuck = a <= a0
        beta = self._beta(a)
        ratio = 1.0 - 2.0 * a0 / a
        dbeta = -(2.0 * a0 / a**2) / np.sqrt(np.maximum(1.0 - ratio**2, 1e-300))
        dreal = self.kf / pi * (1.0 - np.cos(2 * beta)) * dbeta
        dimag = 4 * self.slip_force / pi * (-1.0 / a**2 + 2.0 * a0 / a**3)
        d_da = np.where(stuck, 0.0 + 0j, dreal + 1j * dimag)
        return d_da, np.zeros_like(d_da)

    def force(self, displacement, velocity, state, omega=0.0):
        """Return mapping: trial stick force, slider moves when it exceeds Fs."""
        slider = np.zeros_like(displacement) if state is None else state
        trial = self.kf * (displacement - slider)
        force = np.minimum(np.maximum(trial, -self.slip_force), self.slip_force)
        slipping = force != trial
        new_slider = np.where(slipping, displacement - force / self.kf, slider)
        return force, new_slider

    def initial_state(self, shape: tuple[int, ...]) -> NDArray:
        return np.zeros(shape)

    def stiffness_bound(self, amplitude: float) -> float:
        return self.kf

    # -- harmonic balance: the steady cycle --------------------------------------------------
    def cycle(self, u: NDArray) -> tuple[NDArray, NDArray]:
        """Force samples of the steady cycle through the samples ``u`` (m) and, per sample, the
        index of the last slip sample (−1 while slipping; −2 for a cycle that sticks throughout, centred)."""
        kf, fs = self.kf, self.slip_force
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

    def one_period(self, c: NDArray, fourier) -> PeriodForces:
        u = fourier.to_time(c)
        force, anchor = self.cycle(u)
        if anchor[0] == -2:
            centre = 0.5 * (fourier.E[np.argmax(u)] + fourier.E[np.argmin(u)])
            tangent = self.kf * (fourier.E - centre)
        else:
            stick = anchor >= 0
            tangent = np.zeros_like(fourier.E)
            tangent[stick] = self.kf * (fourier.E[stick] - fourier.E[anchor[stick]])
        return PeriodForces(fourier.to_harmonics(force), fourier.to_harmonics(tangent), np.zeros(fourier.size))

    # -- discovery ----------------------------------------------------------------------------
    @classmethod
    def effect_shapes(cls, amplitude):
        return tuple(np.geomspace(amplitude.min() / 10, amplitude.max() * 3, SHAPE_POINTS))

    @classmethod
    def effect_values(cls, scale, shape):
        return np.array([scale, scale * shape])
