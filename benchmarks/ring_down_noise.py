"""Ring-down damping at 2 % noise: bias or scatter, and where — the segments against the decay fit.

    python benchmarks/ring_down_noise.py [--seeds 40] [--first-seed 0] [--bands 5] [--system 1-jenkins ...]

The four RK4 ring-downs of tests/test_test_type_truth.py (SDOF and 2-DOF, Jenkins and Iwan
joints; white noise of 2 % of the record's peak, seeds 0 … N−1) read two ways: in segments
(``decay_segments``: a complex exponential over each factor 1.5 of decay) and by the decay fit
(``fit_decay``: its samples where ζ is known to 1.5 %). Printed per system, method and
amplitude band (a over the Jenkins slip amplitude a_s = F_s/(k_tψ)): the samples, the mean
and standard deviation of the damping ratio's relative error against the closed-form truth
(mean: bias; deviation: scatter), the largest, the median stated standard error, the mean and
deviation of the frequency's error; then the noise-free record's errors and each method's
largest errors over all seeds, and the damping errors in their own stated standard errors
(z: mean, deviation, largest, the share beyond 2; an honest stated error has deviation 1).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from test_decay_fit import ring_down  # noqa: E402
from test_test_type_truth import SYSTEMS, band, noisy, truth  # noqa: E402

from nlupdate.core.identification.decay_fit import fit_decay  # noqa: E402
from nlupdate.core.identification.impact import decay_segments  # noqa: E402


def rows(method: str, s: dict, t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """(a/a_s, frequency error, damping error, stated damping error) of each sample."""
    if method == "segments":
        parts = decay_segments(t, {"x": x}, band(s), shape=s["phi"][0])
        a = np.array([p.amplitude for p in parts])
        f = np.array([p.frequency_hz for p in parts])
        zeta = np.array([p.damping_ratio for p in parts])
        stated = np.array([p.damping_std for p in parts]) / zeta
    else:
        fit = fit_decay(t, x, band(s), s["phi"][0])
        a = fit.sample_amplitudes()
        f, zeta, _, zeta_std = fit.curves(a)
        stated = zeta_std / zeta
    f_true, zeta_true = truth(s, a)
    return np.column_stack([a / s["slip"], f / f_true - 1, zeta / zeta_true - 1, stated])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=40)
    parser.add_argument("--first-seed", type=int, default=0, help="seeds first … first + seeds − 1")
    parser.add_argument("--bands", type=int, default=5, help="amplitude bands (equal in ln a) per system")
    parser.add_argument("--system", action="append", choices=[f"{d}-{k}" for d, k in SYSTEMS])
    args = parser.parse_args()
    for dofs, kind in SYSTEMS:
        if args.system and f"{dofs}-{kind}" not in args.system:
            continue
        s, t, x = ring_down(dofs, kind)
        for method in ("segments", "decay"):
            started = time.process_time()
            clean = rows(method, s, t, x)
            seeds = range(args.first_seed, args.first_seed + args.seeds)
            r = np.vstack([rows(method, s, t, noisy(x, seed)) for seed in seeds])
            print(f"{dofs}-DOF {kind}, {method} (seeds {seeds.start}–{seeds.stop - 1}, "
                  f"{time.process_time() - started:.1f} s CPU): "
                  f"{len(r) / args.seeds:.1f} samples a record over a/a_s {r[:, 0].min():.3g}–{r[:, 0].max():.3g}; "
                  f"largest errors f {np.abs(r[:, 1]).max():.1e}, ζ {100 * np.abs(r[:, 2]).max():.1f} %")
            z, miss = r[:, 2] / r[:, 3], np.abs(r[:, 2]) > 0.05
            misses = (", ".join(f"{100 * e:+.2f} % at {a:.3g} a_s ({q:+.1f} stated)"
                                for a, e, q in zip(r[miss, 0], r[miss, 2], z[miss])) if 0 < miss.sum() <= 6
                      else str(int(miss.sum())) if miss.any() else "none")
            print(f"  in stated errors: z mean {z.mean():+.2f}, sd {z.std():.2f}, largest {np.abs(z).max():.2f}, "
                  f"beyond 2: {100 * np.mean(np.abs(z) > 2):.0f} %; beyond 5 %: {misses}")
            print("  noise-free: " + ", ".join(f"{a:.3g} a_s {100 * e:+.1f} %" for a, e in clean[:, [0, 2]]))
            print(f"  {'a/a_s':>13s} {'n':>4s} {'ζ mean':>7s} {'ζ sd':>6s} {'ζ max':>6s} {'stated':>6s} "
                  f"{'f mean':>8s} {'f sd':>7s}")
            edges = np.geomspace(r[:, 0].min(), r[:, 0].max() * (1 + 1e-9), args.bands + 1)
            which = np.digitize(r[:, 0], edges) - 1
            for b in range(args.bands):
                e = r[which == b]
                if e.size:
                    print(f"  {edges[b]:6.3g}–{edges[b + 1]:<6.3g} {len(e):4d} {100 * e[:, 2].mean():6.2f}% "
                          f"{100 * e[:, 2].std():5.2f}% {100 * np.abs(e[:, 2]).max():5.1f}% "
                          f"{100 * np.median(e[:, 3]):5.2f}% {e[:, 1].mean():8.1e} {e[:, 1].std():7.1e}")
        print(flush=True)


if __name__ == "__main__":
    main()
