"""Held-out levels of the public Brake–Reuss beam (tests/data/brb), every model beside the baseline.

    python benchmarks/validation_brb.py [--models lines,amplitude-polynomial,amplitude-iwan,auto]

Prints, for ``--hold-out each`` and ``--hold-out top`` (docs/methods.md §10), one row per
held-out level and model: the resonance error (Hz), damping-ratio and peak errors (%), each
with its 95 % band, whether the measured value lies in the band, and the log-amplitude
baseline's errors; then the test's repeatability. docs/validation.md holds its output.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
BRB = ROOT / "tests" / "data" / "brb" / "ForcedFrequencyResponses.mat"


def brb_levels():
    from nlupdate.core.identification.data import FRFLevels
    from nlupdate.core.measurement.frf_files import read_frf_table
    from nlupdate.core.measurement.units import ReadOptions

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        table = read_frf_table(BRB, options=ReadOptions(coordinates={str(BRB): ("acc3:-y", "acc3:y")}))
    return FRFLevels.from_table(table, "acc3:y", "acc3:y")


def main(argv: list[str] | None = None) -> int:
    from nlupdate.core.validation.held_out import validate

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", default="lines,amplitude-polynomial,amplitude-iwan,auto")
    args = parser.parse_args(argv)
    models = [m.strip() for m in args.models.split(",") if m.strip()]
    data = brb_levels()
    started, cpu = time.perf_counter(), time.process_time()
    print(f"Brake–Reuss beam, force-controlled runs {', '.join(f'{v:g}' for v in data.levels)} N; load "
          f"{os.getloadavg()[0]:.1f} (1 min) on {os.cpu_count()} cores; {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}")
    for hold_out in ("each", "top"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            result = validate(data, hold_out, models)
        print(f"\n--hold-out {hold_out}")
        print("| level (N) | model | resonance error (Hz) [95 % band] | damping error (%) [band] | peak error (%) "
              "[band] | in band (f, ζ, peak) | baseline: f (Hz), ζ (%), peak (%) |")
        print("|---|---|---|---|---|---|---|")
        for r in result.held_out:
            c, b = r.compared, r.baseline

            def rel(q):
                return (f"{100 * q.relative_error:+.1f} [{100 * (q.low / q.measured - 1):+.0f}, "
                        f"{100 * (q.high / q.measured - 1):+.0f}]")

            res = c["resonance_hz"]
            inside = ", ".join("–" if c[n].inside is None else ("yes" if c[n].inside else "no") for n in c)
            print(f"| {r.level:g} | {r.label} | {res.error:+.3f} [{res.low - res.measured:+.2f}, "
                  f"{res.high - res.measured:+.2f}] | {rel(c['damping_ratio'])} | {rel(c['peak_abs'])} | {inside} | "
                  f"{b['resonance_hz'].error:+.3f}, {100 * b['damping_ratio'].relative_error:+.1f}, "
                  f"{100 * b['peak_abs'].relative_error:+.1f} |")
        if hold_out == "each":
            repeat = result.repeatability
            print(f"\ntest repeatability (1σ about a line in log amplitude, {repeat.levels} levels): resonance "
                  f"{repeat.resonance_hz:.3f} Hz, damping ratio {100 * repeat.damping_ratio:.3f} % (points)")
    print(f"\n{time.perf_counter() - started:.1f} s wall, {time.process_time() - cpu:.1f} s CPU")
    return 0


if __name__ == "__main__":
    sys.exit(main())
