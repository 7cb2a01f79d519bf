"""The canonical steady-state response entry point (issue 36):
:func:`nlupdate.core.response.steady_state.steady_state_response`.

Checked against the closed-form solution of the single-harmonic Duffing balance (every root of
a cubic, solved here with ``numpy.roots``), in the reading the discovery uses (the stable
solution nearest to a measurement) and in the stepped-sine readings; and the discovery's
misfit and the identification's regeneration are shown to go through the response package.
"""
from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

import nlupdate
from nlupdate.core.discovery import simulation
from nlupdate.core.identification import regenerate
from nlupdate.core.model.elements import CubicStiffness
from nlupdate.core.model.linear import LumpedModel
from nlupdate.core.model.system import NonlinearSystem
from nlupdate.core.response.steady_state import steady_state_response

MASS, STIFFNESS, LOSS, CUBIC, FORCE = 0.1, 2e6, 0.01, 1e10, 130.0  # kg, N/m, -, N/m³, N
SYSTEM = NonlinearSystem(LumpedModel.with_loss_factor([[MASS]], [[STIFFNESS]], LOSS), (CubicStiffness((0,), CUBIC),))
OMEGA = 2 * np.pi * np.linspace(690.0, 800.0, 56)


def duffing_solutions(omega: float) -> list[complex]:
    """Every stable first-harmonic amplitude X (m) of m ẍ + k(1 + iη) x + k₃ x³ = F cos ωt:
    with D = k(1 + iη) − mω² and ν = ¾k₃|X|², X = F/(D + ν) and u = |X|² solves
    (¾k₃)² u³ + 2 Re(D) ¾k₃ u² + |D|² u − F² = 0; a root is stable where that cubic rises."""
    d = STIFFNESS * (1 + 1j * LOSS) - MASS * omega ** 2
    c = 0.75 * CUBIC
    cubic = [c ** 2, 2 * d.real * c, abs(d) ** 2, -FORCE ** 2]
    roots = [r.real for r in np.roots(cubic) if abs(r.imag) <= 1e-9 * abs(r) and r.real > 0]
    rising = [u for u in sorted(roots) if np.polyval(np.polyder(cubic), u) > 0]
    return [FORCE / (d + c * u) for u in rising]


REFERENCE = [duffing_solutions(w) for w in OMEGA]
LOW = np.array([s[0] for s in REFERENCE])
HIGH = np.array([s[-1] for s in REFERENCE])


def test_the_reference_has_two_stable_solutions_over_part_of_the_band():
    assert 5 < sum(len(s) == 2 for s in REFERENCE) < OMEGA.size - 5


@pytest.mark.parametrize("branch", ["low", "high"])
def test_the_nearest_stable_solution_is_the_branch_measured(branch):
    """Given measurements on either stable branch (1 % off), every point takes that branch's
    solution — in the bistable band also the low branch, which the stated up-sweep does not read."""
    exact = LOW if branch == "low" else HIGH
    rng = np.random.default_rng(7)
    measured = (exact * (1 + 0.01 * rng.standard_normal(exact.size)))[:, None]
    found = steady_state_response(SYSTEM, {0: FORCE}, OMEGA, [0], "up", measured=measured, measured_columns=[0])
    assert np.max(np.abs(found.x[:, 0] - exact) / np.abs(exact)) < 1e-7


def test_the_stepped_sine_readings_stay_on_their_branch():
    """Up a hardening Duffing oscillator stays on the high branch wherever it exists, down on the low."""
    up = steady_state_response(SYSTEM, {0: FORCE}, OMEGA, [0], "up")
    down = steady_state_response(SYSTEM, {0: FORCE}, OMEGA, [0], "down")
    assert np.max(np.abs(up.x[:, 0] - HIGH) / np.abs(HIGH)) < 1e-7
    assert np.max(np.abs(down.x[:, 0] - LOW) / np.abs(LOW)) < 1e-7
    assert np.array_equal(up.x_sweep, up.x)


def test_discovery_and_regeneration_go_through_the_response_package(monkeypatch):
    """The discovery's misfit calls the entry point once per force level; the regeneration
    reads its roots with the response package's stepped-sine rule for roots per frequency."""
    calls = {"steady_state_response": 0, "sweep_stable_roots": 0}

    def counting(module, name):
        original = getattr(module, name)

        def wrapper(*args, **kwargs):
            calls[name] += 1
            return original(*args, **kwargs)
        monkeypatch.setattr(module, name, wrapper)

    counting(simulation, "steady_state_response")
    counting(regenerate, "sweep_stable_roots")
    force = np.repeat([20.0, FORCE], OMEGA.size)
    simulation.simulate_nearest(SYSTEM, 0, force, np.tile(OMEGA, 2), [0], None, sweep="up")
    h_linear = SYSTEM.model.receptance(OMEGA, [0], [0])[:, 0, 0]
    regenerate.regenerate_frf(OMEGA / (2 * np.pi), h_linear, SYSTEM.elements[0].describing_function, FORCE, "up")
    assert calls == {"steady_state_response": 2, "sweep_stable_roots": 1}


def test_no_module_outside_the_response_package_traces_or_reads_a_curve_itself():
    """The tracing and stepped-sine reading functions are imported only inside core/response."""
    package = Path(nlupdate.__file__).parent
    inside = package / "core" / "response"
    private = {"trace_frequency_response", "trace_frequency_responses", "trace_harmonic_balance", "stepped_sine",
               "stable_segments"}
    found = []
    for path in sorted(package.rglob("*.py")):
        if inside in path.parents:
            continue
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("nlupdate.core.response"):
                found += [f"{path.relative_to(package)}: {a.name}" for a in node.names if a.name in private]
    assert found == []
