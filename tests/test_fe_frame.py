"""Frame elements against analytical beam, bar and spring–mass solutions."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq

from nlupdate.fe.models.frame import DENSE_LIMIT, FrameModel, Material, Section

STEEL = Material(E=210e9, nu=0.3, rho=7850.0)


def straight_beam(length, n_elements, section, material=STEEL, theory="euler", **kwargs):
    model = FrameModel()
    a = model.add_node((0.0, 0.0, 0.0), "a")
    b = model.add_node((length, 0.0, 0.0), "b")
    model.add_beam(a, b, n_elements, material, section, theory=theory, **kwargs)
    return model


def dominant_direction(model, shapes):
    """Per mode, the dof direction (0..5) carrying the largest share of kinetic energy."""
    nodes = range(model.n_nodes)
    shares = np.array([model.energy_fraction(shapes, nodes, dofs=(d,)) for d in range(6)])
    return shares.argmax(axis=0)


@pytest.mark.parametrize("n_elements", [20, 80])  # 20: dense eigen-solution, 80: shift-invert eigsh
def test_cantilever_euler_bernoulli_both_planes(n_elements):
    length, width, height = 0.43, 0.012, 0.008
    section = Section.rectangular(width, height)
    model = straight_beam(length, n_elements, section)
    model.fix("a")
    assert (6 * n_elements > DENSE_LIMIT) == (n_elements == 80)
    freqs, shapes = model.modal(6)
    rho_a = STEEL.rho * section.area
    beta = np.array([1.8751041, 4.6940911, 7.8547574])
    f_z = beta**2 * np.sqrt(STEEL.E * width * height**3 / 12 / (rho_a * length**4)) / (2 * np.pi)
    f_y = beta**2 * np.sqrt(STEEL.E * height * width**3 / 12 / (rho_a * length**4)) / (2 * np.pi)
    expected = np.sort(np.r_[f_z, f_y])
    np.testing.assert_allclose(freqs, expected, rtol=5e-3)
    # Height is along local z = global z: the lowest mode bends in z, the second in y.
    directions = dominant_direction(model, shapes)
    assert directions[0] == 2 and directions[1] == 1


def test_fixed_fixed_beam():
    length, section = 0.4, Section.rectangular(0.013, 0.0015)
    model = straight_beam(length, 40, section)
    model.fix("a")
    model.fix("b")
    freqs, shapes = model.modal(3)
    beta = np.array([4.7300408, 7.8532046, 10.9956078])
    expected = beta**2 * np.sqrt(STEEL.E * section.iy / (STEEL.rho * section.area * length**4)) / (2 * np.pi)
    np.testing.assert_allclose(freqs, expected, rtol=5e-3)
    assert np.all(dominant_direction(model, shapes) == 2)


def timoshenko_simply_supported(n, length, material, section):
    """Exact Timoshenko frequency (Hz) of mode n of a simply supported beam.

    With w = W sin(kx), ψ = Ψ cos(kx), k = nπ/L, the equations
    κGA(w'' − ψ') = ρA ẅ and EIψ'' + κGA(w' − ψ) = ρI ψ̈ give
    (κGA k² − ρAω²)(EI k² + κGA − ρIω²) − (κGA k)² = 0; the lower root is the
    bending branch.
    """
    k = n * np.pi / length
    E, G, rho = material.E, material.G, material.rho
    A, I, kappa = section.area, section.iy, section.shear_coefficient_z
    kga = kappa * G * A

    def det(omega):
        return (kga * k**2 - rho * A * omega**2) * (E * I * k**2 + kga - rho * I * omega**2) - (kga * k) ** 2

    omega_eb = k**2 * np.sqrt(E * I / (rho * A))
    return brentq(det, 1e-3 * omega_eb, omega_eb) / (2 * np.pi)


def test_timoshenko_thick_beam_matches_exact_and_is_below_euler():
    length, section = 1.0, Section.rectangular(0.1, 0.1)  # L/h = 10
    results = {}
    for theory in ("timoshenko", "euler"):
        model = straight_beam(length, 40, section, theory=theory)
        for node in range(model.n_nodes):
            model.fix(node, ("ux", "uy", "rx", "rz"))  # x–z bending only
        model.fix("a", ("uz",))
        model.fix("b", ("uz",))
        results[theory] = model.modal(3).frequencies_hz
    exact = [timoshenko_simply_supported(n, length, STEEL, section) for n in (1, 2, 3)]
    np.testing.assert_allclose(results["timoshenko"], exact, rtol=5e-3)
    euler_exact = (np.arange(1, 4) * np.pi) ** 2 * np.sqrt(STEEL.E * section.iy / (STEEL.rho * section.area)) / (2 * np.pi * length**2)
    np.testing.assert_allclose(results["euler"], euler_exact, rtol=5e-3)
    # Shear and rotary inertia lower the frequencies, more so for higher modes.
    drop = 1 - results["timoshenko"] / results["euler"]
    assert np.all(drop > 0.01) and np.all(np.diff(drop) > 0)


def test_axial_and_torsional_modes_of_a_bar():
    length, section = 1.0, Section.circular_tube(0.02)
    model = straight_beam(length, 40, section)
    for node in range(model.n_nodes):
        model.fix(node, ("uy", "uz", "ry", "rz"))
    model.fix("a")
    freqs, shapes = model.modal(4)
    odd = np.array([1, 3])
    axial = odd / (4 * length) * np.sqrt(STEEL.E / STEEL.rho)
    torsion = odd / (4 * length) * np.sqrt(STEEL.G / STEEL.rho)  # J = Ip for a circle
    np.testing.assert_allclose(freqs, np.sort(np.r_[axial, torsion]), rtol=5e-3)
    assert list(dominant_direction(model, shapes)) == [3, 0, 3, 0]


@pytest.mark.parametrize("theory", ["euler", "timoshenko"])
def test_tip_mass_on_massless_cantilever_with_spring(theory):
    length, mass, spring = 0.3, 2.0, 5e4
    section = Section.rectangular(0.02, 0.01)
    massless = Material(E=70e9, nu=0.33, rho=0.0)
    model = straight_beam(length, 8, section, material=massless, theory=theory)
    model.fix("a")
    model.add_point_mass("b", mass)
    model.add_spring("b", "uz", spring)
    freqs, shapes = model.modal(3)

    def tip_stiffness(second_moment):
        shear = 0.0 if theory == "euler" else length / (section.shear_coefficient_z * massless.G * section.area)
        return 1.0 / (length**3 / (3 * massless.E * second_moment) + shear)

    expected = np.sqrt(
        np.sort([tip_stiffness(section.iy) + spring, tip_stiffness(section.iz), massless.E * section.area / length]) / mass
    ) / (2 * np.pi)
    np.testing.assert_allclose(freqs, expected, rtol=1e-9)


def test_springs_and_point_masses_two_dof_system():
    """docs/methods.md §8 2-DOF: ground–k1–m1–k2–m2–k3–ground; plus a torsional oscillator."""
    m1, m2, k = 0.1, 0.5, 1e6
    model = FrameModel()
    a = model.add_node((0, 0, 0), "m1")
    b = model.add_node((1, 0, 0), "m2")
    c = model.add_node((2, 0, 0), "disc")
    model.add_point_mass(a, m1)
    model.add_point_mass(b, m2)
    model.add_spring(a, "uz", k)
    model.add_spring(a, "uz", k, other=b)
    model.add_spring(b, "uz", k)
    model.add_point_mass(c, 0.0, inertia=(0.0, 0.02, 0.0))
    model.add_spring(c, "ry", 800.0)
    for node in (a, b):
        model.fix(node, ("ux", "uy", "rx", "ry", "rz"))
    model.fix(c, ("ux", "uy", "uz", "rx", "rz"))
    freqs, shapes = model.modal(3)
    K = np.array([[2 * k, -k], [-k, 2 * k]])
    lam = np.sort(np.linalg.eigvals(np.linalg.solve(np.diag([m1, m2]), K)).real)
    expected = np.sort(np.r_[np.sqrt(lam), np.sqrt(800.0 / 0.02)] / (2 * np.pi))
    np.testing.assert_allclose(freqs, expected, rtol=1e-10)
    assert expected[2] == pytest.approx(732.0, abs=1.0)  # METHODS: mode 2 ≈ 732 Hz
    assert model.shapes_at(shapes, ["m1:uz"])[0, 2] != 0


def test_rigid_link_offset_mass():
    """Mass at distance d beyond the tip of a massless cantilever, carried by a rigid
    link: static flexibility at the mass (L³/3 + L²d + Ld²)/EI."""
    length, offset, mass = 0.5, 0.2, 1.5
    section = Section.rectangular(0.02, 0.01)
    massless = Material(E=200e9, nu=0.3, rho=0.0)
    model = straight_beam(length, 10, section, material=massless)
    model.fix("a")
    end = model.add_node((length + offset, 0, 0), "mass")
    model.add_rigid_link("b", end)
    model.add_point_mass(end, mass)
    for node in range(model.n_nodes):
        if node not in model.rigid_links:
            model.fix(node, ("ux", "uy", "rx", "rz"))
    freqs, shapes = model.modal(1)
    flexibility = (length**3 / 3 + length**2 * offset + length * offset**2) / (massless.E * section.iy)
    assert freqs[0] == pytest.approx(np.sqrt(1 / (flexibility * mass)) / (2 * np.pi), rel=1e-9)
    # Mass-normalised: the mass moves with amplitude 1/√m.
    assert abs(model.shapes_at(shapes, ["mass:uz"])[0, 0]) == pytest.approx(1 / np.sqrt(mass), rel=1e-9)


def test_mass_normalisation_and_orthogonality():
    model = straight_beam(0.6, 30, Section.circular_tube(0.05, 0.04), theory="timoshenko")
    model.fix("a")
    hub = model.add_node((0.6, 0.0, 0.1), "hub")
    model.add_rigid_link("b", hub)
    model.add_point_mass(hub, 0.8, (1e-3, 2e-3, 3e-3))
    model.add_spring("b", "uy", 2e4)
    K, M = model.assemble()
    freqs, shapes = model.modal(10)
    np.testing.assert_allclose(shapes.T @ (M @ shapes), np.eye(10), atol=1e-9)
    np.testing.assert_allclose(shapes.T @ (K @ shapes), np.diag((2 * np.pi * freqs) ** 2), rtol=1e-8, atol=1e-6 * (2 * np.pi * freqs[-1]) ** 2)
    assert np.all(np.diff(freqs) >= 0)


def test_to_lumped_static_receptance_and_loss_factor():
    """Static tip flexibility of a Timoshenko cantilever: L³/(3EI) + L/(κGA)."""
    length, section = 0.3, Section.rectangular(0.03, 0.04)
    model = straight_beam(length, 6, section, theory="timoshenko")
    model.fix("a")
    gamma = 0.02
    lumped = model.to_lumped(loss_factor=gamma)
    tip = lumped.dof_names.index("b:uz")
    h = lumped.receptance([0.0], [tip], [tip])[0, 0, 0]
    flexibility = length**3 / (3 * STEEL.E * section.iy) + length / (section.shear_coefficient_z * STEEL.G * section.area)
    assert h == pytest.approx(flexibility / (1 + 1j * gamma), rel=1e-9)
    assert "a:uz" not in lumped.dof_names  # clamped dofs are removed


def test_bad_input_raises_value_error():
    model = straight_beam(1.0, 2, Section.rectangular(0.01, 0.01))
    with pytest.raises(ValueError, match="coordinate"):
        model.coordinate_index("nowhere:uz")
    with pytest.raises(ValueError, match="dof"):
        model.coordinate_index("a:uw")
    with pytest.raises(ValueError, match="parallel"):
        model.add_element("a", "b", STEEL, Section.rectangular(0.01, 0.01), orientation=(1, 0, 0))
    model.fix("a")
    with pytest.raises(ValueError, match="n_modes"):
        model.modal(10_000)
    slave = model.add_node((1.0, 0.0, 0.5), "s")
    model.add_rigid_link("b", slave)
    model.fix(slave, ("uz",))
    with pytest.raises(ValueError, match="slave"):
        model.modal(2)
    loose = FrameModel()
    node = loose.add_node((0, 0, 0))
    loose.add_point_mass(node, 1.0)  # rotations have neither mass nor stiffness
    with pytest.raises(ValueError, match="singular"):
        loose.modal(1)
    with pytest.raises(ValueError, match="inner_diameter"):
        Section.circular_tube(0.1, 0.2)
    with pytest.raises(ValueError, match="nu"):
        Material(E=1e9, nu=0.6, rho=1.0)
