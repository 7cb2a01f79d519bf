"""T-beam and gun-barrel surrogates against the source's published FE results and
against hand calculations; mesh refinement study."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from nlupdate.fe.models.gunbarrel import GUNBARREL_COORDINATES, GunBarrelParameters, gunbarrel_model
from nlupdate.fe.models.mesh_study import mesh_refinement_study
from nlupdate.fe.models.tbeam import (
    TBEAM_COORDINATES,
    TBeamParameters,
    global_frequencies,
    global_mode_mask,
    tbeam_model,
)

# Achieved (24 elements per beam, Timoshenko, patch joint): −0.1 %, −2.4 %, +0.4 % without
# sensor masses and −0.5 %, −2.5 %, −0.5 % with them. The tolerances below are 1 % for
# modes 1 and 3 and 3 % for mode 2 (a beam model of the solid ANSYS model is ~2.4 % low
# on mode 2, consistently across all published cases).
TOLERANCE = np.array([0.01, 0.03, 0.01])


def relative_error(computed, published):
    return np.abs(np.asarray(computed) / np.asarray(published) - 1.0)


def test_tbeam_initial_fe_without_sensor_masses():
    """Thesis Tables 4.9/4.11 (46.48, 198.05 Hz) and §4.2.4.1 mesh study (mode 3 converged
    to 280–282 Hz, taken as 281)."""
    freqs = global_frequencies(tbeam_model(TBeamParameters()), 3)
    assert np.all(relative_error(freqs, [46.48, 198.05, 281.0]) < TOLERANCE)


def test_tbeam_initial_fe_with_sensor_masses():
    """Thesis Table 4.15: 41.4, 193.3, 266.0 Hz."""
    freqs = global_frequencies(tbeam_model(TBeamParameters().with_sensor_masses()), 3)
    assert np.all(relative_error(freqs, [41.4, 193.3, 266.0]) < TOLERANCE)


def test_tbeam_updated_candidate_1():
    """Thesis Tables 4.17/4.18: E 189.4 GPa, h2 1.600 mm, h1 7.727 mm → 40.76, 178.69, 268.07 Hz."""
    params = TBeamParameters(E=189.4e9, h2=1.600e-3, h1=7.727e-3).with_sensor_masses()
    freqs = global_frequencies(tbeam_model(params), 3)
    assert np.all(relative_error(freqs, [40.76, 178.69, 268.07]) < TOLERANCE)


def test_tbeam_global_modes_are_modes_1_2_and_6():
    """Source §4.2.4.1: the first three global modes are modes 1, 2 and 6; modes 3–5 are
    local modes of the thin beams in which beam 1 does not move."""
    model = tbeam_model(TBeamParameters())
    freqs, shapes = model.modal(6)
    assert list(global_mode_mask(model, shapes)) == [True, True, False, False, False, True]
    tip = model.shapes_at(shapes, ["tip:uz"])[0]
    assert np.all(np.abs(tip[2:5]) < 1e-6 * np.abs(tip).max())


def test_tbeam_nominal_lengths_are_too_soft():
    """Why the effective lengths (420/380 mm) are the default: the nominal 430/400 mm of
    Table 3.3 put the first mode ≥ 5 % below the source's 46.48 Hz."""
    freqs = global_frequencies(tbeam_model(TBeamParameters.table_3_3()), 1)
    assert freqs[0] < 0.95 * 46.48


def rectangle_torsion_constant(a, b, terms=50):
    """Exact Saint-Venant J of an a × b rectangle (a ≥ b), series solution."""
    n = np.arange(1, 2 * terms, 2)
    return a * b**3 / 3 * (1 - 192 / np.pi**5 * (b / a) * np.sum(np.tanh(n * np.pi * a / (2 * b)) / n**5))


def test_tbeam_static_tip_flexibility_point_joint():
    """Euler–Bernoulli, point joint: cantilever (tip w, θy) restrained by the two thin
    beams in bending (192EI/L³ each, centre load) and in torsion (4GJ/L2 each)."""
    p = TBeamParameters()
    model = tbeam_model(p, 8, theory="euler", joint="point")
    lumped = model.to_lumped()
    tip = lumped.dof_names.index("tip:uz")
    h0 = lumped.receptance([0.0], [tip], [tip])[0, 0, 0].real
    G = p.E / (2 * (1 + p.nu))
    ei1 = p.E * p.w1 * p.h1**3 / 12
    k_bend = 2 * 192 * p.E * p.w2 * p.h2**3 / 12 / p.L2**3
    k_twist = 2 * 4 * G * rectangle_torsion_constant(p.w2, p.h2) / p.L2
    L = p.L1
    k_tip = ei1 / L**3 * np.array([[12, 6 * L], [6 * L, 4 * L**2]]) + np.diag([k_bend, k_twist])
    assert h0 == pytest.approx(np.linalg.inv(k_tip)[0, 0], rel=1e-4)


def test_tbeam_coordinates_exist():
    model = tbeam_model(TBeamParameters())
    assert len({model.coordinate_index(c) for c in TBEAM_COORDINATES}) == len(TBEAM_COORDINATES)


def test_gunbarrel_reproduces_source_fe():
    """Thesis Tables 5.30–5.32. The assumed outer diameter, trunnion position and motor
    lever arm were chosen to fit these six values (see the module docstring), so this is
    a calibration check: all within 3 %."""
    published = {140e6: [6.375, 17.777, 43.897], 499e6: [7.46875, 21.816, 45.694]}
    for stiffness, target in published.items():
        freqs = gunbarrel_model(GunBarrelParameters(motor_stiffness=stiffness)).modal(3).frequencies_hz
        assert np.all(relative_error(freqs, target) < 0.03)


def test_gunbarrel_rigid_tube_pitch_mode():
    """With a (nearly) rigid tube the fundamental is pitch about the trunnion:
    ω² = k·arm² / I_trunnion, I from the tube, armor and rear components by hand."""
    p = replace(GunBarrelParameters(), E=207e9 * 1e4)
    freqs = gunbarrel_model(p).modal(1).frequencies_hz
    area = np.pi * (p.outer_diameter**2 - p.inner_diameter**2) / 4
    second_moment = np.pi * (p.outer_diameter**4 - p.inner_diameter**4) / 64
    a, forward = p.trunnion_position, p.length - p.trunnion_position
    inertia = (
        p.rho * area * (forward**3 + a**3) / 3
        + p.rho * second_moment * p.length
        + p.rear_mass * a**2 + p.rear_inertia
        + p.armor_mass * p.armor_position**2 + p.armor_inertia
    )
    expected = np.sqrt(p.motor_stiffness * p.motor_arm**2 / inertia) / (2 * np.pi)
    assert freqs[0] == pytest.approx(expected, rel=1e-3)


def test_gunbarrel_coordinates_and_invalid_geometry():
    model = gunbarrel_model(GunBarrelParameters())
    assert len({model.coordinate_index(c) for c in GUNBARREL_COORDINATES}) == 6
    with pytest.raises(ValueError, match="inner_diameter"):
        GunBarrelParameters(outer_diameter=0.1)
    with pytest.raises(ValueError, match="armor_position"):
        GunBarrelParameters(armor_position=2.0)


def test_mesh_study_converges_monotonically():
    """Nested meshes + consistent mass: Rayleigh–Ritz upper bounds that decrease."""
    table = mesh_refinement_study(tbeam_model, TBeamParameters(), [4, 8, 16, 32], 3, frequencies=global_frequencies)
    assert list(table.columns) == ["mesh_parameter", "elements", "dofs", "mode", "frequency_hz", "change_percent"]
    for _, rows in table.groupby("mode"):
        rows = rows.sort_values("mesh_parameter")
        assert np.all(np.diff(rows["frequency_hz"].to_numpy()) < 0)
        assert rows["change_percent"].iloc[-1] == 0.0
        assert abs(rows["change_percent"].iloc[-2]) < 0.05
    assert table["dofs"].is_monotonic_increasing


def test_mesh_study_gunbarrel_converged():
    table = mesh_refinement_study(gunbarrel_model, GunBarrelParameters(), [12, 48], 3)
    coarse = table[table["mesh_parameter"] == 12]
    assert np.all(np.abs(coarse["change_percent"]) < 0.1)
    with pytest.raises(ValueError, match="element_counts"):
        mesh_refinement_study(gunbarrel_model, GunBarrelParameters(), [12, 12], 3)
