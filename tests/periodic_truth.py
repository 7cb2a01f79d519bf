"""The driving-point truth of the simulated Jenkins systems of tests/test_test_type_truth.py:
their phase-resonance backbone, solved on the whole system by multi-harmonic balance.

The closed form ``truth`` there is the single-nonlinear-mode backbone of the *stuck* mode
(its shape ψ kept as the joint slips). The 2-DOF's shape changes as the joint slips (φ₀
falls by 0.25 % at 15 a_s), and a test that drives and measures at the joint's coordinate
(stepped sine, phase resonance) reads, with ψ, the damping ζ = ψF/(2Ω²a) at 90° phase, a =
|X₁|/ψ — which is 0.12–0.39 % above the closed form over 2–15 a_s on the 2-DOF (and equal
to it on the SDOF but for the harmonics the closed form leaves out). Here that reading is
solved exactly on the simulated system: at modal amplitude a the unknowns are Ω, the force
F at dof 0 and every harmonic but the first of dof 0 (the joint's coordinate, to which the
balance is condensed), the first held at −iψa (90° behind the force), by the library's
condensed harmonic balance residual (AFT from the element's steady cycle), 15 harmonics,
1024 samples a period (converged: 25 harmonics and 4096 samples move ζ by < 1e-5), started
from the describing-function solution of the whole system. Checked against RK4 time
integration of the forced system (tests/test_periodic_truth.py).

Free decay reads another quantity (the decaying mode's eigenvalue, 0.1–0.2 % *below* the
closed form on the 2-DOF, plus the ring-down's own test-type effect near the kink: docs
ring-down.md): no single-mode model with one fixed shape holds both; the sources that
drive and measure at the joint outweigh the ring-down in every fit the coverage benchmark
refines on the stepped sine's lines.
"""
from __future__ import annotations

import numpy as np
import scipy.optimize

from nlupdate.core.model.linear import LumpedModel
from nlupdate.core.model.system import NonlinearSystem
from nlupdate.core.response.harmonic_balance import HarmonicBalanceProblem

HARMONICS = 15
SAMPLES = 1024


def describing_function_point(s: dict, a: float) -> tuple[float, float]:
    """(Ω rad/s, F N) of the single-harmonic phase resonance of the whole system at modal
    amplitude ``a`` (dof 0 at ψa, 90° behind the force at dof 0): the joint replaced by its
    describing function ν(ψa), Ω the root of Re H₀₀(Ω) = 0."""
    psi, m, k, c = s["phi"][0], s["M"], s["K"], s["C"]
    stiffness = k.astype(complex)
    stiffness[0, 0] += s["joint"].describing_function(np.array([abs(psi * a)]))[0]
    unit = np.eye(m.shape[0])[:, 0]

    def receptance(omega: float) -> complex:
        return np.linalg.solve(stiffness - omega**2 * m + 1j * omega * c, unit)[0]

    omega = scipy.optimize.brentq(lambda w: receptance(w).real, 0.9 * s["w0"], 1.1 * s["w0"], xtol=1e-12)
    return omega, abs(psi * a) / abs(receptance(omega))


def describing_function_truth(s: dict, a) -> tuple[np.ndarray, np.ndarray]:
    """(natural frequency Hz, damping ratio) at modal amplitudes ``a`` of the whole system's
    single-harmonic phase resonance (:func:`describing_function_point`): the shape's change
    without the harmonics — on the SDOF the closed form itself (to rounding)."""
    psi = abs(s["phi"][0])
    a = np.atleast_1d(np.asarray(a, dtype=float))
    points = np.array([describing_function_point(s, value) for value in a]).reshape(-1, 2)
    omega, force = points[:, 0], points[:, 1]
    return omega / (2 * np.pi), psi * force / (2 * omega**2 * a)


def phase_resonance_state(s: dict, a: float, harmonics: int = HARMONICS, samples: int = SAMPLES):
    """(Ω rad/s, F N, the balance problem at that F, its complex state (1, H+1, 1) of dof 0) of
    the multi-harmonic phase resonance at modal amplitude ``a`` (module docstring)."""
    psi = s["phi"][0]
    system = NonlinearSystem(LumpedModel(s["M"], s["K"], s["C"]), (s["joint"],))
    x = abs(psi * a)
    omega0, force0 = describing_function_point(s, a)
    unit = HarmonicBalanceProblem(system, {0: 1.0}, harmonics, samples, x_scale=x)
    free = np.array([i for i in range(unit.size) if i not in (1, 2)])  # all but Re X₁, Im X₁

    def state(u):
        y = np.zeros(unit.size)
        y[2] = -1.0  # X₁ = −i·ψa: 90° behind the force
        y[free] = u[2:]
        return y

    def residual(u):
        linear = unit.linear_batch(u[0] * omega0, derivative=False)
        linear = type(linear)(linear.omega, linear.h_aa, linear.x_lin * u[1] * force0)
        return unit.residual_batch(state(u)[None], linear, jacobian=False)[0]

    # Powell's hybrid method, then Levenberg–Marquardt from where it stopped (the AFT of a
    # Jenkins joint is not smooth where it starts or stops slipping); judged by the residual
    # (relative to ψa): hybr may report no progress on a converged point
    start = np.concatenate([[1.0, 1.0], np.zeros(unit.size - 2)])
    for method in ("hybr", "lm"):
        solution = scipy.optimize.root(residual, start, method=method,
                                       options={"xtol": 1e-13} if method == "hybr" else {"xtol": 1e-15, "ftol": 1e-15})
        if np.abs(solution.fun).max() <= 1e-10:
            break
        start = solution.x
    else:
        raise RuntimeError(f"phase resonance at a = {a!r}: {solution.message} "
                           f"(residual {np.abs(solution.fun).max():.2g})")
    omega, force = solution.x[0] * omega0, solution.x[1] * force0
    problem = HarmonicBalanceProblem(system, {0: force}, harmonics, samples)
    return omega, force, problem, unit.to_complex(state(solution.x))[None]


def periodic_truth(s: dict, a, harmonics: int = HARMONICS, samples: int = SAMPLES) -> tuple[np.ndarray, np.ndarray]:
    """(natural frequency Hz, damping ratio) of the driving-point phase-resonance backbone of
    the simulated system at modal amplitudes ``a`` (m·√kg): Ω/2π and ψF/(2Ω²a) (module
    docstring)."""
    psi = abs(s["phi"][0])
    a = np.atleast_1d(np.asarray(a, dtype=float))
    f, z = np.empty(a.size), np.empty(a.size)
    for i, value in enumerate(a):
        omega, force = phase_resonance_state(s, value, harmonics, samples)[:2]
        f[i], z[i] = omega / (2 * np.pi), psi * force / (2 * omega**2 * value)
    return f, z
