"""``nlupdate demo``: run the whole chain on embedded defaults."""
from __future__ import annotations

import argparse
from pathlib import Path

from nlupdate.demo import run_demo


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("demo", help="run the whole chain on the embedded example; archive in results/")
    parser.add_argument("--results", default="results", help="archive root (default ./results)")
    parser.add_argument("--seed", type=int, default=1, help="noise seed (default 1)")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    run_demo(Path(args.results), seed=args.seed)
    return 0
