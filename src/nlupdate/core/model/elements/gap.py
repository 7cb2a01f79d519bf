"""Symmetric gap: a contact spring engaged beyond a clearance ±g."""
from __future__ import annotations

from dataclasses import dataclass
from math import pi
from typing import ClassVar

import numpy as np

from nlupdate.core.model.elements.base import (
    SHAPE_POINTS, EffectForm, ElementBase, ElementParameter, amplitude_array, check_dofs, positive,
)


@dataclass(frozen=True)
class SymmetricGap(ElementBase):
    """Contact spring kc (N/m) engaged beyond a clearance ±g (m).

    ``f = kc·(x − g·sign(x))`` for ``|x| > g``, else 0;
    ``ν = kc·[1 − (2/π)(asin(g/A) + (g/A)√(1 − (g/A)²))]`` for ``A > g``, else 0.
    Discovery: contact stiffness kc the scale, the clearance the shape.
    """

    dofs: tuple[int, ...]
    type_name: ClassVar[str] = "gap"
    order: ClassVar[int] = 50
    parameters: ClassVar[tuple[ElementParameter, ...]] = (
        ElementParameter("gap", "m", meaning="clearance of the gap element: no force while |x| ≤ gap"),
        ElementParameter("kc", "N/m", meaning="contact stiffness beyond the clearance, force = kc·(x − gap·sign x)"),
    )
    effects: ClassVar[tuple[EffectForm, ...]] = (EffectForm("gap", order=50),)
    gap: float
    kc: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "dofs", check_dofs(self.dofs))
        positive("gap", self.gap, allow_zero=True)
        positive("kc", self.kc)

    def describing_function(self, amplitude, omega=0.0):
        a = amplitude_array(amplitude)
        r = np.clip(self.gap / a, 0.0, 1.0)
        value = self.kc * (1 - 2 / pi * (np.arcsin(r) + r * np.sqrt(1 - r**2)))
        return np.where(a <= self.gap, 0.0, value) + 0j

    def describing_function_derivatives(self, amplitude, omega=0.0):
        a = amplitude_array(amplitude)
        r = np.clip(self.gap / a, 0.0, 1.0)
        d_da = 4 * self.kc * self.gap / (pi * a**2) * np.sqrt(1 - r**2)
        d_da = np.where(a <= self.gap, 0.0, d_da) + 0j
        return d_da, np.zeros_like(d_da)

    def force(self, displacement, velocity, state, omega=0.0):
        excess = np.abs(displacement) - self.gap
        return np.where(excess > 0, self.kc * np.sign(displacement) * excess, 0.0), None

    def harmonic_law(self, u, up, w):
        engaged = np.abs(u) > self.gap
        return np.where(engaged, self.kc * (u - self.gap * np.sign(u)), 0.0), np.where(engaged, self.kc, 0.0), None, None

    def stiffness_bound(self, amplitude: float) -> float:
        return self.kc

    @classmethod
    def start_values(cls, amplitude, y, omega, scale):
        a_min = float(np.min(amplitude))
        return {"gap": [f * a_min for f in (0.2, 0.5, 0.8)], "kc": [max(float(np.max(np.abs(y.real))), 1e-3 * scale)]}

    @classmethod
    def effect_shapes(cls, amplitude):
        return tuple(np.geomspace(amplitude.min() / 10, amplitude.max() * 0.95, SHAPE_POINTS))

    @classmethod
    def effect_values(cls, scale, shape):
        return np.array([shape, scale])

    effect_parameters: ClassVar[tuple[str, ...]] = ("gap", "kc")
