"""The element protocol: what one class per local nonlinear element states, and the registry.

Every element acts on the relative displacement ``x = x_r − x_j`` of two coordinates, or
``x = x_r`` when it connects coordinate r to ground (``dofs=(r,)``).

For a relative motion ``x(t) = Re(A e^{iωt}) = A cos ωt`` the describing function (DF) is
the complex ratio of the first harmonic of the element force to the displacement
amplitude: ``ν(A, ω) = F₁/A`` with ``F₁ = (1/π)∫₀^{2π} f(θ) e^{−iθ} dθ``.
``Re ν`` is a stiffness (N/m), ``Im ν > 0`` dissipates energy (same sign as ``iωc``).

An element class (a frozen dataclass of plain floats and tuples, subclass of
:class:`ElementBase`) states, in one module:

* ``type_name`` (the model-file and identification name), ``parameters``
  (:class:`ElementParameter`: unit, meaning, sign, interval), ``order`` (its place in listings);
  defining a subclass with a ``type_name`` registers it in :data:`ELEMENT_TYPES`;
* the describing function and its derivatives ``(∂ν/∂A, ∂ν/∂ω)`` (Newton of the DF solvers,
  identification, discovery);
* ``force(x, v, state, ω)``: the time-domain law, vectorised over samples, with a history
  state for hysteretic elements (return mapping), and ``initial_state``; with
  ``stiffness_bound(A)`` and ``damping_bound(V)`` (tangent bounds for stable time steps);
* for harmonic balance (AFT, :mod:`nlupdate.core.response.aft`), either ``harmonic_law``
  — the force and its tangents at every sample of a period, from which the base class
  computes the harmonics, their Jacobian and Hill's damping coefficients for all such
  elements — or, for a force that is not a function of the sample (a hysteresis cycle,
  a discontinuity integrated exactly), its own ``period_forces``/``damping_harmonics``;
* optional knowledge the identification and discovery read: ``stick_slip`` (the stuck
  stiffness and slip force of an element the PRD assumes stuck at the low force),
  ``start_values`` (fit starts from describing-function points), ``alternatives``
  (a parameter that may be fixed in place of another), ``refit_when_unseen`` and
  ``degenerate`` (what the data cannot show), ``effects`` (the discovery candidates).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, ClassVar, Mapping, Protocol, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

_TINY_AMPLITUDE = 1e-300
#: shape values a discovery effect tries (:meth:`ElementBase.effect_shapes`)
SHAPE_POINTS = 24

#: Every element class by its ``type_name``, in ``order``: the one list model files,
#: response solvers, identification and discovery read. Filled by :class:`ElementBase`.
ELEMENT_TYPES: dict[str, type] = {}


@dataclass(frozen=True)
class ElementParameter:
    """One parameter of an element type, as model files write it.

    ``name``: the constructor keyword and model-file key; ``unit``: its SI unit;
    ``meaning``: what it is, in a few words a new reader understands (the report's ``Terms:``
    line explains an identified parameter with it; required, non-empty, no ';', which
    separates the terms there); ``positive``: it must be > 0 (identification fits its
    logarithm), otherwise signed;
    ``interval``: the open interval it lies in (identification maps it there), if any;
    ``fitted``: False for a setting of the realisation rather than a physical parameter
    (Iwan's slider count, a polynomial's coefficients); ``optional``: a model file may omit it;
    ``sequence``: a list of numbers (a polynomial's coefficients) rather than one number.
    """

    name: str
    unit: str
    positive: bool = True
    interval: tuple[float, float] | None = None
    fitted: bool = True
    optional: bool = False
    sequence: bool = False
    meaning: str = field(kw_only=True)

    def __post_init__(self) -> None:
        if not isinstance(self.meaning, str) or not self.meaning.strip() or ";" in self.meaning:
            raise ValueError(f"element parameter {self.name!r}: its meaning must be a non-empty text without ';', "
                             f"got {self.meaning!r}")


@dataclass(frozen=True)
class EffectForm:
    """A discovery candidate an element class offers: its user-facing ``name``, the sign of
    its scale (+1, −1), ``joint``: a stuck stiffness that may already be
    in the model, the first effect parameter (a ``stuck_in_model`` variant is offered too), ``signs``: the signs of
    the effect parameters by name where not positive; ``order``: its place in the library;
    ``default``: fitted when no effects are named (False: only when named, so that a new element
    does not change what discovery finds by default)."""

    name: str
    sign: int = 1
    joint: bool = False
    signs: tuple[tuple[str, int], ...] = ()
    order: int = 1000  # place in the discovery library
    default: bool = True  # in the library discovery fits when no effects are named (else: by name only)


@dataclass(frozen=True)
class PeriodForces:
    """One element over one period: harmonics G (2H+1,) (N), ∂G/∂c (2H+1, 2H+1) (N/m),
    ∂G/∂ω (2H+1,) (N·s/rad); with a leading axis of P motions from ``period_forces``."""

    g: NDArray
    dg_dc: NDArray
    dg_domega: NDArray


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

    def damping_bound(self, velocity: ArrayLike) -> ArrayLike: ...

    def period_forces(self, c: NDArray, omega: NDArray, fourier: Any) -> PeriodForces: ...

    def damping_harmonics(self, c: NDArray, omega: NDArray, fourier: Any) -> NDArray[np.complex128]: ...


def check_dofs(dofs: Sequence[int]) -> tuple[int, ...]:
    """The element's coordinates as a tuple of one or two distinct indices ≥ 0."""
    dofs = tuple(int(d) for d in dofs)
    if len(dofs) not in (1, 2):
        raise ValueError(f"an element connects one dof to ground or two dofs, got dofs={list(dofs)}")
    if any(d < 0 for d in dofs):
        raise ValueError(f"dof indices must be non-negative, got {list(dofs)}")
    if len(dofs) == 2 and dofs[0] == dofs[1]:
        raise ValueError(f"an element cannot connect dof {dofs[0]} to itself")
    return dofs


def positive(name: str, value: float, allow_zero: bool = False) -> float:
    """``value`` as a float, refused unless finite and > 0 (≥ 0 with ``allow_zero``)."""
    value = float(value)
    if not np.isfinite(value) or value < 0 or (value == 0 and not allow_zero):
        raise ValueError(f"{name} must be a {'non-negative' if allow_zero else 'positive'} number, got {value}")
    return value


def amplitude_array(amplitude: ArrayLike) -> NDArray[np.float64]:
    """|A| as floats, at least 1e-300 (a DF divided by A stays finite at A = 0)."""
    return np.maximum(np.abs(np.asarray(amplitude, dtype=float)), _TINY_AMPLITUDE)


def each_motion(single: Callable[[NDArray, float], PeriodForces], c: NDArray, omega: NDArray, size: int) -> PeriodForces:
    """``single(c_p, ω_p)`` for every motion p, stacked (P, …); for laws followed one motion at a time."""
    parts = [single(ci, wi) for ci, wi in zip(c, omega)]
    if not parts:
        empty = np.zeros((0, size))
        return PeriodForces(empty, np.zeros((0, size, size)), empty)
    return PeriodForces(np.array([p.g for p in parts]), np.array([p.dg_dc for p in parts]),
                        np.array([p.dg_domega for p in parts]))


class ElementBase:
    """Base class of the elements: registration and the defaults of the protocol (module doc)."""

    dofs: tuple[int, ...]
    type_name: ClassVar[str]
    parameters: ClassVar[tuple[ElementParameter, ...]]
    #: place in listings (model-file messages, identification, the discovery library)
    order: ClassVar[int] = 1000
    #: (stuck stiffness, slip force) parameter names of an element the PRD method assumes
    #: stuck at the low force (its slip-force start and trust checks follow from it)
    stick_slip: ClassVar[tuple[str, str] | None] = None
    #: parameters that may be fixed in place of another: {alternative: replaced parameter}
    alternatives: ClassVar[dict[str, str]] = {}
    #: the discovery candidates this element offers
    effects: ClassVar[tuple[EffectForm, ...]] = ()
    #: effect parameter order (the scale first); default: the fitted parameters
    effect_parameters: ClassVar[tuple[str, ...] | None] = None

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if "type_name" in cls.__dict__:
            if cls.type_name in ELEMENT_TYPES and ELEMENT_TYPES[cls.type_name].__qualname__ != cls.__qualname__:
                raise ValueError(f"element type {cls.type_name!r} is defined twice "
                                 f"({ELEMENT_TYPES[cls.type_name].__qualname__}, {cls.__qualname__})")
            ELEMENT_TYPES[cls.type_name] = cls
            ordered = sorted(ELEMENT_TYPES.items(), key=lambda item: (item[1].order, item[0]))
            ELEMENT_TYPES.clear()
            ELEMENT_TYPES.update(ordered)

    # -- time domain ----------------------------------------------------------------------
    def initial_state(self, shape: tuple[int, ...]) -> NDArray | None:
        """The history state before any motion (None: the element has none)."""
        return None

    def damping_bound(self, velocity: ArrayLike) -> ArrayLike:
        """An upper bound of the tangent damping ``∂f/∂ẋ`` (N·s/m) up to relative velocity V (m/s)
        entering the time step (0: the law's velocity terms are not bounded there)."""
        return 0.0

    @property
    def cubic_coefficient(self) -> float | None:
        """k3 (N/m³) when the force is exactly ``k3·x³`` (closed-form roots apply), else None."""
        return None

    # -- harmonic balance -------------------------------------------------------------------
    def harmonic_law(self, u: NDArray, up: NDArray, w: NDArray):
        """The force at the samples of P periods: ``u``, ``up = du/dθ`` (P, N) (m), ω (P, 1)
        (rad/s) → ``(f, ∂f/∂u, ∂f/∂u', ∂f/∂ω)``, None for a part that is zero."""
        raise TypeError(f"{type(self).__name__}: no time-domain law for harmonic balance")

    def period_forces(self, c: NDArray, omega: NDArray, fourier: Any) -> PeriodForces:
        """Harmonics of the force for P relative motions ``c`` (P, 2H+1) (m) at ω (P,) (rad/s),
        from :meth:`harmonic_law` on the samples of ``fourier`` (one transform for all columns)."""
        u, up = fourier.motions(c)
        w = np.asarray(omega, dtype=float)[:, None]
        f, f_u, f_up, f_w = self.harmonic_law(u, up, w)
        signals = np.zeros((c.shape[0], fourier.size + 2, fourier.samples))
        signals[:, 0] = f
        if f_w is not None:
            signals[:, 1] = f_w
        if f_u is not None:
            signals[:, 2:] = f_u[:, None, :] * fourier.E.T
        if f_up is not None:
            signals[:, 2:] += f_up[:, None, :] * fourier.dE.T
        harmonics = fourier.harmonics_of(signals)  # (P, size+2, 2H+1)
        return PeriodForces(harmonics[:, 0], np.swapaxes(harmonics[:, 2:], 1, 2), harmonics[:, 1])

    def damping_harmonics(self, c: NDArray, omega: NDArray, fourier: Any) -> NDArray[np.complex128]:
        """Fourier coefficients (P, 4H+1; m = −2H … 2H) of the tangent damping ``∂f/∂u̇`` (N·s/m)
        along P motions, for Hill's method; from :meth:`harmonic_law`'s ``∂f/∂u'``."""
        omega = np.asarray(omega, dtype=float)
        m = np.arange(-2 * fourier.harmonics, 2 * fourier.harmonics + 1)
        u, up = fourier.motions(c)
        w = omega[:, None]
        _, _, f_up, _ = self.harmonic_law(u, up, w)
        if f_up is None:
            return np.zeros((omega.size, m.size), complex)
        spectrum = np.fft.fft(np.broadcast_to(f_up / w, u.shape), axis=-1) / fourier.samples
        return spectrum[:, m % fourier.samples]

    # -- identification and discovery -------------------------------------------------------
    @classmethod
    def start_values(cls, amplitude: NDArray, y: NDArray, omega: float, scale: float) -> dict[str, list[float]]:
        """Fit starts of parameters by name from DF points ``y`` (N/m) at amplitudes A (m) and
        ω (rad/s) (``scale`` = max |y|); parameters not named start from the shared guesses
        of :meth:`~nlupdate.core.identification.dfmodels.PhysicalModel.initial_guesses`."""
        return {}

    @classmethod
    def with_alternative(cls, kwargs: dict[str, float], alternative: str, value: float) -> dict[str, float]:
        """Constructor keywords with the parameter an ``alternatives`` entry replaces computed from it."""
        raise NotImplementedError(f"{cls.__name__} has no alternative parameter {alternative!r}")

    def refit_when_unseen(self, amplitude_max: float) -> tuple[dict[str, float], float, str] | None:
        """Parameters to fix when the largest measured amplitude (m) does not show them:
        (fixed values by parameter name, reach = amplitude_max over the amplitude needed, why),
        or None."""
        return None

    @classmethod
    def degenerate(cls, values: Mapping[str, float], unit_of: Callable[[str], str]) -> tuple[tuple[str, ...], str] | None:
        """Parameters (names) the data cannot separate at these fitted values and one sentence why,
        or None; ``unit_of(name)`` gives a parameter's unit."""
        return None

    @classmethod
    def effect_shapes(cls, amplitude: NDArray) -> Sequence[float | None]:
        """Shape values worth trying for measured amplitudes A (m) (``(None,)``: shapeless)."""
        return (None,)

    @classmethod
    def effect_values(cls, scale: float, shape: float | None) -> NDArray[np.float64]:
        """Effect parameters (``effect_parameters`` order) from a scale and a shape."""
        return np.array([scale])

    @classmethod
    def effect_clip(cls, values: Mapping[str, float]) -> dict[str, float]:
        """Effect parameters kept inside the element's valid range (default: unchanged)."""
        return dict(values)

    @classmethod
    def effect_parameter_names(cls) -> tuple[str, ...]:
        return cls.effect_parameters or tuple(p.name for p in cls.parameters if p.fitted)


def nonlinear_dofs(elements: Sequence[NonlinearElement]) -> tuple[int, ...]:
    """Sorted coordinates touched by any element (the ``a`` set of docs/methods.md §3)."""
    return tuple(sorted({d for element in elements for d in element.dofs}))


class CycleElement(ElementBase):
    """An element whose harmonic-balance force is followed one motion at a time over its own
    cycle (hysteresis: Jenkins, Iwan's Masing rules; Coulomb's crossings): a subclass writes
    :meth:`one_period`. Rate-independent unless it says otherwise (no tangent damping)."""

    def one_period(self, c: NDArray, fourier: Any) -> PeriodForces:
        """Harmonics of the force, its Jacobian and ω-derivative along one motion ``c`` (2H+1) (m)."""
        raise NotImplementedError

    def period_forces(self, c: NDArray, omega: NDArray, fourier: Any) -> PeriodForces:
        return each_motion(lambda ci, wi: self.one_period(ci, fourier), c, omega, fourier.size)

    def damping_harmonics(self, c: NDArray, omega: NDArray, fourier: Any) -> NDArray[np.complex128]:
        """Zero: the force does not depend on the rate of the motion."""
        return np.zeros((np.size(omega), 4 * fourier.harmonics + 1), complex)
