"""Discovery as a Prefect flow: the candidate fits of every iteration run as cached tasks
on the flow's task runner (threads or Dask), and the run leaves an archive like a study's.

``<results>/discovery-<model file stem>/<UTC time>-<hash>/`` holds the discovery output
(:func:`nlupdate.core.discovery.outputs.write_discovery`), the inputs as run (``model.toml``,
``measured.parquet``), ``manifest.json`` and ``report.md``.
"""
from __future__ import annotations

import datetime as dt
import shutil
import time
from pathlib import Path

from prefect import flow
from prefect.context import FlowRunContext

from nlupdate.core.discovery import discover
from nlupdate.core.discovery.outputs import write_discovery
from nlupdate.orchestration.flows.liveness import claim_flow_run
from nlupdate.orchestration.flows.status_lines import current_progress
from nlupdate.orchestration.flows.cache import Cache
from nlupdate.orchestration.flows.handles import Handle
from nlupdate.reporting.archive import run_folder
from nlupdate.files import atomic_directory
from nlupdate.reporting.discovery_report import discovery_markdown
from nlupdate.reporting.jsonfile import write_json
from nlupdate.fingerprints import file_hash, fingerprint, table_hash
from nlupdate.reporting.manifest import environment
from nlupdate.orchestration.tasks import keys
from nlupdate.orchestration.tasks import cached as tasks
from nlupdate.orchestration.tasks.names import candidate_fit_name


@flow(name="discovery")
def discovery_flow(inputs: Handle, cache: Cache, results_root: str, orchestration: str) -> str:
    """Discover what the model lacks against the measurements; returns the archive path.

    ``inputs.value`` is ``(model_file, system, measured_file, table, options)``."""
    claim_flow_run()
    model_file, system, measured_file, table, options = inputs.value
    started = dt.datetime.now(dt.timezone.utc)
    clock = time.perf_counter()
    progress = current_progress()
    rounds = iter(range(1, 1000))

    def map_candidates(function, jobs):
        jobs = list(jobs)
        round_number = next(rounds)
        round_started = time.perf_counter()
        futures = [cache.task(tasks.candidate_fit, run_name=candidate_fit_name(round_number, effect.name, context.dofs))
                   .submit(keys.candidate_key((context, effect)), (context, effect)) for context, effect in jobs]
        results = [future.result() for future in futures]
        states = [future.state.name for future in futures]
        for state in states:
            progress.record("candidate fit", state)
        computed = sum(state == "Completed" for state in states)
        progress.say(f"[bold]candidates, round {round_number}[/bold]: {len(jobs)} fits ({computed} computed, "
                     f"{len(jobs) - computed} cached) in {time.perf_counter() - round_started:.1f} s")
        return results

    result = discover(system, table, options, map_candidates=map_candidates, source=str(measured_file))
    found = ", ".join(f"{e.name} on {list(e.dofs)}" for e in result.effects) or "none"
    progress.say(f"[bold]discovery[/bold]: {found}; gap {result.gap_before.gap:.3g} → {result.gap_after.gap:.3g}")
    digest = fingerprint(file_hash(model_file), table_hash(table), options)
    folder = run_folder(results_root, f"discovery-{Path(model_file).stem}", started, digest)
    run = {"started_utc": started.isoformat(), "finished_utc": dt.datetime.now(dt.timezone.utc).isoformat(),
           "wall_time_s": time.perf_counter() - clock, "orchestration": orchestration,
           "flow_run_id": str(FlowRunContext.get().flow_run.id), "cache_store": cache.store, "tasks": progress.summary()}
    with atomic_directory(folder, kind="discovery archive") as archive:
        write_discovery(result, archive.path)
        shutil.copyfile(model_file, archive.path / "model.toml")
        table.to_parquet(archive.path / "measured.parquet", index=False)
        manifest = {
            "run_id": folder.name,
            "inputs": {"model": {"file": str(model_file), "sha256": file_hash(model_file)},
                       "measured": {"file": str(measured_file), "sha256": table_hash(table),
                                    "file_sha256": file_hash(measured_file)},
                       "options": repr(options)},
            "environment": environment(), "run": run,
        }
        write_json(manifest, archive.path / "manifest.json")
        (archive.path / "report.md").write_text(discovery_markdown(result, manifest))
    return str(archive.final)
