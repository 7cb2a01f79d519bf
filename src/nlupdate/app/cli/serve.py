"""``nlupdate serve``: run the scheduled studies when they come due, until Ctrl-C.

Reads the studies registered with ``nlupdate schedule`` and runs
each scheduled run in its own process; every run writes its own archive and prints one
line when it starts and one when it ends (its steps go to the run's log in the Prefect UI).
Needs the persistent Prefect server the schedules live in (``prefect server start``, with
``PREFECT_API_URL=http://127.0.0.1:4200/api``): its scheduler creates the runs, this
command runs them. Serving changes nothing that was registered, and Ctrl-C leaves the
schedules active; restart it after scheduling another study.
"""
from __future__ import annotations

import argparse

from nlupdate.app.cli import add_command
from nlupdate.app.cli.schedule import add_serve_options, connect, serve_with


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = add_command(subparsers, "serve", __doc__)
    add_serve_options(parser)
    parser.set_defaults(run=serve_schedules)


def serve_schedules(args: argparse.Namespace) -> int:
    """Serve every registered scheduled study; Ctrl-C ends it (exit 130, one line)."""
    with connect() as schedule:
        return serve_with(schedule, args)
