"""How well phase-resonance points can place a Jenkins joint's slip amplitude a_s at all: the
Cramér–Rao bound on ln a_s (docs/ring-down.md, "The kink from the stepped sine's lines"); with
``--joint iwan``, how well they can give an Iwan joint's damping curve about its full-slip
amplitude φ_max (docs/ring-down.md, "The Iwan fits at φ_max").

    python benchmarks/kink_information.py [--extra N ...]
    python benchmarks/kink_information.py --joint iwan [--seeds 8] [--frequency-noise 1e-6] [--levels N]
    python benchmarks/kink_information.py --levels N [--span LOW HIGH]      (Jenkins: the damping bound)

The Jenkins systems of tests/test_test_type_truth.py, their modal Jenkins backbone at the truth
(``iwan_model`` with β = 10⁶: ω₀, ζ₀ viscous, K_T, F_S), phase-resonance points at the
benchmark's six levels (0.5–15 × a_s, benchmarks/test_type_truth.py) and N more spread
geometrically over 1.1–2 a_s. Each point: the response amplitude x = φa and the force
F = 2ζ(a)ω(a)²a/φ with 2 % relative noise each (the benchmark's), the frequency Ω = ω(a) with
``--frequency-noise`` (relative); unknowns: the four parameters and each point's true amplitude.
Printed: the bound's standard deviation of ln a_s (the slip amplitude φ_max = F_S/K_T), the
smallest scatter any unbiased estimator can have.

``--joint iwan``: the Iwan systems (χ = −0.5, β = 0.5; φ_max = 1.8 a_s), their modal Iwan
backbone at the truth (ω₀, ζ₀ viscous, K_T, F_S, χ, β: six unknowns) and six levels over 0.3–6
a_s (``IWAN_LEVELS``, the benchmark's design until 2026-11-29; ``--levels N``: N spread
geometrically over the same span — ``--levels 16`` is the benchmark's design now, its
``ISSUE_LEVELS``), the same noise and unknowns. Printed per system: the
bound's largest standard deviation of ln ζ(a) over the levels' span and where; and, drawing
the six parameters from the bound's normal distribution (``--draws``), the largest relative
damping error over 60 amplitudes across that span (as the benchmark's own fits are judged),
its median, and the largest of ``--seeds`` such draws (the benchmark's "largest over 8
seeds"): its median, 90th percentile and how often it is within 5 %. An unbiased estimator
can do no better; an efficient one reaches it.

``--levels N`` with the Jenkins joint (the default): the same damping bound of its modal
Jenkins backbone (four unknowns) from N points over ``--span`` (default its six's, 0.5–15 a_s;
``--span 0.3 6`` the benchmark's one design, ``ISSUE_SPAN``), printed over the whole span and
inside and outside the kink band [a_s/1.03, 1.5 a_s], with sd(ln a_s); the frequency exact
(1e-6) as in the benchmark.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import scipy.special

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from test_stepped_sine_truth import IWAN_LEVELS, LEVELS  # noqa: E402
from test_test_type_truth import system, truth  # noqa: E402

from nlupdate.core.identification.iwan_backbone_fit import JENKINS_BETA, JENKINS_CHI, iwan_model  # noqa: E402

FIXED = {"beta": JENKINS_BETA, "chi": JENKINS_CHI}


def truth_unknowns(s: dict, kind: str) -> np.ndarray:
    """The unknowns of ``iwan_model`` at the truth of a system: log ω₀, log ζ₀, logit(K_T/ω₀²),
    log F_S (the joint in modal units, ψ = φ₀), and for an Iwan joint logit(−χ), log β."""
    psi = float(s["phi"][0])
    kt, slip = psi**2 * s["kt"], psi * s["joint"].slip_force
    theta = [np.log(s["w0"]), np.log(0.005), scipy.special.logit(kt / s["w0"] ** 2), np.log(slip)]
    if kind == "iwan":
        theta += [scipy.special.logit(-s["joint"].chi), np.log(s["joint"].beta)]
    return np.array(theta)


def parameter_covariance(s: dict, theta: np.ndarray, fixed: dict, levels: np.ndarray, noise: float,
                         frequency_noise: float) -> np.ndarray:
    """The Cramér–Rao covariance of the backbone's unknowns ``theta`` from phase-resonance points
    at ``levels`` × a_s (module docstring), each point's true amplitude an unknown too."""
    psi = float(s["phi"][0])
    shapes, k = (("0", psi),), theta.size
    p0 = np.concatenate([theta, np.log(levels * s["slip"])])

    def observed(p):
        model = iwan_model(p[:k], shapes, fixed, 1, "viscous")
        a = np.exp(p[k:])
        w, z = model.omega_zeta(a)
        return np.concatenate([p[k:] / noise, np.log(2 * z * w**2 * a / psi) / noise, np.log(w) / frequency_noise])

    step = 1e-6
    jac = np.array([(observed(p0 + step * e) - observed(p0 - step * e)) / (2 * step) for e in np.eye(p0.size)]).T
    return np.linalg.pinv(jac.T @ jac)[:k, :k]


def bound(dofs: int, levels: np.ndarray, noise: float = 0.02, frequency_noise: float = 1e-4) -> float:
    """Cramér–Rao standard deviation of ln a_s from phase-resonance points at ``levels`` × a_s."""
    s = system(dofs, "jenkins")
    theta = truth_unknowns(s, "jenkins")
    cov = parameter_covariance(s, theta, FIXED, levels, noise, frequency_noise)
    # ln a_s = ln F_S − ln K_T, K_T = expit(θ₂)·exp(2θ₀)
    g = np.array([-2.0, 0.0, -(1 - scipy.special.expit(theta[2])), 1.0])
    return float(np.sqrt(g @ cov @ g))


def damping_bound(dofs: int, kind: str = "iwan", noise: float = 0.02, frequency_noise: float = 1e-6,
                  seeds: int = 8, draws: int = 4000, seed: int = 0, levels: np.ndarray | None = None,
                  kink: tuple[float, float] = (1.03, 1.5)) -> dict:
    """The damping-curve bound of a system (``kind`` its joint) from phase-resonance points at
    ``levels`` × a_s (default: the benchmark's six, ``LEVELS`` or ``IWAN_LEVELS``), over the
    levels' span (module docstring): the largest sd of ln ζ and its amplitude (× a_s), the median
    largest error over the span, and of the largest over ``seeds`` draws its median, 90th
    percentile and share within 5 % — over the whole span, and (``*_in``, ``*_off``) inside and
    outside the kink band [a_s/kink[0], kink[1]·a_s] (a Jenkins joint's, docs/ring-down.md "Near
    the stick–slip kink")."""
    s = system(dofs, kind)
    levels = np.asarray((LEVELS if kind == "jenkins" else IWAN_LEVELS) if levels is None else levels, float)
    theta, shapes = truth_unknowns(s, kind), (("0", float(s["phi"][0])),)
    fixed = FIXED if kind == "jenkins" else {}
    cov = parameter_covariance(s, theta, fixed, levels, noise, frequency_noise)
    ratio = np.geomspace(levels.min(), levels.max(), 60)
    a = ratio * s["slip"]
    z_true = truth(s, a)[1]
    inside = (ratio > 1 / kink[0]) & (ratio < kink[1])

    def log_zeta(t):
        return np.log(iwan_model(t, shapes, fixed, 1, "viscous").omega_zeta(a)[1])

    step = 1e-6
    grad = np.array([(log_zeta(theta + step * e) - log_zeta(theta - step * e)) / (2 * step) for e in np.eye(theta.size)]).T
    sd = np.sqrt(np.einsum("ij,jk,ik->i", grad, cov, grad))
    rng = np.random.default_rng(seed)
    errors = np.array([np.abs(np.exp(log_zeta(t)) / z_true - 1)
                       for t in rng.multivariate_normal(theta, cov, draws // seeds * seeds)])
    out = {"sd": float(sd.max()), "at": float(ratio[np.argmax(sd)])}
    for tag, where in (("", np.ones(a.size, bool)), ("_in", inside), ("_off", ~inside)):
        if not where.any():
            continue
        largest = errors[:, where].max(axis=1)
        of_seeds = largest.reshape(-1, seeds).max(axis=1)
        out |= {f"median{tag}": float(np.median(largest)), f"seeds_median{tag}": float(np.median(of_seeds)),
                f"seeds_p90{tag}": float(np.percentile(of_seeds, 90)), f"within{tag}": float(np.mean(of_seeds <= 0.05))}
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--extra", type=int, nargs="*", default=[0, 1, 4, 10, 20, 40],
                        help="numbers of extra levels over 1.1–2 a_s (default 0 1 4 10 20 40)")
    parser.add_argument("--frequency-noise", type=float, default=None,
                        help="relative noise of the locked frequency (default 1e-4; with --levels: 1e-6, the "
                             "benchmark's exact frequencies)")
    parser.add_argument("--joint", default="jenkins", choices=("jenkins", "iwan"))
    parser.add_argument("--seeds", type=int, default=8, help="with --levels: the seeds the largest error is over")
    parser.add_argument("--draws", type=int, default=4000, help="with --levels: parameter draws")
    parser.add_argument("--levels", type=int, default=None, metavar="N",
                        help="the damping bound of N points spread geometrically over --span (--joint iwan: "
                             "default the six of IWAN_LEVELS)")
    parser.add_argument("--span", type=float, nargs=2, default=None, metavar=("LOW", "HIGH"),
                        help="with --levels: the levels' span × a_s (default the joint's six: Jenkins 0.5–15, "
                             "Iwan 0.3–6, the benchmark's ISSUE_SPAN)")
    args = parser.parse_args()
    if args.joint == "iwan" or args.levels is not None:
        noise = 1e-6 if args.frequency_noise is None else args.frequency_noise
        six = LEVELS if args.joint == "jenkins" else IWAN_LEVELS
        low, high = (six[0], six[-1]) if args.span is None else args.span
        levels = np.geomspace(low, high, six.size if args.levels is None else args.levels)
        print(f"{levels.size} points over {low:g}–{high:g} a_s; largest |Δζ/ζ| over 60 amplitudes across them, "
              f"the largest over {args.seeds} seeds: median, 90 %, within 5 %")
        for dofs in (1, 2):
            b = damping_bound(dofs, args.joint, frequency_noise=noise, seeds=args.seeds, draws=args.draws,
                              levels=levels)
            line = (f"{dofs}-DOF  sd(ln ζ) {b['sd']:.4f} at {b['at']:.2f} a_s;  all: {b['seeds_median']:.3f}, "
                    f"{b['seeds_p90']:.3f}, {b['within']:.0%}")
            if args.joint == "jenkins":
                line += (f";  kink band [a_s/1.03, 1.5 a_s]: {b['seeds_median_in']:.3f}, {b['seeds_p90_in']:.3f}, "
                         f"{b['within_in']:.0%};  off it: {b['seeds_median_off']:.3f}, {b['seeds_p90_off']:.3f}, "
                         f"{b['within_off']:.0%};  sd(ln a_s) {bound(dofs, levels, frequency_noise=noise):.4f}")
            print(line)
        return
    args.frequency_noise = 1e-4 if args.frequency_noise is None else args.frequency_noise
    print("extra levels   SDOF sd(ln a_s)   2-DOF sd(ln a_s)")
    for n in args.extra:
        levels = np.sort(np.append(LEVELS, np.geomspace(1.1, 2, n) if n > 1 else [1.3] * n))
        print(f"{n:12d}   {bound(1, levels, frequency_noise=args.frequency_noise):15.4f}   "
              f"{bound(2, levels, frequency_noise=args.frequency_noise):16.4f}")


if __name__ == "__main__":
    main()
