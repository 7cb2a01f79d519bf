"""The held-out-level table of a real data set, as docs/validation.md shows it: one row per
held-out level and model — resonance error (Hz), damping-ratio and peak errors (%), each
with its 95 % band, whether the measured value lies in the band, the log-amplitude
baseline's errors — for ``--hold-out each`` and ``--hold-out top``, then the test's
repeatability. Used by benchmarks/validation_brb.py and validation_transmitter_beam.py.
"""
from __future__ import annotations

import os
import time
import warnings
from typing import TYPE_CHECKING, Sequence

if TYPE_CHECKING:
    from nlupdate.core.identification.data import FRFLevels


def print_validation_tables(data: "FRFLevels", models: Sequence[str], unit: str, hz_digits: int = 3) -> None:
    """Runs :func:`validate` on ``data`` for ``each`` and ``top`` with
    ``models`` and prints both tables (levels in ``unit``; resonance errors with ``hz_digits``
    decimals, their bands with one fewer), the repeatability, the load and the times."""
    from nlupdate.core.validation.held_out import validate

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
            print(f"| {r.level:g} | {r.label} | {error_cells(r, hz_digits)} |")
        for choice in result.choices.values():
            if choice.warning:
                print(f"\nwarning: {choice.warning}")
        if hold_out == "each":
            print("\n" + repeatability_line(result.repeatability, hz_digits))
    print(f"\n{time.perf_counter() - started:.1f} s wall, {time.process_time() - cpu:.1f} s CPU")


def repeatability_line(repeat, hz_digits: int = 3) -> str:
    """The test's repeatability as the tables state it beside every error."""
    trend = "a line" if repeat.degree == 1 else "a parabola"
    return (f"test repeatability (1σ about {trend} in log amplitude, {repeat.levels} curves, {repeat.dof} degrees of "
            f"freedom): resonance {repeat.resonance_hz:.{hz_digits}f} Hz, damping ratio "
            f"{100 * repeat.damping_ratio:.{hz_digits}f} % (points) or {100 * repeat.damping_relative:.0f} % of "
            f"itself, peak {100 * repeat.peak_relative:.0f} % of itself")


def error_cells(r, hz_digits: int = 3) -> str:
    """The table cells of one prediction (a held-out level or a response-controlled run):
    resonance, damping and peak errors with their 95 % bands, in band or not, the baseline's."""
    c, b = r.compared, r.baseline

    def rel(q):
        return f"{100 * q.relative_error:+.1f} [{100 * (q.low / q.measured - 1):+.0f}, {100 * (q.high / q.measured - 1):+.0f}]"

    res = c["resonance_hz"]
    inside = ", ".join("–" if c[n].inside is None else ("yes" if c[n].inside else "no") for n in c)
    own = [n for n in c if c[n].predicted_inside is False and c[n].predicted == c[n].predicted]
    if own:  # never expected: a predicted value outside its own band is said, not printed as if fine
        inside += " (prediction outside its own band: " + ", ".join(own) + ")"
    resonance_hz = (f"{res.error:+.{hz_digits}f} [{res.low - res.measured:+.{hz_digits - 1}f}, "
                    f"{res.high - res.measured:+.{hz_digits - 1}f}]")
    return (f"{resonance_hz} | {rel(c['damping_ratio'])} | {rel(c['peak_abs'])} | {inside} | "
            f"{b['resonance_hz'].error:+.{hz_digits}f}, {100 * b['damping_ratio'].relative_error:+.1f}, "
            f"{100 * b['peak_abs'].relative_error:+.1f}")
