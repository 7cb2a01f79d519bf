"""Crash safety and resume: killed runs, concurrent runs, a full disk, dead runs in the API.

* A run killed with SIGKILL mid-sweep leaves nothing that looks complete; started again it
  takes the finished tasks from the cache, computes the rest and leaves one archive, and
  the killed run is marked Crashed in the Prefect API.
* Two runs of one study at once (one cache, one results root) both finish with equal results.
* Archive renames racing for one name, cache records written while read or killed
  mid-write, the free-space check, and the dead-run sweep on runs made through the API.

The FE failure cases (ccx crashing, hanging, returning garbage) are in
``tests/test_calculix.py`` and ``tests/test_runner.py``.
"""
from __future__ import annotations

import json
import os
import queue
import re
import signal
import subprocess
import sys
import textwrap
import threading
import time
import uuid
from pathlib import Path

import pandas as pd
import pytest

from nlupdate.files import HOST, atomic_directory
from nlupdate.orchestration.flows.liveness import owner
from nlupdate.reporting.catalogue import find_runs
from patience import HANG_S
from prefect_settings import talking_to
from studies import two_dof_study, write_study

ROOT = Path(__file__).resolve().parents[1]
TWO_DOF = ROOT / "examples" / "two_dof.toml"
#: Bookkeeping columns that differ between runs of equal results (who computed a shared point, how long).
BOOKKEEPING = re.compile(r"wall_time|_evaluations$")


def study_file(tmp_path: Path) -> Path:
    return write_study(tmp_path / "study.toml", two_dof_study())


class Run:
    """``nlupdate run`` in a subprocess of its own session, its stdout read by a thread."""

    def __init__(self, study: Path, results: Path, cache: Path, api_url: str, cwd: Path) -> None:
        env = {**os.environ, "PREFECT_API_URL": api_url}
        self.process = subprocess.Popen(
            [sys.executable, "-m", "nlupdate", "run", str(study), "--out", str(results), "--cache-dir", str(cache),
             "--workers", "2"], cwd=cwd, env=env, text=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
            start_new_session=True)
        self.lines: list[str] = []
        self._queue: queue.Queue = queue.Queue()
        self._stderr: list[str] = []
        self._readers = [threading.Thread(target=self._read, daemon=True),
                         threading.Thread(target=lambda: self._stderr.extend(self.process.stderr), daemon=True)]
        for reader in self._readers:
            reader.start()

    def _read(self) -> None:
        for line in self.process.stdout:
            self._queue.put(line.rstrip("\n"))
        self._queue.put(None)

    def wait_for(self, pattern: str, timeout_s: float, count: int = 1) -> None:
        """Read lines until ``count`` of them match ``pattern``."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            try:
                line = self._queue.get(timeout=0.1)
            except queue.Empty:
                continue
            if line is None:
                break
            self.lines.append(line)
            if sum(bool(re.search(pattern, seen)) for seen in self.lines) >= count:
                return
        raise AssertionError(f"no line matching {pattern!r} within {timeout_s} s: {self.lines}")

    def kill(self) -> None:
        os.killpg(self.process.pid, signal.SIGKILL)
        self.process.wait(timeout=HANG_S)  # reaped: its pid names no process any more
        self._drain()

    def finish(self, timeout_s: float) -> tuple[int, str]:
        """Wait for the end; (exit code, stderr)."""
        self.process.wait(timeout=timeout_s)
        for reader in self._readers:
            reader.join(timeout=10)
        self._drain()
        return self.process.returncode, "".join(self._stderr)

    def _drain(self) -> None:
        while True:
            try:
                line = self._queue.get_nowait()
            except queue.Empty:
                return
            if line is not None:
                self.lines.append(line)


STEP_LINE = re.compile(r"^(?P<step>measured data|identification|targets|comparison|(?:updating|prediction): .+?)"
                       r"(?: \(\d+/\d+\))?(?:: (?P<detail>.*?))? — (?P<state>computed|cached|FAILED|CRASHED)")


def outcomes(lines: list[str]) -> dict[str, str]:
    """``{step or job (``updating: <run>``): computed|cached|…}`` from a run's progress lines
    (a job's i/N, the order of finishing, left out)."""
    found = {}
    for line in lines:
        match = STEP_LINE.match(line)
        if match is None:
            continue
        found[match["step"]] = match["state"]
    return found


def complete_archives(results: Path) -> list[Path]:
    return sorted(p for p in (results / "two-dof").iterdir() if not p.name.startswith("."))


def assert_no_record_is_truncated(cache: Path) -> None:
    from prefect.results import ResultRecord

    from nlupdate.orchestration.tasks.store import RECORDS_FOLDER, verified

    records = [p for p in (cache / RECORDS_FOLDER).iterdir() if not p.name.startswith(".")]
    assert records, "the killed run left no cache record"
    for path in records:  # raises on a truncated or mixed record
        ResultRecord.deserialize(verified(path.name, path.read_bytes()))


def flow_runs_of(pid: int, url: str) -> list:
    from prefect.client.orchestration import get_client

    from prefect.client.schemas.sorting import FlowRunSort

    with talking_to(url), get_client(sync_client=True) as client:
        recent = client.read_flow_runs(sort=FlowRunSort.EXPECTED_START_TIME_DESC, limit=200)
    return [run for run in recent if run.infrastructure_pid == owner(pid)]


# ----------------------------------------------------------------------------- killed and resumed


def test_a_run_killed_mid_sweep_resumes_from_the_cache_and_leaves_one_archive(tmp_path, prefect_server):
    study, results, cache = study_file(tmp_path), tmp_path / "results", tmp_path / "cache"
    killed = Run(study, results, cache, prefect_server, tmp_path)
    # two updating runs finished (their i/N is the order they finished, not of their lines)
    killed.wait_for(r"^updating: .* \(\d+/\d+\): .* — computed", timeout_s=300, count=2)
    killed.kill()
    finished_before = {step for step, state in outcomes(killed.lines).items() if state == "computed"}
    assert {"measured data", "identification", "targets"} <= finished_before and len(finished_before) >= 5, killed.lines

    # nothing under a final name; a temporary folder is hidden, named as one, and listed as incomplete
    left = list((results / "two-dof").iterdir()) if (results / "two-dof").exists() else []
    assert all(p.name.startswith(".tmp-") for p in left), left
    assert {run.status for run in find_runs(results)} <= {"incomplete"}
    assert_no_record_is_truncated(cache)

    again = Run(study, results, cache, prefect_server, tmp_path)
    code, stderr = again.finish(timeout_s=600)
    assert code == 0, (stderr, again.lines)
    resumed = outcomes(again.lines)
    assert {step: resumed[step] for step in finished_before} == {step: "cached" for step in finished_before}, again.lines
    assert [resumed["prediction: initial"], resumed["prediction: optimisation {k1}"]] == ["computed"] * 2

    archives = complete_archives(results)
    assert len(archives) == 1 and not [p for p in (results / "two-dof").iterdir() if p.name.startswith(".")]
    assert [(run.folder, run.status) for run in find_runs(results)] == [(archives[0], "complete")]
    manifest = json.loads((archives[0] / "manifest.json").read_text())
    tasks = manifest["run"]["tasks"]
    assert tasks["measured data"] == {"computed": 0, "cached": 1, "failed": 0}
    assert tasks["identification"] == {"computed": 0, "cached": 1, "failed": 0}
    updating_cached = sum(c["cached"] for s, c in tasks.items() if s.startswith("updating"))
    assert updating_cached >= len([s for s in finished_before if s.startswith("updating: ")]) >= 2

    # the killed process's flow runs: crashed by the second run as it started, none left running
    runs = flow_runs_of(killed.process.pid, prefect_server)
    study_runs = [run for run in runs if run.name.startswith("two-dof 20")]  # the study and its start time
    assert len(study_runs) == 1, "the study flow does not call claim_flow_run()"
    marked = [line for line in again.lines if line.startswith("marked ")]
    assert marked and f"{HOST}:{killed.process.pid}" in marked[0], again.lines
    # subflows that had finished stay Completed; none is left Running or Pending
    assert {run.state_name for run in runs} <= {"Crashed", "Completed"}, [(r.name, r.state_name) for r in runs]
    study_run = study_runs[0]
    assert study_run.state_name == "Crashed" and "killed" in study_run.state.message


# ----------------------------------------------------------------------------- two runs at once


def test_two_runs_of_one_study_at_once_both_finish_with_equal_results(tmp_path, prefect_server):
    study, results, cache = study_file(tmp_path), tmp_path / "results", tmp_path / "cache"
    runs = [Run(study, results, cache, prefect_server, tmp_path) for _ in range(2)]
    for run in runs:
        code, stderr = run.finish(timeout_s=600)
        assert code == 0, (stderr, run.lines)
    first, second = complete_archives(results)
    assert first.name != second.name
    assert [run.status for run in find_runs(results)] == ["complete", "complete"]
    assert not [p for p in (results / "two-dof").iterdir() if p.name.startswith(".")]
    assert_no_record_is_truncated(cache)
    tables = sorted(p.name for p in (first / "tables").glob("*.parquet"))
    assert tables == sorted(p.name for p in (second / "tables").glob("*.parquet")) and "runs.parquet" in tables
    for name in tables:
        a, b = (pd.read_parquet(folder / "tables" / name) for folder in (first, second))
        # columns in one order: the std:<parameter> columns come in the order the runs finished
        a, b = (t[sorted(c for c in t.columns if not BOOKKEEPING.search(c))] for t in (a, b))
        pd.testing.assert_frame_equal(a, b, check_exact=False, rtol=1e-10, obj=name)
    for folder in (first, second):
        assert json.loads((folder / "manifest.json").read_text())["failures"] == []


# ----------------------------------------------------------------------------- archive renames


def test_two_archives_finishing_at_once_under_one_name_both_survive(tmp_path, monkeypatch):
    """Both writers find the name free, then rename at the same moment: the loser takes the
    next free name instead of failing (ENOTEMPTY) and losing its archive."""
    import nlupdate.files as files

    original, barrier, seen = files._free_name, threading.Barrier(2, timeout=HANG_S), threading.local()

    def both_look_first(final):
        name = original(final)
        if not getattr(seen, "waited", False):
            seen.waited = True
            barrier.wait()  # both have chosen the same free name
        return name

    monkeypatch.setattr(files, "_free_name", both_look_first)
    final, finals, errors = tmp_path / "study" / "20260101T000000Z-abcdef12", [], []

    def write(text: str) -> None:
        try:
            with atomic_directory(final) as archive:
                (archive.path / "manifest.json").write_text(text)
            finals.append(archive.final)
        except BaseException as error:  # noqa: BLE001 - the test reports it
            errors.append(error)

    threads = [threading.Thread(target=write, args=(f"writer {i}",)) for i in range(2)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert errors == []
    assert sorted(p.name for p in finals) == [final.name, final.name + "-1"]
    assert sorted((p / "manifest.json").read_text() for p in finals) == ["writer 0", "writer 1"]
    assert sorted(p.name for p in final.parent.iterdir()) == [final.name, final.name + "-1"]


RACING_WRITER = textwrap.dedent("""
    import sys, time
    from nlupdate.files import atomic_directory
    final, index = sys.argv[1], sys.argv[2]
    print("ready", flush=True)
    start = float(sys.stdin.readline())  # one moment for all writers, told once all have started
    for round in range(15):
        with atomic_directory(f"{final}-round{round}") as archive:
            (archive.path / "manifest.json").write_text(index)
            while time.time() < start + 0.05 * round:
                pass
""")


def test_processes_racing_for_one_archive_name_all_succeed(tmp_path):
    """Four processes write archives under the same names, round after round, from one
    moment on (told once all four have started: a start-up slower than a fixed head start
    on a loaded machine left a writer out of the race)."""
    final = tmp_path / "study" / "20260101T000000Z-abcdef12"
    writers = [subprocess.Popen([sys.executable, "-c", RACING_WRITER, str(final), str(i)], stdin=subprocess.PIPE,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for i in range(4)]
    try:
        for writer in writers:
            assert writer.stdout.readline().strip() == "ready", writer.communicate()
        start = time.time() + 0.2
        for writer in writers:
            writer.stdin.write(f"{start!r}\n")
            writer.stdin.flush()
        for writer in writers:
            _, stderr = writer.communicate(timeout=HANG_S)
            assert writer.returncode == 0, stderr
    finally:
        for writer in writers:
            writer.kill()
            writer.wait()
    for round in range(15):
        base = f"{final.name}-round{round}"
        names = sorted(p.name for p in final.parent.iterdir() if p.name == base or p.name.startswith(base + "-"))
        assert len(names) == 4, names
        assert sorted((final.parent / n / "manifest.json").read_text() for n in names) == ["0", "1", "2", "3"]
    assert not [p for p in final.parent.iterdir() if p.name.startswith(".")]


# ----------------------------------------------------------------------------- cache records


CACHE_WRITER = textwrap.dedent("""
    import sys
    from pathlib import Path
    from prefect import task
    from prefect.results import ResultStore
    from nlupdate.orchestration.tasks.cached import configured

    @task
    def step():
        pass

    configured_step = configured(step, Path(sys.argv[1]))
    store = ResultStore(result_storage=configured_step.result_storage, serializer=configured_step.result_serializer,
                        cache_result_in_memory=False)
    print("writing", flush=True)
    for i in range(10**9):
        store.write(obj=b"x" * (300_000 if i % 2 else 1_000), key="record")
""")


#: Reads of a record while another process rewrites it (the old code failed about one in 20).
READS = 300


def test_a_record_rewritten_by_another_run_is_never_read_half_written(tmp_path):
    """Another process rewrites a record (a second run computing the same task) while this
    one checks and reads it, as Prefect does for a cached task: Prefect's own local storage
    truncates the file first, so the read fails now and then (a cached task run failing)."""
    from prefect import task
    from prefect.results import ResultStore

    from nlupdate.orchestration.tasks.cached import configured

    @task
    def step():
        pass

    # the storage the study's tasks write their results with: a block, which Prefect's
    # resolve_result_storage returns as it is, after starting a client, and with no API
    # named, an ephemeral Prefect server, which a loaded machine did not start within
    # Prefect's 20 s (in this process and in the writer's)
    configured_step = configured(step, tmp_path)
    store = ResultStore(result_storage=configured_step.result_storage, serializer=configured_step.result_serializer,
                        cache_result_in_memory=False)
    store.write(obj=b"x" * 1_000, key="record")
    writer = subprocess.Popen([sys.executable, "-c", CACHE_WRITER, str(tmp_path)], stdout=subprocess.PIPE, text=True)
    try:
        assert writer.stdout.readline().strip() == "writing"
        # a count of reads, not a time budget: on a loaded machine 2 s held 91 reads
        failures, reads, ends = [], 0, time.monotonic() + 300.0
        while reads < READS and time.monotonic() < ends:
            if not store.exists("record"):
                failures.append("a stored record was not there")
                continue
            try:
                store.read("record")
                reads += 1
            except Exception as error:  # noqa: BLE001 - counted
                failures.append(f"{type(error).__name__}: {error}")
    finally:
        writer.kill()
        writer.wait()
    assert reads == READS and failures == [], (reads, failures[:3], len(failures))


KILLED_CACHE_WRITER = textwrap.dedent("""
    import os, sys, time
    from pathlib import Path
    from prefect import task
    from prefect.results import ResultStore
    from nlupdate.orchestration.tasks.cached import configured

    @task
    def step():
        pass

    def killed_before_the_rename(*args):
        print("written", flush=True)
        time.sleep(60)

    os.replace = killed_before_the_rename
    configured_step = configured(step, Path(sys.argv[1]))
    store = ResultStore(result_storage=configured_step.result_storage, serializer=configured_step.result_serializer)
    store.write(obj="new", key="record")
""")


def test_a_writer_killed_mid_write_leaves_the_record_whole_and_its_leftover_is_cleaned(tmp_path):
    from prefect import task
    from prefect.results import ResultStore

    import nlupdate.orchestration.tasks.cached as steps
    import nlupdate.orchestration.tasks.store as store

    @task
    def step():
        pass

    configured_step = steps.configured(step, tmp_path)
    storage, serializer = configured_step.result_storage, configured_step.result_serializer
    records = tmp_path / store.RECORDS_FOLDER
    ResultStore(result_storage=storage, serializer=serializer).write(obj="old", key="record")
    writer = subprocess.Popen([sys.executable, "-c", KILLED_CACHE_WRITER, str(tmp_path)], stdout=subprocess.PIPE, text=True)
    assert writer.stdout.readline().strip() == "written"
    writer.send_signal(signal.SIGKILL)
    writer.wait(timeout=HANG_S)
    leftovers = [p.name for p in records.iterdir() if p.name.startswith(".")]
    assert len(leftovers) == 1 and f"-{writer.pid}-" in leftovers[0], leftovers
    assert ResultStore(result_storage=storage, serializer=serializer).read("record").result == "old"

    store._CLEANED.discard(records.resolve())  # as in the next run's process
    with pytest.warns(UserWarning, match=rf"unfinished output of an interrupted run \(process {writer.pid}\)"):
        ResultStore(result_storage=storage, serializer=serializer).write(obj="newer", key="other")
    assert sorted(p.name for p in records.iterdir()) == ["other", "record"]


def test_a_truncated_record_is_computed_again_not_fatal(tmp_path, prefect_server):
    """What a SIGKILL mid-write left with Prefect's own storage (and what a disk error may
    leave): the task runs again and rewrites the record."""
    from prefect import flow, task

    from nlupdate.orchestration.tasks.cached import configured

    calls = []

    @task(persist_result=True, cache_key_fn=lambda context, parameters: "fixed-key")
    def step(x: int) -> int:
        calls.append(x)
        return 2 * x

    @flow
    def run() -> tuple[str, int]:
        state = configured(step, tmp_path)(21, return_state=True)
        return state.name, state.result()

    with talking_to(prefect_server):
        assert run() == ("Completed", 42)
        record = tmp_path / "records-v1" / "fixed-key"
        record.write_bytes(record.read_bytes()[: record.stat().st_size // 2])
        with pytest.warns(UserWarning, match=rf"cache record {record}: its signature does not match"):
            assert run() == ("Completed", 42) and calls == [21, 21]
        assert run() == ("Cached", 42) and calls == [21, 21]


# ----------------------------------------------------------------------------- full disk


def test_a_nearly_full_disk_is_refused_before_work(tmp_path, monkeypatch):
    from collections import namedtuple

    from nlupdate.app.cli import CliError, CliRuntimeError
    from nlupdate.app.cli import output

    usage = namedtuple("usage", "total used free")
    monkeypatch.setattr(output.shutil, "disk_usage", lambda path: usage(10**11, 10**11 - 50 * 10**6, 50 * 10**6))
    monkeypatch.delenv("NLUPDATE_MIN_FREE_MB", raising=False)
    with pytest.raises(CliRuntimeError, match=rf"--out {re.escape(str(tmp_path))}: only 50 MB free on its disk, 100 MB needed"):
        output.writable_folder(tmp_path, "--out")
    monkeypatch.setenv("NLUPDATE_MIN_FREE_MB", "20")
    output.writable_folder(tmp_path, "--out")
    monkeypatch.setenv("NLUPDATE_MIN_FREE_MB", "0")
    monkeypatch.setattr(output.shutil, "disk_usage", lambda path: usage(10**11, 10**11, 0))
    output.writable_folder(tmp_path, "--out")
    monkeypatch.setenv("NLUPDATE_MIN_FREE_MB", "lots")
    with pytest.raises(CliError, match="NLUPDATE_MIN_FREE_MB='lots': expected a number of megabytes"):
        output.writable_folder(tmp_path, "--out")


def test_a_command_on_a_full_disk_stops_in_one_line_and_writes_nothing(tmp_path):
    env = {**os.environ, "NLUPDATE_MIN_FREE_MB": str(10**12)}  # more than any disk here has
    out = tmp_path / "out" / "frf.csv"
    result = subprocess.run([sys.executable, "-m", "nlupdate", "simulate", str(TWO_DOF), "--input-dof", "0",
                             "--freqs", "650:800:6", "--forces", "1", "--out", str(out)],
                            capture_output=True, text=True, env=env, timeout=120)
    assert result.returncode == 1, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and re.fullmatch(rf"nlupdate simulate: error: --out {re.escape(str(out.parent))}: only \d+ MB "
                                            rf"free on its disk, \d+ MB needed; .*NLUPDATE_MIN_FREE_MB.*", lines[0]), lines
    assert not out.exists()


# ----------------------------------------------------------------------------- runs of dead processes


def dead_pid() -> int:
    process = subprocess.Popen([sys.executable, "-c", "pass"])
    process.wait()
    return process.pid


def test_runs_of_a_dead_process_are_marked_crashed_and_live_ones_left_alone(prefect_server):
    from prefect import flow, task
    from prefect.client.orchestration import get_client
    from prefect.states import Pending, Running

    from nlupdate.orchestration.flows.liveness import REUSED_PID_SLACK_S, mark_dead_runs_crashed

    @flow(name=f"liveness-{uuid.uuid4().hex[:8]}")
    def a_flow():
        pass

    @task
    def a_task():
        pass

    # live and late are killed at the end; they must outlive the test's API calls on a loaded machine
    dead, live = dead_pid(), subprocess.Popen([sys.executable, "-c", "import time; time.sleep(600)"])
    late = None
    said: list[str] = []
    try:
        with talking_to(prefect_server), get_client(sync_client=True) as client:
            def run(owner: str | None, parent_task_run_id=None):
                created = client.create_flow_run(a_flow, state=Running(), parent_task_run_id=parent_task_run_id)
                if owner is not None:
                    client.update_flow_run(created.id, infrastructure_pid=owner)
                return created

            killed = run(owner(dead))
            killed_task = client.create_task_run(a_task, killed.id, dynamic_key="0", state=Running())
            unclaimed_subflow = run(None, parent_task_run_id=killed_task.id)
            alive = run(owner(live.pid))
            elsewhere = run(f"another-host:{dead}@{os.getuid()}")
            other_user = run(f"{HOST}:{dead}@{os.getuid() + 1}")  # a shared PREFECT_HOME holds their runs too
            userless = run(f"{HOST}:{dead}")  # as Prefect's own workers claim
            unclaimed = run(None)
            # created (scheduled) long before the process that runs it started: not a reused pid
            scheduled = client.create_flow_run(a_flow, state=Pending())
            time.sleep(REUSED_PID_SLACK_S + 0.5)
            late = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(600)"])
            client.set_flow_run_state(scheduled.id, Running())
            client.update_flow_run(scheduled.id, infrastructure_pid=owner(late.pid))

            assert mark_dead_runs_crashed(said.append) >= 2
            state = {name: client.read_flow_run(r.id).state for name, r in
                     [("killed", killed), ("subflow", unclaimed_subflow), ("alive", alive), ("elsewhere", elsewhere),
                      ("other user", other_user), ("userless", userless), ("unclaimed", unclaimed),
                      ("scheduled", scheduled)]}
            task_state = client.read_task_run(killed_task.id).state
            assert mark_dead_runs_crashed(said.append) == 0  # done once
    finally:
        for process in (live, late):
            if process is not None:
                process.kill()
                process.wait()
    assert state["killed"].name == "Crashed" and f"({owner(dead)}) is gone (killed)" in state["killed"].message
    assert state["subflow"].name == "Crashed" and f"({owner(dead)}) is gone" in state["subflow"].message
    assert task_state.name == "Crashed"
    left = ("alive", "elsewhere", "other user", "userless", "unclaimed", "scheduled")
    assert {name: state[name].name for name in left} == {name: "Running" for name in left}
    assert len(said) == 1 and said[0].startswith("marked ") and owner(dead) in said[0]


def test_a_flow_claims_its_run_and_a_claim_never_fails_the_run(prefect_server, monkeypatch):
    from prefect import flow
    from prefect.client.orchestration import get_client
    from prefect.context import FlowRunContext

    from nlupdate.orchestration.flows import liveness

    @flow
    def claimed_in_body() -> str:
        assert liveness.claim_flow_run()
        return str(FlowRunContext.get().flow_run.id)

    @flow(on_running=[liveness.claim_flow_run])
    def claimed_by_hook() -> str:
        return str(FlowRunContext.get().flow_run.id)

    assert not liveness.claim_flow_run()  # outside a flow run: nothing to claim
    with talking_to(prefect_server):
        ids = [claimed_in_body(), claimed_by_hook()]
        with get_client(sync_client=True) as client:
            owners = [client.read_flow_run(i).infrastructure_pid for i in ids]
    assert owners == [liveness.owner()] * 2

    def unreachable(*args, **kwargs):
        raise ConnectionError("the API went away")

    monkeypatch.setattr("prefect.client.orchestration.get_client", unreachable)
    assert liveness.claim_flow_run(flow_run=type("Run", (), {"id": uuid.uuid4()})) is False


def test_prefect_api_goes_on_when_dead_runs_cannot_be_checked(prefect_server, monkeypatch):
    from nlupdate.orchestration.flows import liveness
    from nlupdate.orchestration.flows.server import prefect_api

    def broken(say):
        raise RuntimeError("API too old")

    monkeypatch.setattr(liveness, "mark_dead_runs_crashed", broken)
    said: list[str] = []
    with prefect_api(said.append) as url:
        assert url == prefect_server
    assert said[-1] == "note: could not check for runs left running by killed processes (RuntimeError: API too old)"
