"""Issue 37: how often the amplitude model's 95 % damping band holds the truth, inside the
Jenkins stick–slip kink band [a_s/1.03, 1.5 a_s] and off it, per source and for the joint fit.

    python benchmarks/kink_band_coverage.py [--seeds 8] [--resamples 20] [--system 1-jenkins] [--truth periodic|describing|closed]

The records, noise and fits are those of ``benchmarks/test_type_truth.py`` (``--backbone
jenkins``, the stepped sine refined on its lines). Per fit, two bands at 60 amplitudes over
its samples' range (the held-out stepped sine: over its samples within the others' range):

* ``bootstrap``: the residual bootstrap ``backbone.csv`` had (``backbone_table``: the
  samples' misfits drawn onto the fitted curve, refitted by the sample fit, basic interval);
* ``covariance``: the fit's own estimator linearised, the samples' amplitudes taken as exact;
* ``cov + EIV``: the same with the phase-resonance points' amplitude noise
  (:mod:`nlupdate.core.identification.joint_band`, the band ``backbone.csv`` has for a fit
  not refined on the lines);
* ``line band``: for a fit refined on the stepped sine's lines, the band ``backbone.csv``
  has for it (:mod:`nlupdate.core.identification.line_band`: ``cov + EIV`` with the
  linear-damping law's viscous share among the unknowns, widened to the leave-one-out
  spread); the others: ``cov + EIV``.

The truth (``--truth``, repeatable; default ``periodic``): ``periodic``, the simulated
system's driving-point phase-resonance backbone by multi-harmonic balance
(tests/periodic_truth.py, checked against RK4 time integration in
tests/test_periodic_truth.py) — what the stepped sine and the phase resonance, which drive
and measure at the joint's coordinate, read with the mode's shape ψ; ``describing``, the
same in one harmonic (the whole system's describing-function phase resonance: the shape's
change without the harmonics; on the SDOF the closed form); ``closed``, the
closed-form single-mode backbone of the stuck mode (tests/test_test_type_truth.py, the
truth until 2026-11-29), 0.12–0.39 % low in damping on the 2-DOF over 2–15 a_s, where its
shape changes as the joint slips.

The refinement chooses the linear-damping law on the lines (``refine_on_lines``); with
``--sample-law`` it keeps the sample fit's, as before 2026-11-29.

Printed per system × fit × band: coverage of the damping truth inside the kink band and
off it (pooled over amplitudes and seeds), the coverage where the fit's damping error
exceeds 5 %, the band's median half-width over the fit, inside the kink band and off it, and
off it the median of |error| / half-width (0.34 for a Gaussian band of the right width:
below it the band is wider than the errors, above it narrower), and the largest damping
error inside and off the kink band.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import test_type_truth as ttt  # noqa: E402
from periodic_truth import describing_function_truth, periodic_truth  # noqa: E402
from test_test_type_truth import system, truth  # noqa: E402

from nlupdate.core.identification.amplitude_modal_fit import fit_amplitude_model  # noqa: E402
from nlupdate.core.identification.backbone_samples import backbone_curve, join_samples, own_fit_for, source_noise  # noqa: E402
from nlupdate.core.identification.joint_band import covariance_band, sample_fit_residual  # noqa: E402
from nlupdate.core.identification.line_band import line_refinement_band  # noqa: E402
from nlupdate.core.identification.line_refine import refine_at_law, refine_on_lines, refinement_residual  # noqa: E402
from nlupdate.core.identification.sample_residuals import amplitude_std  # noqa: E402

KINK = (1 / 1.03, 1.5)
#: ``--sample-law``: the refinement keeps the sample fit's linear-damping law (as before)
SAMPLE_LAW = False
BANDS = ("bootstrap", "covariance", "cov + EIV", "line band")
TRUTHS = {"periodic": periodic_truth, "describing": describing_function_truth, "closed": truth}
CELLS = ("own phase-resonance", "own ring-down", "own stepped-sine", "joint", "stepped-sine held out")


def fitted(s: dict, chosen: dict, lines) -> tuple:
    """(model, the residual its fit minimised as θ → r, the bootstrap's refit, the samples, the
    phase-resonance samples' noisy amplitudes for ``covariance_band`` or None):
    as ``test_type_truth.fit`` with the Jenkins backbone and the stepped sine on its lines."""
    shapes = (("m1", float(s["phi"][0])),)
    joined = join_samples([c[0] for c in chosen.values()])
    own_fit = own_fit_for("jenkins", shapes)
    noise = [source_noise(smp, stated, own_fit) for smp, stated in chosen.values()]
    f_std = np.concatenate([np.full(smp.amplitude.size, n[0]) for (smp, _), n in zip(chosen.values(), noise)])
    z_std = np.concatenate([np.full(smp.amplitude.size, n[1]) for (smp, _), n in zip(chosen.values(), noise)])
    model = fit_amplitude_model(joined, shapes, "jenkins", 2, frequency_std=f_std, damping_std=z_std)

    kinds = [n for n, (smp, _) in chosen.items() for _ in range(smp.amplitude.size)]
    a_std = amplitude_std(kinds, z_std)

    def refit(draw):
        return fit_amplitude_model(draw, shapes, "jenkins", 2, frequency_std=f_std, damping_std=z_std)

    if "stepped-sine" not in chosen:
        eiv = (joined, f_std, z_std, a_std) if a_std.any() else None
        return model, sample_fit_residual(model, joined, f_std, z_std), refit, joined, eiv
    keep = np.concatenate([np.full(smp.amplitude.size, n != "stepped-sine") for n, (smp, _) in chosen.items()])
    others = join_samples([chosen[n][0] for n in chosen if n != "stepped-sine"]) if keep.any() else None
    fs, zs = (f_std[keep], z_std[keep]) if others is not None else (1e-3, 0.05)
    if SAMPLE_LAW:
        model, line_noise = refine_at_law(model, lines, others, fs, zs)
    else:
        model, line_noise = refine_on_lines(model, lines, others, fs, zs)
    residual = refinement_residual(model, lines, others, fs, zs)
    eiv = (others, fs, zs, a_std[keep]) if others is not None and a_std[keep].any() else None
    source = np.concatenate([np.full(smp.amplitude.size, i) for i, (smp, _) in enumerate(chosen.values())])[keep]

    def band(a, seed):
        return line_refinement_band(model, lines, line_noise, a, others, fs, zs, source, eiv, seed)[2:]

    residual_at_noise = (lambda theta: residual(theta, line_noise))
    residual_at_noise.line_band = band
    return model, residual_at_noise, refit, joined, eiv


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=8)
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--resamples", type=int, default=20, help="bootstrap refits per fit (the old band; 0: not drawn)")
    parser.add_argument("--system", action="append", choices=("1-jenkins", "2-jenkins"))
    parser.add_argument("--truth", action="append", choices=tuple(TRUTHS),
                        help="the damping truth the bands are checked against (repeatable; default periodic)")
    parser.add_argument("--sample-law", action="store_true",
                        help="the line refinement keeps the sample fit's linear-damping law (as before 2026-11-29)")
    args = parser.parse_args()
    global SAMPLE_LAW
    SAMPLE_LAW = args.sample_law
    truths = args.truth or ["periodic"]
    print(f"{'system':10s} {'truth':10s} {'fit':22s} {'band':10s} {'in kink':>10s} {'off kink':>10s} {'err>5%':>10s} "
          f"{'width in':>8s} {'width off':>9s} {'|e|/hw':>6s} {'err in':>7s} {'err off':>7s}")
    for dofs in (1, 2):
        if args.system and f"{dofs}-jenkins" not in args.system:
            continue
        s, started = system(dofs, "jenkins"), time.process_time()
        made = ttt.records(s, "jenkins", levels=6, span=(0.5, 15.0))  # the six levels its figures were made at
        tally = {(c, b, n): [] for c in CELLS for b in BANDS for n in truths}
        for seed in range(args.first_seed, args.first_seed + args.seeds):
            every, lines, _ = ttt.samples(s, made, seed)  # its own ring-down cell on the samples, as measured
            cases = {"own phase-resonance": ({"phase-resonance": every["phase-resonance"]}, None),
                     "own ring-down": ({"ring-down": every["ring-down"]}, None),
                     "own stepped-sine": ({"stepped-sine": every["stepped-sine"]}, None),
                     "joint": (every, None),
                     "stepped-sine held out": ({n: every[n] for n in ttt.TYPES if n != "stepped-sine"},
                                               every["stepped-sine"][0])}
            for cell, (chosen, held) in cases.items():
                model, residual, refit, joined, eiv = fitted(s, chosen, lines)
                low, high = joined.amplitude.min(), joined.amplitude.max()
                if held is not None:
                    low, high = max(low, held.amplitude.min()), min(high, held.amplitude.max())
                a = np.geomspace(low, high, 60)
                z_fit = model.damping(a)
                bands = {"covariance": covariance_band(model, residual, a, seed=seed)[2:],
                         "cov + EIV": covariance_band(model, residual, a, seed=seed, noisy_amplitudes=eiv)[2:]}
                line_band = getattr(residual, "line_band", None)
                bands["line band"] = line_band(a, seed) if line_band is not None else bands["cov + EIV"]
                if args.resamples:
                    boot = backbone_curve(model, joined, refit=refit, resamples=args.resamples, seed=seed)
                    # backbone_curve spans the samples' range: interpolate onto a in ln a
                    grid = boot["modal_amplitude"].to_numpy()
                    bands["bootstrap"] = tuple(np.interp(np.log(a), np.log(grid), boot[c].to_numpy())
                                               for c in ("damping_ratio_low", "damping_ratio_high"))
                inside = (a >= KINK[0] * s["slip"]) & (a <= KINK[1] * s["slip"])
                for truth_name in truths:
                    z_true = TRUTHS[truth_name](s, a)[1]
                    error = np.abs(z_fit / z_true - 1)
                    for name, (z_low, z_high) in bands.items():
                        held_it = (z_true >= z_low) & (z_true <= z_high)
                        width = (z_high - z_low) / 2 / z_fit
                        tally[(cell, name, truth_name)].append((held_it, inside, error > 0.05, width, error))
        for (cell, name, truth_name), rows in tally.items():
            if not rows:
                continue
            held_it, inside, big, width, error = (np.concatenate([r[k] for r in rows]) for k in range(5))

            def share(mask):
                return f"{held_it[mask].mean():6.1%}/{mask.sum():<3d}" if mask.any() else f"{'—':>10s}"

            print(f"{dofs}-jenkins  {truth_name:10s} {cell:22s} {name:10s} {share(inside):>10s} {share(~inside):>10s} {share(big):>10s} "
                  f"{np.median(width[inside]) if inside.any() else np.nan:8.3f} {np.median(width[~inside]):9.3f} "
                  f"{np.median(error[~inside] / width[~inside]):6.2f} "
                  f"{error[inside].max() if inside.any() else np.nan:7.2%} {error[~inside].max():7.2%}")
        print(f"  ({args.seeds} seeds from {args.first_seed}, {args.resamples} bootstrap refits, "
              f"{time.process_time() - started:.0f} s CPU)", flush=True)


if __name__ == "__main__":
    main()
