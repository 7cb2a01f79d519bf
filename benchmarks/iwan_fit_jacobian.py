"""CPU time of the Iwan backbone fits (``fit_amplitude_model``) with the closed-form Jacobian
(:func:`~nlupdate.core.identification.iwan_backbone_fit.iwan_problem`) against scipy's 2-point
differences (the fits before), in one run, and how far the fitted parameters move.

    python benchmarks/iwan_fit_jacobian.py [--repeats 3]

Cases (samples of a modal Iwan truth: 120 Hz, ζ₀ 0.3 %, K_T = 0.3 ω₀², χ = −0.5, β = 0.5, six
amplitudes; 1e-4 and 1 % relative noise on the frequencies and damping ratios, seed 3): all in
microslip (0.02–0.3 φ_max: the fit with β = 0 and φ_max fixed is kept), into macroslip (0.02–8
φ_max), the ``jenkins`` backbone of the latter, the same samples from FRFs with the shape fitted
(``shape_free``), and phase-resonance points with noisy amplitudes (errors in variables). Each
method runs ``--repeats`` times alternately (the machine is shared); printed per case: the
least CPU time of each, their ratio, and the largest relative change of f₀, ζ₀, K_T, F_S, χ and
β between the two. The 2-point fits are made by calling scipy's least_squares without the
Jacobian (``jac="2-point"``, its default), which is what the fits did.
"""
from __future__ import annotations

import argparse
import time
from unittest import mock

import numpy as np
import scipy.optimize

from nlupdate.core.identification.amplitude_modal_fit import fit_amplitude_model
from nlupdate.core.identification.modal_samples import ModalSamples
from nlupdate.core.model.amplitude_modal import AmplitudeModalModel
from nlupdate.core.model.elements import IwanJoint

W0 = 2 * np.pi * 120.0
JOINT = IwanJoint((0,), slip_force=1e-3 * 0.3 * W0**2 * (0.5 + 0.5 / 1.5) / 1.5, kt=0.3 * W0**2, chi=-0.5, beta=0.5)
TRUTH = AmplitudeModalModel(120.0, 0.003, (("x", 1.0),), joint=JOINT)
_LEAST_SQUARES = scipy.optimize.least_squares


def samples(reach: float, from_frfs: bool = False) -> ModalSamples:
    """Six noisy samples of :data:`TRUTH` up to ``reach`` × φ_max (module docstring)."""
    a = np.geomspace(0.02, reach, 6) * JOINT.phi_max
    omega, zeta = TRUTH.omega_zeta(a)
    noise = np.random.default_rng(3).standard_normal((2, a.size))
    f, z = omega / (2 * np.pi) * (1 + 1e-4 * noise[0]), zeta * (1 + 1e-2 * noise[1])
    if not from_frfs:
        return ModalSamples(a, f, z, np.ones_like(a), 1.0)
    force = 2 * z * (2 * np.pi * f) ** 2 * a  # at resonance, φ_f = 1: x = a
    return ModalSamples(a, f, z, force, 1.0, response_amplitude=a.copy(), shape_free=True)


CASES = {
    "iwan, microslip only": (lambda: samples(0.3), "iwan", None),
    "iwan, into macroslip": (lambda: samples(8.0), "iwan", None),
    "jenkins": (lambda: samples(8.0), "jenkins", None),
    "iwan, shape fitted (FRFs)": (lambda: samples(8.0, True), "iwan", None),
    "iwan, noisy amplitudes": (lambda: samples(8.0), "iwan", np.full(6, 1e-2 / np.sqrt(2))),
}


def _two_point(fun, x0, jac="2-point", **kwargs):
    """scipy's least_squares as the fits called it before: 2-point differences."""
    return _LEAST_SQUARES(fun, x0, **kwargs)


def fit(case: str, two_point: bool) -> tuple[AmplitudeModalModel, float]:
    """The case's fitted model and the CPU time (s) it took."""
    make, backbone, a_std = CASES[case]
    data = make()
    start = time.process_time()
    with mock.patch.object(scipy.optimize, "least_squares", _two_point if two_point else _LEAST_SQUARES):
        model = fit_amplitude_model(data, [("x", 1.0)], backbone, frequency_std=1e-4, damping_std=1e-2,
                                    amplitude_std=a_std)
    return model, time.process_time() - start


def _numbers(model: AmplitudeModalModel) -> np.ndarray:
    j = model.joint
    return np.array([model.natural_frequency_hz, model.damping_ratio, j.kt, j.slip_force, j.chi, j.beta])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    total = np.zeros(2)
    print(f"{'case':28s} {'closed form s':>13s} {'2-point s':>10s} {'ratio':>6s}  largest relative change")
    for case in CASES:
        times: list[list[float]] = [[], []]
        models = [None, None]
        for _ in range(args.repeats):
            for k in (0, 1):
                models[k], seconds = fit(case, two_point=bool(k))
                times[k].append(seconds)
        best = np.array([min(t) for t in times])
        total += best
        a, b = _numbers(models[0]), _numbers(models[1])
        change = np.abs(a - b) / np.maximum(np.abs(b), 1e-12)
        print(f"{case:28s} {best[0]:13.3f} {best[1]:10.3f} {best[1] / best[0]:6.2f}  {change.max():.2e} "
              f"(f0 {change[0]:.1e}, zeta0 {change[1]:.1e}, kt {change[2]:.1e}, F_S {change[3]:.1e}, chi "
              f"{change[4]:.1e}, beta {change[5]:.1e})")
    print(f"{'all':28s} {total[0]:13.3f} {total[1]:10.3f} {total[1] / total[0]:6.2f}")


if __name__ == "__main__":
    main()
