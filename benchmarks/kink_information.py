"""How well phase-resonance points can place a Jenkins joint's slip amplitude a_s at all: the
Cramér–Rao bound on ln a_s (docs/ring-down.md, "The kink from the stepped sine's lines").

    python benchmarks/kink_information.py [--extra N ...]

The Jenkins systems of tests/test_test_type_truth.py, their modal Jenkins backbone at the truth
(``iwan_model`` with β = 10⁶: ω₀, ζ₀ viscous, K_T, F_S), phase-resonance points at the
benchmark's six levels (0.5–15 × a_s, benchmarks/test_type_truth.py) and N more spread
geometrically over 1.1–2 a_s. Each point: the response amplitude x = φa and the force
F = 2ζ(a)ω(a)²a/φ with 2 % relative noise each (the benchmark's), the frequency Ω = ω(a) with
``--frequency-noise`` (relative); unknowns: the four parameters and each point's true amplitude.
Printed: the bound's standard deviation of ln a_s (the slip amplitude φ_max = F_S/K_T), the
smallest scatter any unbiased estimator can have.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import scipy.special

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from test_test_type_truth import system  # noqa: E402

from nlupdate.core.identification.amplitude_modal_fit import JENKINS_BETA, JENKINS_CHI, iwan_model  # noqa: E402

FIXED = {"beta": JENKINS_BETA, "chi": JENKINS_CHI}


def bound(dofs: int, levels: np.ndarray, noise: float = 0.02, frequency_noise: float = 1e-4) -> float:
    """Cramér–Rao standard deviation of ln a_s from phase-resonance points at ``levels`` × a_s."""
    s = system(dofs, "jenkins")
    psi = float(s["phi"][0])
    shapes = (("0", psi),)
    kt, slip = psi**2 * s["kt"], psi * s["joint"].slip_force  # the joint in modal units
    theta = np.array([np.log(s["w0"]), np.log(0.005), scipy.special.logit(kt / s["w0"] ** 2), np.log(slip)])
    p0 = np.concatenate([theta, np.log(levels * s["slip"])])

    def observed(p):
        model = iwan_model(p[:4], shapes, FIXED, 1, "viscous")
        a = np.exp(p[4:])
        w, z = model.omega_zeta(a)
        return np.concatenate([p[4:] / noise, np.log(2 * z * w**2 * a / psi) / noise, np.log(w) / frequency_noise])

    step = 1e-6
    jac = np.array([(observed(p0 + step * e) - observed(p0 - step * e)) / (2 * step) for e in np.eye(p0.size)]).T
    cov = np.linalg.pinv(jac.T @ jac)
    # ln a_s = ln F_S − ln K_T, K_T = expit(θ₂)·exp(2θ₀)
    g = np.zeros(p0.size)
    g[0], g[2], g[3] = -2.0, -(1 - scipy.special.expit(theta[2])), 1.0
    return float(np.sqrt(g @ cov @ g))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--extra", type=int, nargs="*", default=[0, 1, 4, 10, 20, 40],
                        help="numbers of extra levels over 1.1–2 a_s (default 0 1 4 10 20 40)")
    parser.add_argument("--frequency-noise", type=float, default=1e-4)
    args = parser.parse_args()
    print("extra levels   SDOF sd(ln a_s)   2-DOF sd(ln a_s)")
    for n in args.extra:
        levels = np.sort(np.append(np.geomspace(0.5, 15, 6), np.geomspace(1.1, 2, n) if n > 1 else [1.3] * n))
        print(f"{n:12d}   {bound(1, levels, frequency_noise=args.frequency_noise):15.4f}   "
              f"{bound(2, levels, frequency_noise=args.frequency_noise):16.4f}")


if __name__ == "__main__":
    main()
