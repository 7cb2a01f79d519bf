"""Hit rate of discovery on hidden-effect cases measured by time integration.

    python benchmarks/discovery.py [--quick] [--seed-offsets 0,1000,2000]

The 22 cases of :func:`nlupdate.discovery.hidden_cases.benchmark_cases`: every effect of the
library hidden twice (SDOF, and the METHODS 2-DOF at a varied place: m1, m2 or between
them), dry friction + cubic twice, and two negative controls (a linear model, and a model
that already holds cubic + Jenkins). Each truth is measured by direct time integration at
2, 8, 25 and 60 N with 1–2 % noise; discovery gets the model without the hidden effects.

A case is a hit when the set of (effect, coordinates) found equals the hidden one exactly
(nothing missing, nothing extra; for a control: nothing). Printed per case: what was found,
the mean gap (1 − FRAC) before and after and their ratio, and the wall times of the
measurement and of the discovery. ``--quick`` runs the SDOF cases and the controls only;
``--seed-offsets`` repeats the set with shifted seeds (new truth parameters, noise and, on
the 2-DOF, places).
"""
from __future__ import annotations

import argparse
import os
import platform
import time

from nlupdate.discovery import discover
from nlupdate.discovery.hidden_cases import benchmark_cases


def _label(effects) -> str:
    return " + ".join(f"{name}@{list(dofs)}" for name, dofs in effects) or "none"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="SDOF cases and controls only")
    parser.add_argument("--seed-offsets", default="0", help="comma-separated seed offsets (default 0)")
    args = parser.parse_args()
    cases = [case for offset in args.seed_offsets.split(",") for case in benchmark_cases(int(offset))]
    if args.quick:
        cases = [c for c in cases if c.structure.name == "sdof" or not c.expected]
    print(f"machine: {platform.node()}, {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}, {platform.system()} {platform.release()}")
    print(f"{'case':58s} {'found':42s} {'hit':4s} {'gap before':>10s} {'gap after':>10s} {'ratio':>8s} "
          f"{'measure s':>9s} {'discover s':>10s}")
    started = time.perf_counter()
    hits, controls_clean, rows = 0, 0, []
    for case in cases:
        t0 = time.perf_counter()
        measured = case.measure()
        t1 = time.perf_counter()
        result = discover(case.model, measured)
        t2 = time.perf_counter()
        found = tuple((e.name, e.dofs) for e in result.effects)
        hit = sorted(found) == sorted(case.expected)
        hits += hit
        if not case.expected:
            controls_clean += not found
        ratio = result.gap_after.gap / result.gap_before.gap
        rows.append((case, hit, ratio))
        print(f"{case.name:58s} {_label(found):42s} {'yes' if hit else 'NO':4s} {result.gap_before.gap:10.3g} "
              f"{result.gap_after.gap:10.3g} {ratio:8.3g} {t1 - t0:9.1f} {t2 - t1:10.1f}", flush=True)
    effect_rows = [r for r in rows if r[0].expected]
    controls = len(rows) - len(effect_rows)
    worst = max((r[2] for r in effect_rows), default=float("nan"))
    print(f"\nhits: {hits}/{len(rows)} ({100 * hits / len(rows):.0f} %); effect cases "
          f"{sum(r[1] for r in effect_rows)}/{len(effect_rows)}, controls without a false effect {controls_clean}/{controls}")
    print(f"gap after / gap before on effect cases: worst {worst:.3g}, "
          f"median {sorted(r[2] for r in effect_rows)[len(effect_rows) // 2]:.3g}")
    print(f"wall time {time.perf_counter() - started:.0f} s")


if __name__ == "__main__":
    main()
