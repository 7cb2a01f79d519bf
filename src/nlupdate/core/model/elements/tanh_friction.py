"""Smooth (regularised) dry friction ``f = Fs·tanh(ẋ/ε)``, as NLvib's ``tanhDryFriction``.

For ``x = A cos θ`` the force is odd in ``sin θ``, so the describing function is purely
imaginary::

    ν(A, ω) = i·(4Fs/(πA))·J(r),   r = Aω/ε,   J(r) = ∫₀^{π/2} tanh(r sin θ) sin θ dθ,

from ``J ≈ πr/4`` (a viscous damper ``c = Fs/ε``: ``ν = iωFs/ε``) to ``J → 1`` (Coulomb
friction, ``ν = i·4Fs/(πA)``). J and ``J'(r) = ∫ sech²(r sin θ) sin²θ dθ`` are computed by
Gauss–Legendre quadrature (64 nodes) on ``[0, θ_s]`` and ``[θ_s, π/2]`` with
``θ_s = min(π/2, 20/r)``: the transition of width ~1/r lies in the first part, and beyond
it ``tanh = 1`` to 1e-17. Rate-dependent, no history; the tangent damping ``Fs/ε`` bounds
the time step of explicit integration.
"""
from __future__ import annotations

from dataclasses import dataclass
from math import pi
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.model.elements.base import (
    SHAPE_POINTS, EffectForm, ElementBase, ElementParameter, amplitude_array, check_dofs, positive,
)

_NODES, _WEIGHTS = np.polynomial.legendre.leggauss(64)
_SERIES_BELOW = 1e-3  # r below which J' − J/r is taken from its series (the difference cancels)


def _quadrature(r: NDArray, integrand) -> NDArray:
    """``∫₀^{π/2} integrand(r, θ) dθ`` for every r, split at ``θ_s = min(π/2, 20/r)``."""
    r = r[..., None]
    with np.errstate(divide="ignore"):
        split = np.minimum(pi / 2, 20.0 / r)
    total = np.zeros(r.shape[:-1])
    for low, high in ((0.0, split), (split, pi / 2)):
        half = 0.5 * (high - low)
        theta = low + half * (_NODES + 1.0)
        total = total + np.sum(_WEIGHTS * integrand(r, theta) * half, axis=-1)
    return total


def tanh_integrals(r: NDArray) -> tuple[NDArray, NDArray]:
    """``J(r)`` and ``J(r)/r − J'(r)`` (≥ 0) for ``r ≥ 0`` (module docstring)."""
    r = np.asarray(r, dtype=float)
    j = _quadrature(r, lambda r, t: np.tanh(r * np.sin(t)) * np.sin(t))
    dj = _quadrature(r, lambda r, t: (1.0 - np.tanh(r * np.sin(t)) ** 2) * np.sin(t) ** 2)
    small = r < _SERIES_BELOW
    with np.errstate(divide="ignore", invalid="ignore"):
        direct = j / r - dj
    series = pi * r**2 / 8 - pi * r**4 / 12
    return j, np.where(small, series, direct)


@dataclass(frozen=True)
class TanhFriction(ElementBase):
    """Smooth dry friction ``f = Fs·tanh(ẋ/ε)``: slip force Fs (N), regularisation velocity ε (m/s).

    ``ν = i·(4Fs/(πA))·J(Aω/ε)`` (module docstring): viscous (``iωFs/ε``) for ``Aω ≪ ε``,
    Coulomb (``i·4Fs/(πA)``) for ``Aω ≫ ε``. Discovery (``smooth_friction``, fitted when named:
    it nests Coulomb friction and a viscous damper, which the default library holds): Fs the
    scale, ε the shape.
    """

    dofs: tuple[int, ...]
    type_name: ClassVar[str] = "tanh_friction"
    order: ClassVar[int] = 35
    parameters: ClassVar[tuple[ElementParameter, ...]] = (
        ElementParameter("slip_force", "N", meaning="friction force of the smooth slider at high velocity, "
                                                    "force = slip_force·tanh(ẋ/epsilon)"),
        ElementParameter("epsilon", "m/s", meaning="regularisation velocity of the smooth friction: well below "
                                                   "it the slider acts as a viscous damper of coefficient "
                                                   "slip_force/epsilon"),
    )
    effects: ClassVar[tuple[EffectForm, ...]] = (EffectForm("smooth_friction", order=35, default=False),)
    slip_force: float
    epsilon: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "dofs", check_dofs(self.dofs))
        positive("slip_force", self.slip_force)
        positive("epsilon", self.epsilon)

    def describing_function(self, amplitude, omega=1.0):
        a, w = np.broadcast_arrays(amplitude_array(amplitude), np.abs(np.asarray(omega, dtype=float)))
        j, _ = tanh_integrals(a * w / self.epsilon)
        return 1j * 4 * self.slip_force / (pi * a) * j

    def describing_function_derivatives(self, amplitude, omega=1.0):
        a, w = np.broadcast_arrays(amplitude_array(amplitude), np.abs(np.asarray(omega, dtype=float)))
        r = a * w / self.epsilon
        j, gap = tanh_integrals(r)
        gain = 4 * self.slip_force / pi
        d_da = -1j * gain * (w / self.epsilon) * gap / a  # ∂(J/A)/∂A = (ω/ε)(J' − J/r)/A
        slope = np.where(r > 0, j / np.where(r > 0, r, 1.0) - gap, pi / 4)  # J'(r)
        return d_da, 1j * gain / self.epsilon * slope

    def force(self, displacement, velocity, state, omega=1.0):
        return self.slip_force * np.tanh(velocity / self.epsilon), None

    def harmonic_law(self, u, up, w):
        t = np.tanh(w * up / self.epsilon)
        slope = self.slip_force * (1.0 - t * t) / self.epsilon  # ∂f/∂ẋ
        return self.slip_force * t, None, slope * w, slope * up

    def stiffness_bound(self, amplitude: float) -> float:
        return 0.0

    def damping_bound(self, velocity):
        """The largest tangent damping, ``Fs/ε`` (N·s/m, at ẋ = 0)."""
        return self.slip_force / self.epsilon + 0.0 * np.asarray(velocity, dtype=float)

    @classmethod
    def start_values(cls, amplitude, y, omega, scale):
        """ε from a few transition velocities around the middle amplitude's ``Aω``."""
        return {"epsilon": [float(np.median(amplitude)) * omega * f for f in (0.1, 1.0, 10.0)]}

    @classmethod
    def effect_shapes(cls, amplitude):
        """ε from ``A_min/30`` to ``3e4·A_max`` (m/s): transitions for ω up to ~1e4 rad/s."""
        return tuple(np.geomspace(amplitude.min() / 30, amplitude.max() * 3e4, SHAPE_POINTS))

    @classmethod
    def effect_values(cls, scale, shape):
        return np.array([scale, shape])
