"""Cubic spring ``f = k3·x³`` (docs/methods.md §2)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from nlupdate.core.model.elements.base import EffectForm, ElementBase, ElementParameter, check_dofs


@dataclass(frozen=True)
class CubicStiffness(ElementBase):
    """Cubic spring ``f = k3·x³`` (k3 in N/m³); ``ν = ¾ k3 A²``."""

    dofs: tuple[int, ...]
    type_name: ClassVar[str] = "cubic"
    order: ClassVar[int] = 10
    parameters: ClassVar[tuple[ElementParameter, ...]] = (
        ElementParameter("k3", "N/m^3", positive=False,
                         meaning="cubic stiffness coefficient, force = k3·x³ (negative: softening)"),
    )
    effects: ClassVar[tuple[EffectForm, ...]] = (
        EffectForm("cubic_stiffness", order=10), EffectForm("softening_stiffness", -1, signs=(("k3", -1),), order=11),
    )
    k3: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "dofs", check_dofs(self.dofs))
        if not np.isfinite(self.k3):
            raise ValueError(f"k3 must be finite, got {self.k3}")

    def describing_function(self, amplitude, omega=0.0):
        a = np.asarray(amplitude, dtype=float)
        return (0.75 * self.k3 * a**2) + 0j

    def describing_function_derivatives(self, amplitude, omega=0.0):
        a = np.asarray(amplitude, dtype=float)
        return 1.5 * self.k3 * a + 0j, np.zeros_like(a) + 0j

    def force(self, displacement, velocity, state, omega=0.0):
        return self.k3 * (displacement * displacement * displacement), None  # x**3 calls pow(): ~35x slower for x < 0

    def harmonic_law(self, u, up, w):
        u_sq = u * u
        return self.k3 * u_sq * u, 3 * self.k3 * u_sq, None, None

    def stiffness_bound(self, amplitude: float) -> float:
        return 3.0 * abs(self.k3) * amplitude**2

    @property
    def cubic_coefficient(self) -> float:
        return self.k3
