"""``nlupdate archive``: the runs under a results folder — list, show, compare, rerun.

RUN is a run folder, a run id (the folder name: <UTC time>-<hash>, then -1, -2, …
when one second saw the same inputs again) or an unambiguous prefix of one, under
--root. list shows the runs oldest first, an original before its -1, -2, ….

  list      one line per run: study, id, date, status (complete / failed /
            incomplete / writing) and the number of the run's warnings, best
            candidate, its updated parameters, the lowest FRAC of its prediction over
            the force levels
  show      the report's summary and where the archive's files are
  compare   what differs between two runs: what each run is (study, chain steps, FE
            model, parameters, targets, measured curves and force levels), inputs
            (study fields, data hashes, seeds, package and solver versions) and
            results (identified and updated parameters with uncertainty, candidates
            and ranking, FRAC per force level), and a plot of both runs' predictions
            against the measurements at the force levels both runs have. Runs of
            different studies: the fields only one run has are counted, listed
            with --all
  rerun     run the study again from the archive alone (its study file and the copies
            of its input files), recomputing every task in a temporary cache unless
            --cache-dir is given; then say field by field whether the results match
            the archived ones within --rtol, and which inputs differ (versions, data)
            if they do not. Exit code 0 when reproduced, 1 when not.
"""
from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

from nlupdate.app.cli import CliError, CliRuntimeError, add_command, non_negative_float
from nlupdate.app.cli.run import add_execution_options, run_with_prefect

ROOT_HELP = "results folder holding the archives (default ./results)"


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = add_command(subparsers, "archive", __doc__)
    commands = parser.add_subparsers(dest="archive_command", required=True, metavar="ACTION")

    listing = commands.add_parser("list", help="one line per run under --root")
    listing.add_argument("--study", metavar="NAME", help="only the runs of this study")
    listing.add_argument("--root", default="results", metavar="DIR", help=ROOT_HELP)
    listing.add_argument("--json", action="store_true", help="print JSON instead of lines")
    listing.set_defaults(run=list_runs)

    show = commands.add_parser("show", help="the report's summary and where the files are")
    show.add_argument("run_spec", metavar="RUN", help="run folder, run id or its unambiguous prefix")
    show.add_argument("--root", default="results", metavar="DIR", help=ROOT_HELP)
    show.set_defaults(run=show_run)

    compare = commands.add_parser("compare", help="what differs between two runs (inputs and results)")
    compare.add_argument("run_a", metavar="RUN_A", help="run folder, run id or its unambiguous prefix")
    compare.add_argument("run_b", metavar="RUN_B", help="run folder, run id or its unambiguous prefix")
    compare.add_argument("--root", default="results", metavar="DIR", help=ROOT_HELP)
    compare.add_argument("--rtol", type=non_negative_float, default=None,
                         help="relative tolerance for result numbers (default 1e-6)")
    compare.add_argument("--all", action="store_true", help="also list the fields that are the same")
    compare.add_argument("--json", action="store_true", help="print every field as JSON")
    compare.add_argument("--plot", metavar="FILE.png",
                         help="where to draw both runs' predictions (default <root>/comparisons/<A>-vs-<B>.png)")
    compare.set_defaults(run=compare_two)

    rerun = commands.add_parser("rerun", help="run an archived study again from its archive and check the results")
    rerun.add_argument("run_spec", metavar="RUN", help="run folder, run id or its unambiguous prefix")
    rerun.add_argument("--root", default="results", metavar="DIR", help=ROOT_HELP)
    rerun.add_argument("--out", metavar="DIR", help="where the rerun's archive goes (default: the original's results folder)")
    rerun.add_argument("--rtol", type=non_negative_float, default=None,
                       help="relative tolerance for result numbers (default 1e-6)")
    rerun.add_argument("--json", action="store_true", help="print the verdict as JSON")
    add_execution_options(rerun)
    rerun.set_defaults(run=rerun_one)


def _resolve(spec: str, root: str):
    from nlupdate.reporting.catalogue import ArchiveError, resolve_run

    try:
        return resolve_run(spec, root)
    except ArchiveError as error:
        raise CliError(str(error)) from None


def _list_entry(run) -> dict:
    from nlupdate.reporting.catalogue import ArchiveError, key_results

    entry = {"study": run.study, "run_id": run.run_id, "folder": str(run.folder), "status": run.status,
             "started_utc": run.started or None}
    if run.reason:
        entry["reason"] = run.reason
    if run.manifest:
        try:
            entry.update(key_results(run))
        except ArchiveError as error:  # one damaged table: this run is damaged, the others are listed
            return {**entry, "status": "damaged", "reason": str(error)}
        entry["rerun_of"] = run.manifest.get("run", {}).get("rerun_of")
        entry["error"] = run.manifest.get("error")
        entry["failed_runs"] = [failure["run"] for failure in run.manifest.get("failures", [])]
        entry["warnings"] = len(run.manifest.get("warnings", []))
    return entry


def _list_line(entry: dict) -> str:
    from nlupdate.reporting.compare import Estimate, format_value

    date = (entry["started_utc"] or "")[:16].replace("T", " ")
    warned = entry.get("warnings")
    status = entry["status"] + (f", {warned} warning{'s' if warned > 1 else ''} (archive show)" if warned else "")
    parts = [f"{entry['study']:<14}", f"{entry['run_id']:<28}", f"{date or '–':<16}", f"{status:<10}"]
    if entry.get("reason"):
        parts.append(f"({entry['reason']})")
    if entry.get("best"):
        updated = ", ".join(f"{name} {format_value(Estimate(*value))}" for name, value in entry["updated"].items())
        parts.append(f"best {entry['best']!r}: {updated}")
    if entry.get("min_frac") is not None:
        parts.append(f"min FRAC {entry['min_frac']:.3f}")
    if entry.get("error"):
        parts.append(f"error: {entry['error'] if len(entry['error']) <= 160 else entry['error'][:159] + '…'}")
    if entry.get("failed_runs"):
        parts.append(f"{len(entry['failed_runs'])} updating run(s) failed")
    if entry.get("rerun_of"):
        parts.append(f"(rerun of {entry['rerun_of']})")
    return "  ".join(parts).rstrip()


def list_runs(args: argparse.Namespace) -> int:
    from nlupdate.reporting.catalogue import ArchiveError, find_runs

    try:
        runs = find_runs(args.root, args.study)
    except ArchiveError as error:
        raise CliError(str(error)) from None
    entries = [_list_entry(run) for run in runs]
    if args.json:
        from nlupdate.reporting.jsonfile import json_safe

        print(json.dumps(json_safe(entries), indent=2))
    elif not entries:
        print(f"no runs under {args.root}" + (f" for study {args.study!r}" if args.study else ""))
    else:
        for entry in entries:
            print(_list_line(entry))
    return 0


def show_run(args: argparse.Namespace) -> int:
    from nlupdate.reporting.report import summary_section

    run = _resolve(args.run_spec, args.root)
    report = run.folder / "report.md"
    print(f"{run.study} / {run.run_id} — {run.status}, started {run.started or '?'}")
    rerun_of = run.manifest.get("run", {}).get("rerun_of")
    if rerun_of:
        print(f"rerun of {rerun_of}")
    print()
    if report.is_file():
        print(summary_section(report.read_text()))
        print()
    print(f"archive:  {run.folder}\nreport:   {report}\nmanifest: {run.folder / 'manifest.json'}")
    for label, folder in (("tables", "tables"), ("plots", "plots"), ("inputs", "inputs")):
        names = sorted(p.relative_to(run.folder).as_posix() for p in (run.folder / folder).rglob("*") if p.is_file()) \
            if (run.folder / folder).is_dir() else []
        if names:
            print(f"{label + ':':<9} " + ", ".join(names))
    return 0


def _print_rows(title: str, rows, show_same: bool, show_one_sided: bool = True) -> None:
    """The rows that differ (all with ``show_same``); fields only one run has are counted,
    not listed, unless ``show_one_sided``."""
    from nlupdate.reporting.compare import ONE_SIDED, change_table

    one_sided = [r for r in rows if r.status in ONE_SIDED]
    both = [r for r in rows if r.status not in ONE_SIDED]
    shown = [r for r in (rows if show_one_sided else both) if show_same or r.status != "same"]
    if show_one_sided:
        print(f"{title}: {sum(r.status != 'same' for r in rows)} of {len(rows)} fields differ")
    else:
        only_a = sum(r.status == "only A" for r in one_sided)
        print(f"{title}: {sum(r.status != 'same' for r in both)} of the {len(both)} fields both runs have differ"
              + (f"; {only_a} only in A, {len(one_sided) - only_a} only in B (--all lists them)" if one_sided else ""))
    if shown:
        print(change_table(shown).to_string(index=False))
    print()


def _print_overview(rows, show_same: bool) -> None:
    """What each run is: a field both runs share on one line, one that differs as A and B lines."""
    from nlupdate.reporting.compare import format_value

    print(f"overview: {sum(r.status != 'same' for r in rows)} of {len(rows)} fields differ")
    for row in rows:
        if row.status == "same" and show_same:
            print(f"  {row.field}: {format_value(row.a, 200)} (both)")
        elif row.status != "same":
            print(f"  {row.field}:\n      A: {format_value(row.a, 200)}\n      B: {format_value(row.b, 200)}")
    print()


def compare_two(args: argparse.Namespace) -> int:
    from nlupdate.reporting.compare import (DEFAULT_RTOL, compare_inputs, compare_overview, compare_results,
                                            plot_comparison, same_study)

    a, b = _resolve(args.run_a, args.root), _resolve(args.run_b, args.root)
    rtol = DEFAULT_RTOL if args.rtol is None else args.rtol
    overview, inputs, results = compare_overview(a, b), compare_inputs(a, b), compare_results(a, b, rtol)
    plot = Path(args.plot or Path(args.root) / "comparisons" / f"{a.run_id}-vs-{b.run_id}.png")
    plot.parent.mkdir(parents=True, exist_ok=True)
    drawn, plot_note = plot_comparison(a, b, plot)
    one_study = same_study(a, b)
    if args.json:
        from nlupdate.reporting.jsonfile import json_safe

        print(json.dumps(json_safe({"a": str(a.folder), "b": str(b.folder), "same_study": one_study, "rtol": rtol,
                                    "overview": [r.as_dict() for r in overview],
                                    "inputs": [r.as_dict() for r in inputs], "results": [r.as_dict() for r in results],
                                    "plot": str(drawn) if drawn else None, "plot_note": plot_note}), indent=2))
        return 0
    print(f"A: {a.study} / {a.run_id} ({a.folder})\nB: {b.study} / {b.run_id} ({b.folder})\n")
    if not one_study:
        print(f"different studies ({a.study}, {b.study}): what each run is, then the fields both runs have\n")
    _print_overview(overview, show_same=not one_study or args.all)
    _print_rows("inputs", inputs, args.all, show_one_sided=one_study or args.all)
    _print_rows(f"results (numbers equal within rtol {rtol:g}; Δ/σ: difference in the runs' standard deviations)",
                results, args.all, show_one_sided=one_study or args.all)
    print(f"plot: {drawn} — {plot_note}" if drawn else f"plot: none — {plot_note}")
    return 0


def rerun_one(args: argparse.Namespace) -> int:
    from nlupdate.reporting.catalogue import ArchiveError, archived_study, open_run
    from nlupdate.reporting.compare import DEFAULT_RTOL, changed, compare_inputs, compare_results
    from nlupdate.app.cli.run import check_solver

    original = _resolve(args.run_spec, args.root)
    rtol = DEFAULT_RTOL if args.rtol is None else args.rtol
    try:
        study, notes = archived_study(original)
    except ArchiveError as error:
        raise CliError(str(error)) from None
    check_solver(study)
    root = args.out or str(original.folder.parent.parent)
    annotations = {"rerun_of": f"{original.study}/{original.run_id}"}
    with tempfile.TemporaryDirectory(prefix="nlupdate-rerun-cache-") as fresh:
        if args.cache_dir is None:
            args.cache_dir = fresh
        archive = run_with_prefect(study, root, args, annotations)
    rerun = open_run(archive)
    inputs, results = compare_inputs(original, rerun), compare_results(original, rerun, rtol)
    differing_inputs = [r for r in changed(inputs) if r.section != "study" or r.field != "study.name"]
    differing_results = changed(results)
    verdict = {
        "original": str(original.folder), "rerun": str(rerun.folder), "rtol": rtol,
        "reproduced": not differing_results, "fields_compared": len(results),
        "result_changes": [r.as_dict() for r in differing_results],
        "input_changes": [r.as_dict() for r in differing_inputs], "notes": notes,
    }
    _save_verdict(verdict, rerun.folder)
    if args.json:
        from nlupdate.reporting.jsonfile import json_safe

        print(json.dumps(json_safe(verdict), indent=2))
    else:
        if not args.quiet:
            print()
        _print_verdict(verdict, original, rerun, differing_inputs, differing_results)
    return 0 if verdict["reproduced"] else 1


def _save_verdict(verdict: dict, folder: Path) -> None:
    from nlupdate.files import atomic_file
    from nlupdate.reporting.jsonfile import write_json

    try:
        with atomic_file(folder / "rerun-check.json") as temporary:
            write_json(verdict, temporary)
    except OSError as error:
        raise CliRuntimeError(f"{folder}: cannot write rerun-check.json ({error})") from None


def _print_verdict(verdict: dict, original, rerun, differing_inputs, differing_results) -> None:
    from nlupdate.reporting.compare import change_table

    print(f"rerun of {original.study}/{original.run_id} → {rerun.folder}")
    for note in verdict["notes"]:
        print(f"note: {note}")
    if differing_inputs:
        print(f"inputs that differ from the original run ({len(differing_inputs)}):")
        print(change_table(differing_inputs).to_string(index=False))
    else:
        print("inputs: the same study, data, seeds, package and solver versions as the original run")
    n = verdict["fields_compared"]
    if verdict["reproduced"]:
        print(f"REPRODUCED: all {n} result fields match the archived run within rtol {verdict['rtol']:g}")
    else:
        print(f"NOT REPRODUCED: {len(differing_results)} of {n} result fields differ (rtol {verdict['rtol']:g}):")
        print(change_table(differing_results).to_string(index=False))
        if not differing_inputs and not verdict["notes"]:
            print("no input differs: the difference comes from the computation itself (e.g. threads, hardware)")
    print(f"verdict: {rerun.folder / 'rerun-check.json'}")
