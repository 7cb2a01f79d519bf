"""The library of candidate effects: what a model can be missing, as a describing function.

An effect acts at a place — one coordinate (to ground) or two (between them) — on the
relative displacement ``x = x_r − x_j`` (docs/methods.md §1): its describing function (DF)
``ν(A, ω; values)`` gives the first-harmonic force ``ν·X`` (N/m, ``Im ν > 0`` dissipates),
A (m) is the amplitude of the relative displacement and ω (rad/s) the excitation
frequency. Every DF of the library is a scale times a shape,

    ν(A, ω) = c · b_s(A, ω),

with at most one shape parameter s (the slip amplitude of a Jenkins element, the macroslip
displacement of an Iwan joint — whose other parameters start from fixed values —, the clearance
of a gap). Each effect is one small frozen class that states

* ``name`` and ``parameters`` (name, SI unit, sign: positive, negative or either) and
  ``scale_sign``, the sign the scale c must have;
* ``basis(s, A, ω)`` — the DF for c = 1, broadcasting A and ω; ``shapes(A)`` — the shape
  values worth trying for measured amplitudes A (``(None,)`` for shapeless effects);
  ``values(c, s)`` — the parameters from scale and shape;
* ``apply(system, dofs, values)`` — the model with the effect added.

``nu(values, A, ω)`` is the DF at given parameters. Nonlinear effects reuse the elements of
:mod:`nlupdate.core.model.elements` (their DFs are verified there); the linear ones (stiffness,
mass, damping errors) are a spring ``ν = Δk``, a mass ``ν = −ω²Δm`` and a viscous damper
``ν = iωΔc`` that edit the linear model (:mod:`nlupdate.core.discovery.linear_edits`).

A new effect is one subclass of :class:`ElementEffect` or :class:`LinearEffect` passed in
:class:`~nlupdate.core.discovery.workflow.DiscoveryOptions` ``effects``; nothing else changes.
"""
from __future__ import annotations

import functools

from dataclasses import dataclass
from typing import ClassVar, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nlupdate.core.discovery.errors import DiscoveryError
from nlupdate.core.discovery.linear_edits import add_linear_correction
from nlupdate.core.model.elements import (
    CoulombFriction, CubicStiffness, IwanJoint, JenkinsFriction, QuadraticDamping, SymmetricGap,
)
from nlupdate.core.model.system import NonlinearSystem

POSITIVE, NEGATIVE, SIGNED = 1, -1, 0
SHAPE_POINTS = 24


@dataclass(frozen=True)
class EffectParameter:
    """One parameter of an effect: name, SI unit and sign (POSITIVE, NEGATIVE or SIGNED)."""

    name: str
    unit: str
    sign: int = POSITIVE


def _element_parameter(element: type, name: str, sign: int = POSITIVE) -> EffectParameter:
    """Parameter ``name`` of an element class, its unit as the element declares it; the sign
    is the effect's (a softening cubic is an element with k3 < 0)."""
    unit = next(p.unit for p in element.parameters if p.name == name)
    return EffectParameter(name, unit, sign)


@dataclass(frozen=True, eq=False)
class DFSamples:
    """Apparent DF samples at one place: amplitude A (m), ω (rad/s), ν̃ (N/m) and the
    standard deviation of each ν̃ (N/m; relative weights suffice)."""

    amplitude: NDArray[np.float64]
    omega: NDArray[np.float64]
    nu: NDArray[np.complex128]
    std: NDArray[np.float64]


def _broadcast(value: ArrayLike, amplitude: ArrayLike, omega: ArrayLike) -> NDArray[np.complex128]:
    """``value`` as a complex array of the broadcast shape of A and ω."""
    value = np.asarray(value, dtype=complex)
    shape = np.broadcast_shapes(np.shape(amplitude), np.shape(omega))
    return value if value.shape == shape else np.broadcast_to(value, shape)


@dataclass(frozen=True)
class Effect:
    """Base class of candidate effects (see module docstring)."""

    name: ClassVar[str]
    parameters: ClassVar[tuple[EffectParameter, ...]]
    scale_sign: ClassVar[int] = POSITIVE
    to_ground_only: ClassVar[bool] = False

    @property
    def variant(self) -> str:
        """Qualifier of an effect that comes in several forms ("" for most)."""
        return ""

    def applies_to(self, dofs: Sequence[int]) -> bool:
        return len(dofs) == 1 or not self.to_ground_only

    def parameter_dict(self, values: ArrayLike) -> dict[str, float]:
        return {p.name: float(v) for p, v in zip(self.parameters, np.atleast_1d(values))}

    def shapes(self, amplitude: NDArray[np.float64]) -> Sequence[float | None]:
        return (None,)

    def basis(self, shape: float | None, amplitude: ArrayLike, omega: ArrayLike) -> NDArray[np.complex128]:
        raise NotImplementedError

    def values(self, scale: float, shape: float | None) -> NDArray[np.float64]:
        return np.array([scale])

    def nu(self, values: ArrayLike, amplitude: ArrayLike, omega: ArrayLike) -> NDArray[np.complex128]:
        raise NotImplementedError

    def apply(self, system: NonlinearSystem, dofs: Sequence[int], values: ArrayLike) -> NonlinearSystem:
        raise NotImplementedError


@functools.lru_cache(maxsize=256)
def _element_at_origin(effect: "ElementEffect", values: tuple[float, ...]):
    """The effect's element at coordinate 0 with these values (a fit asks for the same one
    thousands of times: building it checks every parameter)."""
    return effect.element((0,), np.array(values))


@dataclass(frozen=True)
class ElementEffect(Effect):
    """An effect that is one element of :mod:`nlupdate.core.model.elements`."""

    def element(self, dofs: Sequence[int], values: ArrayLike):
        raise NotImplementedError

    def nu(self, values, amplitude, omega):
        element = _element_at_origin(self, tuple(np.atleast_1d(np.asarray(values, dtype=float)).tolist()))
        return _broadcast(element.describing_function(amplitude, omega), amplitude, omega)

    def basis(self, shape, amplitude, omega):
        return self.nu(self.values(1.0, shape), amplitude, omega)

    def apply(self, system, dofs, values):
        return system.with_elements(system.elements + (self.element(tuple(dofs), values),))


@dataclass(frozen=True)
class CubicHardening(ElementEffect):
    """Cubic spring ``k3·x³``, k3 > 0 (N/m³): ``ν = ¾k3A²``."""

    name: ClassVar[str] = "cubic_stiffness"
    parameters: ClassVar[tuple[EffectParameter, ...]] = (_element_parameter(CubicStiffness, "k3"),)

    def element(self, dofs, values):
        return CubicStiffness(tuple(dofs), float(values[0]))


@dataclass(frozen=True)
class CubicSoftening(CubicHardening):
    """Softening cubic spring ``k3·x³``, k3 < 0 (N/m³): ``ν = ¾k3A²``."""

    name: ClassVar[str] = "softening_stiffness"
    parameters: ClassVar[tuple[EffectParameter, ...]] = (_element_parameter(CubicStiffness, "k3", NEGATIVE),)
    scale_sign: ClassVar[int] = NEGATIVE


@dataclass(frozen=True)
class JointEffect(ElementEffect):
    """A joint whose stuck stiffness is the first value. ``stuck_in_model=True``: the model's
    linear stiffness at the place already holds it (a model tuned to a low-force test), so the
    model's stiffness there is reduced by it and the DF added is ``ν_joint(A) − k_stuck``
    (zero while stuck, softening and damping once it slips)."""

    stuck_in_model: bool = False

    @property
    def variant(self) -> str:
        return "stuck_in_model" if self.stuck_in_model else ""

    def nu(self, values, amplitude, omega):
        return super().nu(values, amplitude, omega) - (float(values[0]) if self.stuck_in_model else 0.0)

    def apply(self, system, dofs, values):
        with_joint = super().apply(system, dofs, values)
        if not self.stuck_in_model:
            return with_joint
        return NonlinearSystem(add_linear_correction(with_joint.model, dofs, stiffness=-float(values[0])), with_joint.elements)


@dataclass(frozen=True)
class DryFriction(JointEffect):
    """Jenkins element: spring kf (N/m) in series with a slider of slip force Fs (N).

    Shape: the slip amplitude ``a0 = Fs/kf``; scale: kf. ``stuck_in_model``: the model's
    stiffness already holds kf (:class:`JointEffect`, docs/methods.md §2).
    """

    name: ClassVar[str] = "dry_friction"
    parameters: ClassVar[tuple[EffectParameter, ...]] = (
        _element_parameter(JenkinsFriction, "kf"), _element_parameter(JenkinsFriction, "slip_force"),
    )

    def element(self, dofs, values):
        return JenkinsFriction(tuple(dofs), kf=float(values[0]), slip_force=float(values[1]))

    def shapes(self, amplitude):
        return tuple(np.geomspace(amplitude.min() / 10, amplitude.max() * 3, SHAPE_POINTS))

    def values(self, scale, shape):
        return np.array([scale, scale * shape])


@dataclass(frozen=True)
class Microslip(JointEffect):
    """Segalman's four-parameter Iwan joint (:class:`~nlupdate.core.model.elements.IwanJoint`):
    tangential stiffness K_T (N/m, the scale), macroslip force F_S (N), exponent χ ∈ (−1, 0)
    and share β ≥ 0 of its concentrated part.

    Shape: φ_max, the displacement of macroslip, with χ = −0.5 and β = 0.5 to start (the fit
    refines all four; χ is held inside (−1, 0)). ``stuck_in_model``: the model's stiffness
    already holds K_T (:class:`JointEffect`): softening and damping then grow from zero with
    the amplitude as more of the contact slips.
    """

    name: ClassVar[str] = "microslip"
    parameters: ClassVar[tuple[EffectParameter, ...]] = (
        _element_parameter(IwanJoint, "kt"), _element_parameter(IwanJoint, "slip_force"),
        _element_parameter(IwanJoint, "chi", NEGATIVE), _element_parameter(IwanJoint, "beta"),
    )
    start_chi: ClassVar[float] = -0.5
    start_beta: ClassVar[float] = 0.5

    @staticmethod
    def _chi(value: float) -> float:
        return float(np.clip(value, -1.0 + 1e-6, -1e-9))

    def parameter_dict(self, values):
        out = super().parameter_dict(values)
        out["chi"] = self._chi(out["chi"])
        return out

    def element(self, dofs, values):
        kt, slip_force, chi, beta = (float(v) for v in values)
        return IwanJoint(tuple(dofs), slip_force=slip_force, kt=kt, chi=self._chi(chi), beta=beta)

    def shapes(self, amplitude):
        return tuple(np.geomspace(amplitude.min() / 3, amplitude.max() * 3, SHAPE_POINTS))

    def values(self, scale, shape):
        chi, beta = self.start_chi, self.start_beta
        return np.array([scale, shape * scale * (beta + (chi + 1) / (chi + 2)) / (1 + beta), chi, beta])


@dataclass(frozen=True)
class CoulombSlider(ElementEffect):
    """Coulomb friction ``Fs·sign(ẋ)`` (Fs in N): ``ν = i·4Fs/(πA)``."""

    name: ClassVar[str] = "coulomb_friction"
    parameters: ClassVar[tuple[EffectParameter, ...]] = (_element_parameter(CoulombFriction, "slip_force"),)

    def element(self, dofs, values):
        return CoulombFriction(tuple(dofs), float(values[0]))


@dataclass(frozen=True)
class QuadraticDamper(ElementEffect):
    """Quadratic damper ``cq·ẋ|ẋ|`` (cq in N·s²/m²): ``ν = i·8cqω²A/(3π)``."""

    name: ClassVar[str] = "quadratic_damping"
    parameters: ClassVar[tuple[EffectParameter, ...]] = (_element_parameter(QuadraticDamping, "cq"),)

    def element(self, dofs, values):
        return QuadraticDamping(tuple(dofs), float(values[0]))


@dataclass(frozen=True)
class Clearance(ElementEffect):
    """Symmetric gap: contact stiffness kc (N/m, the scale) beyond a clearance ±g (m, the shape)."""

    name: ClassVar[str] = "gap"
    parameters: ClassVar[tuple[EffectParameter, ...]] = (_element_parameter(SymmetricGap, "gap"), _element_parameter(SymmetricGap, "kc"))

    def element(self, dofs, values):
        return SymmetricGap(tuple(dofs), gap=float(values[0]), kc=float(values[1]))

    def shapes(self, amplitude):
        return tuple(np.geomspace(amplitude.min() / 10, amplitude.max() * 0.95, SHAPE_POINTS))

    def values(self, scale, shape):
        return np.array([shape, scale])


@dataclass(frozen=True)
class LinearEffect(Effect):
    """A linear correction ``ν = value·b(ω)`` applied to the linear model."""

    scale_sign: ClassVar[int] = SIGNED
    correction: ClassVar[str]

    def omega_shape(self, omega: ArrayLike) -> NDArray[np.complex128]:
        raise NotImplementedError

    def basis(self, shape, amplitude, omega):
        return _broadcast(self.omega_shape(omega), amplitude, omega)

    def nu(self, values, amplitude, omega):
        return float(np.atleast_1d(values)[0]) * self.basis(None, amplitude, omega)

    def apply(self, system, dofs, values):
        model = add_linear_correction(system.model, dofs, **{self.correction: float(np.atleast_1d(values)[0])})
        return NonlinearSystem(model, system.elements)


@dataclass(frozen=True)
class StiffnessError(LinearEffect):
    """Missing or excess linear stiffness Δk (N/m): ``ν = Δk``."""

    name: ClassVar[str] = "stiffness_error"
    parameters: ClassVar[tuple[EffectParameter, ...]] = (EffectParameter("delta_k", "N/m", SIGNED),)
    correction: ClassVar[str] = "stiffness"

    def omega_shape(self, omega):
        return np.ones_like(np.asarray(omega, dtype=float)) + 0j


@dataclass(frozen=True)
class MassError(LinearEffect):
    """Missing or excess mass Δm (kg) at a coordinate: ``ν = −ω²Δm``."""

    name: ClassVar[str] = "mass_error"
    parameters: ClassVar[tuple[EffectParameter, ...]] = (EffectParameter("delta_m", "kg", SIGNED),)
    correction: ClassVar[str] = "mass"
    to_ground_only: ClassVar[bool] = True

    def omega_shape(self, omega):
        return -np.asarray(omega, dtype=float) ** 2 + 0j


@dataclass(frozen=True)
class DampingError(LinearEffect):
    """Missing or excess viscous damping Δc (N·s/m): ``ν = iωΔc``."""

    name: ClassVar[str] = "damping_error"
    parameters: ClassVar[tuple[EffectParameter, ...]] = (EffectParameter("delta_c", "N s/m", SIGNED),)
    correction: ClassVar[str] = "damping"

    def omega_shape(self, omega):
        return 1j * np.asarray(omega, dtype=float)


LIBRARY: tuple[Effect, ...] = (
    CubicHardening(),
    CubicSoftening(),
    DryFriction(),
    DryFriction(stuck_in_model=True),
    Microslip(),
    Microslip(stuck_in_model=True),
    CoulombSlider(),
    QuadraticDamper(),
    Clearance(),
    StiffnessError(),
    MassError(),
    DampingError(),
)
EFFECT_NAMES: tuple[str, ...] = tuple(dict.fromkeys(effect.name for effect in LIBRARY))


def library(selection: Sequence[str | Effect] | None = None) -> tuple[Effect, ...]:
    """Effects by name (all forms of a name) or as instances; None → the whole library."""
    if selection is None:
        return LIBRARY
    chosen: list[Effect] = []
    for item in selection:
        if isinstance(item, Effect):
            chosen.append(item)
            continue
        matches = [effect for effect in LIBRARY if effect.name == str(item).strip()]
        if not matches:
            raise DiscoveryError(f"options.effects: unknown effect {item!r}; the library has {', '.join(EFFECT_NAMES)}")
        chosen.extend(matches)
    if not chosen:
        raise DiscoveryError(f"options.effects: no effects selected; the library has {', '.join(EFFECT_NAMES)}")
    return tuple(dict.fromkeys(chosen))
