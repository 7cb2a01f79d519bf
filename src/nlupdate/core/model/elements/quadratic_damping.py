"""Quadratic damper ``f = cq·ẋ·|ẋ|``."""
from __future__ import annotations

from dataclasses import dataclass
from math import pi
from typing import ClassVar

import numpy as np

from nlupdate.core.model.elements.base import EffectForm, ElementBase, ElementParameter, check_dofs, positive


@dataclass(frozen=True)
class QuadraticDamping(ElementBase):
    """Quadratic damper ``f = cq·ẋ·|ẋ|`` (cq in N·s²/m²); ``ν = i·8 cq ω² A/(3π)``."""

    dofs: tuple[int, ...]
    type_name: ClassVar[str] = "quadratic_damping"
    order: ClassVar[int] = 40
    parameters: ClassVar[tuple[ElementParameter, ...]] = (
        ElementParameter("cq", "N s^2/m^2", meaning="quadratic damping coefficient, force = cq·ẋ·|ẋ|"),
    )
    effects: ClassVar[tuple[EffectForm, ...]] = (EffectForm("quadratic_damping", order=40),)
    cq: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "dofs", check_dofs(self.dofs))
        positive("cq", self.cq)

    def describing_function(self, amplitude, omega=1.0):
        a = np.asarray(amplitude, dtype=float)
        w = np.asarray(omega, dtype=float)
        return 1j * 8 * self.cq * w**2 * a / (3 * pi)

    def describing_function_derivatives(self, amplitude, omega=1.0):
        a = np.asarray(amplitude, dtype=float)
        w = np.asarray(omega, dtype=float)
        return 1j * 8 * self.cq * w**2 / (3 * pi) + 0 * a, 1j * 16 * self.cq * w * a / (3 * pi)

    def force(self, displacement, velocity, state, omega=1.0):
        return self.cq * velocity * np.abs(velocity), None

    def harmonic_law(self, u, up, w):
        law = up * np.abs(up)
        return self.cq * w**2 * law, None, 2 * self.cq * w**2 * np.abs(up), 2 * self.cq * w * law

    def stiffness_bound(self, amplitude: float) -> float:
        return 0.0

    def damping_bound(self, velocity):
        """The tangent ``2cq·V`` (N·s/m) at relative velocity V (m/s)."""
        return 2 * self.cq * velocity
