"""Hit rate of discovery on hidden-effect cases measured by time integration.

    python benchmarks/discovery.py --cache DIR [--only TAG|TEXT,…] [--cases 0-9,12] [--seed-offsets 0,1000]
    python benchmarks/discovery.py --legacy [--seed-offsets 0,1000]   # the first 22 SDOF/2-DOF cases
    python benchmarks/discovery.py --list

The cases (``benchmarks/discovery_cases.py``, :func:`benchmark_cases`): 3- and 4-DOF chains;
5 % noise on 25 of 43; effects at coordinates that are not driven; only some coordinates
measured (and a drive that is not measured); eight cases with two effects at different
places and two at one place; linear and nonlinear errors together; an effect outside the
library (a one-sided stop, expected as the gap with the same first harmonic); five negative
controls (linear models, a model that already holds cubic + Jenkins, measured from rest and
by a sweep); tests that start each dwell from the linear response, from rest, or sweep up or
down, some with multi-valued responses. Each truth is measured by direct time integration
at 2, 8, 25 and 60 N; discovery gets the model without the hidden effects and the measured
table (which states the sweep direction of the swept tests).

A case is a hit when the set of (effect, coordinates) found equals the hidden one exactly
(nothing missing, nothing extra; for a control: nothing). Printed per case: what was found,
hit, the mean gap (1 − FRAC) before and after and their ratio, the RMS residual over the
noise level after (the ``fit`` verdict is poor above 5), and the wall times of the
measurement (0 when taken from the cache) and of the discovery; then the hit rate, the
controls, and the misses.

Time integration is the expensive part (a stepped sweep dwells at one frequency after the
other: 1–2 min per case here). ``--cache DIR`` keeps the noise-free measurements in DIR
(parquet, keyed by a hash of truth, grid, levels and method; noise is added from the seed
afterwards), so later runs and subsets take them from there. Give a folder outside the
repository. ``--only`` keeps the cases whose name or tags contain any of the given texts;
``--cases`` selects by index in the listed order; ``--json FILE`` writes every row.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from discovery_cases import benchmark_cases, legacy_cases  # noqa: E402

from nlupdate.core.discovery import discover  # noqa: E402


def _label(effects) -> str:
    return " + ".join(f"{name}@{list(dofs)}" for name, dofs in effects) or "none"


def _indices(text: str, count: int) -> list[int]:
    chosen: list[int] = []
    for part in text.split(","):
        if "-" in part:
            low, high = part.split("-")
            chosen += range(int(low), int(high) + 1)
        elif part.strip():
            chosen.append(int(part))
    bad = [k for k in chosen if not 0 <= k < count]
    if bad:
        raise SystemExit(f"--cases: index {bad[0]} is outside 0–{count - 1}")
    return chosen


def select(args: argparse.Namespace) -> list:
    offsets = [int(o) for o in args.seed_offsets.split(",")]
    make = legacy_cases if args.legacy else benchmark_cases
    cases = [case for offset in offsets for case in make(offset)]
    if args.cases:
        cases = [cases[k] for k in _indices(args.cases, len(cases))]
    if args.only:
        wanted = [w.strip() for w in args.only.split(",") if w.strip()]
        cases = [c for c in cases if any(w in c.name or w in c.tags for w in wanted)]
    return cases


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cache", help="folder for the time-integration measurements (outside the repository)")
    parser.add_argument("--only", help="comma-separated texts: keep cases whose name or tags contain one")
    parser.add_argument("--cases", help="indices of the cases to run, e.g. 0-9,12 (see --list)")
    parser.add_argument("--seed-offsets", default="0", help="comma-separated seed offsets (default 0)")
    parser.add_argument("--legacy", action="store_true", help="the first benchmark's 22 SDOF / 2-DOF cases")
    parser.add_argument("--list", action="store_true", help="list the selected cases and stop")
    parser.add_argument("--measure-only", action="store_true", help="fill the cache, do not discover")
    parser.add_argument("--json", help="write every row to this JSON file")
    args = parser.parse_args()
    cases = select(args)
    if args.list:
        for k, case in enumerate(cases):
            print(f"{k:3d} {case.name:58s} {', '.join(case.tags)}")
        return
    if args.cache and Path(args.cache).resolve().is_relative_to(Path(__file__).resolve().parents[1]):
        raise SystemExit(f"--cache {args.cache}: give a folder outside the repository")
    print(f"machine: {platform.node()}, {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}, {platform.system()} {platform.release()}; load "
          f"{', '.join(f'{v:.2f}' for v in os.getloadavg())}")
    print(f"{'case':62s} {'found':44s} {'hit':4s} {'gap before':>10s} {'gap after':>10s} {'ratio':>8s} "
          f"{'res/noise':>9s} {'measure s':>9s} {'discover s':>10s}", flush=True)
    started = time.perf_counter()
    rows = []
    for case in cases:
        t0 = time.perf_counter()
        measured = case.measure(args.cache)
        t1 = time.perf_counter()
        if args.measure_only:
            print(f"{case.name:62s} measured in {t1 - t0:.1f} s", flush=True)
            continue
        result = discover(case.model, measured)
        t2 = time.perf_counter()
        found = tuple((e.name, e.dofs) for e in result.effects)
        hit = sorted((n, tuple(sorted(d))) for n, d in found) == sorted((n, tuple(sorted(d))) for n, d in case.expected)
        ratio = result.gap_after.gap / result.gap_before.gap
        rows.append({
            "case": case.name, "tags": list(case.tags), "expected": _label(case.expected), "found": _label(found),
            "hit": bool(hit), "control": not case.expected, "noise": case.noise, "method": case.method,
            "gap_before": result.gap_before.gap, "gap_after": result.gap_after.gap, "gap_ratio": ratio,
            "misfit_to_noise": result.misfit_ratio, "fit": result.fit, "stop_reason": result.stop_reason,
            "effects": [e.to_dict() for e in result.effects], "measure_s": t1 - t0, "discover_s": t2 - t1,
        })
        print(f"{case.name:62s} {_label(found):44s} {'yes' if hit else 'NO':4s} {result.gap_before.gap:10.3g} "
              f"{result.gap_after.gap:10.3g} {ratio:8.3g} {result.misfit_ratio:9.3g} {t1 - t0:9.1f} {t2 - t1:10.1f}",
              flush=True)
    if args.measure_only or not rows:
        print(f"wall time {time.perf_counter() - started:.0f} s")
        return
    effect_rows = [r for r in rows if not r["control"]]
    controls = [r for r in rows if r["control"]]
    hits = sum(r["hit"] for r in rows)
    ratios = sorted(r["gap_ratio"] for r in effect_rows)
    print(f"\nhits: {hits}/{len(rows)} ({100 * hits / len(rows):.1f} %); effect cases "
          f"{sum(r['hit'] for r in effect_rows)}/{len(effect_rows)}, controls without a false effect "
          f"{sum(r['hit'] for r in controls)}/{len(controls)}")
    if ratios:
        print(f"gap after / gap before on effect cases: worst {ratios[-1]:.3g}, median {ratios[len(ratios) // 2]:.3g}")
    poor = [r["case"] for r in rows if r["fit"] == "poor"]
    print(f"fit reported poor (residual > 5× noise): {len(poor)} {poor if poor else ''}")
    for r in rows:
        if not r["hit"]:
            print(f"MISS {r['case']}: expected {r['expected']}, found {r['found']} ({r['stop_reason']})")
    print(f"wall time {time.perf_counter() - started:.0f} s")
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1, default=float) + "\n")


if __name__ == "__main__":
    main()
