"""Hidden-effect cases: a model, a truth that has one or two more effects, and a test of the truth.

The measurement is made by direct time integration of the truth
(:func:`nlupdate.response.time_integration.steady_state_response`: no describing-function
assumption) at every force level and frequency, plus METHODS §8 noise. Discovery is given
only the model; the case knows which effects it should name and where. The truths are built
here from the elements of :mod:`nlupdate.model.elements` and from explicit matrix edits —
not through the library's :meth:`~nlupdate.discovery.effects.Effect.apply` — so a case is an
independent reference for the workflow.

Strengths are drawn (from the case's seed) relative to the structure at the effect's place:
with ψ the mass-normalised shape of the mode that moves the place most and ω_r its natural
frequency, ``k_ref = ω_r²/ψ²`` is the modal stiffness seen there, and ``A_top``, ``A_low``
are the largest linear amplitudes of the place at the highest and lowest force level.
Nonlinear stiffnesses change k_ref by 2–4 % at A_top (about the loss factor, so the
responses stay free of folds), a Jenkins joint starts to slip between A_low and A_top, a
Coulomb slider is weaker than the force the place transmits (so it slips everywhere, as
its describing function assumes), dampers double the modal damping at A_top, and linear
errors are 3–6 % of k_ref (or of the modal mass 1/ψ²).

Structures: ``sdof`` (m = 0.1 kg, k = 2e6 N/m, loss factor 0.04, 600–830 Hz) and ``two_dof``
(METHODS §8 2-DOF, ground–m1–m2–ground, loss factor 0.04, force at m1, bands around both
modes); force levels 2, 8, 25, 60 N; both coordinates measured.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from nlupdate.measurement.frf_table import frf_table
from nlupdate.measurement.noise import add_table_noise
from nlupdate.model.elements import CoulombFriction, CubicStiffness, JenkinsFriction, QuadraticDamping, SymmetricGap
from nlupdate.model.linear import LumpedModel
from nlupdate.model.system import NonlinearSystem
from nlupdate.response.time_integration import steady_state_response

LEVELS_N = (2.0, 8.0, 25.0, 60.0)
LOSS_FACTOR = 0.04
HIDDEN_EFFECTS = (
    "cubic_stiffness", "softening_stiffness", "dry_friction", "coulomb_friction", "quadratic_damping", "gap",
    "stiffness_error", "mass_error", "damping_error",
)


@dataclass(frozen=True, eq=False)
class Structure:
    """A linear test structure, its excitation and its measured band (Hz)."""

    name: str
    model: LumpedModel
    input_dof: int
    frequency_hz: NDArray[np.float64]
    levels_n: tuple[float, ...] = LEVELS_N


def sdof() -> Structure:
    model = LumpedModel.with_loss_factor([[0.1]], [[2e6]], LOSS_FACTOR)
    return Structure("sdof", model, 0, np.linspace(600.0, 830.0, 50))


def two_dof() -> Structure:
    model = LumpedModel.with_loss_factor(np.diag([0.1, 0.5]), 1e6 * np.array([[2.0, -1.0], [-1.0, 2.0]]), LOSS_FACTOR)
    bands = [np.linspace(f * 0.86, f * 1.14, 30) for f in model.modes()[0] / (2 * np.pi)]
    return Structure("two_dof", model, 0, np.concatenate(bands))


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


def _hidden_element(name: str, dofs: tuple[int, ...], p: Place, rng: np.random.Generator):
    if name == "cubic_stiffness":
        return CubicStiffness(dofs, rng.uniform(0.02, 0.035) * p.k_ref / (0.75 * p.amplitude_top**2))
    if name == "softening_stiffness":
        return CubicStiffness(dofs, -rng.uniform(0.02, 0.03) * p.k_ref / (0.75 * p.amplitude_top**2))
    if name == "dry_friction":
        kf = rng.uniform(0.05, 0.1) * p.k_ref
        slip_amplitude = p.amplitude_low ** (1 - (t := rng.uniform(0.3, 0.5))) * p.amplitude_top**t
        return JenkinsFriction(dofs, kf=kf, slip_force=kf * slip_amplitude)
    if name == "coulomb_friction":  # friction force 4Fs/π of 30–60 % of the smallest transmitted force
        return CoulombFriction(dofs, rng.uniform(0.3, 0.6) * np.pi / 4 * p.force_low)
    if name == "quadratic_damping":
        damping = rng.uniform(0.6, 1.0) * LOSS_FACTOR * p.k_ref
        return QuadraticDamping(dofs, 3 * np.pi * damping / (8 * p.omega_r**2 * p.amplitude_top))
    if name == "gap":
        ratio = rng.uniform(0.3, 0.6)
        return SymmetricGap(dofs, gap=ratio * p.amplitude_top, kc=rng.uniform(0.02, 0.04) * p.k_ref / _gap_shape(ratio))
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


@dataclass(frozen=True, eq=False)
class HiddenCase:
    """A model, its truth, the effects discovery should name (effect, dofs) and the test settings."""

    name: str
    structure: Structure
    model: NonlinearSystem
    truth: NonlinearSystem
    expected: tuple[tuple[str, tuple[int, ...]], ...]
    noise: float
    seed: int

    def measure(self) -> pd.DataFrame:
        """Time-integration test of the truth at every level and frequency, with noise."""
        return measure_by_time_integration(self.truth, self.structure, self.noise, self.seed)


def measure_by_time_integration(
    truth: NonlinearSystem, structure: Structure, noise: float, seed: int, tolerance: float = 1e-6
) -> pd.DataFrame:
    """Measured-FRF table (all coordinates) from the steady-state first harmonics of direct
    time integration, started from the linear response, plus noise of relative std ``noise``."""
    f = structure.frequency_hz
    levels = np.asarray(structure.levels_n, dtype=float)
    force = np.repeat(levels, f.size)
    result = steady_state_response(truth, {structure.input_dof: force}, np.tile(2 * np.pi * f, levels.size), tolerance=tolerance)
    names = np.array(truth.model.dof_names, dtype=object)[None, :]
    table = frf_table(np.tile(f, levels.size)[:, None], force[:, None], names, truth.model.dof_names[structure.input_dof],
                      result.x / force[:, None])
    return add_table_noise(table, noise, seed)


def hidden_case(
    structure: Structure, effects: tuple[tuple[str, tuple[int, ...]], ...], seed: int, noise: float = 0.01,
    model_elements: tuple = (),
) -> HiddenCase:
    """Truth = ``structure`` + ``model_elements`` + the hidden ``effects`` (drawn from ``seed``)."""
    rng = np.random.default_rng(seed)
    linear = structure.model
    hidden = []
    for name, dofs in effects:
        p = place_scales(structure, dofs)
        if name in ("stiffness_error", "mass_error", "damping_error"):
            linear = _with_linear_error(linear, name, dofs, p, rng)
        else:
            hidden.append(_hidden_element(name, dofs, p, rng))
    label = "+".join(f"{name}@{list(dofs)}" for name, dofs in effects) or "control"
    return HiddenCase(
        name=f"{structure.name}:{label}:seed{seed}",
        structure=structure,
        model=NonlinearSystem(structure.model, tuple(model_elements)),
        truth=NonlinearSystem(linear, tuple(model_elements) + tuple(hidden)),
        expected=tuple(effects),
        noise=noise,
        seed=seed,
    )


def benchmark_cases(seed_offset: int = 0) -> list[HiddenCase]:
    """Every effect twice (SDOF and 2-DOF at a varied place), friction + cubic twice (SDOF and
    the METHODS 2-DOF), and two negative controls (a linear model and a model that already
    has cubic + Jenkins) — 22 cases, seeds and noise (1–2 %) varied. ``seed_offset`` shifts
    every seed (new truth parameters and noise); with an offset the 2-DOF places rotate too."""
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
