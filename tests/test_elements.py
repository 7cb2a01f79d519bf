"""Describing functions against a numerical Fourier integral of each force law."""
import numpy as np
import pytest

from nlupdate.core.model.elements import (
    CoulombFriction,
    CubicStiffness,
    JenkinsFriction,
    PolynomialDF,
    QuadraticDamping,
    SymmetricGap,
)

from delta_reference import assemble_delta

N_SAMPLES = 400_000


def fourier_df(element, amplitude, omega, cycles=1):
    """(1/(πA)) ∫ f(θ) e^{−iθ} dθ over the last of ``cycles`` cycles of x = A cos θ.

    Midpoint samples keep the discontinuities of sign-type laws between samples; the
    hysteretic state is carried through the earlier cycles (return mapping).
    """
    theta = (np.arange(N_SAMPLES) + 0.5) * 2 * np.pi / N_SAMPLES
    x = amplitude * np.cos(theta)
    v = -amplitude * omega * np.sin(theta)
    state = element.initial_state(())
    if state is not None:  # hysteresis: march sample by sample, steady cycle last
        forces = np.empty(N_SAMPLES)
        for _ in range(cycles):
            for i in range(N_SAMPLES):
                forces[i], state = element.force(x[i], v[i], state, omega)
    else:
        forces, _ = element.force(x, v, None, omega)
    first_harmonic = np.sum(forces * np.exp(-1j * theta)) * (2 * np.pi / N_SAMPLES) / np.pi
    return first_harmonic / amplitude


CASES = [
    (CubicStiffness((0,), 1e10), [1e-4, 3e-3, 0.02]),
    (CoulombFriction((0,), 1.0), [1e-5, 1e-3, 0.1]),
    (QuadraticDamping((0,), 2.5), [1e-4, 1e-2]),
    (SymmetricGap((0,), gap=1e-3, kc=5e5), [5e-4, 1.2e-3, 4e-3, 0.05]),
    (PolynomialDF((0,), real=(1.56e9, -2.48e6, -190.0), imag=(-2.74e14, 1.1e12, -1.49e9, 8.0e5, -109.0)), [1e-4, 1e-3]),
    (PolynomialDF((0, 1), real=(3.0e9, 0.0, 2.0e4), imag=(5.0e3,)), [2e-3]),
]


@pytest.mark.parametrize("element,amplitudes", CASES, ids=lambda c: type(c).__name__ if not isinstance(c, list) else "")
def test_stateless_describing_functions_match_fourier_integral(element, amplitudes):
    omega = 2 * np.pi * 40.0
    for amplitude in amplitudes:
        expected = fourier_df(element, amplitude, omega)
        actual = complex(element.describing_function(amplitude, omega))
        scale = max(abs(expected), 1e-12)
        assert abs(actual - expected) / scale < 1e-4, (amplitude, actual, expected)


@pytest.mark.parametrize("amplitude", [2e-6, 3.4e-6, 5e-6, 1e-5, 1e-3])
def test_jenkins_describing_function_matches_return_mapping_cycle(amplitude):
    element = JenkinsFriction((0,), kf=3e5, slip_force=1.0)
    global N_SAMPLES
    saved, N_SAMPLES = N_SAMPLES, 20_000  # per-sample return mapping is a Python loop
    try:
        expected = fourier_df(element, amplitude, 1.0, cycles=2)
    finally:
        N_SAMPLES = saved
    actual = complex(element.describing_function(amplitude, 1.0))
    assert abs(actual - expected) / abs(expected) < 1e-4


def test_jenkins_limits_stuck_spring_and_coulomb():
    element = JenkinsFriction((0,), kf=8e4, slip_force=1.0)
    assert complex(element.describing_function(0.5 / 8e4)) == pytest.approx(8e4)
    large = 10.0
    coulomb = CoulombFriction((0,), 1.0).describing_function(large)
    assert complex(element.describing_function(large)).imag == pytest.approx(complex(coulomb).imag, rel=1e-4)


def test_gap_is_zero_inside_clearance():
    gap = SymmetricGap((0,), gap=1e-3, kc=1e6)
    assert complex(gap.describing_function(0.9e-3)) == 0
    assert complex(gap.describing_function(1e3)).real == pytest.approx(1e6, rel=1e-5)


ALL_ELEMENTS = [case[0] for case in CASES] + [JenkinsFriction((0,), kf=3e5, slip_force=1.0)]


@pytest.mark.parametrize("element", ALL_ELEMENTS, ids=lambda e: type(e).__name__)
def test_describing_function_derivatives_match_finite_differences(element):
    omega = 2 * np.pi * 50.0
    for amplitude in (4e-6, 2e-3, 1.5e-2):
        d_da, d_dw = element.describing_function_derivatives(amplitude, omega)
        h = 1e-6 * amplitude
        fd_a = (element.describing_function(amplitude + h, omega) - element.describing_function(amplitude - h, omega)) / (2 * h)
        hw = 1e-6 * omega
        fd_w = (element.describing_function(amplitude, omega + hw) - element.describing_function(amplitude, omega - hw)) / (2 * hw)
        assert abs(complex(d_da) - complex(fd_a)) <= 1e-5 * abs(complex(fd_a)) + 1e-9 * abs(complex(element.describing_function(amplitude, omega))) / amplitude
        assert abs(complex(d_dw) - complex(fd_w)) <= 1e-5 * abs(complex(fd_w)) + 1e-12


def test_nonlinearity_matrix_assembly_follows_methods_section_1():
    cubic = CubicStiffness((0,), 1e10)
    link = CubicStiffness((0, 2), 2e10)
    x = np.array([1e-3, 0.0, -2e-3 + 1e-3j])
    delta = assemble_delta([cubic, link], x, omega=1.0, dofs=(0, 1, 2))
    nu_ground = 0.75 * 1e10 * 1e-3**2
    nu_link = 0.75 * 2e10 * abs(x[0] - x[2]) ** 2
    expected = np.array([[nu_ground + nu_link, 0, -nu_link], [0, 0, 0], [-nu_link, 0, nu_link]])
    np.testing.assert_allclose(delta, expected, rtol=1e-12)


def test_bad_element_input_is_rejected_with_a_clear_message():
    with pytest.raises(ValueError, match="slip_force"):
        JenkinsFriction((0,), kf=1e5, slip_force=-1.0)
    with pytest.raises(ValueError, match="itself"):
        CubicStiffness((1, 1), 1.0)
    with pytest.raises(ValueError, match="one dof to ground or two dofs"):
        CubicStiffness((0, 1, 2), 1.0)


def test_each_element_declares_its_parameters_as_its_constructor_takes_them():
    """The one declaration model files, identification and discovery read: an element's
    ``parameters`` are its dataclass fields (after ``dofs``) in order, and it is listed
    under its own ``type_name``."""
    import dataclasses

    from nlupdate.core.identification.dfmodels import ELEMENT_PARAMETERS
    from nlupdate.core.model.elements import ELEMENT_TYPES

    for name, cls in ELEMENT_TYPES.items():
        assert cls.type_name == name
        fields = [f.name for f in dataclasses.fields(cls) if f.name != "dofs"]
        assert [p.name for p in cls.parameters] == fields, name
        optional = {f.name for f in dataclasses.fields(cls) if f.default is not dataclasses.MISSING}
        assert {p.name for p in cls.parameters if p.optional} == optional, name
    assert set(ELEMENT_PARAMETERS) == set(ELEMENT_TYPES) - {"polynomial"}
    assert ELEMENT_PARAMETERS["iwan"] == (("slip_force", True), ("kt", True), ("chi", False), ("beta", True))
