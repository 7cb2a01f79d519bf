"""Studies as Prefect flows, against the plain sequential run of the same steps.

One Prefect server serves the whole module (session fixture). The study is the small
2-DOF chain of ``tests/data/studies/two_dof.toml`` (simulated test, PRD, four formulas
on two parameter sets, an optimisation candidate, prediction).
"""
from __future__ import annotations

import asyncio
import dataclasses
import json
import logging
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from nlupdate.orchestration.flows.status_lines import Progress
from nlupdate.orchestration.flows.run import run_study_flow
from nlupdate.orchestration.flows.runners import Execution, ExecutionError, task_runner
from patience import HANG_S
from prefect_settings import talking_to
from studies import small_two_dof_study, two_dof_study, study_text, write_study
from nlupdate.study import load_study, run_study, study_from_text
from nlupdate.study.spec import TargetsSpec
from nlupdate.orchestration.tasks.names import JOB_NOUNS

STUDY = Path(__file__).parent / "data" / "studies" / "two_dof.toml"


def flow_run(study, tmp_path: Path, cache: str = "cache", **options) -> tuple[Path, dict]:
    archive = run_study_flow(study, tmp_path / "results", cache_dir=tmp_path / cache, progress=Progress(quiet=True),
                             **options)
    return archive, json.loads((archive / "manifest.json").read_text())


def tally(manifest: dict, step: str) -> dict:
    """Computed / cached / failed task runs of one step (a fan-out step's jobs,
    ``updating: <run>``, ``prediction: <model>``, summed)."""
    total = {"computed": 0, "cached": 0, "failed": 0}
    for name, counts in manifest["run"]["tasks"].items():
        if name == step or name.startswith(JOB_NOUNS.get(step, step) + ": "):
            for key in total:
                total[key] += counts[key]
    return total


@pytest.fixture(scope="module")
def first_run(prefect_server, tmp_path_factory):
    """The study run once under Prefect (threads), on a fresh cache."""
    tmp_path = tmp_path_factory.mktemp("flows")
    archive, manifest = flow_run(load_study(STUDY), tmp_path)
    return tmp_path, archive, manifest


def test_flow_and_sequential_run_give_the_same_numbers(first_run):
    _, archive, manifest = first_run
    sequential = run_study(load_study(STUDY))
    identification = pd.read_parquet(archive / "tables" / "identification.parquet").set_index("parameter")
    for name, value in sequential.identification.parameters().items():
        assert identification.loc[name, "value"] == pytest.approx(value, rel=1e-10)
    runs = pd.read_parquet(archive / "tables" / "runs.parquet").set_index("candidate")
    assert set(runs.index) == {r.name for r in sequential.runs}
    for result in sequential.runs:
        for name, value in result.parameters.items():
            assert runs.loc[result.name, f"p:{name}"] == pytest.approx(value, rel=1e-10)
            assert runs.loc[result.name, f"std:{name}"] == pytest.approx(sequential.uncertainties[result.name].std[name],
                                                                         rel=1e-6)
    correlation = pd.read_parquet(archive / "tables" / "correlation.parquet")
    for prediction in sequential.predictions:
        flow_frac = correlation[correlation["model"] == prediction.name]["frac"].to_numpy()
        np.testing.assert_allclose(flow_frac, prediction.correlation["frac"].to_numpy(), rtol=1e-8)
    assert manifest["failures"] == [] and manifest["study"]["name"] == "two-dof"


def test_the_run_is_recorded_by_the_server(first_run, prefect_server):
    """The run is read back from the API: one flow run, completed, with no flow runs under it
    (a fan-out step's jobs are task runs of the study's flow run), every task run completed,
    and each job's task run recorded as fed by the task runs of its step's inputs — the edges
    the UI's run graph draws (``targets`` → each updating run)."""
    from prefect.client.orchestration import get_client
    from prefect.client.schemas.filters import FlowRunFilter, FlowRunFilterParentFlowRunId

    _, _, manifest = first_run

    async def recorded():
        """The study's flow run, the flow runs under it and its task runs."""
        async with get_client() as client:
            parent = await client.read_flow_run(manifest["run"]["flow_run_id"])
            children = await client.read_flow_runs(flow_run_filter=FlowRunFilter(
                parent_flow_run_id=FlowRunFilterParentFlowRunId(any_=[parent.id])))
            return parent, children, await recorded_task_runs(client, parent.id, 6 + 9 + 2)

    with talking_to(prefect_server):
        parent, children, task_runs = asyncio.run(recorded())
    assert parent.state_name == "Completed"
    assert children == []
    assert len(task_runs) == 6 + 9 + 2 and {run.state_name for run in task_runs} == {"Completed"}
    ids = {run.name: run.id for run in task_runs}
    fed_by = {run.name: {put.id for put in run.task_inputs.get("inputs", [])} for run in task_runs}
    jobs = [name for name in fed_by if name.startswith(("updating: ", "prediction: "))]
    assert len(jobs) == 11
    for name in jobs:  # every updating run is fed by the targets, every prediction by the identification
        source = "targets" if name.startswith("updating: ") else "identification"
        assert ids[f"{source}: two-dof"] in fed_by[name], (name, fed_by[name])
    assert fed_by["identification: two-dof"] == {ids["measured data: two-dof"]}


def test_a_runs_warnings_are_logged_as_warnings_where_its_page_in_the_ui_shows_them(prefect_server, tmp_path):
    """The run's page in the Prefect UI read "Completed" with INFO lines only, though its
    summary opened with results not to be trusted: each line of the summary's Warnings is
    now a WARNING of the flow run (the {k1} runs of the 3-mass chain miss their targets)."""
    from prefect.client.orchestration import get_client
    from prefect.client.schemas.filters import LogFilter, LogFilterFlowRunId
    from test_target_miss_warnings import chain_misses_study

    from nlupdate.core.identification.trust import TrustWarning, warning_texts

    archive, manifest = flow_run(study_from_text(study_text(chain_misses_study()), tmp_path / "study.toml"), tmp_path)
    expected = warning_texts([TrustWarning(**w) for w in manifest["warnings"]])
    assert len(expected) == 1 and "misses its weighted targets" in expected[0]

    async def warned() -> list[str]:
        async with get_client() as client:
            deadline = time.monotonic() + HANG_S
            while True:
                logs = await client.read_logs(LogFilter(flow_run_id=LogFilterFlowRunId(
                    any_=[manifest["run"]["flow_run_id"]])))
                found = [log.message for log in logs if log.level == logging.WARNING]
                if found or time.monotonic() > deadline:
                    return found
                await asyncio.sleep(0.2)

    with talking_to(prefect_server):
        assert asyncio.run(warned()) == expected


def test_the_run_server_runs_only_what_a_run_needs(prefect_server):
    """The server a run starts, as it reports its settings: no event persister, automations
    or event and log streams (a run uses none), its task-run recorder writing once a second
    in batches, no analytics (the one background service Prefect runs in such a server
    is its telemetry, on only with analytics), and the UI's records still made: the
    recorder is on."""
    import httpx

    settings = httpx.get(f"{prefect_server}/admin/settings", timeout=30).json()["server"]
    services = settings["services"]
    assert not services["event_persister"]["enabled"] and not services["triggers"]["enabled"]
    assert not settings["events"]["stream_out_enabled"] and not settings["logs"]["stream_out_enabled"]
    assert services["task_run_recorder"]["enabled"]
    assert (services["task_run_recorder"]["batch_size"], services["task_run_recorder"]["flush_interval"]) == (100, 1)
    assert settings["analytics_enabled"] is False


def test_a_run_talks_to_its_server_whatever_prefect_read_when_imported(prefect_server, tmp_path, monkeypatch):
    """Prefect reads its settings when it is imported: a process that imported it before the
    run's server existed (a notebook, this test session) has no API in them. The run must
    still talk to the server it was given (PREFECT_API_URL here), not start Prefect's own
    server in this process and record the run there."""
    from prefect.server.api.server import SubprocessASGIServer
    from prefect.settings import PREFECT_API_URL, temporary_settings

    def refuse(self, *args, **kwargs):
        raise AssertionError("Prefect started a server of its own in this process")

    monkeypatch.setattr(SubprocessASGIServer, "start", refuse)
    study = write_study(tmp_path / "study.toml", small_two_dof_study())
    with temporary_settings(restore_defaults={PREFECT_API_URL}):  # as imported before the server started
        _, manifest = flow_run(load_study(study), tmp_path)
    assert f"API {prefect_server}" in manifest["run"]["orchestration"]
    with talking_to(prefect_server):
        recorded = asyncio.run(_read_flow_run(manifest["run"]["flow_run_id"]))
    assert recorded.state_name == "Completed"


async def recorded_task_runs(client, flow_run_id, count: int, patience_s: float = 300.0) -> list:
    """The task runs of ``flow_run_id`` once the server has recorded ``count`` of them in a
    final state: the run's server writes the states it receives as events once a second
    (``RUN_SERVER_SETTINGS``), after the run may have returned (``patience_s`` only ends a
    wait for what will not come; the test then asserts what was recorded)."""
    from prefect.client.schemas.filters import FlowRunFilter, FlowRunFilterId

    deadline = time.monotonic() + patience_s
    while True:
        task_runs = await client.read_task_runs(flow_run_filter=FlowRunFilter(id=FlowRunFilterId(any_=[flow_run_id])),
                                                limit=200)
        done = len(task_runs) >= count and all(run.state is not None and run.state.is_final() for run in task_runs)
        if done or time.monotonic() > deadline:
            return task_runs
        await asyncio.sleep(0.1)


async def _read_flow_run(flow_run_id: str):
    from prefect.client.orchestration import get_client

    async with get_client() as client:
        return await client.read_flow_run(flow_run_id)


def test_flow_and_task_runs_are_named_by_what_they_compute(first_run, prefect_server):
    """Every run of the study read back from the API has a name that says what it is —
    the study and its start time, the steps, each updating run and prediction by its name
    in the archive's tables, after its step's (the UI lists and draws a step's jobs together
    by it) — and none has a name Prefect made up (``updating-0``,
    ``stoic-marmoset``). FE points have no task runs. The manifest's entries are these
    names and the tally of FE points."""
    import datetime as dt
    import re

    from prefect.client.orchestration import get_client

    _, archive, manifest = first_run

    async def runs():
        async with get_client() as client:
            parent = await client.read_flow_run(manifest["run"]["flow_run_id"])
            return parent, await recorded_task_runs(client, parent.id, 6 + 9 + 2)

    with talking_to(prefect_server):
        parent, tasks = asyncio.run(runs())
    match = re.fullmatch(r"two-dof (\d{4}-\d\d-\d\d \d\d:\d\d) UTC", parent.name)
    assert match, parent.name
    named_at = dt.datetime.strptime(match[1], "%Y-%m-%d %H:%M").replace(tzinfo=dt.timezone.utc)
    started = dt.datetime.fromisoformat(manifest["run"]["started_utc"])
    # named as it started: the minute of a moment between the run's creation and its start
    # (a bound on the seconds between them failed when the minute turned while a loaded
    # machine took more than 1 s from one to the other)
    created = parent.created.astimezone(dt.timezone.utc).replace(second=0, microsecond=0)
    assert created <= named_at <= started, (parent.name, parent.created, started)

    steps = {"measured data", "identification", "targets", "comparison", "candidate FRFs", "warnings"}
    names = [t.name for t in tasks]
    assert sorted(name for name in names if name.endswith(": two-dof")) == sorted(f"{step}: two-dof" for step in steps)

    candidates = set(pd.read_parquet(archive / "tables" / "runs.parquet")["candidate"])
    assert len(candidates) == 9 and "optimisation {k1}" in candidates
    updating = [name for name in names if name.startswith("updating: ")]
    jobs = set(updating)
    # in ASCII: the UI's run graph draws no other characters (O(h²) and O(h⁴) would both read O(h))
    assert jobs == {f"updating: {candidate}".replace("²", "^2").replace("⁴", "^4") for candidate in candidates}
    assert "updating: eigensensitivity central O(h^2) {k1}" in jobs and all(name.isascii() for name in updating)
    # FE points are computed inside their job's task (issue 39: a task run per point cost the
    # server more than the point): no task run of their own, each still tallied in the manifest
    assert len(updating) == len(jobs) == 9, updating
    assert tally(manifest, "FE point")["computed"] > 0

    models = set(pd.read_parquet(archive / "tables" / "correlation.parquet")["model"])
    assert models >= {"initial"} and len(models) == 2
    assert {name for name in names if name.startswith("prediction: ")} == {f"prediction: {model}" for model in models}
    assert len(names) == len(steps) + len(jobs) + len(models)  # no other task run

    made_up = [name for name in names if ": " not in name or re.search(r"-\d+$", name)]
    assert not made_up, made_up
    assert set(manifest["run"]["tasks"]) == steps | jobs | {f"prediction: {model}" for model in models} | {"FE point"}


def test_an_unchanged_rerun_is_all_cached(first_run):
    """Every task comes from the cache, and the run says so: no FE point computed, no job
    line repeating the FE counts of the run that computed it; the manifest lists the same
    runs under the same names. (The time ratio is measured on the demo, whose computing
    outweighs Prefect's per-flow overhead, in tests/test_demo.py; this study is too small
    for a wall-time comparison on a shared machine.)"""
    import io

    from rich.console import Console

    tmp_path, _, first = first_run
    printed = io.StringIO()
    again = json.loads((run_study_flow(load_study(STUDY), tmp_path / "results", cache_dir=tmp_path / "cache",
                                       progress=Progress(Console(file=printed, width=400))) / "manifest.json").read_text())
    for step, counts in again["run"]["tasks"].items():
        assert counts["computed"] == 0 and counts["failed"] == 0, (step, counts)
    assert tally(again, "updating")["cached"] == 9 and tally(again, "identification")["cached"] == 1
    assert set(again["run"]["tasks"]) == set(first["run"]["tasks"]) - {"FE point"}  # stable names, no points run
    lines = printed.getvalue().splitlines()
    # before the updating jobs, one line says what their names say (it computes nothing)
    intro = [i for i, line in enumerate(lines) if line.startswith("updating: 9 runs; parameters k1 (N/m), k2 (N/m); "
                                                                   "O(h), O(h^2), O(h^4): ")]
    assert len(intro) == 1 and all(not line.startswith("updating: ") for line in lines[:intro[0]]), lines
    jobs = [line for i, line in enumerate(lines) if line.startswith(("updating: ", "prediction: ")) and i not in intro]
    assert len(jobs) == 11 and all(line.endswith("s") and " — cached in " in line and "FE runs" not in line
                                   for line in jobs), jobs
    assert "FE points: none needed, every job came from the cache" in lines, lines


def test_a_rerun_of_the_same_results_keeps_its_figures_and_a_tampered_one_is_drawn_again(first_run, monkeypatch):
    """The archive's figures of unchanged results are the kept PNGs (none drawn, the same
    bytes); a kept figure edited on disk fails its signature, is named in one line and drawn
    again; with ``refresh`` none is read."""
    import nlupdate.reporting.archive as archive_module
    from nlupdate.notices import NlupdateWarning
    from nlupdate.orchestration.tasks.figures import FOLDER

    tmp_path, first, _ = first_run
    drawn: list[int] = []
    real = archive_module.png_bytes
    monkeypatch.setattr(archive_module, "png_bytes", lambda *a, **k: drawn.append(1) or real(*a, **k))
    again, _ = flow_run(load_study(STUDY), tmp_path)
    plots = sorted(p.name for p in (first / "plots").glob("*.png"))
    assert len(plots) >= 6 and not drawn
    assert all((again / "plots" / name).read_bytes() == (first / "plots" / name).read_bytes() for name in plots)
    kept = sorted((tmp_path / "cache" / FOLDER).glob("*-candidate_frfs.png"))
    assert len(kept) == 1
    kept[0].write_bytes(kept[0].read_bytes()[:-1] + b"x")  # one byte of the picture changed
    with pytest.warns(NlupdateWarning, match=r"kept figure .*candidate_frfs\.png: its signature does not match"):
        tampered, _ = flow_run(load_study(STUDY), tmp_path)
    assert len(drawn) == 1
    assert (tampered / "plots" / "candidate_frfs.png").read_bytes() == (first / "plots" / "candidate_frfs.png").read_bytes()
    from nlupdate.orchestration.tasks.figures import FigureStore

    key = kept[0].name.removesuffix("-candidate_frfs.png")
    assert FigureStore(tmp_path / "cache", key).get("candidate_frfs.png") is not None  # kept again, signed
    assert FigureStore(tmp_path / "cache", key, refresh=True).get("candidate_frfs.png") is None


def test_changing_one_bound_reruns_only_the_runs_that_depend_on_it(first_run):
    tmp_path, _, _ = first_run
    study = two_dof_study(model="../../../examples/two_dof.toml")
    assert study["parameters"][1]["name"] == "k2"
    study["parameters"][1]["upper"] = 1.6e6
    _, changed = flow_run(study_from_text(study_text(study), STUDY), tmp_path)
    assert tally(changed, "measured data") == {"computed": 0, "cached": 1, "failed": 0}
    assert tally(changed, "identification") == {"computed": 0, "cached": 1, "failed": 0}
    assert tally(changed, "updating") == {"computed": 4, "cached": 5, "failed": 0}  # the four {k2} runs
    assert tally(changed, "FE point")["computed"] == 0  # the bound is not active: the same points


def test_each_base_point_is_evaluated_once_in_a_four_formula_sweep(prefect_server, tmp_path):
    """On a cold cache the flow computes exactly the distinct points a sequential sweep with
    one shared memo computes; the start point once for the whole sweep (every run starts
    from the study's starts, the parameters it does not update held there)."""
    study = load_study(STUDY)
    study = dataclasses.replace(study, prediction=None, identification=None, measured=None,
                                targets=TargetsSpec(frequencies_hz=(740.0,), model_modes=(2,)))
    _, manifest = flow_run(study, tmp_path, cache="cold")
    sequential = run_study(study).runs  # in order, one memo for the whole sweep
    distinct_points = sum(result.counts["new"] for result in sequential)
    assert tally(manifest, "FE point") == {"computed": distinct_points, "cached": 0, "failed": 0}
    histories = pd.read_parquet(sorted((tmp_path / "results").rglob("histories.parquet"))[0])
    start = histories[histories["iteration"] == 0]
    assert start["new_evaluations"].sum() == 1, start[["run", "new_evaluations", "cached_evaluations"]]
    assert len(start) == 9  # four formulas × two sets + one optimisation candidate


def test_a_dask_cluster_gives_the_same_candidates_as_threads(first_run, tmp_path):
    """One worker process: the jobs still run in a process of their own (sent there and
    back pickled), and a cluster of one worker costs less to start than one of two (each
    worker imports numpy, scipy and nlupdate)."""
    _, threads, _ = first_run
    dask, manifest = flow_run(load_study(STUDY), tmp_path, cache="dask", execution=Execution(workers=1, dask=True))
    assert "local Dask cluster, 1 worker processes" in manifest["run"]["orchestration"]
    assert tally(manifest, "FE point")["computed"] > 0  # nothing came from the threads run's cache
    a = pd.read_parquet(threads / "tables" / "runs.parquet").set_index("candidate").sort_index()
    b = pd.read_parquet(dask / "tables" / "runs.parquet").set_index("candidate").sort_index()
    pd.testing.assert_frame_equal(a.filter(like="p:"), b.filter(like="p:"), rtol=1e-10)


def test_a_failing_branch_is_named_and_the_others_finish(prefect_server, tmp_path, monkeypatch):
    """A candidate whose FE runs fail (the lumped solver made to crash at its start point;
    values a model cannot take are refused when the study is read); the rest of the sweep,
    the comparison and the prediction go on."""
    from nlupdate.fe.adapters.base import AdapterError
    from nlupdate.fe.adapters.lumped import LumpedAdapter

    solve = LumpedAdapter._solve

    def crashes_at_the_candidates_start(self, parameters):
        if parameters.get("m1") == 0.123456:
            raise AdapterError("lumped solver crashed (as a test)")
        return solve(self, parameters)

    monkeypatch.setattr(LumpedAdapter, "_solve", crashes_at_the_candidates_start)
    study = two_dof_study(model="../../../examples/two_dof.toml")
    study["parameters"].append({"name": "m1", "unit": "kg", "start": 0.1, "lower": 0.05, "upper": 0.3})
    study["optimisation"]["candidates"].append({"name": "crashing solver", "parameters": ["m1"],
                                                "start": {"m1": 0.123456}})
    archive, manifest = flow_run(study_from_text(study_text(study), STUDY), tmp_path)
    assert [f["run"] for f in manifest["failures"]] == ["crashing solver"]
    assert "lumped solver crashed" in manifest["failures"][0]["error"]
    runs = pd.read_parquet(archive / "tables" / "runs.parquet")
    assert len(runs) == 9 and "crashing solver" not in set(runs["candidate"])
    report = (archive / "report.md").read_text()
    assert "Failed updating runs" in report and "crashing solver" in report
    assert (archive / "tables" / "correlation.parquet").exists()


def test_an_unreachable_dask_address_fails_clearly_at_the_refused_connection():
    """Refused at the address check, not after a Dask client's connection timeout (whose
    message says "within 5 s"): the reason is the refused connection."""
    with pytest.raises(ExecutionError, match=r"no Dask scheduler answers at tcp://127.0.0.1:9 \(connection refused\)"):
        with task_runner(Execution(dask_address="tcp://127.0.0.1:9"), connect_timeout_s=5):
            pass


def own_server_folder(monkeypatch, tmp_path) -> Path:
    """Kept-server files of the test's own (the session's server is not found, so a run
    starts one), kept for no run after it."""
    from nlupdate.orchestration.flows import server_lease

    folder = tmp_path / "server-state"
    folder.mkdir()
    monkeypatch.setattr(server_lease, "state_folder", lambda: folder)
    monkeypatch.setenv("NLUPDATE_PREFECT_SERVER_KEEP_S", "0")
    monkeypatch.delenv("PREFECT_API_URL", raising=False)
    return folder


def ends(process, timeout_s: float = HANG_S) -> bool:
    """Whether ``process`` (a Popen) ends within ``timeout_s``."""
    import subprocess

    try:
        process.wait(timeout_s)
    except subprocess.TimeoutExpired:
        return False
    return True


def test_a_server_that_cannot_start_or_answer_is_one_clear_error(monkeypatch, tmp_path):
    from nlupdate.orchestration.flows import server, server_lease
    from nlupdate.orchestration.flows.server import ServerError, prefect_api

    started = []

    def broken(self, timeout_s):
        started.append(self.started.process)
        raise RuntimeError("the server did not answer within 120 s")

    folder = own_server_folder(monkeypatch, tmp_path)
    monkeypatch.setattr(server.KeptServer, "wait", broken)
    before = list(server._STARTED)  # the session's server, when a test before started it
    with pytest.raises(ServerError, match="could not start a Prefect server .*prefect server start"):
        with prefect_api(lambda message: None):
            pass
    assert server._STARTED == before  # the process that did not answer is stopped, its record gone
    assert started[0].poll() is not None and server_lease.read_record(folder) is None
    monkeypatch.setenv("PREFECT_API_URL", "http://127.0.0.1:9/api")
    with pytest.raises(ServerError, match="PREFECT_API_URL=http://127.0.0.1:9/api does not answer"):
        with prefect_api(lambda message: None):
            pass


def test_a_server_started_early_is_the_one_the_run_uses_and_stops_after_it(monkeypatch, tmp_path):
    """The CLI starts the run's server before it imports Prefect (so that it boots
    meanwhile); prefect_api waits for that one instead of starting a second; kept for no
    run after it (NLUPDATE_PREFECT_SERVER_KEEP_S=0), the server stops when the run lets go."""
    import httpx

    from nlupdate.orchestration.flows import server

    own_server_folder(monkeypatch, tmp_path)
    before = list(server._STARTED)  # the session's server, when a test before started it
    server.start_server_early()
    early = server._EARLY[0]
    process = early.started.process
    said = []
    with server.prefect_api(said.append) as url:
        assert url == early.api_url
        assert httpx.get(f"{url}/health").status_code == 200
        assert server._STARTED == [*before, early] and not server._EARLY
    assert said[1] == f"Prefect server: {url} (started for this run; stops with the run)", said
    assert ends(process) and server._STARTED == before


def test_discovery_flow_finds_what_the_plain_call_finds_and_archives_it(prefect_server, tmp_path):
    """The SDOF example (time-integration data, friction + cubic hidden): the flow's
    candidate fits are tasks; effects and parameters equal the plain call's; a rerun
    takes every fit from the cache."""
    from nlupdate.core.discovery import DiscoveryOptions, discover
    from nlupdate.orchestration.flows.run import run_discovery_flow
    from nlupdate.core.measurement.frf_files import read_frf_table
    from nlupdate.core.model.model_file import load_system

    examples = Path(__file__).resolve().parents[1] / "examples" / "discovery"
    model, measured = examples / "sdof_linear.toml", examples / "sdof_friction_cubic.csv"
    plain = discover(load_system(model), read_frf_table(measured), DiscoveryOptions())
    progress = Progress(quiet=True)
    archive = run_discovery_flow(model, measured, DiscoveryOptions(), tmp_path / "results", cache_dir=tmp_path / "cache",
                                 progress=progress)
    found = json.loads((archive / "discovery.json").read_text())
    assert [e["effect"] for e in found["effects"]] == [e.name for e in plain.effects] == ["dry_friction", "cubic_stiffness"]
    for flow_effect, plain_effect in zip(found["effects"], plain.effects):
        for name, value in plain_effect.parameters.items():
            assert flow_effect["parameters"][name] == pytest.approx(value, rel=1e-10)
    assert found["gap_after"] <= 0.3 * found["gap_before"]
    assert {"report.md", "manifest.json", "augmented_model.toml", "model.toml", "measured.parquet"} <= {
        p.name for p in archive.iterdir()}
    assert progress.summary()["candidate fit"]["computed"] > 0
    again = Progress(quiet=True)
    run_discovery_flow(model, measured, DiscoveryOptions(), tmp_path / "results", cache_dir=tmp_path / "cache",
                       progress=again)
    assert again.summary()["candidate fit"]["computed"] == 0 and again.summary()["candidate fit"]["cached"] > 0


def closed_port() -> int:
    """A port on 127.0.0.1 nothing listens on (bound for a moment, then released)."""
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_an_unreachable_dask_address_is_refused_before_any_server_starts(tmp_path, two_dof_study_file):
    """``--dask-address`` is checked first (it took 17.6 s when a Prefect server started
    before the 10-second Dask connection timeout): one line, exit 2, nothing started."""
    import os
    import subprocess
    import sys

    address = f"tcp://127.0.0.1:{closed_port()}"
    env = {key: value for key, value in os.environ.items() if key != "PREFECT_API_URL"}  # it would start a server
    result = subprocess.run([sys.executable, "-m", "nlupdate", "run", str(two_dof_study_file), "--dask-address", address,
                             "--out", str(tmp_path / "results")], cwd=tmp_path, env=env, capture_output=True, text=True,
                            timeout=120)
    assert result.returncode == 2, (result.returncode, result.stdout, result.stderr)
    assert result.stderr.splitlines() == [f"nlupdate run: error: --dask-address: no Dask scheduler answers at {address} "
                                          f"(connection refused); start one with `dask scheduler` and `dask worker "
                                          f"ADDRESS`"]
    # no server started ("starting a Prefect server …" would be printed) and no Dask timeout
    # waited out (the reason would be "no answer within"): what took 17.6 s before the fix,
    # asserted as what happened, not as a time (about 2 s idle, 8 s on two loaded cores)
    assert "Prefect" not in result.stdout and not (tmp_path / "results").exists(), result.stdout


def test_a_run_ending_before_its_early_server_is_used_stops_only_that_server(prefect_server, monkeypatch, tmp_path):
    """A run that fails before it needs Prefect lets go of the server it started early,
    which then stops (kept for no run here) — and no other: the session's server (started
    by prefect_api in this process) keeps answering, as several in-process runs of one test
    module need."""
    import httpx

    from nlupdate.orchestration.flows import server

    own_server_folder(monkeypatch, tmp_path)
    server.start_server_early()
    early = server._EARLY[0]
    process = early.started.process
    server.stop_early_server()
    assert ends(process) and not server._EARLY and early not in server._STARTED
    assert httpx.get(f"{prefect_server}/health").status_code == 200


def test_an_fe_point_is_kept_as_a_record_of_its_own_and_an_edited_one_computed_again(tmp_path):
    """FE points computed inside their job's task still persist one by one: a second run's
    registry reads a kept point without computing it (the same modes as the lumped model
    solved afresh), and a record edited without the cache secret is named in one line and
    computed again."""
    import base64
    import warnings
    from concurrent.futures import ThreadPoolExecutor

    from nlupdate.fe.adapters.registry import build_adapter
    from nlupdate.notices import NlupdateWarning
    from nlupdate.orchestration.tasks import records
    from nlupdate.orchestration.tasks.fe_points import PointRegistry, RegistryPointEvaluator
    from nlupdate.orchestration.tasks.signing import RECORDS_FOLDER
    from nlupdate.study.chain import STEPS

    spec = STEPS["updating"].model(load_study(STUDY))
    point = {"k1": 8e5, "k2": 1.2e6}
    expected = build_adapter(spec).evaluate(point).natural_frequencies_hz  # solved afresh, no cache

    def one_run() -> tuple[np.ndarray, dict[str, int], list[str]]:
        with ThreadPoolExecutor(2) as pool:
            registry = PointRegistry(pool.submit, str(tmp_path))
            evaluate = RegistryPointEvaluator(spec, registry)
            (modes,) = evaluate([point])
            return modes.natural_frequencies_hz, evaluate.counts(), registry.states()

    frequencies, counts, states = one_run()
    np.testing.assert_allclose(frequencies, expected, rtol=1e-12)
    assert counts == {"new": 1, "cached": 0} and states == ["Completed"]
    (record,) = (tmp_path / RECORDS_FOLDER).iterdir()

    frequencies, counts, states = one_run()
    np.testing.assert_allclose(frequencies, expected, rtol=1e-12)
    assert counts == {"new": 0, "cached": 1} and states == ["Cached"]

    head, _, rest = record.read_bytes().partition(b"\n")  # the numbers scaled, the old signature kept
    signature, _, payload = rest.partition(b"\n")
    content = json.loads(payload)
    modes = records.loads(base64.b64decode(content["result"]))
    content["result"] = base64.b64encode(records.dumps(dataclasses.replace(
        modes, natural_frequencies_hz=modes.natural_frequencies_hz * 1.37))).decode()
    record.write_bytes(head + b"\n" + signature + b"\n" + json.dumps(content).encode())
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        frequencies, counts, states = one_run()
    np.testing.assert_allclose(frequencies, expected, rtol=1e-12)
    assert counts == {"new": 1, "cached": 0} and states == ["Completed"]
    named = [str(w.message) for w in caught if issubclass(w.category, NlupdateWarning)]
    assert len(named) == 1 and "its signature does not match" in named[0] and record.name in named[0], named
