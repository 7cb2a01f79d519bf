"""``nlupdate schedule``: run a study on a schedule — each run writes its own archive.

  nlupdate schedule STUDY.toml --cron "0 2 * * *"     every day at 02:00 (UTC unless --timezone)
  nlupdate schedule STUDY.toml --interval 3600        every hour
  nlupdate schedule list [--json]                     the scheduled studies and their next run
  nlupdate schedule delete NAME                       remove one (its future runs go with it)

A schedule is a registration in the user's own nlupdate folder (the study's text and hash,
results root, cache store, threads, schedule) and a Prefect deployment of the flow
"scheduled study" named after the study (``--name`` to choose) that says only which
registration to run. The study and the schedule are checked before anything is registered.
Schedules live in a persistent Prefect server: start one with ``prefect server start`` and
set ``PREFECT_API_URL=http://127.0.0.1:4200/api`` (used without it when it answers there).
Runs happen only while ``nlupdate serve`` runs (or ``schedule … --serve``); each runs the
study as registered (register it again with --replace after editing it) and writes
``<out>/<study>/<UTC time>-<hash>/``. Keep the Prefect API on 127.0.0.1: whoever can reach
it can see the runs (a run can only name a registered study, never a file or program).
"""
from __future__ import annotations

import argparse
import contextlib
import json
import sys
from pathlib import Path
from types import ModuleType
from typing import Iterator

from nlupdate.app.cli import CliError, CliRuntimeError, add_command, positive_int

ACTIONS = ("list", "delete")
FORBIDDEN_IN_NAMES = "/%&<>"
USAGE = ("nlupdate schedule STUDY.toml (--cron EXPR | --interval SECONDS) [options]\n"
         "       nlupdate schedule list [--json]\n"
         "       nlupdate schedule delete NAME")


#: ``schedule list --help`` and ``schedule delete --help``: the action's own usage and text
#: (the positional ACTION is not a sub-parser, so argparse alone would print the whole help).
ACTION_HELP = {
    "list": ("nlupdate schedule list [--json]",
             "The scheduled studies: schedule, next run (UTC), study file and results folder.\n"
             "Needs the Prefect server the schedules live in (see 'nlupdate schedule --help').",
             [("--json", "print JSON instead of lines")]),
    "delete": ("nlupdate schedule delete NAME",
               "Remove the scheduled study NAME; its future runs go with it (archives of past\n"
               "runs stay). 'nlupdate schedule list' names the scheduled studies.",
               [("NAME", "the scheduled study to delete")]),
}


class _HelpAction(argparse.Action):
    """``-h``: the help of the action named before it (list, delete), else the whole help."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS, help=None):
        super().__init__(option_strings, dest=dest, default=default, nargs=0, help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        action = getattr(namespace, "target", None)
        if action in ACTION_HELP:
            usage, text, items = ACTION_HELP[action]
            width = max(len(name) for name, _ in items) + 4
            print(f"usage: {usage}\n\n{text}\n\n" + "\n".join(f"  {name:<{width}}{help}" for name, help in items))
        else:
            parser.print_help()
        parser.exit()


NOTE = "stopped serving; the schedules stay registered (nlupdate schedule list); a run in progress, if any, was stopped"


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = add_command(subparsers, "schedule", __doc__, add_help=False)
    parser.usage = USAGE
    parser.add_argument("-h", "--help", action=_HelpAction,
                        help="show this help (after list or delete: that action's help) and exit")
    parser.add_argument("target", metavar="STUDY.toml | list | delete", help="study file to schedule, or an action")
    parser.add_argument("name_to_delete", nargs="?", metavar="NAME", help="the scheduled study to delete (with delete)")
    parser.add_argument("--cron", metavar="EXPR", help='cron expression, e.g. "0 2 * * *" (minute hour day month weekday)')
    parser.add_argument("--interval", type=positive_int, metavar="SECONDS", help="run every SECONDS (at least 1)")
    parser.add_argument("--timezone", metavar="TZ", help="time zone of --cron, e.g. Europe/Paris (default UTC)")
    parser.add_argument("--name", help="deployment name (default: the study's name)")
    parser.add_argument("--replace", action="store_true", help="replace a scheduled study of the same name")
    parser.add_argument("--out", metavar="DIR", help="archive root of the runs (default ./results)")
    parser.add_argument("--workers", type=positive_int, metavar="N", help="threads per run (default: as `nlupdate run`'s)")
    parser.add_argument("--cache-dir", metavar="DIR",
                        help="task result store shared by the runs (default $NLUPDATE_CACHE_DIR or ./.nlupdate-cache)")
    parser.add_argument("--serve", action="store_true", help="then run the schedules here, as 'nlupdate serve' does")
    add_serve_options(parser)
    parser.add_argument("--json", action="store_true", help="with list: print JSON")
    parser.set_defaults(run=run)


def _schedule_options(args: argparse.Namespace) -> list[str]:
    given = {"--cron": args.cron, "--interval": args.interval, "--timezone": args.timezone, "--name": args.name,
             "--replace": args.replace, "--out": args.out, "--workers": args.workers, "--cache-dir": args.cache_dir,
             "--serve": args.serve, "--limit": args.limit != 1}
    return [option for option, value in given.items() if value not in (None, False)]


@contextlib.contextmanager
def connect() -> Iterator[ModuleType]:
    """Within the block: the schedule module, talking to the Prefect API that holds the
    schedules; its errors (no server, nothing to serve) are one line with exit code 1."""
    from nlupdate.orchestration.flows.environment import prepare_environment

    prepare_environment()
    from nlupdate.orchestration.flows import schedule

    try:
        with schedule.schedule_api(lambda message: print(message, file=sys.stderr)):
            yield schedule
    except schedule.ScheduleError as error:
        raise CliRuntimeError(str(error)) from None


def run(args: argparse.Namespace) -> int:
    if args.target in ACTIONS:
        extra = _schedule_options(args)
        if extra:
            raise CliError(f"schedule {args.target} takes {'--json' if args.target == 'list' else 'a NAME'} only, "
                           f"not {', '.join(extra)}")
        if args.target == "list":
            return list_schedules(args)
        return delete_schedule(args)
    if args.name_to_delete is not None:
        raise CliError(f"unexpected argument {args.name_to_delete!r} after the study file "
                       f"(to delete a schedule: nlupdate schedule delete NAME)")
    if args.json:
        raise CliError("--json goes with 'schedule list' only")
    return add_schedule(args)


def _check_schedule(args: argparse.Namespace):
    from nlupdate.orchestration.flows.environment import prepare_environment

    if (args.cron is None) == (args.interval is None):
        raise CliError("give exactly one of --cron EXPR and --interval SECONDS"
                       + (", not both" if args.cron is not None else ""))
    if args.timezone and args.cron is None:
        raise CliError("--timezone goes with --cron only (an interval does not depend on the time zone)")
    prepare_environment()
    from nlupdate.orchestration.flows.schedule import cron_schedule, interval_schedule

    return cron_schedule(args.cron, args.timezone) if args.cron is not None else interval_schedule(args.interval)


def _check_name(name: str, option: str) -> str:
    if not name.strip() or any(c in name for c in FORBIDDEN_IN_NAMES):
        raise CliError(f"{option} {name!r}: a schedule name must not be empty nor contain any of {FORBIDDEN_IN_NAMES}")
    return name


def add_schedule(args: argparse.Namespace) -> int:
    from nlupdate.app.cli.output import writable_folder
    from nlupdate.app.cli.run import check_solver
    from nlupdate.orchestration.flows import registrations
    from nlupdate.orchestration.flows.run import cache_directory
    from nlupdate.orchestration.flows.runners import default_workers
    from nlupdate.study import load_study

    when = _check_schedule(args)
    if args.limit != 1 and not args.serve:
        raise CliError("--limit goes with --serve only")
    study = load_study(args.target)
    check_solver(study)
    name = (_check_name(args.name, "--name") if args.name is not None
            else _check_name(study.name, f"{args.target}: [study] name"))
    out = Path(args.out or "results")
    writable_folder(out, "--out")
    writable_folder(cache_directory(args.cache_dir), "--cache-dir")
    with connect() as schedule:
        existing = {s.name: s for s in schedule.registered()}
        if name in existing and not args.replace:
            raise CliError(f"a scheduled study named {name!r} exists ({existing[name].schedule}, "
                           f"{existing[name].study_file}); pass --replace to replace it, or --name to choose another name")
        registration = registrations.new_registration(
            name, args.target, study.text, out, cache_directory(args.cache_dir), args.workers or default_workers(study),
            schedule.when_of(when))
        schedule.register(registration)
        print(f"{'replaced' if name in existing else 'registered'} scheduled study {name!r}: "
              f"{schedule.describe_schedule(when)}; study {registration.study_file} (sha256 "
              f"{registration.study_sha256[:12]}, kept as registered) → {registration.results_root} "
              f"({registration.workers} threads, cache {registration.cache_dir})")
        if not args.serve:
            print("its runs start while `nlupdate serve` runs")
            return 0
        return serve_with(schedule, args)


def list_schedules(args: argparse.Namespace) -> int:
    with connect() as schedule:
        listed = schedule.registered()
    if args.json:
        print(json.dumps([s.as_dict() for s in listed], indent=2))
        return 0
    if not listed:
        print('no scheduled studies; add one with nlupdate schedule STUDY.toml --cron "0 2 * * *" (or --interval SECONDS)')
    for s in listed:
        print(f"{s.name}: {s.schedule}{', paused' if s.paused else ''}; next run "
              f"{s.next_run_utc + ' UTC' if s.next_run_utc else '—'}; study {s.study_file} "
              f"(sha256 {s.study_sha256[:12]}) → {s.results_root}")
        if s.server_drift:
            print(f"  warning: {s.server_drift}; `nlupdate serve` restores the registered one", file=sys.stderr)
    return 0


def delete_schedule(args: argparse.Namespace) -> int:
    if args.name_to_delete is None:
        raise CliError("schedule delete needs the NAME of a scheduled study (see nlupdate schedule list)")
    with connect() as schedule:
        try:
            schedule.delete(args.name_to_delete)
        except schedule.UnknownSchedule:
            names = [s.name for s in schedule.registered()]
            raise CliError(f"no scheduled study named {args.name_to_delete!r} "
                           f"({'registered: ' + ', '.join(names) if names else 'none is registered'})") from None
    print(f"deleted scheduled study {args.name_to_delete!r} and its future runs")
    return 0


def add_serve_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--limit", type=positive_int, default=1, metavar="N",
                        help="scheduled runs at a time (default 1: a run that comes due during another waits for it)")


def serve_with(schedule: ModuleType, args: argparse.Namespace) -> int:
    """Serve with :mod:`nlupdate.orchestration.flows.schedule` already talking to the server."""
    from nlupdate.app.cli.run import prefect_errors

    args.interrupt_note = NOTE
    with prefect_errors(args):
        schedule.serve(limit=getattr(args, "limit", 1))
    return 0
