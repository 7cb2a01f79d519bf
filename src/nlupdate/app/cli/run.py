"""``nlupdate run``: run a study as Prefect flows — cached tasks, parallel sweeps, one archive.

Starts what the run needs (a Prefect server unless ``PREFECT_API_URL`` is set, threads or
a Dask cluster), prints each step as it finishes (computed or cached), and writes the
archive ``<out>/<study>/<UTC time>-<hash>/``.
"""
from __future__ import annotations

import argparse
import contextlib
import importlib.util
import json
import sys
from pathlib import Path
from typing import Iterator

from nlupdate.app.cli import CliError, CliRuntimeError, add_command, one_line, positive_int
from nlupdate.app.cli.output import writable_folder


def add_execution_options(parser: argparse.ArgumentParser) -> None:
    """Options shared by ``run`` and ``demo``: where results go and where tasks run."""
    parser.add_argument("--workers", type=positive_int,
                        help="threads (or local Dask worker processes with --dask) for the tasks (default: one per CPU "
                             "with --dask, for an external FE program or a discovery; one thread for an FE model "
                             "evaluated in this process, whose evaluations would only contend on more)")
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--dask", action="store_true", help="run the tasks on a local Dask cluster started for the run")
    where.add_argument("--dask-address", metavar="ADDR", help="run the tasks on an existing Dask scheduler, tcp://HOST:PORT")
    parser.add_argument("--no-cache", action="store_true",
                        help="recompute every task even when the cache has its result (and refresh the cache)")
    parser.add_argument("--cache-dir", metavar="DIR",
                        help="task result store (default $NLUPDATE_CACHE_DIR or ./.nlupdate-cache)")
    parser.add_argument("--quiet", action="store_true", help="print only where the archive is")


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = add_command(subparsers, "run", __doc__)
    parser.add_argument("study", metavar="STUDY.toml", help="study file (docs/study-files.md)")
    parser.add_argument("--out", default="results", metavar="DIR", help="archive root (default ./results)")
    add_execution_options(parser)
    parser.set_defaults(run=run)


#: the optional packages --dask and --dask-address need (``pip install 'nlupdate[dask]'``)
DASK_MODULES = ("distributed", "prefect_dask")


def dask_installed() -> bool:
    """Whether the optional Dask packages can be imported (looked up, not imported: seconds)."""
    try:
        return all(importlib.util.find_spec(name) is not None for name in DASK_MODULES)
    except (ImportError, ValueError):  # ValueError: a module set to None in sys.modules
        return False


def check_dask_address(args: argparse.Namespace) -> None:
    """--dask or --dask-address without Dask installed, or a ``--dask-address`` where nothing
    answers, is a mistake in the input: one line, exit 2, in milliseconds — before any
    folder is made or server started."""
    from nlupdate.orchestration.flows.runners import ExecutionError, check_scheduler_address

    if (getattr(args, "dask", False) or getattr(args, "dask_address", None)) and not dask_installed():
        option = "--dask" if getattr(args, "dask", False) else "--dask-address"
        raise CliError(f"{option} needs Dask, an optional part of nlupdate that is not installed: "
                       f"pip install 'nlupdate[dask]'")
    if getattr(args, "dask_address", None):
        try:
            check_scheduler_address(args.dask_address)
        except ExecutionError as error:
            raise CliError(f"--dask-address: {error}") from None


@contextlib.contextmanager
def prefect_errors(args: argparse.Namespace, start_server: bool = False) -> Iterator[None]:
    """Check a ``--dask-address`` before anything starts (exit 2 when nothing answers
    there), prepare the environment before Prefect is imported, turn set-up failures
    (server, Dask) into one-line errors, and stop the Prefect server this run started even
    when an interrupt must end the process before it has unwound
    (:mod:`nlupdate.app.cli.interrupts`). ``start_server``: start the run's server now (unless
    ``PREFECT_API_URL`` names one), so that it boots while this process imports Prefect and
    the flows."""
    check_dask_address(args)
    from nlupdate.orchestration.flows.environment import prepare_environment

    prepare_environment()
    from nlupdate.app.cli import interrupts
    from nlupdate.orchestration.flows.runners import ExecutionError
    from nlupdate.orchestration.flows.server import ServerError, start_server_early, stop_early_server, stop_started_servers

    stop = interrupts.on_deadline(stop_started_servers)
    try:
        if start_server:
            start_server_early()
        yield
    except (ExecutionError, ServerError) as error:
        raise CliRuntimeError(str(error)) from None
    finally:
        stop_early_server()  # one started early for a run that ended before using it
        interrupts.forget(stop)


def check_solver(study) -> None:
    """A study whose FE program is missing fails here, in one line, before any work."""
    from nlupdate.fe.adapters.registry import build_adapter

    if study.adapter is not None:
        build_adapter(study.adapter).check_available()


def exit_code_for_failures(failures: list[dict]) -> int:
    """1 with one line on stderr when updating runs failed (the archive names every one), else 0."""
    if not failures:
        return 0
    first = failures[0]
    print(f"nlupdate: error: {len(failures)} updating run(s) failed, first {first['run']!r}: {one_line(first['error'])}",
          file=sys.stderr)
    return 1


def run_with_prefect(study, results_root: str, args: argparse.Namespace, annotations: dict[str, str] | None = None) -> Path:
    """Run ``study`` under Prefect with the execution options of ``args``; one-line errors.
    ``annotations`` go into the manifest's ``run`` record. A study whose every result is in
    the cache is answered from it without Prefect (:mod:`nlupdate.orchestration.flows.from_cache`;
    not with ``--no-cache``)."""
    from nlupdate.orchestration.flows.run import cache_directory

    check_dask_address(args)
    writable_folder(Path(results_root), "--out" if hasattr(args, "out") else "--results")
    writable_folder(cache_directory(args.cache_dir), "--cache-dir")
    args.interrupt_note = f"no archive was written to {results_root}; finished tasks stay in the cache"
    if not args.no_cache:
        from nlupdate.orchestration.flows.from_cache import answer_from_cache
        from nlupdate.orchestration.flows.status_lines import Progress

        archive = answer_from_cache(study, results_root, cache_directory(args.cache_dir), Progress(quiet=args.quiet),
                                    annotations)
        if archive is not None:
            return archive
    with prefect_errors(args, start_server=True):
        from nlupdate.orchestration.flows.status_lines import Progress
        from nlupdate.orchestration.flows.run import run_study_flow
        from nlupdate.orchestration.flows.runners import Execution

        return run_study_flow(study, results_root, Execution(args.workers, args.dask, args.dask_address), args.cache_dir,
                              args.no_cache, Progress(quiet=args.quiet), annotations)


def print_summary(archive: Path) -> None:
    """The report's summary and where the archive is."""
    from nlupdate.reporting.report import summary_section

    print(summary_section((archive / "report.md").read_text()))
    print(f"archive: {archive}\nreport:  {archive / 'report.md'}")


def may_answer_from_cache(args: argparse.Namespace) -> bool:
    """Whether the cache folder of ``args`` has records a run could be answered from (then
    the run's server is not started before the cache is looked at)."""
    from nlupdate.orchestration.flows.run import cache_directory
    from nlupdate.orchestration.tasks.signing import RECORDS_FOLDER

    return not args.no_cache and (cache_directory(args.cache_dir) / RECORDS_FOLDER).is_dir()


def run(args: argparse.Namespace) -> int:
    from nlupdate.study import load_study

    study = load_study(args.study)
    check_solver(study)
    archive = run_with_prefect(study, args.out, args)
    if not args.quiet:
        print_summary(archive)
    else:
        print(archive)
    return exit_code_for_failures(json.loads((archive / "manifest.json").read_text())["failures"])
