"""``nlupdate update``: run a study in this process, in order, without Prefect.

The same steps as ``nlupdate run``, one after another, no server, no cache; the archive
(tables, plots, report, manifest) goes to ``--out``.
"""
from __future__ import annotations

import argparse
import datetime as dt
import time

import numpy as np

from nlupdate.app.cli import add_command
from nlupdate.app.cli.output import add_overwrite_option, checked_output
from nlupdate.app.cli.run import check_solver, exit_code_for_failures
from nlupdate.reporting.archive import ARCHIVE_KIND, write_archive
from nlupdate.reporting.report import none_converged_line, study_warning_lines
from nlupdate.study import inputs_read_once, load_study, run_study


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = add_command(subparsers, "update", __doc__)
    parser.add_argument("study", metavar="STUDY.toml", help="study file (docs/study-files.md)")
    parser.add_argument("--out", required=True, metavar="DIR", help="output directory (appears when complete)")
    add_overwrite_option(parser)
    parser.add_argument("--quiet", action="store_true", help="print only the results, not each step")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    study = load_study(args.study)
    out = checked_output(args.out, args.overwrite, folder=True, kind=ARCHIVE_KIND,
                         inputs=[args.study, *study.input_files.values()])
    check_solver(study)
    args.interrupt_note = f"nothing was written to {out}"
    started = dt.datetime.now(dt.timezone.utc)
    clock = time.perf_counter()
    with inputs_read_once(study) as study:  # what was read is what is hashed and archived
        result = run_study(study, (lambda message: None) if args.quiet else (lambda message: print(f"  {message}")))
        run_info = {"started_utc": started.isoformat(), "finished_utc": dt.datetime.now(dt.timezone.utc).isoformat(),
                    "wall_time_s": time.perf_counter() - clock,
                    "orchestration": "sequential, in one process (nlupdate update)"}
        folder = write_archive(result, out, run_info, on_exists="replace" if args.overwrite else "error")
    headline = none_converged_line(result.runs)
    if headline is not None:
        print("".join(headline))
    for warning in study_warning_lines(result):  # what not to trust, before the numbers it qualifies
        print(f"warning: {warning}")
    if result.targets is not None:
        targets = result.targets.targets
        print(f"study {study.name!r}: targets " + ", ".join(
            f"{label} {f:.4g} Hz" for label, f in zip(targets.labels, targets.frequencies_hz)))
    for r in result.runs:
        values = ", ".join(f"{k} = {v:.6g}" for k, v in r.parameters.items())
        state = "converged" if r.converged else "NOT converged"
        steps = "iterations" if r.method == "eigensensitivity" else "objective calls"
        print(f"  {r.name}: {state} ({r.reason}) after {r.iterations} {steps}, {r.counts['new']} new / "
              f"{r.counts['cached']} cached FE runs; {values}")
    for failure in result.failures:
        print(f"  {failure.name}: FAILED: {failure.error}")
    if result.ranking is not None:
        best = result.ranking.iloc[0]
        converged = best.get("converged")
        state = ", NOT converged" if isinstance(converged, (bool, np.bool_)) and not converged else ""
        print(f"best for the user weights: {best['candidate']} (weighted |error| {best['weighted_abs_error_pct']:.3f} %"
              f"{state})")
    print(f"wrote {folder} (report.md)")
    return exit_code_for_failures([{"run": f.name, "error": f.error} for f in result.failures])
