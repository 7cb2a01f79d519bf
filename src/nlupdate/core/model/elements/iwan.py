"""Segalman's four-parameter Iwan joint: its describing function in closed form, a
parallel-Jenkins time-domain realisation, and Masing's rules for harmonic balance.

Harmonic balance (:func:`masing_branches`): every sample lies on a branch from a turning
point o, ``f = F_o + 2 sgn(u − u_o) F_bb(|u − u_o|/2)`` with the joint's backbone F_bb, and a
turning point's force is built the same way from the one before it, down to the outer
loop's ``±F_bb(a)`` at the global extremes (a = half the peak-to-peak motion; the sliders
that never slip are centred, as for Jenkins). So ``∂f/∂c = ∂F_o/∂c + F_bb'(|u − u_o|/2)(E(θ) − E(θ_o))``,
recursively. Exact for the continuous distribution (not the time-domain sliders); turning
points are taken on the samples.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from math import pi
from typing import ClassVar, NamedTuple, Sequence

import numpy as np
import scipy.special
from numpy.typing import ArrayLike, NDArray

from nlupdate.core.model.elements.base import (
    SHAPE_POINTS, CycleElement, EffectForm, ElementParameter, PeriodForces, amplitude_array, check_dofs,
    positive,
)

MACROSLIP_REACH = 2.0
"""An Iwan joint's F_S, K_T and β count as determined only when the largest measured
amplitude reaches ``MACROSLIP_REACH × φ_max`` of the fit."""
JENKINS_END = -0.98  # an Iwan joint's χ at or below this acts as a Jenkins element
START_CHI, START_BETA = -0.5, 0.5  # a discovery candidate's χ and β before the fit

IWAN_DECADES = 6
"""Decades of slip displacement below φ_max that the sliders of an :class:`IwanJoint`'s
time-domain realisation cover (the lowest bin holds [0, 10^−6 φ_max])."""


def _unit_jenkins_df(amplitude: NDArray, slip: NDArray) -> NDArray[np.complex128]:
    """DF of Jenkins elements of unit stiffness and slip displacements ``slip`` (m) at
    amplitudes ``amplitude`` (m), broadcast together."""
    r = np.minimum(1.0, slip / amplitude)
    b = np.arccos(1.0 - 2.0 * r)
    real = (b - 0.5 * np.sin(2 * b)) / pi
    imag = np.where(amplitude > slip, 4 * slip / (pi * amplitude) * (1 - slip / amplitude), 0.0)
    return real + 1j * imag


#: terms of the two series of :func:`_scaled_incomplete_beta_da` (each ≤ 2⁻⁴⁰ ≈ 1e-12 of its
#: first), their n (a column) and (1 − t)^½ = Σ c_n t^n's coefficients
_SERIES_TERMS = 40
_SERIES_N = np.arange(_SERIES_TERMS, dtype=float)[:, None]
_SERIES_C = np.cumprod(np.concatenate([[1.0], (_SERIES_N[1:, 0] - 1.5) / _SERIES_N[1:, 0]]))[:, None]


def _scaled_incomplete_beta_da(r: NDArray, a: float) -> NDArray:
    """``r^(3/2 − a) ∂B(r; a, 3/2)/∂a`` for 0 < r ≤ 1 (B(r; a, 3/2) = ∫₀^r t^(a−1)(1−t)^½ dt, the
    incomplete beta function of the Iwan DF; the factor keeps it finite as r → 0). Below r = ½
    the series of (1−t)^½ = Σ c_n t^n integrated term by term, ``Σ c_n r^(n+3/2) (ln r/(a+n) −
    1/(a+n)²)``; above, B(a, 3/2)(ψ(a) − ψ(a + 3/2)) less the tail ∫_r^1, whose integrand
    (1−u)^(a−1) u^½ (u = 1 − t) is expanded in u ≤ ½ with coefficients d_n = (1−a)_n/n!
    differentiated in a (by their recursion where a is an integer, a factor then 0)."""
    n, r = _SERIES_N, np.asarray(r, dtype=float).ravel()
    low = r <= 0.5
    out = np.zeros(r.shape)
    if np.any(low):
        x = r[low]
        out[low] = np.sum(_SERIES_C * x ** (n + 1.5) * (np.log(x) / (a + n) - 1 / (a + n) ** 2), axis=0)
    if not np.all(low):
        k = n[1:, 0]
        if a != round(a):  # d_n = Π_{k≤n} (k−a)/k, so d_n' = −d_n Σ_{k≤n} 1/(k−a)
            d = np.cumprod(np.concatenate([[1.0], (k - a) / k]))
            dd = -d * np.concatenate([[0.0], np.cumsum(1 / (k - a))])
        else:
            d, dd = np.ones(_SERIES_TERMS), np.zeros(_SERIES_TERMS)
            for m in range(1, _SERIES_TERMS):
                d[m], dd[m] = d[m - 1] * (m - a) / m, (dd[m - 1] * (m - a) - d[m - 1]) / m
        x = r[~low]
        complete = scipy.special.beta(a, 1.5) * (scipy.special.digamma(a) - scipy.special.digamma(a + 1.5))
        out[~low] = (complete - (dd / (n[:, 0] + 1.5)) @ (1.0 - x) ** (n + 1.5)) * x ** (1.5 - a)
    return out


#: The most Jenkins sliders of an Iwan joint's time-domain realisation: each is a state per
#: time step; beyond this the realisation's error (O(1/sliders²)) is below any measurement.
MAX_IWAN_SLIDERS = 100_000


@lru_cache(maxsize=64)
def _iwan_sliders(phi_max: float, continuous: float, chi: float, concentrated: float, count: int):
    """Stiffnesses (N/m) and slip displacements (m) of the parallel-Jenkins realisation;
    ``continuous`` = R'φ_max^(χ+1) = K_T/(1+β) (N/m), the stiffness of the continuous part
    (the bins are written relative to φ_max, so nothing overflows when φ_max is tiny)."""
    edges = np.concatenate([[0.0], np.logspace(-IWAN_DECADES, 0.0, count)])  # φ/φ_max
    stiffness = continuous * np.diff(edges ** (chi + 1))
    slip = phi_max * (chi + 1) / (chi + 2) * np.diff(edges ** (chi + 2)) / np.diff(edges ** (chi + 1))
    if concentrated > 0:
        stiffness, slip = np.append(stiffness, concentrated), np.append(slip, phi_max)
    stiffness.setflags(write=False)
    slip.setflags(write=False)
    return stiffness, slip


def _phi_max(kt, slip_force, chi, beta):
    """φ_max = F_S (1+β) / (K_T (β + (χ+1)/(χ+2))) (m) of parameters that broadcast."""
    return slip_force * (1 + beta) / (kt * (beta + (chi + 1) / (chi + 2)))


def slip_force_at(phi_max: ArrayLike, kt: ArrayLike, chi: ArrayLike, beta: ArrayLike) -> NDArray:
    """F_S (N) of the joint whose largest slip displacement is ``phi_max`` (m), :attr:`IwanJoint.phi_max`
    inverted: ``F_S = φ_max K_T (β + (χ+1)/(χ+2))/(1+β)``; parameters that broadcast."""
    return phi_max * kt * (beta + (chi + 1) / (chi + 2)) / (1 + beta)


def _df_parts(a: NDArray, kt, slip_force, chi, beta):
    """The DF's pieces at amplitudes ``a`` (m) of the joint(s) of parameters ``kt``,
    ``slip_force``, ``chi``, ``beta`` (scalars, or arrays that broadcast with ``a``), written with
    ratios in [0, 1] only so that they stay finite for any valid parameters (a φ_max that
    underflows included): χ; r = min(1, φ_max/A); s = min(1, A/φ_max); b = arccos(1 − 2r);
    ``g = K_T r/(1+β)`` (N/m; in macroslip ``F_S/((β + (χ+1)/(χ+2)) A)``, exact however small
    φ_max is); and ``J = (A/φ_max)^(χ+1) B(r; χ+5/2, 3/2)`` (B the incomplete beta function,
    complete where r = 1: microslip; ``r^1.5/(χ+5/2)`` to O(r) for r < 1e-12)."""
    phi = _phi_max(kt, slip_force, chi, beta)
    macro = a > phi
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        r = np.where(macro, phi / a, 1.0)
        s = np.where(macro, 1.0, a / np.where(macro, 1.0, phi))
        g = np.where(macro, slip_force / ((beta + (chi + 1) / (chi + 2)) * a), kt / (1 + beta))
    complete = scipy.special.beta(chi + 2.5, 1.5)
    if not np.any(macro):
        return chi, r, s, np.full(r.shape, pi), g, s ** (chi + 1) * complete
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        scaled = np.where(r > 1e-12, scipy.special.betainc(chi + 2.5, 1.5, r) * complete * r ** -(chi + 1),
                          r**1.5 / (chi + 2.5))
    return chi, r, s, np.arccos(1.0 - 2.0 * r), g, np.where(macro, scaled, s ** (chi + 1) * complete)


def _df_value(parts, kt, beta) -> NDArray[np.complex128]:
    """ν (N/m) from :func:`_df_parts` (class docstring of :class:`IwanJoint`)."""
    chi, r, s, b, g, j = parts
    real = kt * (b - 0.5 * np.sin(2 * b)) / pi - 8 * (kt / (1 + beta)) / pi * j
    imag = 4 * g / pi * ((chi + 1) * s ** (chi + 1) * (1 / (chi + 2) - r / (chi + 3)) + beta * (1 - r))
    return real + 1j * imag


def iwan_describing_function(amplitude: ArrayLike, kt: ArrayLike, slip_force: ArrayLike, chi: ArrayLike,
                             beta: ArrayLike) -> NDArray[np.complex128]:
    """:meth:`IwanJoint.describing_function` (N/m) of many joints at once: the parameters (valid
    ones: :class:`IwanJoint`) broadcast with the amplitudes (m), e.g. draws of a fit (a column)
    against an amplitude grid (a row)."""
    return _df_value(_df_parts(np.asarray(amplitude, dtype=float), kt, slip_force, chi, beta), kt, beta)


#: the parameters :meth:`IwanJoint.describing_function_gradient` differentiates by
GRADIENT_PARAMETERS = ("kt", "slip_force", "chi", "beta")


class DFGradient(NamedTuple):
    """An Iwan joint's describing function ν (N/m) at amplitudes A, ∂ν/∂A (N/m²) and ∂ν/∂p for
    each parameter p (``kt``, ``slip_force``, ``chi``, ``beta``) with the others held."""

    value: NDArray[np.complex128]
    amplitude: NDArray[np.complex128]
    parameters: dict[str, NDArray[np.complex128]]


@dataclass(frozen=True)
class IwanJoint(CycleElement):
    """Segalman's four-parameter Iwan model of a bolted (lap) joint: a continuum of Jenkins
    elements (unit-stiffness springs in series with sliders) with slip displacements φ
    distributed as ``ρ(φ) = R φ^χ [H(φ) − H(φ − φ_max)] + S δ(φ − φ_max)``.

    Parameters: ``slip_force`` F_S (N), the force at which the whole joint slips
    (macroslip); ``kt`` K_T (N/m), the tangential stiffness of the stuck joint;
    ``chi`` χ ∈ (−1, 0], the exponent of the distribution (microslip dissipation per cycle
    ∝ A^(χ+3)); ``beta`` β ≥ 0, the stiffness of the concentrated part S over that of the
    continuous part. With ``R' = R/(χ+1)``::

        φ_max = F_S (1+β) / (K_T (β + (χ+1)/(χ+2))),   R' φ_max^(χ+1) = K_T/(1+β),
        S = β K_T/(1+β).

    Backbone (virgin loading, u ≥ 0): ``F_bb(u) = K_T u − R' u^(χ+2)/(χ+2)`` for u < φ_max,
    ``F_S`` beyond. The steady cycle follows Masing's rules, and its describing function
    in closed form (r = min(1, φ_max/A), b = arccos(1 − 2r), a = χ + 5/2, ``B(r; a, 3/2)``
    the incomplete beta function)::

        Re ν = K_T (b − ½ sin 2b)/π − (8R'/π) A^(χ+1) B(r; a, 3/2)
        Im ν = (4(χ+1)R'/(πA)) [m^(χ+2)/(χ+2) − m^(χ+3)/((χ+3)A)]
               + S (4φ_max/(πA)) (1 − φ_max/A) [A > φ_max],      m = min(A, φ_max).

    In microslip (A ≤ φ_max) ``Re ν = K_T − (8R'/π) B(a, 3/2) A^(χ+1)`` and
    ``Im ν = 4(χ+1)R' A^(χ+1)/(π(χ+2)(χ+3))``: the energy dissipated per cycle,
    ``πA² Im ν``, grows as A^(χ+3). Jenkins limits: β → ∞ is a Jenkins element
    (kf = K_T, Fs = F_S); χ → −1 at fixed β is a Jenkins element (kf = βK_T/(1+β),
    Fs = F_S) at every A > 0.

    Time domain: ``sliders`` Jenkins elements realise the continuous part (bins of the
    slip displacement, geometric over the :data:`IWAN_DECADES` decades below φ_max plus
    [0, 10⁻⁶φ_max]; each slider has the bin's stiffness ∫ρ and slip force ∫φρ, so the
    realisation's backbone interpolates the exact one at the bin edges), plus one slider
    (S, φ_max) for the concentrated part. Its describing function differs from the exact
    one by O(1/sliders²): with the default 400, by less than 1.5e-4 in Re ν and 1e-3 in
    Im ν (relative) for 1e-4 ≤ A/φ_max ≤ 10 (χ from −0.99 to 0, β from 0 to 100; 1000
    sliders: 1e-4 and 1.5e-4); below 1e-5 φ_max it barely slips. The state is
    the slider positions (m), shape ``x.shape + (n_sliders,)``.
    """

    dofs: tuple[int, ...]
    type_name: ClassVar[str] = "iwan"
    order: ClassVar[int] = 60
    parameters: ClassVar[tuple[ElementParameter, ...]] = (
        ElementParameter("slip_force", "N", meaning="force at which the whole Iwan joint slips (macroslip)"),
        ElementParameter("kt", "N/m", meaning="tangential stiffness of the stuck Iwan joint"),
        ElementParameter("chi", "1", positive=False, interval=(-1.0, 0.0),
                         meaning="exponent of the distribution of the Iwan joint's sliders over slip displacement "
                                 "(microslip dissipation per cycle grows as amplitude^(chi+3))"),
        ElementParameter("beta", "1", meaning="stiffness of the part of the Iwan joint that slips all at once "
                                              "over that of the rest"),
        ElementParameter("sliders", "1", fitted=False, optional=True, meaning="sliders of its time-domain form"),
    )
    alternatives: ClassVar[dict[str, str]] = {"phi_max": "slip_force"}
    effects: ClassVar[tuple[EffectForm, ...]] = (EffectForm("microslip", joint=True, signs=(("chi", -1),), order=25),)
    effect_parameters: ClassVar[tuple[str, ...]] = ("kt", "slip_force", "chi", "beta")
    slip_force: float
    kt: float
    chi: float
    beta: float
    sliders: int = 400

    def __post_init__(self) -> None:
        object.__setattr__(self, "dofs", check_dofs(self.dofs))
        for name in ("slip_force", "kt", "chi", "beta"):
            object.__setattr__(self, name, float(getattr(self, name)))
        positive("slip_force", self.slip_force)
        positive("kt", self.kt)
        chi = self.chi
        if not (np.isfinite(chi) and -1.0 < chi <= 0.0):
            raise ValueError(f"chi must be a number with -1 < chi <= 0, got {self.chi}")
        positive("beta", self.beta, allow_zero=True)
        sliders = float(self.sliders)
        if not (np.isfinite(sliders) and sliders == int(sliders) and 2 <= sliders <= MAX_IWAN_SLIDERS):
            raise ValueError(f"sliders must be an integer from 2 to {MAX_IWAN_SLIDERS} (the time-domain error falls "
                             f"as 1/sliders²: the default 400 is within 1.5e-4), got {sliders:g}")
        object.__setattr__(self, "sliders", int(sliders))

    # -- the distribution ---------------------------------------------------------------
    @property
    def phi_max(self) -> float:
        """Largest slip displacement (m): the joint is in macroslip beyond it."""
        return _phi_max(self.kt, self.slip_force, self.chi, self.beta)

    @property
    def r_prime(self) -> float:
        """``R' = R/(χ+1)`` (N/m^(χ+2)), with ``R' φ_max^(χ+1) = K_T/(1+β)``; from the
        logarithms of the parameters, so a φ_max that underflows (F_S/K_T below ~1e-308)
        gives a large or infinite R' rather than a division by zero."""
        chi, beta = self.chi, self.beta
        log_phi = np.log(self.slip_force) + np.log1p(beta) - np.log(self.kt) - np.log(beta + (chi + 1) / (chi + 2))
        with np.errstate(over="ignore"):
            return float(np.exp(np.log(self._continuous) - (chi + 1) * log_phi))

    @property
    def _continuous(self) -> float:
        """``K_T/(1+β)`` (N/m): the stiffness of the continuous part, ``R' φ_max^(χ+1)``."""
        return self.kt / (1 + self.beta)

    @property
    def concentrated_stiffness(self) -> float:
        """S = βK_T/(1+β) (N/m), the stiffness of the sliders that slip at φ_max."""
        return self.beta * self.kt / (1 + self.beta)

    def backbone(self, displacement: ArrayLike) -> tuple[NDArray, NDArray]:
        """Virgin-loading force ``F_bb(u)`` (N, odd in u) and its slope (N/m)."""
        u = np.asarray(displacement, dtype=float)
        phi, stuck = self.phi_max, np.abs(u) < self.phi_max
        q = np.where(stuck, np.abs(u) / np.where(stuck, phi, 1.0), 1.0)  # |u|/φ_max while it holds
        force = self.kt * np.abs(u) - self._continuous * phi * q ** (self.chi + 2) / (self.chi + 2)
        slope = np.where(stuck, self.kt - self._continuous * q ** (self.chi + 1), 0.0)
        return np.sign(u) * np.where(stuck, force, self.slip_force), slope

    # -- describing function ------------------------------------------------------------
    def _parts(self, a: NDArray):
        """The DF's pieces at amplitudes ``a`` (m): :func:`_df_parts`."""
        return _df_parts(a, self.kt, self.slip_force, self.chi, self.beta)

    def describing_function(self, amplitude, omega=0.0):
        return self.describing_function_and_parts(amplitude)[0]

    def describing_function_and_parts(self, amplitude: ArrayLike) -> tuple[NDArray[np.complex128], tuple]:
        """(:meth:`describing_function` at ``amplitude``, the pieces it was computed from:
        :meth:`describing_function_gradient` at the same amplitudes takes them as ``known``
        instead of computing them again — a fit asks for the gradient where it has just
        evaluated ν)."""
        parts = self._parts(amplitude_array(amplitude))
        return self._value(parts), parts

    def _value(self, parts) -> NDArray[np.complex128]:
        """ν from :meth:`_parts` (class docstring)."""
        return _df_value(parts, self.kt, self.beta)

    def describing_function_derivatives(self, amplitude, omega=0.0):
        a = amplitude_array(amplitude)
        d_da = self._slope(a, self._parts(a))
        return d_da, np.zeros_like(d_da)

    def _slope(self, a: NDArray, parts) -> NDArray[np.complex128]:
        """∂ν/∂A at amplitudes ``a`` from their :meth:`_parts`."""
        chi, r, s, b, g, j = parts
        beta, k0 = self.beta, self._continuous
        root = np.sqrt(np.maximum(1 - r, 0.0))
        d_real = (-8 / pi * (1 + beta) * g * np.sqrt(np.maximum(r * (1 - r), 0.0)) / a
                  - 8 * k0 / (pi * a) * ((chi + 1) * j - s ** (chi + 1) * r**1.5 * root))
        micro_imag = 4 * (chi + 1) ** 2 * k0 * s ** (chi + 1) / (pi * a * (chi + 2) * (chi + 3))
        macro_imag = 4 * g / (pi * a) * ((chi + 1) * (-1 / (chi + 2) + 2 * r / (chi + 3)) + beta * (2 * r - 1))
        return d_real + 1j * np.where(a > self.phi_max, macro_imag, micro_imag)

    def describing_function_gradient(self, amplitude: ArrayLike, parameters: Sequence[str] = GRADIENT_PARAMETERS,
                                     known: tuple[NDArray[np.complex128], tuple] | None = None) -> DFGradient:
        """ν, ∂ν/∂A and ∂ν/∂p at amplitudes A (m) for each p of ``parameters`` (of ``kt``,
        ``slip_force``, ``chi`` and ``beta``; χ's costs most), the other three held
        (:class:`DFGradient`). From ν = K_T N(A/φ_max; χ, β) (class docstring): at fixed φ_max,
        ∂ν/∂ln K_T = ν, ∂ν/∂ln φ_max = −A ∂ν/∂A, and χ and β enter N only through 1/(1+β), the
        power s^(χ+1), the polynomial in χ of Im ν and J = (A/φ_max)^(χ+1) B(r; χ+5/2, 3/2),
        ``∂J/∂χ = J(ln s + ψ(χ+5/2) − ψ(χ+4))`` in microslip and ``−J ln r + r^−(χ+1) ∂B/∂a`` in
        macroslip (:func:`_scaled_incomplete_beta_da`); then φ_max's own dependence on K_T, F_S,
        χ and β (``ln φ_max = ln F_S + ln(1+β) − ln K_T − ln(β + (χ+1)/(χ+2))``). ``known``: this
        joint's :meth:`describing_function_and_parts` at these amplitudes, if at hand."""
        if unknown := [name for name in parameters if name not in GRADIENT_PARAMETERS]:
            raise ValueError(f"describing_function_gradient: parameters {unknown} not among {list(GRADIENT_PARAMETERS)}")
        a = amplitude_array(amplitude)
        nu, parts = known if known is not None else (None, self._parts(a))
        chi, r, s, b, g, j = parts
        kt, beta, nu_a = self.kt, self.beta, self._slope(a, parts)
        nu = self._value(parts) if nu is None else nu
        d_phi = -a * nu_a  # ∂ν/∂ln φ_max
        c = (chi + 1) / (chi + 2)
        p = (chi + 1) * s ** (chi + 1) * (1 / (chi + 2) - r / (chi + 3))
        d_beta = kt / (pi * np.square(1 + beta)) * (8 * j + 4j * r * ((1 - r) - p))  # at fixed φ_max (β may be huge)
        out = {"kt": (nu - d_phi) / kt, "slip_force": d_phi / self.slip_force,
               "beta": d_beta + d_phi * (1 / (1 + beta) - 1 / (beta + c))}
        if "chi" in parameters:
            out["chi"] = self._chi_derivative(parts) - d_phi / ((chi + 2) ** 2 * (beta + c))
        return DFGradient(nu, nu_a, {name: out[name] for name in parameters})

    def _chi_derivative(self, parts) -> NDArray[np.complex128]:
        """∂ν/∂χ at fixed K_T, φ_max and β from the DF's :meth:`_parts`
        (:meth:`describing_function_gradient`)."""
        chi, r, s, b, g, j = parts
        with np.errstate(divide="ignore", invalid="ignore"):
            log_s = np.where(s > 0, np.log(np.where(s > 0, s, 1.0)), 0.0)
        power = s ** (chi + 1)
        dp = power * ((1 / (chi + 2) - r / (chi + 3)) * (1 + (chi + 1) * log_s)
                      + (chi + 1) * (r / (chi + 3) ** 2 - 1 / (chi + 2) ** 2))
        macro = r < 1.0
        digammas = scipy.special.digamma(chi + 2.5) - scipy.special.digamma(chi + 4.0)
        dj = j * (log_s + digammas)
        if np.any(macro):
            dj = np.where(macro, -j * np.log(r) + _scaled_incomplete_beta_da(r, chi + 2.5), dj)
        return self.kt / (pi * (1 + self.beta)) * (-8 * dj + 4j * r * dp)

    # -- time domain --------------------------------------------------------------------
    def realisation(self) -> tuple[NDArray, NDArray]:
        """(stiffness N/m, slip displacement m) of the time-domain sliders (read-only)."""
        return _iwan_sliders(self.phi_max, self._continuous, float(self.chi), self.concentrated_stiffness, self.sliders)

    def realisation_describing_function(self, amplitude: ArrayLike) -> NDArray[np.complex128]:
        """Exact DF of the time-domain realisation: Σ k_i ν_Jenkins(A; φ_i) (N/m)."""
        stiffness, slip = self.realisation()
        a = amplitude_array(amplitude)[..., None]
        return _unit_jenkins_df(a, slip) @ stiffness

    def force(self, displacement, velocity, state, omega=0.0):
        """Return mapping of every slider: its force is ``k_i·clip(u − x_i, ±φ_i)``."""
        stiffness, slip = self.realisation()
        u = np.asarray(displacement, dtype=float)
        sliders = self.initial_state(u.shape) if state is None else state
        stretch = np.minimum(np.maximum(u[..., None] - sliders, -slip), slip)  # np.clip, without its overhead
        return stretch @ stiffness, u[..., None] - stretch

    def initial_state(self, shape: tuple[int, ...]) -> NDArray:
        return np.zeros(tuple(shape) + (self.realisation()[0].size,))

    def stiffness_bound(self, amplitude: float) -> float:
        return self.kt

    # -- harmonic balance: Masing's rules on the samples ------------------------------------
    def one_period(self, c: NDArray, fourier) -> PeriodForces:
        u = fourier.to_time(c)
        origin, force_at, gradient_at = masing_branches(self, u, fourier)
        keys = np.array(sorted(force_at))
        slot = np.searchsorted(keys, origin)
        turning_force = np.array([force_at[k] for k in keys])
        turning_gradient = np.array([gradient_at[k] for k in keys])
        stretch = u - u[origin]
        f_bb, t_bb = self.backbone(0.5 * stretch)
        force = turning_force[slot] + 2.0 * f_bb
        tangent = turning_gradient[slot] + t_bb[:, None] * (fourier.E - fourier.E[origin])
        return PeriodForces(fourier.to_harmonics(force), fourier.to_harmonics(tangent), np.zeros(fourier.size))

    # -- identification ---------------------------------------------------------------------
    @classmethod
    def start_values(cls, amplitude, y, omega, scale):
        """K_T from the stiffness lost at the largest amplitude; F_S from the damping there
        (``Im ν ≈ 4F_S/(πA)`` in macroslip) and, in case that level is not in macroslip, from
        K_T times the middle amplitude; two exponents and two shares of the concentrated part."""
        largest = int(np.argmax(amplitude))
        kt = max(-float(np.min(y.real)), 1e-3 * scale) * 1.2
        floor = 1e-6 * kt * float(amplitude.min())
        slips = [max(float(np.pi / 4 * y.imag[largest] * amplitude[largest]), floor), kt * float(np.median(amplitude))]
        return {"slip_force": slips, "kt": [kt], "chi": [-0.3, -0.7], "beta": [0.1, 1.0]}

    @classmethod
    def with_alternative(cls, kwargs, alternative, value):
        """F_S from a fixed φ_max (:attr:`phi_max` inverted)."""
        chi, beta = kwargs["chi"], kwargs["beta"]
        return {**kwargs, "slip_force": slip_force_at(value, kwargs["kt"], chi, beta)}

    def refit_when_unseen(self, amplitude_max):
        """Below ``MACROSLIP_REACH × φ_max`` the data determine χ and
        ``R' = K_T/((1+β)φ_max^(χ+1))`` only: fix β = 0 and φ_max at the largest measured
        amplitude, the smallest joint that keeps every level in microslip."""
        if amplitude_max >= MACROSLIP_REACH * self.phi_max:
            return None
        why = (f"no measured level reaches the Iwan joint's macroslip (largest amplitude {amplitude_max:.4g} m, "
               "{reach} × the φ_max of a free fit; " f"{MACROSLIP_REACH:g} × needed): the data determine its "
               f"chi and R' = kt/((1+beta)·phi_max^(chi+1)) only (kt trades with the linear stiffness, slip_force "
               f"and beta act above φ_max). Fixed beta = 0 and phi_max = the largest amplitude — the smallest joint "
               f"that keeps every level in microslip — so kt and slip_force are lower bounds, and the extracted "
               f"linear FRF holds the rest of the joint's stiffness")
        return {"beta": 0.0, "phi_max": float(amplitude_max)}, amplitude_max / self.phi_max, why

    @classmethod
    def degenerate(cls, values, unit_of):
        """At χ ≤ :data:`JENKINS_END` the joint acts as a Jenkins element (kf = βK_T/(1+β),
        Fs = F_S): K_T and β are not determined separately."""
        chi = values.get("chi")
        if chi is None or chi > JENKINS_END:
            return None
        kt, beta, slip = values["kt"], values["beta"], values["slip_force"]
        return ("kt", "beta"), (
            f"chi{{suffix}} = {chi:.4g} sits at the Jenkins end of the Iwan joint (chi → −1): it acts as a Jenkins "
            f"element with kf = beta·kt/(1+beta) = {beta * kt / (1 + beta):.4g} {unit_of('kf')} and slip "
            f"force {slip:.4g} {unit_of('slip_force')}; "
            f"kt and beta are not determined separately (fit a jenkins element instead)")

    # -- discovery ------------------------------------------------------------------------------
    @classmethod
    def effect_clip(cls, values):
        return {**values, "chi": float(np.clip(values["chi"], -1.0 + 1e-6, -1e-9))}

    @classmethod
    def effect_shapes(cls, amplitude):
        return tuple(np.geomspace(amplitude.min() / 3, amplitude.max() * 3, SHAPE_POINTS))

    @classmethod
    def effect_values(cls, scale, shape):
        """Shape φ_max, with χ = −0.5 and β = 0.5 to start (the fit refines all four)."""
        chi, beta = START_CHI, START_BETA
        return np.array([scale, slip_force_at(shape, scale, chi, beta), chi, beta])


def masing_branches(element: "IwanJoint", u: NDArray, fourier):
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
