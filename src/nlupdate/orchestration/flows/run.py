"""Running a study under Prefect from Python or the CLI: :func:`run_study_flow`.

It sets up everything a run needs and nothing the user must start by hand: at most one
Prefect server for the run (or the user's, via ``PREFECT_API_URL``), the task runner
(threads, a local Dask cluster, or an existing one), the cache store, and the progress
printer; then it runs :func:`~nlupdate.orchestration.flows.study.study_flow` and returns the archive.
"""
from __future__ import annotations

import contextlib
import os
from pathlib import Path
from typing import Iterator

from nlupdate.orchestration.flows.environment import prepare_environment
from nlupdate.orchestration.flows.status_lines import Progress, using
from nlupdate.orchestration.flows.runners import Execution, check_scheduler_address, task_runner
from nlupdate.orchestration.flows.server import prefect_api
from nlupdate.study.spec import Study

CACHE_ENV = "NLUPDATE_CACHE_DIR"
DEFAULT_CACHE = ".nlupdate-cache"


def cache_directory(given: str | os.PathLike | None = None) -> Path:
    """The result store: ``given``, else ``$NLUPDATE_CACHE_DIR``, else ``./.nlupdate-cache``."""
    return Path(given or os.environ.get(CACHE_ENV) or DEFAULT_CACHE).resolve()


@contextlib.contextmanager
def _flow_session(execution: Execution, cache_dir, progress: Progress) -> Iterator[tuple[str, object, str, Path]]:
    """What every run needs around its flow: a reachable Dask scheduler when one is named
    (checked first), the environment, the result store, one
    Prefect API, the task runner and no flow-run heartbeats (each costs a second at the
    end of every (sub)flow run). Yields (where the run is recorded — the API's URL when the
    user gave it, a note for the server kept for the runs, whose URL changes when it restarts —,
    task runner, its description, store)."""
    if execution.dask_address is not None:  # before the server, which takes seconds to start
        check_scheduler_address(execution.dask_address)
    prepare_environment()
    store = cache_directory(cache_dir)
    store.mkdir(parents=True, exist_ok=True)
    from prefect.settings import PREFECT_FLOWS_HEARTBEAT_FREQUENCY, temporary_settings

    users_api = bool(os.environ.get("PREFECT_API_URL"))
    with prefect_api(progress.say) as url, task_runner(execution) as (runner, description), \
            temporary_settings(updates={PREFECT_FLOWS_HEARTBEAT_FREQUENCY: None}), using(progress):
        recorded = f"API {url}" if users_api else ("the Prefect server kept for the runs (the run stays in "
                                                   "Prefect's local database)")
        yield recorded, runner, description, store


def _started_now(what: str):
    """A flow run name: ``what`` and the time the run starts (called by Prefect then)."""
    import datetime as dt

    from nlupdate.orchestration.tasks.names import study_run_name

    return lambda: study_run_name(what, dt.datetime.now(dt.timezone.utc))


def run_study_flow(
    study: Study,
    results_root: str | os.PathLike = "results",
    execution: Execution = Execution(),
    cache_dir: str | os.PathLike | None = None,
    refresh: bool = False,
    progress: Progress | None = None,
    annotations: dict[str, str] | None = None,
) -> Path:
    """Run ``study`` as Prefect flows and write its archive under ``results_root``
    (``annotations``: extra entries of the manifest's ``run`` record). Its input files are
    read once, as the run starts (:func:`nlupdate.study.spec.inputs_read_once`)."""
    from nlupdate.orchestration.flows.cache import Cache
    from nlupdate.orchestration.flows.handles import study_handle
    from nlupdate.orchestration.flows.study import study_flow

    from nlupdate.study.spec import inputs_read_once

    progress = progress or Progress()
    execution = execution.for_study(study)
    with inputs_read_once(study) as study, _flow_session(execution, cache_dir, progress) as (recorded, runner,
                                                                                           description, store):
        progress.say(f"study [bold]{study.name}[/bold]: tasks on {description}; cache {store}"
                     + (" (refreshing)" if refresh else ""))
        orchestration = f"Prefect flow `study` on {description}, {recorded}"
        archive = study_flow.with_options(task_runner=runner, flow_run_name=_started_now(study.name))(
            study_handle(study), Cache(str(store), refresh), str(Path(results_root).resolve()), orchestration, annotations)
    return Path(archive)


def run_discovery_flow(
    model_file: str | os.PathLike,
    measured_file: str | os.PathLike,
    options,
    results_root: str | os.PathLike = "results",
    execution: Execution = Execution(),
    cache_dir: str | os.PathLike | None = None,
    refresh: bool = False,
    progress: Progress | None = None,
) -> Path:
    """Run :func:`~nlupdate.orchestration.flows.discovery.discovery_flow` on a model file and measured
    data (FRF or modal table); returns the archive."""
    from nlupdate.orchestration.flows.discovery import discovery_flow
    from nlupdate.orchestration.flows.cache import Cache
    from nlupdate.orchestration.flows.handles import handle
    from nlupdate.core.measurement.frf_files import read_frf_table
    from nlupdate.core.measurement.modal_table import is_modal_table_file, read_modal_table
    from nlupdate.core.model.model_file import load_system

    system = load_system(model_file)
    table = read_modal_table(measured_file) if is_modal_table_file(measured_file) else read_frf_table(measured_file)
    inputs = handle((Path(model_file).resolve(), system, Path(measured_file).resolve(), table, options),
                    f"model {model_file}, measured {measured_file}")
    progress = progress or Progress()
    with _flow_session(execution, cache_dir, progress) as (recorded, runner, description, store):
        progress.say(f"discovery: tasks on {description}; cache {store}")
        archive = discovery_flow.with_options(task_runner=runner,
                                              flow_run_name=_started_now(f"discovery {Path(model_file).stem}"))(
            inputs, Cache(str(store), refresh), str(Path(results_root).resolve()),
            f"Prefect flow `discovery` on {description}, {recorded}")
    return Path(archive)
