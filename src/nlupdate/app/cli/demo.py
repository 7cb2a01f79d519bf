"""``nlupdate demo``: ``nlupdate run`` on the embedded T-beam study (``src/nlupdate/data/demo.toml``).

The built-in T-beam with a hidden truth (E = 195 GPa, h2 = 1.45 mm, cubic spring and
Jenkins friction at the tip), a simulated stepped-sine test at 0.01 N and 0.5…50 N with
5 % noise, PRD identification with Monte-Carlo uncertainty, updating with all four
difference formulas on two parameter sets plus optimisation candidates, and the
prediction at every force level. ``--seed`` changes the noise (and Monte-Carlo) seed.
"""
from __future__ import annotations

import argparse
import json
import re
from importlib import resources
from pathlib import Path

from nlupdate.app.cli import add_command, non_negative_int
from nlupdate.app.cli.run import (add_execution_options, exit_code_for_failures, may_answer_from_cache, prefect_errors,
                                  print_summary, run_with_prefect)

DEMO_STUDY = "data/demo.toml"


def demo_study_text(seed: int = 1) -> str:
    """The embedded demo study with ``seed`` as its noise and Monte-Carlo seed."""
    text = resources.files("nlupdate").joinpath(DEMO_STUDY).read_text()
    return re.sub(r"(?m)^seed = \d+", f"seed = {seed}", text)


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = add_command(subparsers, "demo", __doc__)
    parser.add_argument("--results", default="results", metavar="DIR", help="archive root (default ./results)")
    parser.add_argument("--seed", type=non_negative_int, default=1, help="noise and Monte-Carlo seed, ≥ 0 (default 1)")
    add_execution_options(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    # the server boots while the study is read, unless the cache may answer the run without it
    with prefect_errors(args, start_server=not may_answer_from_cache(args)):
        from nlupdate.study import study_from_text

        study = study_from_text(demo_study_text(args.seed), Path("demo.toml"))
        archive = run_with_prefect(study, args.results, args)
    if not args.quiet:
        print_summary(archive)
    else:
        print(archive)
    return exit_code_for_failures(json.loads((archive / "manifest.json").read_text())["failures"])
