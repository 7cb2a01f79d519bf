"""Hill stability on the reduced coordinates against every dof (issue 38).

Run from the repository root, one BLAS thread (set here unless given):

    python benchmarks/hill_reduction.py [--repeats 5] [--dense-points 3] [--figure docs/figures/hill_reduction.png] [--write-docs]

``--write-docs``: the output becomes its block of docs/performance.md (benchmarks/docs_block.py).

Part 1, the target case: a fixed–free chain of 100 dofs with 10 joints (cubic springs
between node pairs (10j, 10j + 1), k3 = 3e12 N/m³), 5 N at the tip, H = 3, band [0.97, 1.08]·ω1. The curve
is traced once without stability; then, on its points, Hill's method on the reduced
coordinates (:func:`nlupdate.core.response.hill_reduction.hill_model`; the basis built once
per curve, timed apart) against the dense computation on every dof (a few points: seconds
each). Per point: the median over ``--repeats`` of CPU time (process) beside wall time.

Part 2, the verdicts: an 18- and a 24-dof chain with 3 cubic joints and a Jenkins slider
(the case of tests/test_hill_reduction.py, and a larger one), H = 3, a curve with two folds:
the verdict at every point by both computations, and the same with smaller cut-offs
(``CUTOFF`` of the module), to show what the margin buys.
"""
from __future__ import annotations

import argparse
import datetime
import os
import sys
import time
import warnings
from pathlib import Path

for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")
if __package__ in (None, ""):  # run as a script: make the repository root importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402

from benchmarks import docs_block  # noqa: E402

from nlupdate.core.model.elements import CubicStiffness, JenkinsFriction  # noqa: E402
from nlupdate.core.model.system import NonlinearSystem  # noqa: E402
from nlupdate.core.response import hill_reduction  # noqa: E402
from nlupdate.core.response.harmonic_balance import HarmonicTruncationWarning, trace_harmonic_balance  # noqa: E402
from nlupdate.core.response.hill import HillModel, floquet_batch  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from test_hill_reduction import fixed_free_chain as chain  # noqa: E402  (the test's chain: one definition)

H = 3


def jointed(n: int, joints: int, jenkins: bool, k3: float = 1e11) -> NonlinearSystem:
    """``joints`` cubic springs k3 (N/m³) between node pairs spread along the chain, the first
    with a Jenkins slider if asked."""
    stride = n // joints
    elements = [CubicStiffness((j * stride, j * stride + 1), k3) for j in range(joints)]
    if jenkins:
        elements.append(JenkinsFriction((0, 1), kf=0.3e4 * n, slip_force=3.0))
    return NonlinearSystem(chain(n), tuple(elements))


def trace(system: NonlinearSystem):
    w1 = float(system.model.modes(1)[0][0])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HarmonicTruncationWarning)  # both computations see the same orbit
        return trace_harmonic_balance(system, {system.model.n_dof - 1: 5.0}, 0.97 * w1, 1.08 * w1, harmonics=H,
                                      stability=False), w1


def inputs(curve, points=slice(None)):
    problem = curve.problem
    coefficients = problem.coefficients(curve.x_nonlinear[points])
    omega = curve.omega[points]
    _, jacobians, _ = problem.forces_batch(coefficients, omega, jacobian=True)
    return problem, coefficients, omega, jacobians


def verdicts(multipliers, turning):
    stable = np.abs(multipliers).max(axis=1) < 1.0 + 1e-7
    stable[turning] = False
    return stable


def clock(function, repeats: int):
    """Medians (CPU s, wall s) of ``repeats`` calls, and the last result."""
    cpu, wall = [], []
    for _ in range(repeats):
        c, w = time.process_time(), time.perf_counter()
        result = function()
        cpu.append(time.process_time() - c)
        wall.append(time.perf_counter() - w)
    return float(np.median(cpu)), float(np.median(wall)), result


def part1(repeats: int, dense_points: int) -> None:
    system = jointed(100, 10, jenkins=False, k3=3e12)
    curve, w1 = trace(system)
    problem, coefficients, omega, jacobians = inputs(curve)
    build = lambda: hill_reduction.hill_model(system.model, problem.a, problem.element_index, omega.max(), H)  # noqa: E731
    cpu_b, wall_b, hill = clock(build, repeats)
    solve = lambda: floquet_batch(hill, problem.element_index, coefficients, omega, problem.fourier, jacobians)  # noqa: E731
    cpu_r, wall_r, (_, mu_r) = clock(solve, repeats)
    picks = np.linspace(0, omega.size - 1, dense_points).round().astype(int)
    folds = np.flatnonzero(curve.turning_point)
    if folds.size == 2:  # one point on the middle branch, so both verdicts are timed
        picks[len(picks) // 2] = (folds[0] + folds[1]) // 2
    dense = HillModel.of(system.model, problem.a)
    cpu_d, wall_d = [], []
    mu_d = []
    for p in picks:
        c, w, (_, mu) = clock(lambda p=p: floquet_batch(dense, problem.element_index, coefficients[p : p + 1],
                                                        omega[p : p + 1], problem.fourier, jacobians[p : p + 1]), 1)
        cpu_d.append(c)
        wall_d.append(w)
        mu_d.append(mu[0])
    mu_d = np.array(mu_d)
    v_d, v_r = verdicts(mu_d, curve.turning_point[picks]), verdicts(mu_r[picks], curve.turning_point[picks])
    n = omega.size
    per_r, per_rw = cpu_r / n, wall_r / n
    print(f"\nPart 1: 100 dofs, 10 joints (cubic between node pairs), H = {H}, {n} curve points, folds at "
          f"{np.round(omega[folds] / w1, 4).tolist()}·ω1; load average {load()}")
    print(f"  reduced: n_q = {hill.mass.shape[0]} ({hill.mass.shape[0] - 10} modes up to "
          f"{hill_reduction.CUTOFF:g}·(H + 1)·ω_max, 10 joint directions); companion {2 * hill.mass.shape[0] * (2 * H + 1)}²")
    print(f"  reduced Hill, all {n} points at once: {1e3 * per_r:.2f} ms CPU / {1e3 * per_rw:.2f} ms wall per point "
          f"(median of {repeats}); the basis, once per curve: {1e3 * cpu_b:.1f} ms CPU / {1e3 * wall_b:.1f} ms wall "
          f"({1e3 * (cpu_r + cpu_b) / n:.2f} ms CPU per point with it)")
    print(f"  dense Hill on all 100 dofs (companion {2 * 100 * (2 * H + 1)}²), {len(picks)} points one at a time: "
          f"{np.median(cpu_d):.3f} s CPU / {np.median(wall_d):.3f} s wall per point (median)")
    print(f"  ratio dense / reduced per point: {np.median(cpu_d) / per_r:.0f}× on CPU")
    print(f"  verdicts at the dense points {picks.tolist()}: dense {['stable' if v else 'unstable' for v in v_d]}, "
          f"equal: {bool(np.array_equal(v_d, v_r))}; critical |μ| apart by "
          f"{np.abs(np.abs(mu_d).max(axis=1) - np.abs(mu_r[picks]).max(axis=1)).max():.1e}")
    force = {system.model.n_dof - 1: 5.0}
    band = (0.97 * w1, 1.08 * w1)

    def traced(stability):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", HarmonicTruncationWarning)
            return trace_harmonic_balance(system, force, *band, harmonics=H, stability=stability)

    cpu_off, _, off = clock(lambda: traced(False), 3)
    cpu_on, _, on = clock(lambda: traced(True), 3)
    print(f"  as users call it, trace_harmonic_balance(stability=True) against stability=False: "
          f"{1e3 * (cpu_on - cpu_off) / on.omega.size:.2f} ms CPU per point more (trace {1e3 * cpu_off / off.omega.size:.2f}"
          f" ms CPU per point; medians of 3); its verdicts equal these: {bool(np.array_equal(on.stable, verdicts(mu_r, curve.turning_point)))}")
    goal = per_r <= 0.020
    print(f"  Goal (≤ 20 ms CPU per point, reduced): {'met' if goal else 'NOT met'}.")


def part2(figure: str | None) -> None:
    print(f"\nPart 2: verdicts at every point, reduced against dense (H = {H}); load average {load()}")
    shown = None
    for n in (18, 24):
        system = jointed(n, 3, jenkins=True)
        curve, w1 = trace(system)
        problem, coefficients, omega, jacobians = inputs(curve)
        _, mu_d = floquet_batch(HillModel.of(system.model, problem.a), problem.element_index, coefficients, omega,
                                problem.fourier, jacobians)
        v_d = verdicts(mu_d, curve.turning_point)
        default = hill_reduction.CUTOFF
        for cutoff in (0.5, 1.0, default):
            hill_reduction.CUTOFF = cutoff
            try:
                hill = hill_reduction.hill_model(system.model, problem.a, problem.element_index, omega.max(), H)
            finally:
                hill_reduction.CUTOFF = default
            reduced = hill.mass.shape[0] < n
            _, mu_r = floquet_batch(hill, problem.element_index, coefficients, omega, problem.fourier, jacobians)
            v_r = verdicts(mu_r, curve.turning_point)
            differ = np.flatnonzero(v_d != v_r)
            print(f"  {n} dofs, CUTOFF {cutoff:g}: n_q = {hill.mass.shape[0]}{'' if reduced else ' (not reduced)'}; "
                  f"{omega.size} points, {int((~v_d).sum())} unstable (dense); verdicts differ at {differ.size}; "
                  f"critical |μ| apart ≤ {np.abs(np.abs(mu_d).max(axis=1) - np.abs(mu_r).max(axis=1)).max():.1e}")
            if n == 24 and cutoff == default:
                shown = (curve, w1, mu_d, mu_r, v_d, v_r, hill.mass.shape[0])
    if figure:
        draw(figure, *shown)


def draw(path: str, curve, w1, mu_d, mu_r, v_d, v_r, n_q) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x = curve.omega / w1
    amplitude = np.abs(curve.harmonics([curve.problem.model.n_dof - 1])[:, 1, 0]) * 1e3
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(6.4, 5.2), sharex=True)
    top.plot(x, amplitude, color="0.7", lw=1)
    top.plot(x[v_d], amplitude[v_d], "o", ms=5, mfc="none", color="C0", label="stable, dense (24 dofs)")
    top.plot(x[v_r], amplitude[v_r], ".", ms=3, color="C1", label=f"stable, reduced (n_q = {n_q})")
    top.plot(x[~v_d], amplitude[~v_d], "x", ms=5, color="C3", label="unstable, dense")
    top.set_ylabel("tip amplitude, 1st harmonic (mm)")
    top.legend(fontsize=8)
    bottom.plot(x, np.abs(mu_d).max(axis=1), "o", ms=4, mfc="none", label="dense")
    bottom.plot(x, np.abs(mu_r).max(axis=1), ".", ms=3, label="reduced")
    bottom.axhline(1.0, color="0.5", lw=0.8)
    bottom.set_ylabel("max |μ|")
    bottom.set_xlabel("ω / ω1")
    bottom.legend(fontsize=8)
    fig.suptitle(f"Hill stability, H = {H}: 24-dof chain, 3 cubic joints + Jenkins", fontsize=10)
    fig.tight_layout()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    print(f"  figure: {path}")


def load() -> str:
    return ", ".join(f"{value:.2f}" for value in os.getloadavg())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--dense-points", type=int, default=3)
    parser.add_argument("--figure", default=None, help="write the Part 2 figure (PNG) here")
    docs_block.add_option(parser)
    args = parser.parse_args()
    with docs_block.writing_docs(args.write_docs, "hill_reduction.py"):
        print(f"{datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC; threads "
              f"OMP={os.environ['OMP_NUM_THREADS']} OPENBLAS={os.environ['OPENBLAS_NUM_THREADS']}; load average {load()}")
        part1(args.repeats, args.dense_points)
        part2(args.figure)


if __name__ == "__main__":
    main()
