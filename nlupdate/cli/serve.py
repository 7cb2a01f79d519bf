"""``nlupdate serve``: run the scheduled studies when they come due, until Ctrl-C.

Reads the studies registered with ``nlupdate schedule`` from the Prefect server and runs
each scheduled run in its own process; every run writes its own archive and prints one
line when it starts and one when it ends (its steps go to the run's log in the Prefect UI).
Needs the persistent Prefect server the schedules live in (``prefect server start``, with
``PREFECT_API_URL=http://127.0.0.1:4200/api``): its scheduler creates the runs, this
command runs them. Serving changes nothing that was registered, and Ctrl-C leaves the
schedules active; restart it after scheduling another study.
"""
from __future__ import annotations

import argparse
from types import ModuleType

from nlupdate.cli import add_command, positive_int

NOTE = "stopped serving; the schedules stay registered (nlupdate schedule list); a run in progress, if any, was stopped"


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = add_command(subparsers, "serve", __doc__, help="run the scheduled studies as they come due")
    add_serve_options(parser)
    parser.set_defaults(run=serve_schedules)


def add_serve_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--limit", type=positive_int, default=1, metavar="N",
                        help="scheduled runs at a time (default 1: a run that comes due during another waits for it)")


def serve_schedules(args: argparse.Namespace) -> int:
    """Serve every registered scheduled study; Ctrl-C ends it (exit 130, one line)."""
    from nlupdate.cli.schedule import connect

    with connect() as schedule:
        return serve_with(schedule, args)


def serve_with(schedule: ModuleType, args: argparse.Namespace) -> int:
    """Serve with :mod:`nlupdate.flows.schedule` already talking to the server."""
    from nlupdate.cli.run import prefect_errors

    args.interrupt_note = NOTE
    with prefect_errors(args):
        schedule.serve(limit=getattr(args, "limit", 1))
    return 0
