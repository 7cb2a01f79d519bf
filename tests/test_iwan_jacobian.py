"""The Iwan backbone fit's Jacobian in closed form (core/identification/iwan_backbone_fit.py)
against finite differences: the joint's describing function differentiated in its parameters
(``IwanJoint.describing_function_gradient``), the series of ∂B(r; a, 3/2)/∂a it uses against
quadrature, and the fit's whole Jacobian against central differences of its own residuals, at
parameter points either side of φ_max (where the DF changes form)."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import scipy.integrate
import scipy.special

from nlupdate.core.identification.iwan_backbone_fit import JENKINS_BETA, JENKINS_CHI, iwan_problem
from nlupdate.core.identification.modal_samples import ModalSamples
from nlupdate.core.model.elements import IwanJoint
from nlupdate.core.model.elements.iwan import _scaled_incomplete_beta_da

W0 = 2 * np.pi * 121.0


def _richardson(f, h: float):
    """Central difference of ``f(δ)`` at 0 with Richardson's extrapolation (error O(h⁴))."""
    return (4 * (f(h / 2) - f(-h / 2)) / h - (f(h) - f(-h)) / (2 * h)) / 3


@pytest.mark.parametrize("a", [1.5001, 2.0, 2.2, 2.4999])
def test_the_series_of_the_incomplete_beta_functions_derivative_is_the_integral(a):
    """``r^(3/2−a) ∫₀^r ln t · t^(a−1)(1−t)^½ dt`` by adaptive quadrature, across both series'
    ranges (r ≤ ½ and above, r = 1 the complete function) and at the integer a = 2 (χ = −½),
    where the coefficients' closed form has a zero factor."""
    r = np.array([1e-14, 1e-3, 0.3, 0.5, 0.5000001, 0.8, 0.999, 1.0])
    quad = [scipy.integrate.quad(lambda t: np.log(t) * t ** (a - 1) * np.sqrt(1 - t), 0, x, epsabs=0, epsrel=1e-13,
                                 limit=200)[0] * x ** (1.5 - a) for x in r]
    assert _scaled_incomplete_beta_da(r, a) == pytest.approx(quad, rel=1e-11)


@pytest.mark.parametrize("chi", [-0.999, -0.5, -0.1, 0.0])
@pytest.mark.parametrize("beta", [0.0, 0.3, 5.0, 1e6])
def test_the_describing_functions_parameter_gradient_is_its_finite_difference(chi, beta):
    """∂ν/∂(K_T, F_S, χ, β) against central differences of ``describing_function`` (Richardson)
    within 1e-6 relative (1e-9 of |ν| where the derivative is ~0), from deep microslip to deep
    macroslip and at 0.999 and 1.001 φ_max. Steps: 3e-4 relative (in χ, at most 1 % of χ + 1:
    ν changes on that scale as χ → −1; smaller steps lose digits to the cancelling terms of Re ν
    in deep macroslip), and small enough that φ_max moves by at most 1 % of a point's distance
    from it (ν has a √(1 − φ_max/A) beyond φ_max; at χ = −0.999, ∂ ln φ_max/∂χ ≈ −1000).
    β = 0 has no two-sided difference."""
    joint = IwanJoint((0,), slip_force=2.0, kt=3e5, chi=chi, beta=beta)
    a = joint.phi_max * np.array([1e-3, 0.3, 0.999, 1.001, 3.0, 1e3])
    nu, nu_a, gradient = joint.describing_function_gradient(a)
    assert np.array_equal(nu, joint.describing_function(a))
    assert np.array_equal(nu_a, joint.describing_function_derivatives(a)[0])
    steps = {"kt": 3e5 * 3e-4, "slip_force": 2 * 3e-4, "chi": min(3e-4, 1e-2 * (chi + 1)), "beta": 3e-4 * beta}
    for name, base in steps.items():
        if (name == "chi" and chi == 0.0) or (name == "beta" and beta == 0.0):
            continue
        value = getattr(joint, name)
        moved = lambda d: replace(joint, **{name: value + d})  # noqa: E731
        phi_rate = abs(_richardson(lambda d: np.log(moved(d).phi_max), 1e-3 * base))  # |∂ ln φ_max/∂p|
        for k, amplitude in enumerate(a):
            h = min(base, 1e-2 * abs(np.log(amplitude / joint.phi_max)) / phi_rate)
            reference = _richardson(lambda d: moved(d).describing_function(amplitude), h)
            for part in (np.real, np.imag):
                error = abs(part(gradient[name][k]) - part(reference))
                assert error <= 1e-6 * abs(part(reference)) + 1e-9 * abs(nu[k]), (name, amplitude / joint.phi_max, part)


def _samples(shape_free: bool = False) -> ModalSamples:
    a = np.geomspace(0.2, 3.0, 6) * 1e-3
    frequency, zeta = 120 * (1 - 0.01 * a / a.max()), 0.003 * (1 + a / a.max())
    return ModalSamples(a, frequency, zeta, np.ones_like(a), 1.0, response_amplitude=a.copy() if shape_free else None,
                        shape_free=shape_free)


CASES = {  # fixed parameters, shape fitted, amplitude noise, linear damping
    "all free, viscous": ({}, False, None, "viscous"),
    "all free, structural": ({}, False, None, "structural"),
    "microslip: beta = 0, phi_max fixed": ({"beta": 0.0, "phi_max": 3e-3}, False, None, "viscous"),
    "jenkins": ({"beta": JENKINS_BETA, "chi": JENKINS_CHI}, False, None, "viscous"),
    "shape fitted": ({}, True, None, "viscous"),
    "noisy amplitudes": ({}, False, np.array([0, 0.007, 0, 0.007, 0.007, 0]), "structural"),
}


def test_an_unknown_gradient_parameter_is_refused_in_one_line_naming_the_accepted():
    joint = IwanJoint((0,), slip_force=1.0, kt=100.0, chi=-0.5, beta=0.5)
    with pytest.raises(ValueError, match=r"\['phi_max'\] not among \['kt', 'slip_force', 'chi', 'beta'\]") as error:
        joint.describing_function_gradient(np.array([1e-3]), ("kt", "phi_max"))
    assert "\n" not in str(error.value)


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("phi_max", [0.5e-3, 0.999 * 3e-3, 1.0005 * 3e-3, 1e-2])
def test_the_fits_jacobian_is_the_finite_difference_of_its_residuals(case, phi_max):
    """The fit's ``jacobian(θ)`` against Richardson central differences (step 1e-6) of its
    ``residual(θ)``: within 1e-6 of each residual's largest derivative (entries far below it
    are the differences' rounding: a residual ~1e3 carries 1e-13 relative), with φ_max below,
    just either side of the largest sample (3e-3 m·√kg) and above every sample. Asked where the
    residuals were just evaluated (as scipy asks), it takes the describing function they
    computed and is the same to the bit."""
    fixed, shape, amplitude_std, damping = CASES[case]
    samples = _samples(shape)
    problem = iwan_problem(samples, [("x", 1.0)], 1e-4, 1e-2, 1, damping, fixed, amplitude_std)
    chi, beta, kt = fixed.get("chi", -0.4), fixed.get("beta", 0.7), 0.2 * W0**2
    slip = phi_max * kt * (beta + (chi + 1) / (chi + 2)) / (1 + beta)
    theta = [np.log(W0), np.log(0.003), scipy.special.logit(0.2)]
    theta += [np.log(slip)] * ("phi_max" not in fixed) + [scipy.special.logit(-chi)] * ("chi" not in fixed)
    theta += [np.log(0.7)] * ("beta" not in fixed) + [np.log(1.02)] * shape
    if amplitude_std is not None:
        theta += list(np.log(samples.amplitude[amplitude_std > 0] * 1.003))
    theta = np.array(theta)
    assert problem.unknowns + int(problem.noisy.sum()) == theta.size
    jacobian = problem.jacobian(theta)
    reference = np.column_stack([_richardson(lambda d: problem.residual(theta + d * np.eye(theta.size)[k]), 1e-6)
                                 for k in range(theta.size)])
    assert np.all(np.abs(problem.residual(theta)) < 1e6)  # no residual on its "no model" value
    scale = np.abs(reference).max(axis=1)
    assert np.all(scale > 0)
    assert np.max(np.abs(jacobian - reference).max(axis=1) / scale) <= 1e-6
    problem.residual(theta)
    np.testing.assert_array_equal(problem.jacobian(theta), jacobian)
