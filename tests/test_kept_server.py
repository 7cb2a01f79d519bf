"""The Prefect server kept for the runs of one database (server_lease, server_process).

A run starts the server when none is running and lets go of it at its end; the next run
uses the same one; the server stops by itself once no run has used it for the keep time
(``NLUPDATE_PREFECT_SERVER_KEEP_S``), also when the runs were killed. The runs' history is
on it: its API (on 127.0.0.1) answers for the flow run and its task runs.
"""
from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import httpx
import pytest

import prefect_home
from studies import small_two_dof_study, write_study

HOLD = """
import sys, time
from nlupdate.orchestration.flows import server_lease
from nlupdate.orchestration.flows.server import KeptServer
server = KeptServer()
server.wait(600)  # only ends a hang: a server starting on a loaded machine answers when it answers
print(server.pid, server.port, flush=True)
time.sleep(600)
"""


def gone(pid: int) -> bool:
    """Whether process ``pid`` has ended (a zombie counts: it serves nothing)."""
    from nlupdate.orchestration.flows.server_lease import serving

    return not serving(pid)


def wait_until(condition, patience_s: float = 300.0) -> bool:
    """Whether ``condition()`` came to hold, polled until it does (``patience_s`` only ends
    a wait for something that will not happen: the tests assert the condition, never how
    long it took)."""
    deadline = time.monotonic() + patience_s
    while not condition() and time.monotonic() < deadline:
        time.sleep(0.1)
    return condition()


@pytest.fixture
def own_home(tmp_path, monkeypatch):
    """An environment with a Prefect home of the test's own (the session's database copied
    in), so that runs in it find no server but the ones the test makes."""
    home = tmp_path / "prefect-home"
    prefect_home.seed(home)
    env = {**{k: v for k, v in os.environ.items() if k != "PREFECT_API_URL"}, "PREFECT_HOME": str(home)}
    return home, env


def test_the_keep_time_is_checked():
    from nlupdate.orchestration.flows.server_lease import KEEP_ENV, keep_seconds

    for text, seconds in (("", 300.0), ("0", 0.0), ("2.5", 2.5)):
        os.environ[KEEP_ENV] = text
        try:
            assert keep_seconds() == seconds
        finally:
            os.environ[KEEP_ENV] = "0"
    for text in ("ten", "-1", "nan"):
        os.environ[KEEP_ENV] = text
        try:
            with pytest.raises(ValueError, match=f"{KEEP_ENV}='{text}': expected seconds, a number ≥ 0"):
                keep_seconds()
        finally:
            os.environ[KEEP_ENV] = "0"


def test_runs_at_once_share_one_server_which_stops_after_the_keep_time_once_all_are_killed(own_home):
    """Two runs take the server together: one starts it, the other uses it. Both are
    killed (SIGKILL: no clean-up); while one still holds it the server outlives the other
    by more than its keep time (3 s), and once both are gone it stops and its record is
    gone (that it is kept after its last run: the next test)."""
    home, env = own_home
    env = {**env, "NLUPDATE_PREFECT_SERVER_KEEP_S": "3"}
    holders = [subprocess.Popen([sys.executable, "-c", HOLD], env=env, text=True, stdout=subprocess.PIPE)
               for _ in range(2)]
    try:
        answers = [holder.stdout.readline().split() for holder in holders]
        assert answers[0] == answers[1] and len(answers[0]) == 2, answers
        pid, port = map(int, answers[0])
        assert httpx.get(f"http://127.0.0.1:{port}/api/health").status_code == 200
        holders[0].kill()
        holders[0].wait()
        time.sleep(4)  # longer than the keep time: the other run still holds it
        assert not gone(pid)
        holders[1].kill()
        holders[1].wait()
        assert wait_until(lambda: gone(pid))
        record = home / "nlupdate-server" / "server.json"
        assert not record.exists()
    finally:
        for holder in holders:
            holder.kill()
            holder.wait()


def test_a_server_whose_prefect_home_is_deleted_stops_at_once(own_home):
    """A server kept for 600 s whose Prefect home is then deleted (as a test session's
    temporary home is) can be found by no run: it stops within seconds, not after its
    keep time (its watchdog died on the missing lease file before, and each test session
    left its workers' servers running)."""
    import shutil

    home, env = own_home
    env = {**env, "NLUPDATE_PREFECT_SERVER_KEEP_S": "600"}
    holder = subprocess.Popen([sys.executable, "-c", HOLD], env=env, text=True, stdout=subprocess.PIPE)
    try:
        pid, port = map(int, holder.stdout.readline().split())
        assert httpx.get(f"http://127.0.0.1:{port}/api/health").status_code == 200
        holder.kill()
        holder.wait()
        time.sleep(1)
        assert not gone(pid)  # kept: its keep time is 600 s
        shutil.rmtree(home)
        assert wait_until(lambda: gone(pid))
    finally:
        holder.kill()
        holder.wait()


def test_a_second_run_in_process_uses_the_server_the_first_kept(tmp_path, monkeypatch):
    """Two runs in turn (prefect_api, as run_study_flow uses it): the second says the
    server is already running and uses the same one; it still answers after both."""
    from nlupdate.orchestration.flows import server, server_lease

    folder = tmp_path / "server-state"
    folder.mkdir()
    monkeypatch.setattr(server_lease, "state_folder", lambda: folder)
    monkeypatch.setenv("NLUPDATE_PREFECT_SERVER_KEEP_S", "60")
    monkeypatch.delenv("PREFECT_API_URL", raising=False)
    said: list[str] = []
    try:
        for _ in range(2):
            with server.prefect_api(said.append) as url:
                assert httpx.get(f"{url}/health").status_code == 200
        lines = [line for line in said if line.startswith("Prefect server:")]
        assert lines == [f"Prefect server: {url} (started for this run; kept 60 s after the last run using it)",
                         f"Prefect server: {url} (already running; kept 60 s after the last run using it)"], said
        assert httpx.get(f"{url}/health").status_code == 200
    finally:
        record = server_lease.read_record(folder)
        if record is not None:
            os.kill(record["pid"], signal.SIGTERM)
            assert wait_until(lambda: gone(record["pid"]))


def cli_run(study: Path, out: Path, env: dict) -> list[str]:
    result = subprocess.run([sys.executable, "-m", "nlupdate", "run", str(study), "--out", str(out)], cwd=study.parent,
                            env=env, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, (result.stdout, result.stderr)
    return result.stdout.splitlines()


@pytest.mark.slow  # two CLI runs: 55 s at load 6 (the in-process test above is the fast version)
def test_a_second_run_uses_the_kept_server_and_both_are_in_its_api(own_home, tmp_path):
    """``nlupdate run`` twice (the second with its cache emptied, so that it runs its
    flow): the second finds the server the first started; both flow runs are on it,
    completed, with their steps as task runs. Stopped at the end by the test (SIGTERM)."""
    home, env = own_home
    env = {**env, "NLUPDATE_PREFECT_SERVER_KEEP_S": "120"}
    study = write_study(tmp_path / "study.toml", small_two_dof_study())
    record = home / "nlupdate-server" / "server.json"
    pid = None
    try:
        first = cli_run(study, tmp_path / "first", {**env, "NLUPDATE_CACHE_DIR": str(tmp_path / "cache-1")})
        pid = json.loads(record.read_text())["pid"]
        second = cli_run(study, tmp_path / "second", {**env, "NLUPDATE_CACHE_DIR": str(tmp_path / "cache-2")})
        lines = [[line for line in out if line.startswith("Prefect server:")] for out in (first, second)]
        assert lines[0][0].endswith("(started for this run; kept 120 s after the last run using it)"), first
        assert lines[1] == [lines[0][0].replace("started for this run", "already running")], second
        url = lines[0][0].split()[2]
        assert not gone(pid) and httpx.get(f"{url}/health").status_code == 200  # kept after the runs
        for folder in ("first", "second"):
            manifest = json.loads(next((tmp_path / folder).rglob("manifest.json")).read_text())
            flow_run_id = manifest["run"]["flow_run_id"]
            flow_run = httpx.get(f"{url}/flow_runs/{flow_run_id}").json()
            assert flow_run["state"]["type"] == "COMPLETED", flow_run
            def recorded() -> tuple[list, set]:
                runs = httpx.post(f"{url}/task_runs/filter", json={"flow_runs": {"id": {"any_": [flow_run_id]}}}).json()
                return runs, {run["name"].split(":")[0].split(" ")[0] for run in runs}

            def complete() -> bool:
                runs, names = recorded()
                return {"measured", "identification"} <= names and all(run["state"]["type"] == "COMPLETED" for run in runs)

            # the server writes the task runs' states from their events once a second, after the run may have ended
            wait_until(complete)
            task_runs, names = recorded()
            assert {"measured", "identification"} <= names, names
            assert all(task_run["state"]["type"] == "COMPLETED" for task_run in task_runs), task_runs
    finally:
        if pid is not None and not gone(pid):
            os.kill(pid, signal.SIGTERM)
            assert wait_until(lambda: gone(pid))


TAKEN_FIRST = """
import socket, sys, time
from nlupdate.orchestration.flows import server
taken = socket.socket()
taken.bind(("127.0.0.1", 0))
taken.listen()
ports = [taken.getsockname()[1]]
free = server._free_port
server._free_port = lambda: ports.pop() if ports else free()
kept = server.KeptServer()
kept.wait(600)
print(kept.pid, kept.port, flush=True)
time.sleep(600)
"""


def test_a_server_that_cannot_bind_its_port_is_replaced_once_for_runs_waiting_on_it(own_home):
    """The first run's server finds its port taken (uvicorn exits with code 3) and, before
    the first run notices (it is stopped: SIGSTOP), a second run comes for the server: the
    second starts one under the start lock, and the first, let go on, uses that one — both
    end on one server, which answers (before, the second found no live server and failed,
    or started its own beside the first's replacement: two servers for one database, as the
    suite saw under load)."""
    home, env = own_home
    env = {**env, "NLUPDATE_PREFECT_SERVER_KEEP_S": "3"}
    record = home / "nlupdate-server" / "server.json"
    first = subprocess.Popen([sys.executable, "-c", TAKEN_FIRST], env=env, text=True, stdout=subprocess.PIPE)
    holders = [first]
    try:
        assert wait_until(record.exists)
        doomed = int(json.loads(record.read_text())["pid"])
        first.send_signal(signal.SIGSTOP)
        assert wait_until(lambda: gone(doomed))  # its port was taken: it exits, unseen by the first run
        holders.append(subprocess.Popen([sys.executable, "-c", HOLD], env=env, text=True, stdout=subprocess.PIPE))
        second = holders[1].stdout.readline().split()
        first.send_signal(signal.SIGCONT)
        answers = [first.stdout.readline().split(), second]
        assert answers[0] == answers[1] and len(answers[0]) == 2, answers
        pid, port = map(int, answers[0])
        assert pid != doomed
        assert httpx.get(f"http://127.0.0.1:{port}/api/health").status_code == 200
        assert json.loads(record.read_text()) == {"pid": pid, "port": port}
    finally:
        first.send_signal(signal.SIGCONT)
        for holder in holders:
            holder.kill()
            holder.wait()
        with contextlib.suppress(OSError, ValueError, KeyError):
            os.kill(int(json.loads(record.read_text())["pid"]), signal.SIGTERM)
