"""``nlupdate simulate``: nonlinear FRFs of a TOML model at several force levels.

Writes the measured-FRF table (receptance, m/N; all response coordinates, one forced
coordinate) of MODEL at each force level, as a stepped-sine test would measure it, with
optional noise: H + σ(n₁ + i n₂)/√2, σ = NOISE·|H|. The file appears only when complete.
"""
from __future__ import annotations

import argparse
import sys
import time

from nlupdate.cli import add_command, non_negative_float, non_negative_int
from nlupdate.cli.output import add_overwrite_option, checked_output
from nlupdate.cli.progress import terminal_progress
from nlupdate.measurement.frf_table import table_suffix, write_frf_table
from nlupdate.model.model_file import load_system
from nlupdate.response.simulate import METHODS, parse_force_levels, parse_frequency_grid, simulate_frf_table


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = add_command(subparsers, "simulate", __doc__,
                         help="simulate measured FRFs (all dofs) of a model at several force levels")
    parser.add_argument("model", metavar="MODEL.toml", help="model file ([model] + [[nonlinear]] tables)")
    parser.add_argument("--input-dof", required=True, help="forced coordinate (index or name)")
    parser.add_argument("--freqs", required=True, help="frequency grid in Hz: START:STOP:COUNT or F1,F2,…")
    parser.add_argument("--forces", required=True, help="force amplitudes in N, comma-separated")
    parser.add_argument("--noise", type=non_negative_float, default=0.0,
                        help="noise std as a fraction of |H| (e.g. 0.05; default 0)")
    parser.add_argument("--seed", type=non_negative_int, default=None, help="noise seed ≥ 0 (reproducible)")
    parser.add_argument("--method", choices=METHODS, default="continuation", help="solver (default continuation)")
    parser.add_argument("--sweep", choices=("up", "down"), default="up", help="stepped-sine direction (default up)")
    parser.add_argument("--out", required=True, help="output table (.parquet, .csv or .uff)")
    add_overwrite_option(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    out = checked_output(args.out, args.overwrite, folder=False)
    table_suffix(out)
    system = load_system(args.model)
    input_dof = int(args.input_dof) if args.input_dof.isdigit() else args.input_dof
    frequencies, forces = parse_frequency_grid(args.freqs), parse_force_levels(args.forces)
    args.interrupt_note = f"nothing was written to {out}"
    started = time.perf_counter()
    with terminal_progress() as progress:
        table, report = simulate_frf_table(system, input_dof, frequencies, forces, method=args.method,
                                           sweep=args.sweep, noise=args.noise, seed=args.seed, progress=progress)
    path = write_frf_table(table, out)
    for level, dropped in report.dropped_points.items():
        if dropped:
            print(f"warning: {dropped} points at {level:g} N did not converge and were left out", file=sys.stderr)
    jumps = {level: j for level, j in report.jumps_hz.items() if j}
    if jumps:
        print("jumps (Hz): " + "; ".join(f"{lvl:g} N: {', '.join(f'{f:.2f}' for f in j)}" for lvl, j in jumps.items()))
    print(f"wrote {len(table)} rows to {path} in {time.perf_counter() - started:.2f} s")
    return 0
