"""Local nonlinear elements and their single-harmonic describing functions (docs/methods.md §2).

Every element acts on the relative displacement ``x = x_r − x_j`` of two coordinates, or
``x = x_r`` when it connects coordinate r to ground (``dofs=(r,)``).

For a relative motion ``x(t) = Re(A e^{iωt}) = A cos ωt`` the describing function (DF) is
the complex ratio of the first harmonic of the element force to the displacement
amplitude: ``ν(A, ω) = F₁/A`` with ``F₁ = (1/π)∫₀^{2π} f(θ) e^{−iθ} dθ``.
``Re ν`` is a stiffness (N/m), ``Im ν > 0`` dissipates energy (same sign as ``iωc``).

Each element provides
* ``describing_function(A, ω)`` and its derivatives ``(∂ν/∂A, ∂ν/∂ω)`` (for Newton);
* ``force(x, v, state, ω)``: the time-domain force law, vectorised, with a history
  state for hysteretic elements (return mapping); used for time integration and for
  the Fourier-integral check of the DF;
* ``stiffness_bound(A)``: an upper bound of the tangent stiffness up to amplitude A,
  used to choose stable time steps.

Elements are frozen dataclasses of plain floats and tuples, hence hashable. Each class
also states what it is called and what its parameters are (``type_name``, ``parameters``:
:class:`ElementParameter`); model files, identification and discovery read that one
declaration, collected in :data:`ELEMENT_TYPES`.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from math import gamma, pi, sqrt
from typing import ClassVar, Protocol, Sequence, Union

import numpy as np
import scipy.special
from numpy.typing import ArrayLike, NDArray

_TINY_AMPLITUDE = 1e-300


@dataclass(frozen=True)
class ElementParameter:
    """One parameter of an element type, as model files write it.

    ``name``: the constructor keyword and model-file key; ``unit``: its SI unit;
    ``positive``: it must be > 0 (identification fits its logarithm), otherwise signed;
    ``interval``: the open interval it lies in (identification maps it there), if any;
    ``fitted``: False for a setting of the realisation rather than a physical parameter
    (Iwan's slider count, a polynomial's coefficients); ``optional``: a model file may omit it.
    """

    name: str
    unit: str
    positive: bool = True
    interval: tuple[float, float] | None = None
    fitted: bool = True
    optional: bool = False


class NonlinearElement(Protocol):
    dofs: tuple[int, ...]

    def describing_function(self, amplitude: ArrayLike, omega: ArrayLike) -> NDArray[np.complex128]: ...

    def describing_function_derivatives(
        self, amplitude: ArrayLike, omega: ArrayLike
    ) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]: ...

    def force(
        self, displacement: NDArray, velocity: NDArray, state: NDArray | None, omega: ArrayLike
    ) -> tuple[NDArray, NDArray | None]: ...

    def initial_state(self, shape: tuple[int, ...]) -> NDArray | None: ...

    def stiffness_bound(self, amplitude: float) -> float: ...


def _check_dofs(dofs: Sequence[int]) -> tuple[int, ...]:
    dofs = tuple(int(d) for d in dofs)
    if len(dofs) not in (1, 2):
        raise ValueError(f"an element connects one dof to ground or two dofs, got dofs={list(dofs)}")
    if any(d < 0 for d in dofs):
        raise ValueError(f"dof indices must be non-negative, got {list(dofs)}")
    if len(dofs) == 2 and dofs[0] == dofs[1]:
        raise ValueError(f"an element cannot connect dof {dofs[0]} to itself")
    return dofs


def _positive(name: str, value: float, allow_zero: bool = False) -> float:
    value = float(value)
    if not np.isfinite(value) or value < 0 or (value == 0 and not allow_zero):
        raise ValueError(f"{name} must be a {'non-negative' if allow_zero else 'positive'} number, got {value}")
    return value


def _amplitude(amplitude: ArrayLike) -> NDArray[np.float64]:
    return np.maximum(np.abs(np.asarray(amplitude, dtype=float)), _TINY_AMPLITUDE)


class _Stateless:
    def initial_state(self, shape: tuple[int, ...]) -> None:
        return None


@dataclass(frozen=True)
class CubicStiffness(_Stateless):
    """Cubic spring ``f = k3·x³`` (k3 in N/m³); ``ν = ¾ k3 A²``."""

    dofs: tuple[int, ...]
    type_name: ClassVar[str] = "cubic"
    parameters: ClassVar[tuple[ElementParameter, ...]] = (ElementParameter("k3", "N/m^3", positive=False),)
    k3: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "dofs", _check_dofs(self.dofs))
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

    def stiffness_bound(self, amplitude: float) -> float:
        return 3.0 * abs(self.k3) * amplitude**2


@dataclass(frozen=True)
class JenkinsFriction:
    """Jenkins element: spring kf (N/m) in series with a Coulomb slider of slip force Fs (N).

    Stuck below ``A = Fs/kf`` (ν = kf); above, with ``β = arccos(1 − 2Fs/(kf A))``:
    ``Re ν = (kf/π)(β − ½ sin 2β)``, ``Im ν = (4Fs/(πA))(1 − Fs/(kf A))``.
    The time-domain state is the slider position (m).
    """

    dofs: tuple[int, ...]
    type_name: ClassVar[str] = "jenkins"
    parameters: ClassVar[tuple[ElementParameter, ...]] = (ElementParameter("kf", "N/m"), ElementParameter("slip_force", "N"))
    kf: float
    slip_force: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "dofs", _check_dofs(self.dofs))
        _positive("kf", self.kf)
        _positive("slip_force", self.slip_force)

    @property
    def slip_amplitude(self) -> float:
        """Amplitude (m) at which the slider starts to slip."""
        return self.slip_force / self.kf

    def _beta(self, a: NDArray) -> NDArray:
        ratio = np.clip(1.0 - 2.0 * self.slip_amplitude / a, -1.0, 1.0)
        return np.arccos(ratio)

    def describing_function(self, amplitude, omega=0.0):
        a = _amplitude(amplitude)
        stuck = a <= self.slip_amplitude
        beta = self._beta(a)
        real = self.kf / pi * (beta - 0.5 * np.sin(2 * beta))
        imag = 4 * self.slip_force / (pi * a) * (1 - self.slip_amplitude / a)
        return np.where(stuck, self.kf + 0j, real + 1j * imag)

    def describing_function_derivatives(self, amplitude, omega=0.0):
        a = _amplitude(amplitude)
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


@dataclass(frozen=True)
class CoulombFriction(_Stateless):
    """Coulomb friction ``f = Fs·sign(ẋ)``; ``ν = i·4Fs/(πA)``."""

    dofs: tuple[int, ...]
    type_name: ClassVar[str] = "coulomb"
    parameters: ClassVar[tuple[ElementParameter, ...]] = (ElementParameter("slip_force", "N"),)
    slip_force: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "dofs", _check_dofs(self.dofs))
        _positive("slip_force", self.slip_force)

    def describing_function(self, amplitude, omega=0.0):
        a = _amplitude(amplitude)
        return 1j * 4 * self.slip_force / (pi * a)

    def describing_function_derivatives(self, amplitude, omega=0.0):
        a = _amplitude(amplitude)
        d_da = -1j * 4 * self.slip_force / (pi * a**2)
        return d_da, np.zeros_like(d_da)

    def force(self, displacement, velocity, state, omega=0.0):
        return self.slip_force * np.sign(velocity), None

    def stiffness_bound(self, amplitude: float) -> float:
        return 0.0


@dataclass(frozen=True)
class QuadraticDamping(_Stateless):
    """Quadratic damper ``f = cq·ẋ·|ẋ|`` (cq in N·s²/m²); ``ν = i·8 cq ω² A/(3π)``."""

    dofs: tuple[int, ...]
    type_name: ClassVar[str] = "quadratic_damping"
    parameters: ClassVar[tuple[ElementParameter, ...]] = (ElementParameter("cq", "N s^2/m^2"),)
    cq: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "dofs", _check_dofs(self.dofs))
        _positive("cq", self.cq)

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

    def stiffness_bound(self, amplitude: float) -> float:
        return 0.0


@dataclass(frozen=True)
class SymmetricGap(_Stateless):
    """Contact spring kc (N/m) engaged beyond a clearance ±g (m).

    ``f = kc·(x − g·sign(x))`` for ``|x| > g``, else 0;
    ``ν = kc·[1 − (2/π)(asin(g/A) + (g/A)√(1 − (g/A)²))]`` for ``A > g``, else 0.
    """

    dofs: tuple[int, ...]
    type_name: ClassVar[str] = "gap"
    parameters: ClassVar[tuple[ElementParameter, ...]] = (ElementParameter("gap", "m"), ElementParameter("kc", "N/m"))
    gap: float
    kc: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "dofs", _check_dofs(self.dofs))
        _positive("gap", self.gap, allow_zero=True)
        _positive("kc", self.kc)

    def describing_function(self, amplitude, omega=0.0):
        a = _amplitude(amplitude)
        r = np.clip(self.gap / a, 0.0, 1.0)
        value = self.kc * (1 - 2 / pi * (np.arcsin(r) + r * np.sqrt(1 - r**2)))
        return np.where(a <= self.gap, 0.0, value) + 0j

    def describing_function_derivatives(self, amplitude, omega=0.0):
        a = _amplitude(amplitude)
        r = np.clip(self.gap / a, 0.0, 1.0)
        d_da = 4 * self.kc * self.gap / (pi * a**2) * np.sqrt(1 - r**2)
        d_da = np.where(a <= self.gap, 0.0, d_da) + 0j
        return d_da, np.zeros_like(d_da)

    def force(self, displacement, velocity, state, omega=0.0):
        excess = np.abs(displacement) - self.gap
        return np.where(excess > 0, self.kc * np.sign(displacement) * excess, 0.0), None

    def stiffness_bound(self, amplitude: float) -> float:
        return self.kc


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


@dataclass(frozen=True)
class IwanJoint:
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
    parameters: ClassVar[tuple[ElementParameter, ...]] = (
        ElementParameter("slip_force", "N"), ElementParameter("kt", "N/m"),
        ElementParameter("chi", "1", positive=False, interval=(-1.0, 0.0)), ElementParameter("beta", "1"),
        ElementParameter("sliders", "1", fitted=False, optional=True),
    )
    slip_force: float
    kt: float
    chi: float
    beta: float
    sliders: int = 400

    def __post_init__(self) -> None:
        object.__setattr__(self, "dofs", _check_dofs(self.dofs))
        for name in ("slip_force", "kt", "chi", "beta"):
            object.__setattr__(self, name, float(getattr(self, name)))
        _positive("slip_force", self.slip_force)
        _positive("kt", self.kt)
        chi = self.chi
        if not (np.isfinite(chi) and -1.0 < chi <= 0.0):
            raise ValueError(f"chi must be a number with -1 < chi <= 0, got {self.chi}")
        _positive("beta", self.beta, allow_zero=True)
        sliders = float(self.sliders)
        if not (np.isfinite(sliders) and sliders == int(sliders) and 2 <= sliders <= MAX_IWAN_SLIDERS):
            raise ValueError(f"sliders must be an integer from 2 to {MAX_IWAN_SLIDERS} (the time-domain error falls "
                             f"as 1/sliders²: the default 400 is within 1.5e-4), got {sliders:g}")
        object.__setattr__(self, "sliders", int(sliders))

    # -- the distribution ---------------------------------------------------------------
    @property
    def phi_max(self) -> float:
        """Largest slip displacement (m): the joint is in macroslip beyond it."""
        chi, beta = self.chi, self.beta
        return self.slip_force * (1 + beta) / (self.kt * (beta + (chi + 1) / (chi + 2)))

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
        """The DF's pieces at amplitudes ``a`` (m), written with ratios in [0, 1] only so that
        they stay finite for any valid parameters (a φ_max that underflows included):
        χ; r = min(1, φ_max/A); s = min(1, A/φ_max); b = arccos(1 − 2r);
        ``g = K_T r/(1+β)`` (N/m; in macroslip ``F_S/((β + (χ+1)/(χ+2)) A)``, exact however
        small φ_max is); and ``J = (A/φ_max)^(χ+1) B(r; χ+5/2, 3/2)`` (B the incomplete
        beta function, complete where r = 1: microslip; ``r^1.5/(χ+5/2)`` to O(r) for
        r < 1e-12)."""
        phi, chi, beta = self.phi_max, self.chi, self.beta
        macro = a > phi
        with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
            r = np.where(macro, phi / a, 1.0)
            s = np.where(macro, 1.0, a / np.where(macro, 1.0, phi))
            g = np.where(macro, self.slip_force / ((beta + (chi + 1) / (chi + 2)) * a), self._continuous)
        complete = scipy.special.beta(chi + 2.5, 1.5)
        if not np.any(macro):
            return chi, r, s, np.full(r.shape, pi), g, s ** (chi + 1) * complete
        with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
            scaled = np.where(r > 1e-12, scipy.special.betainc(chi + 2.5, 1.5, r) * complete * r ** -(chi + 1),
                              r**1.5 / (chi + 2.5))
        return chi, r, s, np.arccos(1.0 - 2.0 * r), g, np.where(macro, scaled, s ** (chi + 1) * complete)

    def describing_function(self, amplitude, omega=0.0):
        a = _amplitude(amplitude)
        chi, r, s, b, g, j = self._parts(a)
        real = self.kt * (b - 0.5 * np.sin(2 * b)) / pi - 8 * self._continuous / pi * j
        imag = 4 * g / pi * ((chi + 1) * s ** (chi + 1) * (1 / (chi + 2) - r / (chi + 3)) + self.beta * (1 - r))
        return real + 1j * imag

    def describing_function_derivatives(self, amplitude, omega=0.0):
        a = _amplitude(amplitude)
        chi, r, s, b, g, j = self._parts(a)
        beta, k0 = self.beta, self._continuous
        root = np.sqrt(np.maximum(1 - r, 0.0))
        d_real = (-8 / pi * (1 + beta) * g * np.sqrt(np.maximum(r * (1 - r), 0.0)) / a
                  - 8 * k0 / (pi * a) * ((chi + 1) * j - s ** (chi + 1) * r**1.5 * root))
        micro_imag = 4 * (chi + 1) ** 2 * k0 * s ** (chi + 1) / (pi * a * (chi + 2) * (chi + 3))
        macro_imag = 4 * g / (pi * a) * ((chi + 1) * (-1 / (chi + 2) + 2 * r / (chi + 3)) + beta * (2 * r - 1))
        d_da = d_real + 1j * np.where(a > self.phi_max, macro_imag, micro_imag)
        return d_da, np.zeros_like(d_da)

    # -- time domain --------------------------------------------------------------------
    def realisation(self) -> tuple[NDArray, NDArray]:
        """(stiffness N/m, slip displacement m) of the time-domain sliders (read-only)."""
        return _iwan_sliders(self.phi_max, self._continuous, float(self.chi), self.concentrated_stiffness, self.sliders)

    def realisation_describing_function(self, amplitude: ArrayLike) -> NDArray[np.complex128]:
        """Exact DF of the time-domain realisation: Σ k_i ν_Jenkins(A; φ_i) (N/m)."""
        stiffness, slip = self.realisation()
        a = _amplitude(amplitude)[..., None]
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


def _cos_power_mean(power: int) -> float:
    """``(1/π)∫₀^{2π} |cos θ|^{power+2} dθ``: DF gain of the force ``x|x|^power``."""
    n = power + 2
    return 2.0 / sqrt(pi) * gamma((n + 1) / 2) / gamma(n / 2 + 1)


@dataclass(frozen=True)
class PolynomialDF(_Stateless):
    """Identified describing function ``ν(A) = Σ p_k A^k + i Σ q_k A^k``.

    ``real`` and ``imag`` hold the coefficients highest order first (``numpy.polyval``
    convention), in SI units (N/m^(k+1) for the A^k term).

    The matching time-domain law (used for time integration) is
    ``f = Σ (p_k/γ_k)·x|x|^k + Σ (q_k/γ_k)·u|u|^k`` with ``u = ẋ/ω`` and
    ``γ_k = (1/π)∫|cos θ|^{k+2} dθ``, whose DF is exactly ν.
    """

    dofs: tuple[int, ...]
    type_name: ClassVar[str] = "polynomial"
    parameters: ClassVar[tuple[ElementParameter, ...]] = (
        ElementParameter("real", "N/m^(k+1)", positive=False, fitted=False),
        ElementParameter("imag", "N/m^(k+1)", positive=False, fitted=False, optional=True),
    )
    real: tuple[float, ...]
    imag: tuple[float, ...] = (0.0,)

    def __post_init__(self) -> None:
        object.__setattr__(self, "dofs", _check_dofs(self.dofs))
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
                total = total + coefficient / _cos_power_mean(power) * x * np.abs(x) ** power
        return total

    def force(self, displacement, velocity, state, omega=1.0):
        return self._law(self.real, displacement) + self._law(self.imag, velocity / omega), None

    def stiffness_bound(self, amplitude: float) -> float:
        order = len(self.real) - 1
        return sum(
            abs(c) / _cos_power_mean(order - i) * (order - i + 1) * amplitude ** (order - i)
            for i, c in enumerate(self.real)
        )


Element = Union[
    CubicStiffness, JenkinsFriction, CoulombFriction, QuadraticDamping, SymmetricGap, IwanJoint, PolynomialDF
]

#: Every element class by its ``type_name``: the one list model files, identification and
#: discovery read.
ELEMENT_TYPES: dict[str, type] = {
    cls.type_name: cls
    for cls in (CubicStiffness, JenkinsFriction, CoulombFriction, QuadraticDamping, SymmetricGap, IwanJoint,
                PolynomialDF)
}


def nonlinear_dofs(elements: Sequence[NonlinearElement]) -> tuple[int, ...]:
    """Sorted coordinates touched by any element (the ``a`` set of docs/methods.md §3)."""
    return tuple(sorted({d for element in elements for d in element.dofs}))
