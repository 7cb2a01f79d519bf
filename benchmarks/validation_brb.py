"""Held-out levels of the public Brake–Reuss beam (tests/data/brb), every model beside the baseline.

    python benchmarks/validation_brb.py [--models lines,lines-background,amplitude-polynomial,amplitude-iwan,auto]

Prints, for ``--hold-out each`` and ``--hold-out top`` (docs/methods.md §10), one row per
held-out level and model: the resonance error (Hz), damping-ratio and peak errors (%), each
with its 95 % band, whether the measured value lies in the band, and the log-amplitude
baseline's errors; then the test's repeatability (:mod:`benchmarks.validation_table`); then
the eight response-controlled runs predicted from all four force-controlled levels, the same
way; then ``--response-controlled kept``: the runs kept beside the levels as backbone
evidence (lines models and auto). docs/validation.md holds its output.
"""
from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

if __package__ in (None, ""):  # run as a script: make the repository root importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.validation_table import error_cells, print_validation_tables, repeatability_line  # noqa: E402

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
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", default="lines,lines-background,amplitude-polynomial,amplitude-iwan,auto")
    args = parser.parse_args(argv)
    models = [m.strip() for m in args.models.split(",") if m.strip()]
    data = brb_levels()
    print(f"Brake–Reuss beam, force-controlled runs {', '.join(f'{v:g}' for v in data.levels)} N")
    print_validation_tables(data, models, "N")
    print_response_controlled(data, models)
    print_with_runs_kept(data, [m for m in models if m in ("lines", "lines-background", "auto")])
    return 0


def _runs(data):
    from nlupdate.core.measurement.units import ReadOptions
    from nlupdate.core.validation.held_response import held_runs_of

    return held_runs_of([BRB], ReadOptions(coordinates={str(BRB): ("acc3:-y", "acc3:y")}), data)[0]


def print_with_runs_kept(data, models) -> None:
    """``validate --response-controlled kept``: the eight response-controlled runs kept beside
    the force-controlled levels as backbone evidence, each force-controlled level held out."""
    import time

    from nlupdate.core.validation.held_out import validate

    started, cpu = time.perf_counter(), time.process_time()
    runs = _runs(data)
    for hold_out in ("each", "top"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            result = validate(data, hold_out, models, runs=runs)
        print(f"\n--hold-out {hold_out} --response-controlled kept ({len(runs)} runs, held "
              f"{1e6 * runs[0].held_m:.1f}–{1e6 * runs[-1].held_m:.1f} µm, kept beside the levels)")
        print("| level (N) | model | resonance error (Hz) [95 % band] | damping error (%) [band] | peak error (%) [band] "
              "| in band (f, ζ, peak) | baseline: f (Hz), ζ (%), peak (%) |")
        print("|---|---|---|---|---|---|---|")
        for r in result.held_out:
            print(f"| {r.level:g} | {r.label} | {error_cells(r)} |")
    print("\n" + repeatability_line(result.repeatability) + " (levels and runs pooled)")
    print(f"\n{time.perf_counter() - started:.1f} s wall, {time.process_time() - cpu:.1f} s CPU")


def print_response_controlled(data, models) -> None:
    """The response-controlled runs of the file, each model fitted on every force-controlled level."""
    import time

    from nlupdate.core.validation.held_out import Validation, repeatability
    from nlupdate.core.validation.held_response import with_held_runs

    started, cpu = time.perf_counter(), time.process_time()
    runs = _runs(data)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = with_held_runs(Validation((), repeatability(data)), data, runs, models)
    print(f"\nresponse-controlled runs predicted from the {data.levels.size} force-controlled levels")
    print("| run | held X (µm) | model | resonance error (Hz) [95 % band] | damping error (%) [band] | peak error "
          "(%) [band] | in band (f, ζ, peak) | baseline: f (Hz), ζ (%), peak (%) |")
    print("|---|---|---|---|---|---|---|---|")
    for r in result.response_controlled:
        print(f"| {r.run.split('.')[-1]} | {1e6 * r.held_m:.1f} | {r.label} | {error_cells(r)} |")
    for note in result.response_controlled_notes:
        print(f"note: {note}")
    print("\n" + repeatability_line(result.runs_repeatability) + " (levels and runs pooled: the runs' bands)")
    print(f"\n{time.perf_counter() - started:.1f} s wall, {time.process_time() - cpu:.1f} s CPU")


if __name__ == "__main__":
    sys.exit(main())
