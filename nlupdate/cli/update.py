"""``nlupdate update``: run a linear model-updating study (TOML) and write its results."""
from __future__ import annotations

import argparse
from pathlib import Path

from nlupdate.cli import CliError
from nlupdate.updating.study import load_study, run_study


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "update",
        help="update a linear FE model against natural frequencies (study file)",
        description=(
            "Run the inverse-eigensensitivity formulas and optimisation candidates of STUDY and write "
            "history/candidate/comparison tables (parquet), summary.json and plots (PNG) to DIR."
        ),
    )
    parser.add_argument("study", metavar="STUDY.toml", help="study file (see nlupdate.updating.study)")
    parser.add_argument("--out", required=True, metavar="DIR", help="output directory (created atomically)")
    parser.add_argument("--overwrite", action="store_true", help="replace DIR if it exists")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    out = Path(args.out)
    if out.exists() and not args.overwrite:
        raise CliError(f"output directory {out} exists; pass --overwrite to replace it")
    study = load_study(args.study)
    outcome = run_study(study, out, overwrite=args.overwrite)
    targets = outcome.targets
    print(f"study {study.name!r}: targets " + ", ".join(
        f"{label} {f:.4g} Hz" for label, f in zip(targets.labels, targets.frequencies_hz)))
    for result in outcome.results:
        values = ", ".join(f"{k} = {v:.6g}" for k, v in result.parameters.items())
        frequencies = ", ".join(f"{f:.4g}" for f in result.frequencies_hz())
        state = "converged" if result.converged else "NOT converged"
        steps = "iterations" if result.method == "eigensensitivity" else "objective calls"
        print(f"  {result.name}: {state} ({result.reason}) after {result.iterations} {steps}, "
              f"{result.counts['new']} new / {result.counts['cached']} cached evaluations, {result.wall_time_s:.2f} s; "
              f"{values}; f = {frequencies} Hz")
    best = outcome.ranking.iloc[0]
    print(f"best for the user weights: {best['candidate']} (weighted |error| {best['weighted_abs_error_pct']:.3f} %)")
    print(f"wrote {outcome.out_dir}")
    return 0
