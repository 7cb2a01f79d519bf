"""The Craig–Bampton model with a friction joint between its boundary dofs (issue 38) against the
full model: a 30-mass chain (kept small so its time integration is affordable), a Jenkins
element in place of the spring between masses 14 and 15, driven at the free end.

The reduction keeps the joint's two dofs and the drive point plus 6 fixed-interface modes (9
coordinates for 30). References: the full model by the same describing-function continuation
(default suite) and by direct time integration (slow).
"""
from __future__ import annotations

import numpy as np
import pytest

import nlupdate as nlu
from nlupdate.core.model.model_file import system_from_dict
from nlupdate.fe.reduction import craig_bampton

N, MASS, SPRING, JOINT = 30, 0.05, 4e5, 15  # masses, kg, N/m, the joint replaces the spring between JOINT-1 and JOINT
ELEMENT = {"type": "jenkins", "dofs": [f"x{JOINT - 1}", f"x{JOINT}"], "kf": 2e5, "slip_force": 0.5}
LOSS_FACTOR = 0.02
DRIVE = f"x{N - 1}"


def _chain():
    stiffness = np.zeros((N, N))
    stiffness[0, 0] = SPRING  # to ground at the left end
    for i in range(1, N):
        if i != JOINT:
            stiffness[[i, i - 1], [i, i - 1]] += SPRING
            stiffness[i, i - 1] -= SPRING
            stiffness[i - 1, i] -= SPRING
    return MASS * np.eye(N), stiffness


def _system(mass, stiffness, names):
    return system_from_dict({"model": {"kind": "lumped", "mass": mass.tolist(), "stiffness": stiffness.tolist(),
                                       "loss_factor": LOSS_FACTOR, "dof_names": list(names)}, "nonlinear": [ELEMENT]})


@pytest.fixture(scope="module")
def systems():
    mass, stiffness = _chain()
    full = _system(mass, stiffness, [f"x{i}" for i in range(N)])
    reduced = craig_bampton(stiffness, mass, [JOINT - 1, JOINT, N - 1], [f"x{JOINT - 1}", f"x{JOINT}", DRIVE],
                            n_modes=6)
    stuck = stiffness.copy()
    stuck[[JOINT, JOINT - 1], [JOINT, JOINT - 1]] += ELEMENT["kf"]
    stuck[JOINT, JOINT - 1] -= ELEMENT["kf"]
    stuck[JOINT - 1, JOINT] -= ELEMENT["kf"]
    f1 = np.sqrt(np.linalg.eigvalsh(stuck / MASS)[0]) / (2 * np.pi)
    return full, _system(reduced.mass, reduced.stiffness, reduced.dof_names), f1


def _h(system, frequency, force, method):
    table = nlu.simulate(system, DRIVE, frequency, [force], method=method)
    curve = table[table.response_dof == DRIVE].sort_values("frequency_hz")
    return (curve.h_real + 1j * curve.h_imag).to_numpy()


def test_reduced_friction_joint_follows_the_full_chain(systems):
    """Describing-function continuation through the first resonance, the joint slipping (0.05 N: the
    peak falls to a quarter of the stuck one): reduced and full within 0.2 %."""
    full, reduced, f1 = systems
    frequency = np.linspace(0.9 * f1, 1.1 * f1, 9)
    h_full, h_reduced = _h(full, frequency, 0.05, "continuation"), _h(reduced, frequency, 0.05, "continuation")
    assert np.max(np.abs(h_reduced / h_full - 1)) < 2e-3
    mass, stiffness = _chain()
    stuck = stiffness.copy()
    stuck[[JOINT, JOINT - 1], [JOINT, JOINT - 1]] += ELEMENT["kf"]
    stuck[JOINT, JOINT - 1] -= ELEMENT["kf"]
    stuck[JOINT - 1, JOINT] -= ELEMENT["kf"]
    dynamic = stuck * (1 + 1j * LOSS_FACTOR) - (2 * np.pi * f1) ** 2 * mass
    linear_peak = abs(np.linalg.solve(dynamic, np.eye(N)[N - 1])[N - 1])
    assert np.max(np.abs(h_full)) < 0.3 * linear_peak  # the joint does slip


@pytest.mark.slow
def test_reduced_friction_joint_against_time_integration_of_the_full_chain(systems):
    """The first harmonic at the drive point by time integration of the full chain (30 dofs) and of
    the reduced model (9): within 1 % below and at the resonance."""
    full, reduced, f1 = systems
    frequency = np.array([0.95, 1.0]) * f1
    h_full, h_reduced = _h(full, frequency, 0.05, "time"), _h(reduced, frequency, 0.05, "time")
    assert np.max(np.abs(h_reduced / h_full - 1)) < 1e-2
