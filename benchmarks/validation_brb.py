"""Held-out levels of the public Brake–Reuss beam (tests/data/brb), every model beside the baseline.

    python benchmarks/validation_brb.py [--models lines,lines-background,amplitude-polynomial,amplitude-iwan,auto]

Prints, for ``--hold-out each`` and ``--hold-out top`` (docs/methods.md §10), one row per
held-out level and model: the resonance error (Hz), damping-ratio and peak errors (%), each
with its 95 % band, whether the measured value lies in the band, and the log-amplitude
baseline's errors; then the test's repeatability (:mod:`benchmarks.validation_table`); then
the eight response-controlled runs predicted from all four force-controlled levels, the same
way. docs/validation.md holds its output.
"""
from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

if __package__ in (None, ""):  # run as a script: make the repository root importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.validation_table import error_cells, print_validation_tables  # noqa: E402

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
    return 0


def print_response_controlled(data, models) -> None:
    """The response-controlled runs of the file, each model fitted on every force-controlled level."""
    import time

    from nlupdate.core.measurement.units import ReadOptions
    from nlupdate.core.validation.held_out import Validation, repeatability
    from nlupdate.core.validation.held_response import held_runs_of, with_held_runs

    started, cpu = time.perf_counter(), time.process_time()
    runs, _ = held_runs_of([BRB], ReadOptions(coordinates={str(BRB): ("acc3:-y", "acc3:y")}), data)
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
    print(f"\n{time.perf_counter() - started:.1f} s wall, {time.process_time() - cpu:.1f} s CPU")


if __name__ == "__main__":
    sys.exit(main())
