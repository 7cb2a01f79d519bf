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

``nu(values, A, ω)`` is the DF at given parameters. The nonlinear effects are generated from
the element registry (:data:`nlupdate.core.model.elements.ELEMENT_TYPES`): each element class
declares its forms (``effects``: name, signs, whether it is a joint whose stuck stiffness may
already be in the model) and its shapes and start values, and its DF is the element's (verified
there). The linear ones (stiffness, mass, damping errors) are a spring ``ν = Δk``, a mass
``ν = −ω²Δm`` and a viscous damper ``ν = iωΔc`` that edit the linear model
(:mod:`nlupdate.core.discovery.linear_edits`).

A new nonlinear effect is declared by its element class, so a new element module brings it;
a linear one is a subclass of :class:`LinearEffect`; any :class:`Effect` instance may also be
passed in :class:`~nlupdate.core.discovery.workflow.DiscoveryOptions` ``effects``.
"""
from __future__ import annotations

import functools

from dataclasses import dataclass, make_dataclass
from typing import ClassVar, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nlupdate.core.discovery.errors import DiscoveryError
from nlupdate.core.discovery.linear_edits import add_linear_correction
from nlupdate.core.model.elements import ELEMENT_TYPES, EffectForm
from nlupdate.core.model.system import NonlinearSystem

POSITIVE, NEGATIVE, SIGNED = 1, -1, 0


@dataclass(frozen=True)
class EffectParameter:
    """One parameter of an effect: name, SI unit and sign (POSITIVE, NEGATIVE or SIGNED)."""

    name: str
    unit: str
    sign: int = POSITIVE


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
    in_default_library: ClassVar[bool] = True  # fitted when no effects are named

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
    """An effect that is one element of :mod:`nlupdate.core.model.elements`, as the element
    class declares it (its ``effects``: name, signs; ``effect_shapes``, ``effect_values``).

    ``stuck_in_model=True`` (a joint's form only): the model's linear stiffness at the place
    already holds the joint's stuck stiffness, the first value (a model tuned to a low-force
    test), so the model's stiffness there is reduced by it and the DF added is
    ``ν_joint(A) − k_stuck`` (zero while stuck, softening and damping once it slips)."""

    kind: ClassVar[type]
    form: ClassVar[EffectForm]
    stuck_in_model: bool = False

    def __post_init__(self) -> None:
        if self.stuck_in_model and not self.form.joint:
            raise DiscoveryError(f"effect {self.name}: stuck_in_model applies to joints only")

    @property
    def variant(self) -> str:
        return "stuck_in_model" if self.stuck_in_model else ""

    def parameter_dict(self, values):
        return self.kind.effect_clip(super().parameter_dict(values))

    def element(self, dofs: Sequence[int], values: ArrayLike):
        names = self.kind.effect_parameter_names()
        return self.kind(tuple(dofs), **self.kind.effect_clip({n: float(v) for n, v in zip(names, np.atleast_1d(values))}))

    def shapes(self, amplitude):
        return self.kind.effect_shapes(amplitude)

    def values(self, scale, shape):
        return self.kind.effect_values(scale, shape)

    def nu(self, values, amplitude, omega):
        element = _element_at_origin(self, tuple(np.atleast_1d(np.asarray(values, dtype=float)).tolist()))
        nu = _broadcast(element.describing_function(amplitude, omega), amplitude, omega)
        return nu - float(np.atleast_1d(values)[0]) if self.stuck_in_model else nu

    def basis(self, shape, amplitude, omega):
        return self.nu(self.values(1.0, shape), amplitude, omega)

    def apply(self, system, dofs, values):
        with_joint = system.with_elements(system.elements + (self.element(tuple(dofs), values),))
        if not self.stuck_in_model:
            return with_joint
        return NonlinearSystem(add_linear_correction(with_joint.model, dofs, stiffness=-float(values[0])), with_joint.elements)


def _element_effect_class(kind: type, form: EffectForm) -> type:
    """The effect class of one form an element class declares."""
    signs = dict(form.signs)
    units = {p.name: p.unit for p in kind.parameters}
    parameters = tuple(EffectParameter(name, units[name], signs.get(name, POSITIVE))
                       for name in kind.effect_parameter_names())
    title = "".join(part.title() for part in form.name.split("_"))
    namespace = {"name": form.name, "kind": kind, "form": form, "parameters": parameters, "scale_sign": form.sign,
                 "in_default_library": form.default,
                 "__doc__": f"{kind.__name__} as the discovery effect {form.name!r}: {(kind.__doc__ or '').strip().splitlines()[0]}"}
    cls = make_dataclass(f"{title}Effect", (), bases=(ElementEffect,), frozen=True, namespace=namespace)
    cls.__module__ = __name__  # pickled by reference (candidate jobs run in other processes)
    return cls


def _element_effects() -> tuple[dict[str, type], tuple[Effect, ...]]:
    """Every element class's effect forms: classes by effect name, and the library entries
    (joint forms twice: with and without the stuck stiffness in the model), in form order."""
    forms = sorted(((form, kind) for kind in ELEMENT_TYPES.values() for form in kind.effects),
                   key=lambda pair: (pair[0].order, pair[0].name))
    classes = {form.name: _element_effect_class(kind, form) for form, kind in forms}
    entries = []
    for form, _ in forms:
        entries.append(classes[form.name]())
        if form.joint:
            entries.append(classes[form.name](stuck_in_model=True))
    return classes, tuple(entries)


#: The element effects' classes by effect name (read from the element registry).
ELEMENT_EFFECTS, _ELEMENT_LIBRARY = _element_effects()
globals().update({cls.__name__: cls for cls in ELEMENT_EFFECTS.values()})  # where pickle looks them up
CubicHardening, CubicSoftening = ELEMENT_EFFECTS["cubic_stiffness"], ELEMENT_EFFECTS["softening_stiffness"]
DryFriction, Microslip = ELEMENT_EFFECTS["dry_friction"], ELEMENT_EFFECTS["microslip"]
CoulombSlider, QuadraticDamper = ELEMENT_EFFECTS["coulomb_friction"], ELEMENT_EFFECTS["quadratic_damping"]
Clearance = ELEMENT_EFFECTS["gap"]


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


#: Every effect discovery knows, in order (those named in ``options.effects`` come from here).
ALL_EFFECTS: tuple[Effect, ...] = _ELEMENT_LIBRARY + (StiffnessError(), MassError(), DampingError())
#: The effects fitted when none are named (an element form with ``default=False`` is left out).
LIBRARY: tuple[Effect, ...] = tuple(e for e in ALL_EFFECTS if e.in_default_library)
EFFECT_NAMES: tuple[str, ...] = tuple(dict.fromkeys(effect.name for effect in ALL_EFFECTS))


def library(selection: Sequence[str | Effect] | None = None) -> tuple[Effect, ...]:
    """Effects by name (all forms of a name, from :data:`ALL_EFFECTS`) or as instances; None → :data:`LIBRARY`."""
    if selection is None:
        return LIBRARY
    chosen: list[Effect] = []
    for item in selection:
        if isinstance(item, Effect):
            chosen.append(item)
            continue
        matches = [effect for effect in ALL_EFFECTS if effect.name == str(item).strip()]
        if not matches:
            raise DiscoveryError(f"options.effects: unknown effect {item!r}; the library has {', '.join(EFFECT_NAMES)}")
        chosen.extend(matches)
    if not chosen:
        raise DiscoveryError(f"options.effects: no effects selected; the library has {', '.join(EFFECT_NAMES)}")
    return tuple(dict.fromkeys(chosen))
