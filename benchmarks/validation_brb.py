"""Held-out levels of the public Brake–Reuss beam (tests/data/brb), every model beside the baseline.

    python benchmarks/validation_brb.py [--models lines,lines-background,amplitude-polynomial,amplitude-iwan,auto]
                                        [--write-docs]

Prints, for ``--hold-out each`` and ``--hold-out top`` (docs/methods.md §10), one row per
held-out level and model: the resonance error (Hz), damping-ratio and peak errors (%), each
with its 95 % band, whether the measured value lies in the band, and the log-amplitude
baseline's errors, as ``nlupdate validate`` states them (:mod:`benchmarks.validation_table`);
then the test's repeatability; then
the eight response-controlled runs predicted from all four force-controlled levels, the same
way; then ``--response-controlled kept``: the runs kept beside the levels as backbone
evidence (lines models and auto); then the hammer impact's linear limit
(tests/data/brb/HammerImpact_1600Hz.mat, acc3, 60–100 Hz) kept beside the levels, without
and with the runs, and the runs predicted from the levels and the impact. ``--write-docs``
writes the output into its block of docs/validation.md (benchmarks/docs_block.py).
"""
from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

if __package__ in (None, ""):  # run as a script: make the repository root importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks import docs_block  # noqa: E402
from benchmarks.validation_table import print_notes, print_validation_tables, row_cells  # noqa: E402
from nlupdate.reporting.validation_text import repeatability_line  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
BRB = ROOT / "tests" / "data" / "brb" / "ForcedFrequencyResponses.mat"
IMPACT = ROOT / "tests" / "data" / "brb" / "HammerImpact_1600Hz.mat"
HEADER = ("| level (N) | model | resonance error (Hz) [95 % band] | damping error (%) [band] | peak error (%) [band] "
          "| in band (f, ζ, peak) | baseline: f (Hz), ζ (%), peak (%) |\n|---|---|---|---|---|---|---|")
RUN_HEADER = ("| run | held X (µm) | model | resonance error (Hz) [95 % band] | damping error (%) [band] | peak error "
              "(%) [band] | in band (f, ζ, peak) | baseline: f (Hz), ζ (%), peak (%) |\n|---|---|---|---|---|---|---|---|")


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
    docs_block.add_option(parser)
    args = parser.parse_args(argv)
    models = [m.strip() for m in args.models.split(",") if m.strip()]
    with docs_block.writing_docs(args.write_docs, "validation_brb.py", argv, ROOT / "docs" / "validation.md"):
        data = brb_levels()
        print(f"Brake–Reuss beam, force-controlled runs {', '.join(f'{v:g}' for v in data.levels)} N")
        print_validation_tables(data, models, "N")
        print_response_controlled(data, models)
        lines_models = [m for m in models if m in ("lines", "lines-background", "auto")]
        print_with_runs_kept(data, lines_models)
        print_with_impact(data, lines_models)
    return 0


def impact_limit():
    """The BRB hammer impact's linear limit at acc3 (60–100 Hz), as ``validate --impact`` fits it."""
    from nlupdate.core.identification.impact import fit_linear_limit, split_force
    from nlupdate.core.identification.ring_down import read_channels

    time_s, responses, force = split_force(read_channels(IMPACT, "impact record"), "acc3")
    return fit_linear_limit(time_s, responses, (60.0, 100.0), None, force, source=str(IMPACT.relative_to(ROOT)))


def print_with_impact(data, models) -> None:
    """``validate --impact``: the impact's linear limit kept beside the force-controlled levels
    (the lines models' polynomials at a = 0), without and with the runs kept; then the runs
    predicted from the levels and the impact."""
    import dataclasses
    import time

    from nlupdate.core.validation.held_out import Validation, repeatability, validate
    from nlupdate.core.validation.held_response import with_held_runs

    started, cpu = time.perf_counter(), time.process_time()
    limit = impact_limit()
    anchored = dataclasses.replace(data, linear_limit=limit)
    runs = _runs(data)
    print(f"\nthe impact's linear limit kept beside the levels (--impact {limit.source}): {limit.frequency_hz:.4f} ± "
          f"{limit.frequency_std_hz:.4f} Hz, damping ratio {100 * limit.damping_ratio:.4f} ± "
          f"{100 * limit.damping_std:.4f} %")
    for hold_out, kept_runs in (("each", ()), ("top", ()), ("each", runs)):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            result = validate(anchored, hold_out, models, runs=kept_runs)
        kept = f" --response-controlled kept ({len(kept_runs)} runs)" if kept_runs else " --response-controlled off"
        print(f"\n--hold-out {hold_out}{kept} --impact\n{HEADER}")
        for r in result.held_out:
            print(f"| {r.level:g} | {r.label} | {row_cells(r)} |")
        print_notes([(f"{r.level:g} N", r) for r in result.held_out])
        print("\n" + repeatability_line(result.repeatability, "levels and runs pooled" if kept_runs else "levels"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = with_held_runs(Validation((), repeatability(anchored)), anchored, runs, models)
    print(f"\nresponse-controlled runs predicted from the {data.levels.size} force-controlled levels and the impact\n"
          f"{RUN_HEADER}")
    for r in result.response_controlled:
        print(f"| {r.run.split('.')[-1]} | {1e6 * r.held_m:.1f} | {r.label} | {row_cells(r)} |")
    print_notes([(r.run.split(".")[-1], r) for r in result.response_controlled])
    print_extrapolations(result)
    print("\n" + repeatability_line(result.runs_repeatability, "levels and runs pooled: the runs' bands"))
    print(f"\n{time.perf_counter() - started:.1f} s wall, {time.process_time() - cpu:.1f} s CPU")


def print_extrapolations(result) -> None:
    """Each run predicted outside the amplitudes the kept data cover, once (the warning
    ``nlupdate validate`` prints: nlupdate.core.validation.held_response)."""
    for warning in dict.fromkeys(r.extrapolation for r in result.response_controlled if r.extrapolation):
        print(f"warning: {warning}")


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
        print(HEADER)
        for r in result.held_out:
            print(f"| {r.level:g} | {r.label} | {row_cells(r)} |")
        print_notes([(f"{r.level:g} N", r) for r in result.held_out])
    print("\n" + repeatability_line(result.repeatability, "levels and runs pooled"))
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
    print(RUN_HEADER)
    for r in result.response_controlled:
        print(f"| {r.run.split('.')[-1]} | {1e6 * r.held_m:.1f} | {r.label} | {row_cells(r)} |")
    print_notes([(r.run.split(".")[-1], r) for r in result.response_controlled])
    print_extrapolations(result)
    for note in result.response_controlled_notes:
        print(f"note: {note}")
    print("\n" + repeatability_line(result.runs_repeatability, "levels and runs pooled: the runs' bands"))
    print(f"\n{time.perf_counter() - started:.1f} s wall, {time.process_time() - cpu:.1f} s CPU")


if __name__ == "__main__":
    sys.exit(main())
