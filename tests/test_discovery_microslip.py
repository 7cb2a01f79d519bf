"""Discovery of a hidden Iwan joint (``microslip``) from time-integration data with 2 % noise.

The truth is the discovery benchmark's structure (``benchmarks/discovery_cases.py``) plus an
Iwan joint at a chosen place, sized like the benchmark's friction: K_T = 8 % of the modal
stiffness seen there, macroslip (φ_max) between the lowest and the highest level's amplitude,
χ = −0.4, β = 0.3; the workflow gets the structure without it.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from nlupdate.core.discovery import discover
from nlupdate.core.discovery.effects import Microslip, library
from nlupdate.core.model.elements import IwanJoint
from nlupdate.core.measurement.noise import add_table_noise
from nlupdate.core.model.system import NonlinearSystem

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from discovery_cases import Structure, place_scales, sdof, time_integration_table, two_dof  # noqa: E402


def hidden_joint(structure: Structure, dofs: tuple[int, ...], chi: float = -0.4, beta: float = 0.3,
                 sliders: int = 400) -> IwanJoint:
    place = place_scales(structure, dofs)
    phi_max = place.amplitude_low ** 0.4 * place.amplitude_top ** 0.6
    kt = 0.08 * place.k_ref
    return IwanJoint(dofs, slip_force=phi_max * kt * (beta + (chi + 1) / (chi + 2)) / (1 + beta), kt=kt, chi=chi,
                     beta=beta, sliders=sliders)


def test_microslip_is_in_the_library_and_fits_its_own_describing_function():
    assert "microslip" in {effect.name for effect in library()}
    assert library(["microslip"]) == (Microslip(), Microslip(stuck_in_model=True))
    joint = IwanJoint((0,), slip_force=2.0, kt=1e5, chi=-0.3, beta=0.7)
    values = np.array([1e5, 2.0, -0.3, 0.7])
    a = np.geomspace(1e-6, 1e-3, 30)
    np.testing.assert_allclose(Microslip().nu(values, a, 1.0), joint.describing_function(a), rtol=1e-12)
    np.testing.assert_allclose(Microslip(stuck_in_model=True).nu(values, a, 1.0), joint.describing_function(a) - 1e5,
                               rtol=1e-12, atol=1e-9)
    start = Microslip().values(1e5, joint.phi_max)  # scale × shape at the start exponent and share
    assert IwanJoint((0,), slip_force=start[1], kt=start[0], chi=start[2], beta=start[3]).phi_max == pytest.approx(joint.phi_max)


def _discover(structure: Structure, dofs: tuple[int, ...], seed: int, sliders: int = 400):
    joint = hidden_joint(structure, dofs, sliders=sliders)
    table = add_table_noise(time_integration_table(NonlinearSystem(structure.model, (joint,)), structure), 0.02, seed)
    return joint, discover(NonlinearSystem(structure.model, ()), table)


def test_microslip_hidden_in_an_sdof_is_named_at_its_place_and_closes_the_gap():
    joint, result = _discover(sdof(), (0,), seed=5, sliders=150)  # the truth's DF within 1e-2 of the exact joint's
    assert result.effect == "microslip" and result.dofs == (0,), result.stop_reason
    assert result.gap_after.gap <= 0.3 * result.gap_before.gap  # measured 0.0015
    p = result.parameters
    assert p["kt"] == pytest.approx(joint.kt, rel=0.05) and p["slip_force"] == pytest.approx(joint.slip_force, rel=0.05)
    assert p["chi"] == pytest.approx(joint.chi, abs=0.05)


@pytest.mark.slow
@pytest.mark.parametrize("dofs", [(1,), (0, 1)], ids=["at_m2", "between_masses"])
def test_microslip_hidden_in_a_two_dof_is_named_at_its_place_and_closes_the_gap(dofs):
    joint, result = _discover(two_dof(), dofs, seed=6)
    assert result.effect == "microslip" and result.dofs == dofs, result.stop_reason
    assert result.gap_after.gap <= 0.3 * result.gap_before.gap  # measured 0.0018 and 0.0020
