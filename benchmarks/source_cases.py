"""The source's simulated identification cases (thesis §3.1, §3.2, §3.5; docs/methods.md §8).

Each case is a lumped linear model with local elements at dof 0, forced and measured at
dof 0. Data are made like the source's: single-harmonic (describing-function) responses,
here by continuation + an upward stepped-sine sweep (:func:`nlupdate.core.response.simulate.simulate_frf_table`)
on a 1 Hz grid, noise-free; noise (docs/methods.md §8, 5 % of |H|) is added per seed by the
benchmark scripts.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from nlupdate.core.model.elements import CubicStiffness, JenkinsFriction
from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.model.linear import LumpedModel
from nlupdate.core.response.simulate import simulate_frf_table
from nlupdate.core.model.system import NonlinearSystem


@dataclass(frozen=True)
class Case:
    """A simulated PRD/DDF test: the system, force levels (N) and frequency grid (Hz)."""

    name: str
    system: NonlinearSystem
    forces: tuple[float, ...]
    frequency_hz: tuple[float, ...]
    true: dict[str, float]

    def linear_frf(self, frequency_hz: np.ndarray) -> np.ndarray:
        """Receptance of the underlying linear system at dof 0 (m/N)."""
        return self.system.model.receptance(2 * np.pi * np.asarray(frequency_hz), [0], [0])[:, 0, 0]


def _grid(start: float, stop: float) -> tuple[float, ...]:
    return tuple(float(f) for f in np.arange(start, stop + 0.5, 1.0))


def sdof_friction() -> Case:
    """§3.1: m 0.1 kg, k 2e6 N/m, γ 0.01, k* 1e10 N/m³, Jenkins kf 3e5 N/m, Fs = μN = 1 N;
    0.01 N and 100…400 N in 30 N steps."""
    model = LumpedModel.with_loss_factor([[0.1]], [[2e6]], 0.01)
    system = NonlinearSystem(model, (CubicStiffness((0,), 1e10), JenkinsFriction((0,), 3e5, 1.0)))
    forces = (0.01,) + tuple(float(f) for f in np.arange(100.0, 401.0, 30.0))
    return Case("sdof_friction", system, forces, _grid(600, 900), {"k3": 1e10, "kf": 3e5, "slip_force": 1.0})


def two_dof_friction() -> Case:
    """§3.2: m 0.1/0.5 kg, k1 = k2 = k3 = 1e6 N/m (ground–m1–m2–ground), γ 0.005; k* 1e10,
    Jenkins kf 8e4, Fs 1 N between m1 and ground; same force levels as §3.1."""
    mass = np.diag([0.1, 0.5])
    stiffness = np.array([[2e6, -1e6], [-1e6, 2e6]])
    model = LumpedModel.with_loss_factor(mass, stiffness, 0.005)
    system = NonlinearSystem(model, (CubicStiffness((0,), 1e10), JenkinsFriction((0,), 8e4, 1.0)))
    forces = (0.01,) + tuple(float(f) for f in np.arange(100.0, 401.0, 30.0))
    return Case("two_dof_friction", system, forces, _grid(650, 850), {"k3": 1e10, "kf": 8e4, "slip_force": 1.0})


def sdof_cubic() -> Case:
    """§3.5: m 0.1, k 2e6, γ 0.01, k* 1e10, no friction; PRD levels 50…400 N (12 levels),
    DDF levels 100, 150, 350, 450 N; grid 600–950 Hz."""
    model = LumpedModel.with_loss_factor([[0.1]], [[2e6]], 0.01)
    system = NonlinearSystem(model, (CubicStiffness((0,), 1e10),))
    prd_levels = tuple(float(f) for f in np.linspace(50.0, 400.0, 12))
    forces = tuple(sorted(set(prd_levels) | {100.0, 150.0, 350.0, 450.0}))
    return Case("sdof_cubic", system, forces, _grid(600, 950), {"k3": 1e10})


CASES = {"sdof_friction": sdof_friction, "two_dof_friction": two_dof_friction, "sdof_cubic": sdof_cubic}


@lru_cache(maxsize=None)
def case_data(name: str) -> tuple[Case, FRFLevels]:
    """The case and its noise-free measured FRFs at dof 0 (driving point)."""
    case = CASES[name]()
    table, report = simulate_frf_table(case.system, 0, np.array(case.frequency_hz), case.forces)
    dropped = {level: n for level, n in report.dropped_points.items() if n}
    if dropped:
        raise RuntimeError(f"{name}: continuation left points out: {dropped}")
    return case, FRFLevels.from_table(table, "0", "0")
