"""A run whose every result is in the cache, answered without Prefect: :func:`answer_from_cache`.

A rerun of an unchanged study computes nothing: each step and job of the flow would read
its record from the cache (:mod:`nlupdate.orchestration.tasks.store`). Through Prefect that
costs a server's start, Prefect's imports and a task run per step and job, about three
quarters of computing the study in one process (docs/performance.md, "Prefect's share of
the demo"). This module walks the chain (:data:`nlupdate.study.chain.CHAIN`) as
:func:`nlupdate.orchestration.flows.study.run_chain` does — the same keys
(:mod:`nlupdate.orchestration.tasks.keys`), the same records, verified the same way
(:func:`nlupdate.orchestration.tasks.signing.read_result`), a fan-out step's outcomes gathered
by the step — and when every record the study needs is there and valid, writes the
archive with the kept figures, without importing Prefect or starting a server.

What the user sees: the progress lines of a cached run (every step and job ``cached``),
and an archive whose manifest says ``answered from the cache`` with no ``flow_run_id``.
No flow run is recorded in Prefect for it: nothing ran; the Prefect UI keeps the runs that
computed the results. As soon as one record is missing, unreadable or fails its check,
nothing is printed or written here and the run goes through Prefect, which computes what
is missing (and names a record that failed its check).
"""
from __future__ import annotations

import datetime as dt
import time
from pathlib import Path
from typing import Any

from nlupdate.orchestration.flows.status_lines import Progress
from nlupdate.orchestration.tasks import keys
from nlupdate.orchestration.tasks.names import job_run_name
from nlupdate.orchestration.tasks.signing import Missing, RECORDS_FOLDER, read_result
from nlupdate.study.chain import CHAIN, StudyResult, study_result
from nlupdate.study.spec import Study, inputs_read_once


def _job_name(job: Any) -> str:
    return str(getattr(job, "name", job))


def cached_chain(study: Study, store: Path) -> tuple[StudyResult, dict[str, str], list[tuple]] | None:
    """The study's result from the records in ``store`` (a study whose input files are
    pinned, :func:`nlupdate.study.spec.inputs_read_once`), every step's key, and the
    progress lines to print, ``(name, detail, position)`` (a fan-out step's introduction:
    ``(name, text)``, :attr:`~nlupdate.study.chain.Step.introduce`); None when a record is missing or a
    step fails (the flow then runs and reports the failure with a failed archive)."""
    from nlupdate.fe.adapters.registry import build_adapter
    from nlupdate.input_files import pinned

    results: dict[str, Any] = {}
    result_keys: dict[str, str] = {}
    lines: list[tuple] = []
    try:
        with pinned(study.snapshots):
            for step in CHAIN:
                if not step.applies(study, results):
                    continue
                values = [results.get(name) for name in step.inputs]
                input_keys = [result_keys.get(name) for name in step.inputs]
                if not step.fans_out:
                    key = keys.step_key(step, study, input_keys)
                    results[step.name], result_keys[step.name] = read_result(store, key), key
                    lines.append((step.name, step.describe(study, results[step.name]), ""))
                    continue
                spec = step.model(study)
                model = keys.model_identity(spec, build_adapter(spec).model_fingerprint())
                jobs = step.jobs(study, *values)
                job_keys = [keys.job_key(step, study, job, model, input_keys) for job in jobs]
                outcomes = [read_result(store, key) for key in job_keys]
                intro = step.introduce(study, jobs)
                lines += [(step.name, intro)] if intro else []
                lines += [(job_run_name(step.name, _job_name(job)), "", f"{i}/{len(jobs)}")
                          for i, job in enumerate(jobs, start=1)]
                results[step.name] = step.compute(study, outcomes, *values)
                result_keys[step.name] = keys.gathered_key(step, job_keys)
    except Missing:
        return None
    except Exception:  # noqa: BLE001 — e.g. a [prediction] candidate that is not a run: the flow
        return None    # reports it, with a failed archive; this path only answers when all is well
    return study_result(study, results), result_keys, lines


def answer_from_cache(study: Study, results_root: str | Path, store: Path, progress: Progress,
                      annotations: dict[str, str] | None = None) -> Path | None:
    """Write the archive of ``study`` under ``results_root`` from the cache folder ``store``
    when it holds every result the study needs (the module docstring); its path, or None
    (nothing printed or written) when something must be computed."""
    from nlupdate.orchestration.tasks.figures import FigureStore
    from nlupdate.reporting.archive import inputs_hash, run_folder, write_archive

    if not (store / RECORDS_FOLDER).is_dir():
        return None
    started = dt.datetime.now(dt.timezone.utc)
    clock = time.perf_counter()
    with inputs_read_once(study) as study:
        answered = cached_chain(study, store)
        if answered is None:
            return None
        result, step_keys, lines = answered
        progress.say(f"study [bold]{study.name}[/bold]: every result is in the cache {store}; answered from it "
                     f"without Prefect (no run recorded there; --no-cache computes it again)")
        for line in lines:
            if len(line) == 2:  # a fan-out step's introduction
                progress.introduce(*line)
            else:
                progress.finished(line[0], "Cached", line[1], None, line[2])
        progress.say("[bold]FE points[/bold]: none needed, every job came from the cache")
        progress.say(f"steps done in {time.perf_counter() - clock:.1f} s; writing the archive …")
        record = {"started_utc": started.isoformat(), "finished_utc": dt.datetime.now(dt.timezone.utc).isoformat(),
                  "wall_time_s": time.perf_counter() - clock,
                  "orchestration": "answered from the cache: every result was there (no Prefect run)",
                  "flow_run_id": None, "cache_store": str(store), "cache_refreshed": False,
                  "tasks": progress.summary(), **(annotations or {})}
        figures = FigureStore(store, keys.figures_key(study, step_keys))
        return write_archive(result, run_folder(str(Path(results_root).resolve()), study.name, started,
                                                inputs_hash(result)), record, figures=figures)
