"""An identified describing function as an element (its time-domain law matches it exactly)."""
from __future__ import annotations

from dataclasses import dataclass
from math import gamma, pi, sqrt
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.model.elements.base import ElementBase, ElementParameter, check_dofs


def cos_power_mean(power: int) -> float:
    """``(1/π)∫₀^{2π} |cos θ|^{power+2} dθ``: DF gain of the force ``x|x|^power``."""
    n = power + 2
    return 2.0 / sqrt(pi) * gamma((n + 1) / 2) / gamma(n / 2 + 1)


@dataclass(frozen=True)
class PolynomialDF(ElementBase):
    """Identified describing function ``ν(A) = Σ p_k A^k + i Σ q_k A^k``.

    ``real`` and ``imag`` hold the coefficients highest order first (``numpy.polyval``
    convention), in SI units (N/m^(k+1) for the A^k term).

    The matching time-domain law (used for time integration) is
    ``f = Σ (p_k/γ_k)·x|x|^k + Σ (q_k/γ_k)·u|u|^k`` with ``u = ẋ/ω`` and
    ``γ_k = (1/π)∫|cos θ|^{k+2} dθ``, whose DF is exactly ν.
    """

    dofs: tuple[int, ...]
    type_name: ClassVar[str] = "polynomial"
    order: ClassVar[int] = 70
    parameters: ClassVar[tuple[ElementParameter, ...]] = (
        ElementParameter("real", "N/m^(k+1)", positive=False, fitted=False, sequence=True,
                         meaning="coefficients of the describing function's real part (stiffness), highest power first"),
        ElementParameter("imag", "N/m^(k+1)", positive=False, fitted=False, optional=True, sequence=True,
                         meaning="coefficients of the describing function's imaginary part (damping), highest power "
                                 "first"),
    )
    real: tuple[float, ...]
    imag: tuple[float, ...] = (0.0,)

    def __post_init__(self) -> None:
        object.__setattr__(self, "dofs", check_dofs(self.dofs))
        for name in ("real", "imag"):
            coefficients = tuple(float(c) for c in np.atleast_1d(getattr(self, name)))
            if not coefficients or not all(np.isfinite(coefficients)):
                raise ValueError(f"polynomial DF '{name}' coefficients must be a non-empty list of finite numbers")
            object.__setattr__(self, name, coefficients)

    def describing_function(self, amplitude, omega=0.0):
        a = np.asarray(amplitude, dtype=float)
        return np.polyval(self.real, a) + 1j * np.polyval(self.imag, a)

    def describing_function_derivatives(self, amplitude, omega=0.0):
        a = np.asarray(amplitude, dtype=float)
        d_da = np.polyval(np.polyder(self.real), a) + 1j * np.polyval(np.polyder(self.imag), a)
        return d_da + 0 * a, np.zeros_like(a) + 0j

    def _law(self, coefficients: tuple[float, ...], x: NDArray) -> NDArray:
        order = len(coefficients) - 1
        total = np.zeros_like(x, dtype=float)
        for index, coefficient in enumerate(coefficients):
            power = order - index
            if coefficient != 0.0:
                total = total + coefficient / cos_power_mean(power) * x * np.abs(x) ** power
        return total

    def force(self, displacement, velocity, state, omega=1.0):
        return self._law(self.real, displacement) + self._law(self.imag, velocity / omega), None

    def _law_and_tangent(self, coefficients: tuple[float, ...], x: NDArray) -> tuple[NDArray, NDArray]:
        order = len(coefficients) - 1
        f, df = np.zeros_like(x), np.zeros_like(x)
        for index, coefficient in enumerate(coefficients):
            power = order - index
            if coefficient != 0.0:
                gain = coefficient / cos_power_mean(power)
                f = f + gain * x * np.abs(x) ** power
                df = df + gain * (power + 1) * np.abs(x) ** power
        return f, df

    def harmonic_law(self, u, up, w):
        f_real, k_real = self._law_and_tangent(self.real, u)
        f_imag, k_imag = self._law_and_tangent(self.imag, up)
        return f_real + f_imag, k_real, k_imag, None

    def stiffness_bound(self, amplitude: float) -> float:
        order = len(self.real) - 1
        return sum(
            abs(c) / cos_power_mean(order - i) * (order - i + 1) * amplitude ** (order - i)
            for i, c in enumerate(self.real)
        )
