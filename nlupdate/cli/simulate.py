"""``nlupdate simulate``: nonlinear FRFs of a TOML model at several force levels."""
from __future__ import annotations

import argparse
import sys
import time

from nlupdate.measurement.frf_table import write_frf_table
from nlupdate.model.model_file import load_system
from nlupdate.response.simulate import METHODS, parse_force_levels, parse_frequency_grid, simulate_frf_table


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "simulate",
        help="simulate measured FRFs (all dofs) of a model at several force levels",
        description="Write the measured-FRF table (receptance, m/N) of MODEL at each force level.",
    )
    parser.add_argument("model", metavar="MODEL.toml", help="model file ([model] + [[nonlinear]] tables)")
    parser.add_argument("--input-dof", required=True, help="forced coordinate (index or name)")
    parser.add_argument("--freqs", required=True, help="frequency grid in Hz: START:STOP:COUNT or F1,F2,…")
    parser.add_argument("--forces", required=True, help="force amplitudes in N, comma-separated")
    parser.add_argument("--noise", type=float, default=0.0, help="noise std as a fraction of |H| (e.g. 0.05)")
    parser.add_argument("--seed", type=int, default=None, help="noise seed (reproducible)")
    parser.add_argument("--method", choices=METHODS, default="continuation", help="solver (default continuation)")
    parser.add_argument("--sweep", choices=("up", "down"), default="up", help="stepped-sine direction (default up)")
    parser.add_argument("--out", required=True, help="output table (.parquet, .csv or .uff)")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    system = load_system(args.model)
    input_dof = int(args.input_dof) if args.input_dof.isdigit() else args.input_dof
    started = time.perf_counter()
    table, report = simulate_frf_table(
        system,
        input_dof,
        parse_frequency_grid(args.freqs),
        parse_force_levels(args.forces),
        method=args.method,
        sweep=args.sweep,
        noise=args.noise,
        seed=args.seed,
        progress=lambda message: print(message, file=sys.stderr),
    )
    path = write_frf_table(table, args.out)
    for level, dropped in report.dropped_points.items():
        if dropped:
            print(f"warning: {dropped} points at {level:g} N did not converge and were left out", file=sys.stderr)
    jumps = {level: j for level, j in report.jumps_hz.items() if j}
    if jumps:
        print("jumps (Hz): " + "; ".join(f"{lvl:g} N: {', '.join(f'{f:.2f}' for f in j)}" for lvl, j in jumps.items()))
    print(f"wrote {len(table)} rows to {path} in {time.perf_counter() - started:.2f} s")
    return 0
