"""Hidden-effect cases for discovery: a model, a truth with more effects, and a test of the truth.

Used by ``benchmarks/discovery.py`` and by the discovery tests (loaded from this file; it is
test scaffolding, not part of the package).

The measurement is made by direct time integration of the truth
(:func:`nlupdate.core.response.time_integration.steady_state_response`: no describing-function
assumption) at every force level and frequency, plus docs/methods.md §8 noise. Discovery is given
only the model; the case knows which effects it should name and where. The truths are built
here from the elements of :mod:`nlupdate.core.model.elements` (and one element outside the
library, :class:`OneSidedStop`) and from explicit matrix edits — not through the library's
:meth:`~nlupdate.core.discovery.effects.Effect.apply` — so a case is an independent reference.

How the test reaches each frequency (``method``):

* ``"linear"`` — every dwell starts from the linear response (the settled state does not
  depend on a sweep; on a single-valued response this is any stepped-sine test);
* ``"rest"`` — every dwell starts from rest (a test that switches the shaker on at each
  frequency): in a multi-valued region it usually settles on the lower branch;
* ``"up"`` / ``"down"`` — a stepped sweep: the frequencies are visited in order and each
  dwell starts from the first harmonic settled at the previous one (displacement, velocity
  and the element histories driven through two cycles of that motion), so the response
  stays on its branch until the branch ends, as in a stepped-sine test. All force levels
  are swept together (one vectorised integration per frequency).

Strengths are drawn (from the case's seed) relative to the structure at the effect's place:
with ψ the mass-normalised shape of the mode that moves the place most and ω_r its natural
frequency, ``k_ref = ω_r²/ψ²`` is the modal stiffness seen there, and ``A_top``, ``A_low``
are the largest linear amplitudes of the place at the highest and lowest force level.
Nonlinear stiffnesses change k_ref by 2–4 % at A_top (``strength`` scales this; about the
loss factor, so the responses stay free of folds unless a case asks for more), a Jenkins
joint starts to slip between A_low and A_top, a Coulomb slider is weaker than the force the
place transmits (so it slips everywhere, as its describing function assumes), dampers
double the modal damping at A_top, and linear errors are 3–6 % of k_ref (or of the modal
mass 1/ψ²).

Measurements are cached (noise-free, all coordinates, as parquet) in a folder the caller
names, keyed by a hash of the truth, the grid, the levels and the method; the noise is
added afterwards from the case's seed.
"""
from __future__ import annotations

import hashlib
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from nlupdate.core.measurement.frf_table import frf_table
from nlupdate.core.measurement.noise import add_table_noise
from nlupdate.core.model.elements import CoulombFriction, CubicStiffness, JenkinsFriction, QuadraticDamping, SymmetricGap
from nlupdate.core.model.linear import LumpedModel
from nlupdate.core.model.system import NonlinearSystem
from nlupdate.core.response.time_integration import steady_state_response

LEVELS_N = (2.0, 8.0, 25.0, 60.0)
LOSS_FACTOR = 0.04
LINEAR_EFFECTS = ("stiffness_error", "mass_error", "damping_error")
HIDDEN_EFFECTS = (
    "cubic_stiffness", "softening_stiffness", "dry_friction", "coulomb_friction", "quadratic_damping", "gap",
    *LINEAR_EFFECTS,
)
METHODS = ("linear", "rest", "up", "down")
_CACHE_VERSION = "1"


@dataclass(frozen=True, eq=False)
class Structure:
    """A linear test structure, its excitation, the measured coordinates and band (Hz)."""

    name: str
    model: LumpedModel
    input_dof: int
    frequency_hz: NDArray[np.float64]
    levels_n: tuple[float, ...] = LEVELS_N
    measured_dofs: tuple[int, ...] | None = None  # None: every coordinate

    @property
    def measured(self) -> tuple[int, ...]:
        return tuple(range(self.model.n_dof)) if self.measured_dofs is None else self.measured_dofs

    def measuring(self, dofs: tuple[int, ...], name: str | None = None) -> "Structure":
        """The same structure with only ``dofs`` measured."""
        return replace(self, measured_dofs=tuple(dofs), name=name or f"{self.name}[{','.join(map(str, dofs))}]")


def _bands(model: LumpedModel, points: int, half_width: float) -> NDArray[np.float64]:
    natural = model.modes()[0] / (2 * np.pi)
    return np.concatenate([np.linspace(f * (1 - half_width), f * (1 + half_width), points) for f in natural])


def chain(name: str, masses, springs, input_dof: int = 0, loss_factor: float = LOSS_FACTOR, points: int = 24,
          half_width: float = 0.12) -> Structure:
    """Masses in a line held by springs ground–m0–m1–…–ground (``len(springs) = len(masses) + 1``,
    N/m), a loss factor on every spring, bands of ``points`` frequencies within ±``half_width``
    of every natural frequency (separate bands: a banded grid)."""
    n = len(masses)
    k = np.zeros((n, n))
    for i, spring in enumerate(springs):
        left, right = i - 1, i
        if left >= 0:
            k[left, left] += spring
        if right < n:
            k[right, right] += spring
        if left >= 0 and right < n:
            k[left, right] -= spring
            k[right, left] -= spring
    model = LumpedModel.with_loss_factor(np.diag(masses), k, loss_factor)
    return Structure(name, model, input_dof, _bands(model, points, half_width))


def sdof() -> Structure:
    model = LumpedModel.with_loss_factor([[0.1]], [[2e6]], LOSS_FACTOR)
    return Structure("sdof", model, 0, np.linspace(600.0, 830.0, 50))


def two_dof() -> Structure:
    """docs/methods.md §8 2-DOF (ground–m1–m2–ground), loss factor 0.04, force at m1, bands around both modes."""
    model = LumpedModel.with_loss_factor(np.diag([0.1, 0.5]), 1e6 * np.array([[2.0, -1.0], [-1.0, 2.0]]), LOSS_FACTOR)
    return Structure("two_dof", model, 0, _bands(model, 30, 0.14))


def three_dof(input_dof: int = 0) -> Structure:
    """Chain 0.1 / 0.2 / 0.15 kg, four 1 MN/m springs (modes 300, 624, 786 Hz)."""
    return chain(f"3dof-f{input_dof}", [0.1, 0.2, 0.15], [1e6, 1e6, 1e6, 1e6], input_dof)


def four_dof(input_dof: int = 1) -> Structure:
    """Chain 0.1 / 0.15 / 0.2 / 0.12 kg, springs 1.2, 0.8, 1.0, 0.9, 1.1 MN/m."""
    return chain(f"4dof-f{input_dof}", [0.1, 0.15, 0.2, 0.12], [1.2e6, 0.8e6, 1.0e6, 0.9e6, 1.1e6], input_dof,
                 points=20)


@dataclass(frozen=True)
class OneSidedStop:
    """An effect outside the discovery library: a contact spring kc (N/m) engaged only on one
    side, ``f = kc·(x − g)`` for ``x > g`` (g ≥ 0, m), else 0. Its first harmonic about a zero
    mean is half that of a symmetric gap; the offset it causes is ignored by that estimate
    (the time integration has it)."""

    dofs: tuple[int, ...]
    gap: float
    kc: float

    def describing_function(self, amplitude, omega=0.0):
        return 0.5 * SymmetricGap(self.dofs, self.gap, self.kc).describing_function(amplitude, omega)

    def describing_function_derivatives(self, amplitude, omega=0.0):
        d_a, d_w = SymmetricGap(self.dofs, self.gap, self.kc).describing_function_derivatives(amplitude, omega)
        return 0.5 * d_a, 0.5 * d_w

    def force(self, displacement, velocity, state, omega=0.0):
        return self.kc * np.maximum(displacement - self.gap, 0.0), None

    def initial_state(self, shape):
        return None

    def stiffness_bound(self, amplitude: float) -> float:
        return self.kc


@dataclass(frozen=True)
class Place:
    """Reference scales of a place (see module docstring): k_ref (N/m), ω_r (rad/s), ψ (1/√kg),
    the largest linear amplitudes (m) at the lowest and highest force level, and the smallest
    force (N) the place transmits at the lowest level, ``min |H_uf/H_uu|·F_low`` over the band
    (a slider weaker than that slips everywhere)."""

    k_ref: float
    omega_r: float
    psi: float
    amplitude_low: float
    amplitude_top: float
    force_low: float


def place_scales(structure: Structure, dofs: tuple[int, ...]) -> Place:
    model = structure.model
    omega = 2 * np.pi * structure.frequency_hz
    s = np.zeros(model.n_dof)
    s[dofs[0]] = 1.0
    if len(dofs) == 2:
        s[dofs[1]] = -1.0
    h = model.receptance(omega, list(range(model.n_dof)), list(range(model.n_dof)))
    u = h[:, :, structure.input_dof] @ s
    h_uu = np.einsum("i,wij,j->w", s, h, s)
    natural, shapes = model.modes()
    psi = s @ shapes
    mode = int(np.argmin(np.abs(natural - omega[np.argmax(np.abs(u))])))
    peak, low = float(np.max(np.abs(u))), min(structure.levels_n)
    return Place(
        natural[mode] ** 2 / psi[mode] ** 2, float(natural[mode]), float(psi[mode]),
        peak * low, peak * max(structure.levels_n), float(np.min(np.abs(u / h_uu))) * low,
    )


def _gap_shape(ratio: float) -> float:
    """DF of a unit-stiffness gap at amplitude A over kc, for ratio = g/A < 1."""
    return 1 - 2 / np.pi * (np.arcsin(ratio) + ratio * np.sqrt(1 - ratio**2))


def _hidden_element(name: str, dofs: tuple[int, ...], p: Place, rng: np.random.Generator, strength: float):
    if name == "cubic_stiffness":
        return CubicStiffness(dofs, strength * rng.uniform(0.02, 0.035) * p.k_ref / (0.75 * p.amplitude_top**2))
    if name == "softening_stiffness":
        return CubicStiffness(dofs, -strength * rng.uniform(0.02, 0.03) * p.k_ref / (0.75 * p.amplitude_top**2))
    if name == "dry_friction":
        kf = strength * rng.uniform(0.05, 0.1) * p.k_ref
        slip_amplitude = p.amplitude_low ** (1 - (t := rng.uniform(0.3, 0.5))) * p.amplitude_top**t
        return JenkinsFriction(dofs, kf=kf, slip_force=kf * slip_amplitude)
    if name == "coulomb_friction":  # friction force 4Fs/π of 30–60 % of the smallest transmitted force
        return CoulombFriction(dofs, rng.uniform(0.3, 0.6) * np.pi / 4 * p.force_low)
    if name == "quadratic_damping":
        damping = strength * rng.uniform(0.6, 1.0) * LOSS_FACTOR * p.k_ref
        return QuadraticDamping(dofs, 3 * np.pi * damping / (8 * p.omega_r**2 * p.amplitude_top))
    if name in ("gap", "one_sided_stop"):
        ratio = rng.uniform(0.3, 0.6)
        kc = strength * rng.uniform(0.02, 0.04) * p.k_ref / _gap_shape(ratio)
        if name == "gap":
            return SymmetricGap(dofs, gap=ratio * p.amplitude_top, kc=kc)
        return OneSidedStop(dofs, gap=ratio * p.amplitude_top, kc=2 * kc)  # the same first-harmonic stiffness
    raise ValueError(f"{name!r} is not a nonlinear hidden effect")


def _with_linear_error(model: LumpedModel, name: str, dofs: tuple[int, ...], p: Place, rng: np.random.Generator):
    """The model with a linear error edited into its matrices (random sign)."""
    s = np.zeros(model.n_dof)
    s[dofs[0]] = 1.0
    if len(dofs) == 2:
        s[dofs[1]] = -1.0
    sign = rng.choice([-1.0, 1.0])
    mass, stiffness = np.array(model.mass), np.array(model.stiffness)
    damping = np.zeros_like(mass) if model.damping is None else np.array(model.damping)
    if name == "stiffness_error":
        stiffness = stiffness + sign * rng.uniform(0.03, 0.06) * p.k_ref * np.outer(s, s)
    elif name == "mass_error":
        mass[dofs[0], dofs[0]] += sign * rng.uniform(0.03, 0.06) / p.psi**2
    elif name == "damping_error":
        # a missing damper doubles-ish the modal damping; an excess one removes up to half of it
        fraction = rng.uniform(0.6, 1.0) if sign > 0 else -rng.uniform(0.3, 0.5)
        damping = damping + fraction * LOSS_FACTOR * p.k_ref / p.omega_r * np.outer(s, s)
    else:
        raise ValueError(f"{name!r} is not a linear hidden effect")
    return LumpedModel(mass, stiffness, damping, model.structural_damping, model.dof_names)


def _cache_key(truth: NonlinearSystem, structure: Structure, method: str, tolerance: float) -> str:
    digest = hashlib.sha256(_CACHE_VERSION.encode())
    for part in (truth.model.fingerprint(), repr(truth.elements), structure.input_dof, structure.levels_n, method,
                 tolerance):
        digest.update(repr(part).encode())
    digest.update(np.ascontiguousarray(structure.frequency_hz, dtype=float).tobytes())
    return digest.hexdigest()[:24]


def time_integration_table(
    truth: NonlinearSystem, structure: Structure, method: str = "linear", tolerance: float = 1e-6
) -> pd.DataFrame:
    """Noise-free measured-FRF table (every coordinate) from the steady-state first harmonics
    of direct time integration; ``method`` says how each dwell starts (module docstring)."""
    if method not in METHODS:
        raise ValueError(f"method: expected one of {METHODS}, got {method!r}")
    f = np.sort(structure.frequency_hz)
    levels = np.asarray(structure.levels_n, dtype=float)
    input_dof = structure.input_dof
    n = truth.model.n_dof
    if method in ("linear", "rest"):
        force = np.repeat(levels, f.size)
        initial = None if method == "linear" else np.zeros(n)
        x = steady_state_response(truth, {input_dof: force}, np.tile(2 * np.pi * f, levels.size), initial=initial,
                                  tolerance=tolerance).x
    else:
        per_level = np.full((levels.size, f.size, n), np.nan + 0j)
        previous = None
        for k in (range(f.size) if method == "up" else range(f.size - 1, -1, -1)):
            result = steady_state_response(truth, {input_dof: levels}, np.full(levels.size, 2 * np.pi * f[k]),
                                           initial=previous, tolerance=tolerance)
            per_level[:, k] = result.x
            previous = result.x
        force = np.repeat(levels, f.size)
        x = per_level.reshape(-1, n)
    names = np.array(truth.model.dof_names, dtype=object)[None, :]
    return frf_table(np.tile(f, levels.size)[:, None], force[:, None], names, truth.model.dof_names[input_dof],
                     x / force[:, None])


@dataclass(frozen=True, eq=False)
class HiddenCase:
    """A model, its truth, the effects discovery should name (effect, dofs) and the test settings.

    ``outside_library``: the truth holds an effect the library lacks; ``expected`` then names
    the library effect whose describing function is the same first harmonic (a hit names it at
    the right place). ``sweep_direction`` is what the measured table states ("up", "down" or
    "unknown")."""

    name: str
    structure: Structure
    model: NonlinearSystem
    truth: NonlinearSystem
    expected: tuple[tuple[str, tuple[int, ...]], ...]
    noise: float
    seed: int
    method: str = "linear"
    outside_library: bool = False
    tags: tuple[str, ...] = field(default=())

    @property
    def sweep_direction(self) -> str:
        return self.method if self.method in ("up", "down") else "unknown"

    def measure(self, cache: str | Path | None = None) -> pd.DataFrame:
        """The test of the truth at the measured coordinates with noise (time integration,
        taken from / stored in the folder ``cache`` when given)."""
        clean = None
        path = None
        if cache is not None:
            path = Path(cache) / f"{_cache_key(self.truth, self.structure, self.method, 1e-6)}.parquet"
            if path.is_file():
                clean = pd.read_parquet(path)
        if clean is None:
            clean = time_integration_table(self.truth, self.structure, self.method)
            if path is not None:
                path.parent.mkdir(parents=True, exist_ok=True)
                partial = path.with_name(f".{path.name}.partial")
                clean.to_parquet(partial, index=False)
                partial.replace(path)
        names = [self.truth.model.dof_names[d] for d in self.structure.measured]
        table = clean[clean["response_dof"].isin(names)].reset_index(drop=True)
        noisy = add_table_noise(table, self.noise, self.seed)
        if self.method in ("up", "down"):
            noisy["excitation"] = "stepped_sine"
            noisy["sweep_direction"] = self.method
        return noisy


def hidden_case(
    structure: Structure, effects: tuple[tuple[str, tuple[int, ...]], ...], seed: int, noise: float = 0.01,
    model_elements: tuple = (), method: str = "linear", strength: float = 1.0, tags: tuple[str, ...] = (),
) -> HiddenCase:
    """Truth = ``structure`` + ``model_elements`` + the hidden ``effects`` (drawn from ``seed``).

    An effect named ``one_sided_stop`` is outside the library: expected as ``gap`` (the same
    first harmonic). ``strength`` scales the nonlinear (not the linear) effects."""
    rng = np.random.default_rng(seed)
    linear = structure.model
    hidden = []
    for name, dofs in effects:
        p = place_scales(structure, dofs)
        if name in LINEAR_EFFECTS:
            linear = _with_linear_error(linear, name, dofs, p, rng)
        else:
            hidden.append(_hidden_element(name, dofs, p, rng, strength))
    label = "+".join(f"{name}@{list(dofs)}" for name, dofs in effects) or "control"
    outside = any(name == "one_sided_stop" for name, _ in effects)
    expected = tuple(("gap" if name == "one_sided_stop" else name, dofs) for name, dofs in effects)
    return HiddenCase(
        name=f"{structure.name}:{label}:{100 * noise:g}%:{method}:s{seed}",
        structure=structure,
        model=NonlinearSystem(structure.model, tuple(model_elements)),
        truth=NonlinearSystem(linear, tuple(model_elements) + tuple(hidden)),
        expected=expected,
        noise=noise,
        seed=seed,
        method=method,
        outside_library=outside,
        tags=tuple(tags),
    )


def legacy_cases(seed_offset: int = 0) -> list[HiddenCase]:
    """The first benchmark (22 cases): every effect twice (SDOF and the 2-DOF of docs/methods.md §8 at a
    varied place), friction + cubic twice, two negative controls; 1–2 % noise. ``seed_offset``
    shifts every seed (new truth parameters and noise); with an offset the 2-DOF places rotate."""
    one, two = sdof(), two_dof()
    places = [(0,), (1,), (0, 1)]
    cases = []
    for k, name in enumerate(HIDDEN_EFFECTS):
        place = places[(k + seed_offset) % 3]
        if name in ("mass_error", "coulomb_friction"):
            # a mass sits at one coordinate; a Coulomb slider between the masses would stick at
            # the lowest level, which its describing function cannot represent (use a Jenkins joint)
            place = (place[0],)
        cases.append(hidden_case(one, ((name, (0,)),), seed=100 + k + seed_offset, noise=0.01))
        cases.append(hidden_case(two, ((name, place),), seed=200 + k + seed_offset, noise=0.015 if k % 2 else 0.01))
    pair = (("dry_friction", (0,)), ("cubic_stiffness", (0,)))
    cases.append(hidden_case(one, pair, seed=301 + seed_offset, noise=0.01))
    cases.append(hidden_case(two, pair, seed=302 + seed_offset, noise=0.02))
    cases.append(hidden_case(one, (), seed=401 + seed_offset, noise=0.01))
    known = (CubicStiffness((0,), 2e11), JenkinsFriction((0,), kf=1e5, slip_force=4.0))
    cases.append(hidden_case(two, (), seed=402 + seed_offset, noise=0.02, model_elements=known))
    return cases


def benchmark_cases(seed_offset: int = 0) -> list[HiddenCase]:
    """The hard cases (issue 22): 3- and 4-DOF chains, 5 % noise on more than half, effects at
    coordinates that are not driven, only some coordinates measured, two effects at different
    places, linear and nonlinear errors together, an effect outside the library, negative
    controls, and tests that reach each frequency from rest or by stepped sweeps up and down
    (some with multi-valued responses). Tags group them (``--only TAG`` in the benchmark).
    ``seed_offset`` shifts every seed: new truth parameters and noise."""
    t0 = three_dof(0)
    t1 = three_dof(1).measuring((0, 2), "3dof-f1[0,2]")
    f1 = four_dof(1)
    f1s = four_dof(1).measuring((0, 1, 3), "4dof-f1[0,1,3]")
    cases: list[HiddenCase] = []

    def add(structure, effects, seed, noise, tags, **options):
        cases.append(hidden_case(structure, effects, seed=seed + seed_offset, noise=noise, tags=tags, **options))

    single_3 = [("cubic_stiffness", (2,)), ("softening_stiffness", (1,)), ("dry_friction", (1, 2)),
                ("coulomb_friction", (2,)), ("quadratic_damping", (1,)), ("gap", (0, 1)), ("stiffness_error", (2,)),
                ("mass_error", (1,)), ("damping_error", (1, 2))]
    for k, effect in enumerate(single_3):
        add(t0, (effect,), 1000 + k, 0.05, ("single", "3dof"))
    single_4 = [("cubic_stiffness", (3,)), ("softening_stiffness", (0,)), ("dry_friction", (0, 1)),
                ("coulomb_friction", (3,)), ("quadratic_damping", (0,)), ("gap", (3,)), ("stiffness_error", (0,)),
                ("mass_error", (3,)), ("damping_error", (0, 1))]
    for k, effect in enumerate(single_4):
        add(f1s, (effect,), 1100 + k, 0.02, ("single", "4dof", "subset"))
    pairs = [
        (t0, (("cubic_stiffness", (2,)), ("dry_friction", (0,))), 0.05),
        (t0, (("stiffness_error", (0,)), ("cubic_stiffness", (2,))), 0.05),
        (t0, (("gap", (1, 2)), ("damping_error", (0,))), 0.05),
        (f1, (("dry_friction", (0, 1)), ("softening_stiffness", (3,))), 0.05),
        (f1, (("mass_error", (3,)), ("quadratic_damping", (1,))), 0.02),
        (f1, (("coulomb_friction", (0,)), ("cubic_stiffness", (1, 2))), 0.05),
        (f1s, (("stiffness_error", (1,)), ("dry_friction", (3,))), 0.02),
        (t1, (("cubic_stiffness", (0,)), ("stiffness_error", (2,))), 0.05),
    ]
    for k, (structure, effects, noise) in enumerate(pairs):
        add(structure, effects, 1200 + k, noise, ("two places",))
    add(t0, (("dry_friction", (1,)), ("cubic_stiffness", (1,))), 1300, 0.05, ("one place",))
    add(f1s, (("dry_friction", (0,)), ("cubic_stiffness", (0,))), 1301, 0.02, ("one place",))
    add(t0, (("gap", (2,)),), 1400, 0.02, ("multi-valued", "rest"), method="rest", strength=5.0)
    add(t0, (("cubic_stiffness", (0,)),), 1401, 0.02, ("multi-valued", "sweep"), method="up", strength=4.0)
    add(t0, (("cubic_stiffness", (0,)),), 1402, 0.02, ("multi-valued", "sweep"), method="down", strength=4.0)
    add(f1s, (("softening_stiffness", (3,)),), 1403, 0.05, ("multi-valued", "rest"), method="rest", strength=3.0)
    add(t0, (("gap", (1, 2)),), 1404, 0.05, ("multi-valued", "sweep"), method="up", strength=4.0)
    add(f1s, (("dry_friction", (1,)),), 1405, 0.02, ("sweep",), method="down")
    add(t0, (("quadratic_damping", (2,)),), 1406, 0.05, ("rest",), method="rest")
    add(t0, (("one_sided_stop", (2,)),), 1500, 0.02, ("outside library",))
    add(f1s, (("one_sided_stop", (0, 1)),), 1501, 0.05, ("outside library",))
    add(t0, (("cubic_stiffness", (1,)),), 1600, 0.05, ("weak",), strength=0.5)
    known = (CubicStiffness((2,), 2e11), JenkinsFriction((0,), kf=1.5e5, slip_force=8.0))
    add(t0, (), 1700, 0.05, ("control",))
    add(f1, (), 1701, 0.02, ("control", "rest"), method="rest")
    add(t0, (), 1702, 0.05, ("control", "nonlinear model"), model_elements=known)
    add(f1s, (), 1703, 0.05, ("control", "sweep"), method="up")
    add(t1, (), 1704, 0.05, ("control",))
    return cases
