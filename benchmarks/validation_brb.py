"""Held-out levels of the public Brake–Reuss beam (tests/data/brb), every model beside the baseline.

    python benchmarks/validation_brb.py [--models lines,amplitude-polynomial,amplitude-iwan,auto]

Prints, for ``--hold-out each`` and ``--hold-out top`` (docs/methods.md §10), one row per
held-out level and model: the resonance error (Hz), damping-ratio and peak errors (%), each
with its 95 % band, whether the measured value lies in the band, and the log-amplitude
baseline's errors; then the test's repeatability (:mod:`benchmarks.validation_table`).
docs/validation.md holds its output.
"""
from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

if __package__ in (None, ""):  # run as a script: make the repository root importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.validation_table import print_validation_tables  # noqa: E402

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
    parser.add_argument("--models", default="lines,amplitude-polynomial,amplitude-iwan,auto")
    args = parser.parse_args(argv)
    models = [m.strip() for m in args.models.split(",") if m.strip()]
    data = brb_levels()
    print(f"Brake–Reuss beam, force-controlled runs {', '.join(f'{v:g}' for v in data.levels)} N")
    print_validation_tables(data, models, "N")
    return 0


if __name__ == "__main__":
    sys.exit(main())
