"""Describing-function models fitted by the identification methods.

Length: the two model families and their shared fitting interface; most of it is
:class:`PhysicalModel`, whose parameters, bounds and starts follow from the element
library.

A model maps a real parameter vector ``p`` to two describing functions (DFs) of the
response amplitude ``A`` (m) at the nonlinear coordinate (complex, N/m, first-harmonic
force = ν·X, docs/methods.md §1):

* ``nu_high(p, A, ω)`` — the DF acting at the high force levels;
* ``nu_low(p, A, ω)`` — the DF acting at the low force level (``Δ_f1`` of the PRD
  method, docs/methods.md §4).

The PRD relation at one excitation frequency is then
``1/H_i = Z_L(ω) + nu_high(A_i)`` (i ≥ 2) and ``1/H_1 = Z_L(ω) + nu_low(A_1)``, so
``y_i = 1/H_i − 1/H_1 = nu_high(A_i) − nu_low(A_1)``.

:class:`PolynomialModel` — the source's model. The PRD curve is a polynomial
``y(A) = Σ a_k A^k + i Σ b_k A^k`` (powers chosen by the user, must include 0). The
high-force nonlinearity is assumed to vanish at zero amplitude, so ``Δ_f1 = −y(0)``
(constant), ``nu_low = Δ_f1`` and ``nu_high = y + Δ_f1``. With cubic stiffness plus
*stuck* friction, ``Re y = ¾k*A² − kf``: ``k3 = (4/3)a_2`` and ``kf = −a_0`` (reported
as ``k3`` and ``kf`` when those powers are fitted).

What Δ_f1 really is: the total DF of every element at the low-force amplitude ``A_1``.
For a stuck Jenkins element it is ``kf`` (+ ¾k3A_1², negligible) — real. If the low
force makes the slider slip it is complex (``Im > 0``: friction damping) and amplitude
dependent; then ``−Re y(0)`` is *not* kf and only a physical model (below) separates the
two. The imaginary part of ``−y(0)`` is not a measurement of Im Δ_f1 in the source's
setting: the friction damping at high forces, ``4Fs/(πA)``, grows as A decreases, so a
polynomial extrapolation of ``Im y`` to A = 0 is meaningless (on the §3.1 data it gives
``Im Δ_f1 ≈ −1.4e3 N/m``: negative damping, 7 % of the structural damping ``γk``, and a
linear-FRF FRAC of only 0.9987). Hence by default ``Δ_f1 = −Re y(0)`` (real: stuck
friction, the source's assumption in its case studies) and the imaginary constant of
``y`` stays in the high-force DF; ``complex_delta_f1=True`` uses the full ``−y(0)``.
``delta_f1_imag`` reports the imaginary part used.

:class:`PhysicalModel` — named elements of :data:`nlupdate.core.model.elements.ELEMENT_TYPES`
(``cubic``, ``jenkins``, ``iwan``, … every element type with fitted parameters) acting at all
force levels: ``nu_high = nu_low = Σ ν_e(A; θ)``. Positive parameters are fitted as
logarithms; signed ones (``k3``: softening) linearly; those with an interval (an Iwan joint's
exponent χ ∈ (−1, 0)) through a logistic map. Each element class states its starts, the
parameters that may be fixed in place of others and those the data may not show
(:class:`~nlupdate.core.model.elements.base.ElementBase`); nothing here names an element. This model is exact for describing-function data of
those elements, including a slipping low-force level.

What PRD data determine of an Iwan joint: ``y = ν(A_i) − ν(A_1)``. While every level stays
in microslip (A < φ_max), ``ν = K_T − c_r A^(χ+1) + i c_i A^(χ+1)`` with c_i/c_r fixed by χ:
K_T cancels in y (it is part of the linear stiffness the PRD extracts) and F_S and β enter
only through ``R' = K_T/((1+β)φ_max^(χ+1))`` — the data determine χ and R' alone. A level
in macroslip adds the stiffness the joint loses (K_T) and its slip force (F_S); β (the
sharpness of the transition) needs levels near φ_max.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np
import scipy.special
from numpy.typing import ArrayLike, NDArray

from nlupdate.core.model.elements import ELEMENT_TYPES, PolynomialDF
from nlupdate.core.model.elements.iwan import MACROSLIP_REACH  # noqa: F401 (the amplitude model's fit reads it here)

#: Fitted parameter names of each physical element (constructor keyword order) and whether
#: they are positive (fitted as log) or signed; those in INTERVAL_PARAMETERS are fitted
#: through a logistic map onto their open interval. Read from the element classes.
ELEMENT_PARAMETERS: dict[str, tuple[tuple[str, bool], ...]] = {
    name: tuple((p.name, p.positive) for p in cls.parameters if p.fitted)
    for name, cls in ELEMENT_TYPES.items() if any(p.fitted for p in cls.parameters)
}
INTERVAL_PARAMETERS: dict[str, tuple[float, float]] = {
    p.name: p.interval for cls in ELEMENT_TYPES.values() for p in cls.parameters if p.interval is not None
}
_INTERVAL_MARGIN = 1e-9  # interval values are kept this far (relative) inside their ends


class ModelError(ValueError):
    """A describing-function model was specified wrongly (message says how to fix it)."""


def _as_powers(name: str, powers: Sequence[int]) -> tuple[int, ...]:
    values = tuple(sorted({int(p) for p in powers}, reverse=True))
    if not values or values[-1] < 0:
        raise ModelError(f"{name}: polynomial powers must be non-negative integers, got {list(powers)}")
    if 0 not in values:
        raise ModelError(
            f"{name}: the PRD polynomial must include the power 0 (its constant term is −Δ_f1), got {list(values)}"
        )
    return values


def _full_coefficients(powers: tuple[int, ...], values: NDArray) -> list[float]:
    """Coefficients highest order first (numpy.polyval), zeros for absent powers."""
    out = np.zeros(powers[0] + 1)
    for power, value in zip(powers, values):
        out[powers[0] - power] = value
    return [float(v) for v in out]


@dataclass(frozen=True)
class PolynomialModel:
    """PRD polynomial ``y(A)`` with separate real and imaginary powers (see module doc)."""

    real_powers: tuple[int, ...] = (2, 1, 0)
    imag_powers: tuple[int, ...] = (2, 1, 0)
    complex_delta_f1: bool = False
    kind: str = field(default="polynomial", init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "real_powers", _as_powers("real part", self.real_powers))
        object.__setattr__(self, "imag_powers", _as_powers("imaginary part", self.imag_powers))

    @classmethod
    def of_order(cls, order: int, imag_order: int | None = None, complex_delta_f1: bool = False) -> "PolynomialModel":
        """Full polynomials (all powers ``order..0``) like MATLAB ``polyfit``."""
        if int(order) < 0 or (imag_order is not None and int(imag_order) < 0):
            raise ModelError(f"polynomial order must be ≥ 0, got {order}")
        imag = order if imag_order is None else imag_order
        return cls(tuple(range(int(order), -1, -1)), tuple(range(int(imag), -1, -1)), complex_delta_f1)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(f"re_c{p}" for p in self.real_powers) + tuple(f"im_c{p}" for p in self.imag_powers)

    @property
    def n_params(self) -> int:
        return len(self.real_powers) + len(self.imag_powers)

    def description(self) -> str:
        kind = "complex −y(0)" if self.complex_delta_f1 else "real −Re y(0) (stuck friction)"
        return (f"polynomial PRD fit, real powers {list(self.real_powers)}, imaginary powers "
                f"{list(self.imag_powers)}, Δ_f1 = {kind}")

    def split(self, p: ArrayLike) -> tuple[NDArray, NDArray]:
        p = np.asarray(p, dtype=float)
        n = len(self.real_powers)
        return p[:n], p[n:]

    def design(self, amplitude: ArrayLike) -> tuple[NDArray, NDArray]:
        """Regressor matrices of the real and imaginary parts of ``y`` at amplitudes A."""
        a = np.asarray(amplitude, dtype=float)[:, None]
        return a ** np.array(self.real_powers), a ** np.array(self.imag_powers)

    def y(self, p: ArrayLike, amplitude: ArrayLike, omega: ArrayLike = 0.0) -> NDArray[np.complex128]:
        """PRD curve at amplitudes of any shape."""
        re, im = self.split(p)
        a = np.asarray(amplitude, dtype=float)
        real = sum(c * a**k for c, k in zip(re, self.real_powers))
        imag = sum(c * a**k for c, k in zip(im, self.imag_powers))
        return np.asarray(real + 1j * imag, dtype=complex) + np.zeros(a.shape)

    def delta_f1(self, p: ArrayLike) -> complex:
        """``Δ_f1 = −y(0)`` (N/m); only its real part unless ``complex_delta_f1``."""
        re, im = self.split(p)
        return complex(-re[-1], -im[-1] if self.complex_delta_f1 else 0.0)

    def nu_high(self, p: ArrayLike, amplitude: ArrayLike, omega: ArrayLike = 0.0) -> NDArray[np.complex128]:
        return self.y(p, amplitude) + self.delta_f1(p)

    def nu_low(self, p: ArrayLike, amplitude: ArrayLike, omega: ArrayLike = 0.0) -> NDArray[np.complex128]:
        return np.full(np.shape(amplitude), self.delta_f1(p), dtype=complex)

    def function(self, p: ArrayLike, level: str = "high") -> Callable[[NDArray, NDArray], NDArray]:
        """``ν(A, ω)`` at the ``"high"`` or ``"low"`` force level as a function."""
        if level == "low":
            return lambda amplitude, omega=0.0: self.nu_low(p, amplitude, omega)
        return lambda amplitude, omega=0.0: self.nu_high(p, amplitude, omega)

    def parameters(self, p: ArrayLike) -> dict[str, float]:
        """``k3 = (4/3)a_2`` (if A² is fitted), ``kf = −a_0``, ``delta_f1_imag = −b_0`` (with
        ``complex_delta_f1``) and the raw coefficients ``re_c<k>``, ``im_c<k>`` (SI)."""
        re, im = self.split(p)
        out: dict[str, float] = {}
        if 2 in self.real_powers:
            out["k3"] = float(4.0 / 3.0 * re[self.real_powers.index(2)])
        out["kf"] = float(-re[-1])
        if self.complex_delta_f1:
            out["delta_f1_imag"] = float(self.delta_f1(p).imag)
        out.update({name: float(value) for name, value in zip(self.names, np.concatenate([re, im]))})
        return out

    def prd_polynomial(self, p: ArrayLike) -> tuple[list[float], list[float]]:
        """The fitted PRD curve ``y(A)``: (real, imag) coefficients, highest order first."""
        re, im = self.split(p)
        return _full_coefficients(self.real_powers, re), _full_coefficients(self.imag_powers, im)

    def describing_function(self, p: ArrayLike) -> tuple[list[float], list[float]]:
        """High-force DF ``ν(A) = y(A) + Δ_f1``: (real, imag) coefficients, highest order first."""
        real, imag = self.prd_polynomial(p)
        delta = self.delta_f1(p)
        real[-1] += delta.real
        imag[-1] += delta.imag
        return real, imag

    def elements(self, p: ArrayLike, dofs: tuple[int, ...] = (0,)) -> list:
        """The high-force DF as a :class:`~nlupdate.core.model.elements.PolynomialDF` element."""
        real, imag = self.describing_function(p)
        return [PolynomialDF(tuple(dofs), real=tuple(real), imag=tuple(imag))]


@dataclass(frozen=True)
class PhysicalModel:
    """Sum of named physical elements acting at every force level (see module doc).

    ``fixed`` holds parameters not fitted, by reported name (an Iwan joint's ``phi_max``
    may be fixed in place of its ``slip_force``, which then follows from K_T, χ and β);
    ``note`` says why they are fixed."""

    element_names: tuple[str, ...]
    fixed: tuple[tuple[str, float], ...] = ()
    note: str = ""
    kind: str = field(default="physical", init=False)

    def __post_init__(self) -> None:
        names = tuple(str(n).strip().lower() for n in self.element_names)
        if not names:
            raise ModelError("no elements given: name at least one of " + ", ".join(ELEMENT_PARAMETERS))
        unknown = [n for n in names if n not in ELEMENT_PARAMETERS]
        if unknown:
            raise ModelError(
                f"unknown element(s) {unknown}; identifiable elements: {', '.join(ELEMENT_PARAMETERS)}"
            )
        object.__setattr__(self, "element_names", names)
        object.__setattr__(self, "fixed", tuple((str(k), float(v)) for k, v in self.fixed))
        known = {name for _, name, _ in self._all_slots()} | {
            alternative + sfx for el, sfx in self._suffixes() for alternative in ELEMENT_TYPES[el].alternatives}
        unknown = [k for k, _ in self.fixed if k not in known]
        if unknown:
            raise ModelError(f"fixed parameter(s) {unknown} are not parameters of {' + '.join(names)}")

    def _suffixes(self) -> list[tuple[str, str]]:
        """(element, suffix of its parameter names) per element: the copies of a repeated
        element type are numbered (``kf_1``, ``kf_2``), and an element whose parameter name
        another element type of the model also has carries its type's name too
        (``slip_force_jenkins``, ``slip_force_coulomb``; ``kf_jenkins1`` for a numbered copy),
        so that every reported name is one parameter — Jenkins + Coulomb reported one
        ``slip_force`` for the two and dropped the other."""
        out, seen = [], {}
        for element in self.element_names:
            seen[element] = seen.get(element, 0) + 1
            out.append((element, "" if self.element_names.count(element) == 1 else f"_{seen[element]}"))
        def names_of(element: str) -> set[str]:
            return {p.name for p in ELEMENT_TYPES[element].parameters} | set(ELEMENT_TYPES[element].alternatives)

        types = sorted(set(self.element_names))
        shared = {name for i, a in enumerate(types) for b in types[i + 1:] for name in names_of(a) & names_of(b)}
        return [(element, f"_{element}{suffix[1:]}" if shared & names_of(element) else suffix)
                for element, suffix in out]

    def _base_names(self) -> dict[str, str]:
        """Each reported parameter name → the name its element type declares (``kf_2`` → ``kf``,
        ``epsilon_tanh_friction`` → ``epsilon``)."""
        return {name + suffix: name for element, suffix in self._suffixes() for name, _ in ELEMENT_PARAMETERS[element]}

    def _all_slots(self) -> list[tuple[str, str, bool]]:
        return [(element, name + suffix, positive) for element, suffix in self._suffixes()
                for name, positive in ELEMENT_PARAMETERS[element]]

    @property
    def _slots(self) -> list[tuple[str, str, bool]]:
        """(element, reported parameter name, positive) per entry of p (the fitted ones)."""
        fixed = dict(self.fixed)
        replaced = {name + suffix for element, suffix in self._suffixes()
                    for alternative, name in ELEMENT_TYPES[element].alternatives.items() if alternative + suffix in fixed}
        return [slot for slot in self._all_slots() if slot[1] not in fixed and slot[1] not in replaced]

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(name for _, name, _ in self._slots)

    @property
    def n_params(self) -> int:
        return len(self._slots)

    def parameter_meanings(self) -> list[tuple[tuple[str, ...], str]]:
        """What each fitted element parameter is, as its element declares it
        (:attr:`~nlupdate.core.model.elements.base.ElementParameter.meaning`): (the reported
        names of its copies, meaning) per parameter of each element type, in model order; the
        copies of a repeated element (``kf_1``, ``kf_2``) share one entry, whose meaning says
        what the number counts."""
        copies: dict[tuple[str, str], list[str]] = {}
        for element, suffix in self._suffixes():
            for parameter in ELEMENT_TYPES[element].parameters:
                if parameter.fitted:
                    copies.setdefault((element, parameter.name), []).append(parameter.name + suffix)
        out = []
        for (element, name), names in copies.items():
            meaning = next(p.meaning for p in ELEMENT_TYPES[element].parameters if p.name == name)
            if len(names) > 1:
                meaning += f" — {', '.join(n[len(name):] for n in names)}: the {element} elements in the order listed"
            out.append((tuple(names), meaning))
        return out

    def description(self) -> str:
        text = "physical elements: " + " + ".join(self.element_names)
        if self.fixed:
            text += " (fixed: " + ", ".join(f"{k} = {v:.4g}" for k, v in self.fixed) + ")"
        return text

    def _intervals(self) -> tuple[NDArray[np.bool_], NDArray[np.float64], NDArray[np.float64]]:
        """Which entries are interval parameters, and their lower and upper ends."""
        base = self._base_names()
        ends = [INTERVAL_PARAMETERS.get(base[name]) for _, name, _ in self._slots]
        inside = np.array([e is not None for e in ends])
        low = np.array([e[0] if e else 0.0 for e in ends])
        high = np.array([e[1] if e else 1.0 for e in ends])
        return inside, low, high

    def values(self, p: ArrayLike) -> NDArray[np.float64]:
        """Parameter values in SI units from the fitted vector (exp of the log entries, the
        logistic map onto their interval for :data:`INTERVAL_PARAMETERS`)."""
        p = np.asarray(p, dtype=float)
        positive = np.array([pos for _, _, pos in self._slots])
        inside, low, high = self._intervals()
        share = np.clip(scipy.special.expit(p), _INTERVAL_MARGIN, 1 - _INTERVAL_MARGIN)
        return np.where(positive, np.exp(np.clip(p, -700, 700)), np.where(inside, low + (high - low) * share, p))

    def vector(self, values: ArrayLike) -> NDArray[np.float64]:
        """Inverse of :meth:`values`."""
        v = np.asarray(values, dtype=float)
        positive = np.array([pos for _, _, pos in self._slots])
        if np.any(v[positive] <= 0):
            raise ModelError(f"parameters {[n for n, pos, x in zip(self.names, positive, v) if pos and x <= 0]} must be > 0")
        inside, low, high = self._intervals()
        outside = inside & ((v <= low) | (v > high))
        if np.any(outside):
            raise ModelError(f"parameters {[n for n, x in zip(self.names, outside) if x]} must lie in their intervals "
                             f"{[INTERVAL_PARAMETERS.get(self._base_names()[n]) for n, x in zip(self.names, outside) if x]}")
        share = np.clip((v - low) / (high - low), _INTERVAL_MARGIN, 1 - _INTERVAL_MARGIN)
        return np.where(positive, np.log(np.where(positive, v, 1.0)), np.where(inside, scipy.special.logit(share), v))

    def elements(self, p: ArrayLike, dofs: tuple[int, ...] = (0,)) -> list:
        values = {**dict(zip(self.names, self.values(p))), **dict(self.fixed)}
        out = []
        for element, suffix in self._suffixes():
            kwargs = {name: float(values[name + suffix]) for name, _ in ELEMENT_PARAMETERS[element]
                      if name + suffix in values}
            kind = ELEMENT_TYPES[element]
            for alternative, name in kind.alternatives.items():
                if name not in kwargs and alternative + suffix in values:  # fixed in its place
                    kwargs = kind.with_alternative(kwargs, alternative, values[alternative + suffix])
            out.append(kind(tuple(dofs), **kwargs))
        return out

    def function(self, p: ArrayLike, level: str = "high") -> Callable[[NDArray, NDArray], NDArray]:
        """``ν(A, ω)`` with the elements built once (same DF at every level)."""
        elements = self.elements(p)

        def nu(amplitude: ArrayLike, omega: ArrayLike = 0.0) -> NDArray[np.complex128]:
            a = np.asarray(amplitude, dtype=float)
            total = np.zeros(np.broadcast_shapes(a.shape, np.shape(omega)), dtype=complex)
            with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
                for element in elements:
                    total = total + element.describing_function(a, omega)
            return total

        return nu

    def nu(self, p: ArrayLike, amplitude: ArrayLike, omega: ArrayLike = 0.0) -> NDArray[np.complex128]:
        return self.function(p)(amplitude, omega)

    nu_high = nu
    nu_low = nu

    def parameters(self, p: ArrayLike) -> dict[str, float]:
        """Every element parameter (SI) by reported name, fitted or fixed."""
        out = {}
        for (element, suffix), built in zip(self._suffixes(), self.elements(p)):
            out.update({name + suffix: float(getattr(built, name)) for name, _ in ELEMENT_PARAMETERS[element]})
        return out

    def initial_guesses(
        self, amplitude: NDArray, y: NDArray, amplitude_low: float, omega: float
    ) -> list[NDArray[np.float64]]:
        """Starting vectors from PRD points ``y_i`` at amplitudes ``A_i``: the shared guesses
        below, overridden by each element class's ``start_values`` (several for gaps)."""
        a = np.asarray(amplitude, dtype=float)
        y = np.asarray(y, dtype=complex)
        scale = float(np.max(np.abs(y))) or 1.0
        slope, intercept = np.polyfit(a**2, y.real, 1) if a.size >= 2 else (0.0, float(y.real.mean()))
        damping_force = float(np.median(y.imag * a)) * np.pi / 4
        a_min = float(a.min())
        kf = max(-intercept, 1e-3 * scale)
        guess: dict[str, list[float]] = {
            "k3": [4.0 / 3.0 * slope],
            "kf": [kf],
            # slip force: between stuck at the low level and slipping at the high levels
            "slip_force": [float(np.clip(damping_force, kf * amplitude_low * 2, kf * a_min * 0.5))
                           if damping_force > 0 else kf * np.sqrt(max(amplitude_low, 1e-30) * a_min)],
            "cq": [max(float(np.median(y.imag / (omega**2 * a))) * 3 * np.pi / 8, 1e-12)],
        }
        if not any(ELEMENT_TYPES[name].stick_slip for name in self.element_names):  # no element stuck at the low force
            guess["slip_force"] = [max(damping_force, 1e-6 * scale * a_min)]
        own = {name: {**guess, **ELEMENT_TYPES[name].start_values(a, y, omega, scale)} for name in set(self.element_names)}
        starts, base = [[]], self._base_names()
        for element, name, _ in self._slots:
            options = own[element]
            starts = [s + [o] for s in starts for o in options.get(base[name], [1.0])]
        return [self.vector(s) for s in starts]


#: A describing-function model PRD fits: polynomial coefficients or physical elements.
Model = PolynomialModel | PhysicalModel


def iwan_identifiability(model: "PhysicalModel | PolynomialModel | None", p: ArrayLike | None,
                         amplitude_max: float) -> "PhysicalModel | None":
    """The model to refit when an element of a fit has parameters no measured level shows
    (the element's ``refit_when_unseen``), else None.

    An Iwan joint with no level in macroslip: below φ_max the PRD/DDF data determine the
    joint's χ and ``R' = K_T/((1+β)φ_max^(χ+1))`` only (module docstring). The refit fixes
    β = 0 and φ_max at the largest measured amplitude: the smallest joint that keeps every
    level in microslip, so its K_T and F_S are lower bounds, and χ and R' are what the data say.

    A model that is already such a refit (given to a Monte-Carlo sample, which skips the
    free fit) is returned with its φ_max moved to this fit's largest amplitude when that
    differs — the refit the free fit of the same data would have led to — else None."""
    if isinstance(model, PhysicalModel) and model.fixed and p is not None:
        fixed = dict(model.fixed)
        moved = {name: float(amplitude_max) for name in fixed if name.startswith("phi_max")
                 and fixed[name] != float(amplitude_max)}
        return PhysicalModel(model.element_names, tuple({**fixed, **moved}.items()), model.note) if moved else None
    if not isinstance(model, PhysicalModel) or model.fixed or p is None:
        return None
    fixed, reaches, why = [], [], ""
    for (element, suffix), built in zip(model._suffixes(), model.elements(p)):
        refit = built.refit_when_unseen(amplitude_max)
        if refit is not None:
            values, reach, why = refit
            fixed += [(name + suffix, value) for name, value in values.items()]
            reaches.append(reach)
    if not fixed:
        return None
    return PhysicalModel(model.element_names, tuple(fixed), why.replace("{reach}", f"{min(reaches):.2g}"))


def polynomial_approximation(
    nu: Callable[[NDArray], NDArray], amplitude_range: tuple[float, float], order: int, omega: float = 0.0
) -> tuple[list[float], list[float]]:
    """Least-squares polynomial (highest order first) of a DF over an amplitude range,
    200 points; used to report a physical model in the polynomial-DF format."""
    a = np.linspace(amplitude_range[0], amplitude_range[1], 200)
    values = nu(a)
    real = np.polyfit(a, values.real, order)
    imag = np.polyfit(a, values.imag, order)
    return [float(c) for c in real], [float(c) for c in imag]


def parse_elements(text: str | Sequence[str] | None) -> PhysicalModel | None:
    """``"cubic,jenkins"`` → :class:`PhysicalModel`; None/empty → None."""
    if text is None:
        return None
    names = [n.strip() for n in (text.split(",") if isinstance(text, str) else text) if n and n.strip()]
    return PhysicalModel(tuple(names)) if names else None


def with_clipped_damping(nu: Callable, low: float, high: float) -> Callable:
    """A DF whose real part (stiffness) is extrapolated but whose imaginary part (damping)
    is held at its values at the ends of the fitted amplitude range [low, high] (m).

    Friction damping behaves like 4Fs/(πA), which a fitted polynomial extrapolates wildly.
    """

    def clipped(amplitude: ArrayLike, omega: ArrayLike | None = None) -> NDArray[np.complex128]:
        a = np.asarray(amplitude, dtype=float)
        return nu(a, omega).real + 1j * nu(np.clip(a, low, high), omega).imag

    return clipped
