"""The held-out-level table of a real data set, as docs/validation.md shows it: one row per
held-out level and model — resonance error (Hz), damping-ratio and peak errors (%), each
with its 95 % band, whether the measured value lies in the band, the log-amplitude
baseline's errors — for ``--hold-out each`` and ``--hold-out top``, then the test's
repeatability. The cells, notes and the repeatability line are those ``nlupdate validate``
prints (:mod:`nlupdate.reporting.validation_text`), here as markdown rows. Used by
benchmarks/validation_brb.py and validation_transmitter_beam.py.
"""
from __future__ import annotations

import os
import time
import warnings
from typing import TYPE_CHECKING, Sequence

if TYPE_CHECKING:
    from nlupdate.core.identification.data import FRFLevels


def print_validation_tables(data: "FRFLevels", models: Sequence[str], unit: str) -> None:
    """Runs :func:`validate` on ``data`` for ``each`` and ``top`` with ``models`` and prints
    both tables (levels in ``unit``) with their notes, the repeatability, the load and the times."""
    from nlupdate.core.validation.held_out import validate
    from nlupdate.reporting.validation_text import repeatability_line

    print(f"load {os.getloadavg()[0]:.1f} (1 min) on {os.cpu_count()} cores; "
          f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}")
    started, cpu = time.perf_counter(), time.process_time()
    for hold_out in ("each", "top"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            result = validate(data, hold_out, models)
        print(f"\n--hold-out {hold_out}")
        print(f"| level ({unit}) | model | resonance error (Hz) [95 % band] | damping error (%) [band] | peak error "
              "(%) [band] | in band (f, ζ, peak) | baseline: f (Hz), ζ (%), peak (%) |")
        print("|---|---|---|---|---|---|---|")
        for r in result.held_out:
            print(f"| {r.level:g} | {r.label} | {row_cells(r)} |")
        print_notes([(f"{r.level:g} {unit}", r) for r in result.held_out])
        for choice in result.choices.values():
            if choice.warning:
                print(f"\nwarning: {choice.warning}")
        if hold_out == "each":
            print("\n" + repeatability_line(result.repeatability, "held-out levels"))
    print(f"\n{time.perf_counter() - started:.1f} s wall, {time.process_time() - cpu:.1f} s CPU")


def row_cells(r) -> str:
    """The markdown cells of one prediction (a held-out level or a response-controlled run):
    its errors with their 95 % bands, in band or not, the baseline's errors — the cells
    ``nlupdate validate`` prints."""
    from nlupdate.reporting.validation_text import error_cells, in_band_cell

    return " | ".join([*error_cells(r.compared, True), in_band_cell(r.compared),
                       ", ".join(error_cells(r.baseline, False))])


def print_notes(rows: Sequence[tuple[str, object]]) -> None:
    """How many of the table's values lie in their band and how many of those in a band that
    tests nothing (:func:`~nlupdate.core.validation.verdict.in_band`), then what a
    table cannot show of each (name, prediction) — no predicted value, a prediction outside
    its own band, a half-power band of few lines, the model's note — as ``nlupdate validate``
    notes it."""
    from nlupdate.core.validation.verdict import comparison_notes, in_band

    banded, inside, idle = in_band([r for _, r in rows])
    print(f"\nin band: {inside} of {banded} values, {idle} of them in uninformative bands (they test nothing), "
          f"{inside - idle} in informative ones")
    lines = [f"note at {name} ({r.label}): {note}" for name, r in rows for note in comparison_notes(r)]
    if lines:
        print("\n" + "\n".join(lines))
