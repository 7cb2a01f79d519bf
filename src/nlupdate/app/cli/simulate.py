"""``nlupdate simulate``: nonlinear FRFs of a TOML model at several force levels.

Writes the measured-FRF table (receptance, m/N; all response coordinates, one forced
coordinate) of MODEL at each force level, as a stepped-sine test would measure it, with
optional noise: H + σ(n₁ + i n₂)/√2, σ = NOISE·|H|. The file appears only when complete.

With --method hb (multi-harmonic balance; the table holds the first harmonic) it says per
force level the harmonics used, the largest share of the highest harmonics in the response,
the bifurcations found (kind, Hz) and the jumps of the sweep; a truncation or aliasing
warning names its force level.
"""
from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

from nlupdate.app.cli import CliError, add_command, non_negative_float, non_negative_int
from nlupdate.app.cli.harmonics import add_harmonic_options, harmonic_settings
from nlupdate.app.cli.output import add_overwrite_option, checked_output
from nlupdate.app.cli.progress_bar import terminal_progress
from nlupdate.core.measurement.frf_files import is_frf_table, table_suffix, write_frf_table
from nlupdate.core.model.model_file import load_system
from nlupdate.core.response.harmonic_balance import HarmonicSettings, HarmonicTruncationWarning
from nlupdate.core.response.method import MAX_FREQUENCIES
from nlupdate.core.response.simulate import (
    METHODS,
    SimulationReport,
    simulate_frf_table,
)


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = add_command(subparsers, "simulate", __doc__)
    parser.add_argument("model", metavar="MODEL.toml", help="model file ([model] + [[nonlinear]] tables)")
    parser.add_argument("--input-dof", required=True, help="forced coordinate (index or name)")
    parser.add_argument("--freqs", required=True, help="frequency grid in Hz: START:STOP:COUNT or F1,F2,…")
    parser.add_argument("--forces", required=True, help="force amplitudes in N, comma-separated")
    parser.add_argument("--noise", type=non_negative_float, default=0.0,
                        help="noise std as a fraction of |H| (e.g. 0.05; default 0)")
    parser.add_argument("--seed", type=non_negative_int, default=None, help="noise seed ≥ 0 (reproducible)")
    parser.add_argument("--method", choices=METHODS, default="continuation",
                        help="solver (default continuation: describing function; hb: harmonic balance)")
    parser.add_argument("--sweep", choices=("up", "down"), default="up", help="stepped-sine direction (default up)")
    parser.add_argument("--out", required=True, help="output table (.parquet, .csv or .uff)")
    add_overwrite_option(parser)
    add_harmonic_options(parser)
    parser.set_defaults(run=run)


GRID_FORM = "START:STOP:COUNT in Hz (e.g. 600:850:501) or F1,F2,… with 0 < START < STOP"


def _numbers(items: list[str], text: str, option: str, form: str) -> list[float]:
    """``items`` as numbers > 0; a :class:`CliError` quoting the option's ``text`` otherwise."""
    try:
        values = [float(v) for v in items if v.strip()]
    except ValueError:
        raise CliError(f"{option} {text!r}: expected {form}") from None
    bad = [v for v in values if not np.isfinite(v) or v <= 0]
    if not values or bad:
        raise CliError(f"{option} {text!r}: expected {form}; {f'{bad[0]:g}' if bad else 'nothing'} is not a number > 0")
    return values


def frequency_grid(text: str) -> np.ndarray:
    """``--freqs``: ``START:STOP:COUNT`` (inclusive) or ``F1,F2,…`` in Hz, increasing, at
    most :data:`MAX_FREQUENCIES`; a :class:`CliError` naming the option otherwise."""
    if ":" in text:
        parts = text.split(":")
        if len(parts) != 3:
            raise CliError(f"--freqs {text!r}: expected {GRID_FORM}")
        start, stop = _numbers(parts[:2], text, "--freqs", GRID_FORM)
        try:
            count = int(parts[2])
        except ValueError:
            raise CliError(f"--freqs {text!r}: COUNT {parts[2]!r} is not an integer") from None
        if not 2 <= count <= MAX_FREQUENCIES or stop <= start:
            raise CliError(f"--freqs {text!r}: expected {GRID_FORM}, 2 ≤ COUNT ≤ {MAX_FREQUENCIES}")
        return np.linspace(start, stop, count)
    values = np.array(_numbers(text.split(","), text, "--freqs", GRID_FORM))
    if len(values) > MAX_FREQUENCIES or np.any(np.diff(values) <= 0):
        raise CliError(f"--freqs {text[:60]!r}: expected increasing frequencies, at most {MAX_FREQUENCIES}")
    return values


def force_levels(text: str) -> list[float]:
    """``--forces``: distinct force amplitudes in N, each > 0."""
    values = _numbers(text.split(","), text, "--forces",
                      "comma-separated force amplitudes in N, each > 0 (e.g. 0.01,100,150)")
    repeated = sorted({v for v in values if values.count(v) > 1})
    if repeated:
        raise CliError(f"--forces {text!r}: {repeated[0]:g} N is given more than once")
    return values


def run(args: argparse.Namespace) -> int:
    settings = harmonic_settings(args)
    frequencies, forces = frequency_grid(args.freqs), force_levels(args.forces)
    table_suffix(Path(args.out))
    system = load_system(args.model)
    input_dof = int(args.input_dof) if args.input_dof.isdigit() else args.input_dof
    out = checked_output(args.out, args.overwrite, folder=False, inputs=[args.model], replaceable_file=is_frf_table)
    args.interrupt_note = f"nothing was written to {out}"
    started = time.perf_counter()
    level_starts: dict[int, int] = {}  # force level index → warnings recorded before it started
    with terminal_progress() as progress, warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", HarmonicTruncationWarning)

        def tracking(task: str, done: int, total: int) -> None:
            if task.startswith("force levels"):
                level_starts.setdefault(done, len(caught))
            progress(task, done, total)

        table, report = simulate_frf_table(system, input_dof, frequencies, forces, method=args.method,
                                           sweep=args.sweep, noise=args.noise, seed=args.seed,
                                           harmonic_balance=settings or HarmonicSettings(), progress=tracking)
    _show_warnings(caught, level_starts, [float(f) for f in forces])
    path = write_frf_table(table, out)
    for level, dropped in report.dropped_points.items():
        if dropped:
            print(f"warning: {dropped} points at {level:g} N did not converge and were left out", file=sys.stderr)
    if settings is not None:
        for line in harmonic_balance_lines(report):
            print(line)
    else:
        jumps = {level: j for level, j in report.jumps_hz.items() if j}
        if jumps:
            print("jumps (Hz): " + "; ".join(f"{lvl:g} N: {_hz(j)}" for lvl, j in jumps.items()))
    print(f"wrote {len(table)} rows to {path} in {time.perf_counter() - started:.2f} s")
    return 0


def _hz(frequencies) -> str:
    return ", ".join(f"{f:.2f}" for f in frequencies)


def _show_warnings(caught, level_starts: dict[int, int], levels: list[float]) -> None:
    """Re-issue the recorded warnings, one line each; a harmonic balance warning names the
    force level it came from (the one whose simulation was running when it was raised)."""
    for i, warning in enumerate(caught):
        message = str(warning.message)
        if issubclass(warning.category, HarmonicTruncationWarning):
            started = [k for k, first in level_starts.items() if first <= i and k < len(levels)]
            if started:
                message = f"{levels[max(started)]:g} N: {message}"
        warnings.showwarning(message, warning.category, warning.filename, warning.lineno)


def harmonic_balance_lines(report: SimulationReport) -> list[str]:
    """One line per force level: harmonics, share of the highest ones, bifurcations, jumps."""
    lines = []
    for level, harmonics in report.harmonics.items():
        share = report.harmonic_share.get(level, 0.0)
        highest = ("one harmonic" if harmonics == 1
                   else f"highest harmonics ≤ {100 * share:.2g} % of the response")
        found = report.bifurcations.get(level, ())
        kinds = {}
        for kind, hz in found:
            kinds.setdefault(kind, []).append(hz)
        bifurcations = "; ".join(
            f"{kind} at {_hz(sorted(hz))} Hz" if len(hz) <= 6
            else f"{len(hz)} × {kind} between {min(hz):.2f} and {max(hz):.2f} Hz"
            for kind, hz in kinds.items()
        ) or "none"
        jumps = report.jumps_hz.get(level, ())
        lines.append(f"{level:g} N: H = {harmonics} ({highest}); bifurcations: {bifurcations}; "
                     f"jumps: {_hz(jumps) + ' Hz' if jumps else 'none'}")
    return lines
