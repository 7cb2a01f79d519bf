"""Scheduled studies: ``nlupdate schedule`` registers, lists and deletes Prefect deployments,
``nlupdate serve`` runs them, each run writing its own complete archive.

* Mistakes in the command line or the study are one line and exit code 2, before any
  server is asked (in this process, through :func:`nlupdate.app.cli.main`).
* A cron schedule is registered on the session's Prefect server (in this process) and read
  back from the API as the server stores it; ``list`` shows it, ``delete`` removes it.
* A real ``prefect server start`` (its scheduler creates the runs) with a 2-second
  interval and ``nlupdate serve``: at least two scheduled runs complete, each with its own
  archive (manifest.json, report.md); SIGINT stops serve at once with exit code 130.
"""
from __future__ import annotations

import contextlib
import hashlib
import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import httpx
import pytest

from nlupdate.app.cli import main

import prefect_home
from cli_runs import run_cli
from patience import HANG_S
from prefect_settings import talking_to
from studies import small_two_dof_study, write_study

ROOT = Path(__file__).resolve().parents[1]
FLOW = "scheduled study"


def nlupdate(*args: object, cwd: Path, env: dict, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "nlupdate", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, env=env, timeout=timeout)


def api_env(url: str, **extra: str) -> dict:
    return {**os.environ, "PREFECT_API_URL": url, **extra}


def in_process(capsys, url: str, *args: object) -> tuple[int, str, str]:
    """``nlupdate ARGS`` in this process with Prefect talking to ``url``; (exit code, stdout,
    stderr)."""
    with talking_to(url):
        return run_cli(capsys, *args)


@pytest.fixture(autouse=True)
def own_registrations(tmp_path, monkeypatch):
    """Each test its own nlupdate folder: registrations are the user's, not the server's."""
    monkeypatch.setenv("NLUPDATE_CONFIG_DIR", str(tmp_path / "nlupdate-config"))


@pytest.fixture
def study(two_dof_study_file) -> Path:
    """The two-dof study with its model path made absolute, so it runs from anywhere."""
    return two_dof_study_file


def one_line_error(capsys, code: int, expected: int, *fragments: str) -> str:
    stderr = capsys.readouterr().err.strip()
    assert code == expected, (code, stderr)
    assert "Traceback" not in stderr and 1 <= len(stderr.splitlines()) <= 2, stderr
    for fragment in fragments:
        assert fragment in stderr.splitlines()[0], (fragment, stderr)
    return stderr


# ------------------------------------------------------------------ mistakes, before any server
@pytest.mark.parametrize("args, fragments", [
    (["--cron", "0 2 * *"], ("--cron '0 2 * *': Invalid cron string", "five fields")),
    (["--cron", "61 * * * *"], ("--cron '61 * * * *': Invalid cron string",)),
    (["--cron", "0 2 * * *", "--interval", "5"], ("exactly one of --cron EXPR and --interval SECONDS, not both",)),
    ([], ("exactly one of --cron EXPR and --interval SECONDS",)),
    (["--cron", "0 2 * * *", "--timezone", "Mars/Base"], ("--timezone 'Mars/Base': Invalid timezone",)),
    (["--interval", "5", "--timezone", "UTC"], ("--timezone goes with --cron only",)),
    (["--interval", "5", "--name", "a/b"], ("--name 'a/b': a schedule name must not",)),
    (["--interval", "5", "--limit", "2"], ("--limit goes with --serve only",)),
])
def test_bad_schedules_are_one_line_before_registering(tmp_path, study, capsys, args, fragments):
    code = main(["schedule", str(study), *args, "--out", str(tmp_path / "results")])
    one_line_error(capsys, code, 2, *fragments)
    assert not (tmp_path / "results").exists()


def test_a_missing_or_broken_study_is_one_line(tmp_path, study, capsys):
    code = main(["schedule", str(tmp_path / "missing.toml"), "--cron", "0 2 * * *"])
    one_line_error(capsys, code, 2, f"{tmp_path / 'missing.toml'}: no such file (study file)")
    broken = tmp_path / "broken.toml"
    broken.write_text(study.read_text().replace("samples = 8", "samples = -8"))
    code = main(["schedule", str(broken), "--interval", "60"])
    one_line_error(capsys, code, 2, "broken.toml", "[identification]", "samples")


@pytest.mark.parametrize("args, fragments", [
    (["--interval", "0"], ("argument --interval: expected an integer ≥ 1, got '0'",)),
    (["--interval", "1.5"], ("argument --interval: expected an integer ≥ 1",)),
])
def test_interval_below_one_second_is_refused(study, capsys, args, fragments):
    with pytest.raises(SystemExit) as stop:
        main(["schedule", str(study), *args])
    one_line_error(capsys, stop.value.code, 2, *fragments)


@pytest.mark.parametrize("args, fragment", [
    (["list", "--cron", "0 2 * * *"], "schedule list takes --json only, not --cron"),
    (["delete"], "schedule delete needs the NAME of a scheduled study"),
    (["delete", "x", "--out", "r"], "schedule delete takes a NAME only, not --out"),
])
def test_list_and_delete_take_their_own_arguments(capsys, args, fragment):
    one_line_error(capsys, main(["schedule", *args]), 2, fragment)


def test_a_server_that_does_not_answer_is_one_line_saying_what_to_start(tmp_path):
    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        dead = f"http://127.0.0.1:{s.getsockname()[1]}/api"
    result = nlupdate("schedule", "list", cwd=tmp_path, env=api_env(dead), timeout=60)
    assert result.returncode == 1 and len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert f"the Prefect API at PREFECT_API_URL={dead} does not answer" in result.stderr
    assert "`prefect server start`" in result.stderr and "PREFECT_API_URL=http://127.0.0.1:4200/api" in result.stderr


# ------------------------------------------------------------------ a cron schedule on the API
def read_deployment(url: str, name: str) -> httpx.Response:
    return httpx.get(f"{url}/deployments/name/{FLOW}/{name}", timeout=30)


def test_cron_schedule_is_registered_listed_and_deleted(tmp_path, study, prefect_server, capsys, monkeypatch):
    """In this process, against the session's server."""
    monkeypatch.chdir(tmp_path)

    def cli(*args: object) -> tuple[int, str, str]:
        return in_process(capsys, prefect_server, *args)

    code, out, err = cli("schedule", study, "--cron", "0 2 * * *", "--workers", "1", "--out", "results",
                         "--cache-dir", "cache")
    assert code == 0, err
    assert out.startswith("registered scheduled study 'two-dof': cron \"0 2 * * *\" (UTC)"), out

    deployment = read_deployment(prefect_server, "two-dof")
    assert deployment.status_code == 200, deployment.text
    deployment = deployment.json()
    assert [s["schedule"]["cron"] for s in deployment["schedules"]] == ["0 2 * * *"]
    assert all(s["active"] for s in deployment["schedules"]) and not deployment["paused"]
    # the API says only which registration to run; the rest stays in the user's own folder
    sha = hashlib.sha256(study.read_text().encode()).hexdigest()
    assert deployment["parameters"] == {"name": "two-dof", "study_sha256": sha}
    assert deployment["entrypoint"] == "nlupdate.orchestration.flows.schedule.scheduled_study"

    code, _, err = cli("schedule", study, "--interval", "60")
    assert code == 2 and "a scheduled study named 'two-dof' exists" in err, err
    assert "--replace" in err

    code, out, err = cli("schedule", "list")
    assert code == 0, err
    line = next(line for line in out.splitlines() if line.startswith("two-dof:"))
    assert line.startswith('two-dof: cron "0 2 * * *" (UTC); next run ')
    assert f"study {study.resolve()} (sha256 {sha[:12]}) → " in line
    as_json = json.loads(cli("schedule", "list", "--json")[1])
    entry = next(e for e in as_json if e["name"] == "two-dof")
    assert entry["schedule"] == 'cron "0 2 * * *" (UTC)' and entry["results_root"] == str(tmp_path / "results")
    assert entry["workers"] == 1 and entry["cache_dir"] == str(tmp_path / "cache") and entry["server_drift"] is None

    code, out, err = cli("schedule", "delete", "two-dof")
    assert code == 0 and "deleted scheduled study 'two-dof'" in out, err
    assert read_deployment(prefect_server, "two-dof").status_code == 404
    code, _, err = cli("schedule", "delete", "two-dof")
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert "no scheduled study named 'two-dof'" in err


# ------------------------------------------------------------------ a real server: runs fire, serve runs them
def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def stop_group(process: subprocess.Popen, sig: int = signal.SIGTERM, timeout_s: float = 10) -> None:
    """Stop ``process`` and everything it started (its own process group)."""
    if process.poll() is None:
        try:
            os.killpg(process.pid, sig)
            process.wait(timeout=timeout_s)
        except (ProcessLookupError, subprocess.TimeoutExpired):
            pass
    try:
        os.killpg(process.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    process.wait(timeout=HANG_S)


@contextlib.contextmanager
def prefect_server_process(tmp_path: Path, **extra_env: str):
    """``prefect server start`` (scheduler included) in its own PREFECT_HOME, on a free
    port; yields its API URL. Its scheduler looks for new deployments every second
    (Prefect's default: 5 s), so a test waits for runs, not for the scheduler's loop, and
    creates 3 runs ahead of time, not Prefect's 100: for a 2-second interval it wrote 100
    scheduled runs (and their events) to the server's SQLite database while serve's runs
    wrote theirs — 107 flow runs on the server at the end of the interval test, 10 with 3
    ahead, the same runs served. The home starts from the session's migrated database
    (:mod:`prefect_home`)."""
    prefect_home.seed(tmp_path / "server-home")
    port = free_port()
    env = {k: v for k, v in os.environ.items() if k != "PREFECT_API_URL"}
    env.update(PREFECT_HOME=str(tmp_path / "server-home"), PREFECT_SERVER_ANALYTICS_ENABLED="false",
               PREFECT_UI_ENABLED="false", PREFECT_SERVER_SERVICES_SCHEDULER_RECENT_DEPLOYMENTS_LOOP_SECONDS="1",
               PREFECT_SERVER_SERVICES_SCHEDULER_MAX_RUNS="3", **extra_env)
    with open(tmp_path / "server.log", "w") as log:
        server = subprocess.Popen([sys.executable, "-m", "prefect", "server", "start", "--host", "127.0.0.1",
                                   "--port", str(port)], env=env, stdout=log, stderr=subprocess.STDOUT,
                                  start_new_session=True)
    url = f"http://127.0.0.1:{port}/api"
    try:
        deadline = time.monotonic() + 300  # only ends a hang: ~4 s of CPU, far longer on a loaded machine
        while True:
            assert server.poll() is None, (tmp_path / "server.log").read_text()
            try:
                if httpx.get(f"{url}/health", timeout=5).status_code == 200:
                    break
            except httpx.HTTPError:
                pass
            assert time.monotonic() < deadline, (tmp_path / "server.log").read_text()
            time.sleep(0.5)
        yield url
    finally:
        stop_group(server)


@pytest.fixture(scope="module")
def real_server(tmp_path_factory):
    """One ``prefect server start`` for the module's two serve tests (a server's start is
    ~4 s of CPU); each test registers its study in its own nlupdate folder, and the
    interval test deletes its schedule (and the runs it left scheduled) as it ends."""
    with prefect_server_process(tmp_path_factory.mktemp("real-server")) as url:
        yield url


def completed_runs(url: str) -> list[dict]:
    """The study's completed flow runs; none yet when the server does not answer within 30 s
    (it once did not while a scheduled run was writing to its database, on an idle machine:
    the callers' own deadline decides, not one poll)."""
    body = {"flows": {"name": {"any_": [FLOW]}}, "flow_runs": {"state": {"type": {"any_": ["COMPLETED"]}}}}
    try:
        return httpx.post(f"{url}/flow_runs/filter", json=body, timeout=30).json()
    except httpx.TimeoutException:
        return []


def complete_archives(root: Path) -> list[Path]:
    return sorted(p.parent for p in root.glob("two-dof/*/manifest.json") if (p.parent / "report.md").is_file())


def test_serve_runs_an_interval_schedule_each_run_with_its_own_archive(tmp_path, real_server, capsys):
    """The small two-dof study (what it computes does not matter here), every 2 s,
    registered in this process and served by ``nlupdate serve`` in its own."""
    started = time.monotonic()
    study = write_study(tmp_path / "study.toml", small_two_dof_study())
    results = tmp_path / "results"
    env = api_env(real_server, PREFECT_RUNNER_POLL_FREQUENCY="1")
    code, _, err = in_process(capsys, real_server, "schedule", study, "--interval", "2", "--workers", "2", "--out",
                              results, "--cache-dir", tmp_path / "cache")
    assert code == 0, err

    serve = subprocess.Popen([sys.executable, "-m", "nlupdate", "serve"], cwd=tmp_path, env=env, text=True,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
    out, err = LineReader(serve.stdout), LineReader(serve.stderr)
    try:
        # serve prints a run's line as it relays the run's output, which can come after the
        # server has the run completed: wait for the lines too before interrupting
        deadline = time.monotonic() + 600  # only ends a hang
        while (len(completed_runs(real_server)) < 2 or len(complete_archives(results)) < 2
               or sum(" finished in " in line for line in out.lines) < 2):
            assert serve.poll() is None, (out.lines, err.lines)
            assert time.monotonic() < deadline, (completed_runs(real_server), complete_archives(results), out.lines)
            time.sleep(0.25)
        serve.send_signal(signal.SIGINT)
        serve.wait(timeout=HANG_S)  # it stops itself within its grace time (3 s) on an idle machine
        stdout, stderr = out.text(), err.text()
    finally:
        stop_group(serve)

    assert serve.returncode == 130, (serve.returncode, stderr)
    assert stderr.strip().splitlines()[-1] == ("nlupdate serve: interrupted; stopped serving; the schedules stay "
                                               "registered (nlupdate schedule list); a run in progress, if any, was stopped")
    assert "Traceback" not in stderr, stderr
    lines = stdout.splitlines()
    assert "serving 1 scheduled study: two-dof (every 2 s); Ctrl-C stops" in lines[0], stdout
    finished = [line for line in lines if " finished in " in line]
    assert len(finished) >= 2 and all(line.split("UTC  ")[1].startswith("two-dof: run '") for line in finished), stdout

    archives = complete_archives(results)
    assert len(archives) >= 2 and len(set(archives)) == len(archives)
    for archive in archives[:2]:
        manifest = json.loads((archive / "manifest.json").read_text())
        assert manifest["run"]["scheduled"].startswith(f"deployment 'two-dof' of flow '{FLOW}', flow run ")
        assert f"archive {archive}" in stdout
    # serving changed nothing that was registered, and Ctrl-C left the schedule active
    deployment = read_deployment(real_server, "two-dof").json()
    assert not deployment["paused"] and all(s["active"] for s in deployment["schedules"])
    assert [s["schedule"]["interval"] for s in deployment["schedules"]] == [2.0]
    print(f"scheduled runs test: {time.monotonic() - started:.1f} s after the server answered")
    code, out, err = in_process(capsys, real_server, "schedule", "delete", "two-dof")
    assert code == 0 and "deleted scheduled study 'two-dof' and its future runs" in out, err
    assert read_deployment(real_server, "two-dof").status_code == 404


class LineReader:
    """The lines of a text stream, read on a thread as they come (``lines``); ``text()`` all
    of them once the stream has ended."""

    def __init__(self, stream) -> None:
        self.lines: list[str] = []
        self._thread = threading.Thread(target=self._read, args=(stream,), daemon=True)
        self._thread.start()

    def _read(self, stream) -> None:
        for line in stream:
            self.lines.append(line.rstrip("\n"))

    def text(self, timeout_s: float = 10) -> str:
        self._thread.join(timeout_s)
        return "\n".join(self.lines) + "\n"


def api_call(method: str, url: str, **kwargs) -> httpx.Response:
    """One API request, retried while a busy server answers 503 (SQLite locked under load)."""
    deadline = time.monotonic() + HANG_S
    while True:
        response = httpx.request(method, url, timeout=30, **kwargs)
        if response.status_code != 503 or time.monotonic() > deadline:
            return response
        time.sleep(0.5)


def flow_run_state(url: str, run_id: str) -> str:
    return api_call("GET", f"{url}/flow_runs/{run_id}").json()["state"]["type"]


def test_serve_runs_only_the_registered_study_whatever_the_api_asks(tmp_path, study, real_server, capsys):
    """The attacks of the issue: any local process can use the Prefect API. A flow run
    created with its own study file (a CalculiX study whose "solver" is a script), one
    naming the registered study with another hash, and a deployment PATCHed to other
    parameters: nothing runs, each run is failed with one line, `schedule list` reports
    the change and serve restores the registered deployment."""
    marker = tmp_path / "the-script-ran"
    script = tmp_path / "evil-ccx"
    script.write_text(f"#!/bin/sh\ntouch {marker}\n")
    script.chmod(0o755)
    evil = tmp_path / "evil.toml"
    evil.write_text((ROOT / "tests" / "data" / "studies" / "calculix_tbeam_E.toml").read_text().replace(
        'work_root = "ccx_runs"', f'work_root = "{tmp_path / "runs"}"\nexecutable = "{script}"'))
    env = api_env(real_server, PREFECT_RUNNER_POLL_FREQUENCY="1")
    code, _, err = in_process(capsys, real_server, "schedule", study, "--cron", "0 2 1 1 *", "--out",
                              tmp_path / "results", "--cache-dir", tmp_path / "cache")
    assert code == 0, err
    deployment = read_deployment(real_server, "two-dof").json()
    sha = deployment["parameters"]["study_sha256"]

    serve = subprocess.Popen([sys.executable, "-m", "nlupdate", "serve"], cwd=tmp_path, env=env, text=True,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
    try:
        first = serve.stdout.readline()  # serving starts after the deployment is applied
        assert "serving 1 scheduled study" in first, (first, serve.poll())
        created = []
        for parameters in ({"study_file": str(evil), "results_root": str(tmp_path / "evil-results"), "workers": 1,
                            "cache_dir": str(tmp_path / "evil-cache")},
                           {"name": "two-dof", "study_sha256": "0" * 64},
                           {"name": "not-registered", "study_sha256": sha}):
            response = api_call("POST", f"{real_server}/deployments/{deployment['id']}/create_flow_run",
                                json={"parameters": parameters})
            if response.status_code < 300:  # else the API itself refused the parameters
                created.append(response.json()["id"])
        patched = api_call("PATCH", f"{real_server}/deployments/{deployment['id']}",
                           json={"parameters": {"name": "two-dof", "study_sha256": "f" * 64}})
        assert patched.status_code < 300, patched.text
        assert read_deployment(real_server, "two-dof").json()["parameters"]["study_sha256"] == "f" * 64
        response = api_call("POST", f"{real_server}/deployments/{deployment['id']}/create_flow_run", json={})
        assert response.status_code < 300, response.text
        created.append(response.json()["id"])
        assert len(created) >= 3

        _, listed, warned = in_process(capsys, real_server, "schedule", "list")
        assert f"study {study.resolve()} (sha256 {sha[:12]})" in listed
        assert "warning: the server's deployment was changed: parameters" in warned, warned

        deadline = time.monotonic() + 600  # only ends a hang
        while any(flow_run_state(real_server, run) not in ("FAILED", "CRASHED", "COMPLETED") for run in created):
            assert serve.poll() is None, serve.communicate()
            assert time.monotonic() < deadline, [flow_run_state(real_server, run) for run in created]
            time.sleep(0.25)
        serve.send_signal(signal.SIGINT)
        stdout, stderr = serve.communicate(timeout=HANG_S)
    finally:
        stop_group(serve)
    assert [flow_run_state(real_server, run) for run in created] == ["FAILED"] * len(created), stdout
    messages = [api_call("GET", f"{real_server}/flow_runs/{run}").json()["state"]["message"] for run in created]
    assert all(" REFUSED: " in message and "nothing was run" in message for message in messages), messages
    assert not marker.exists() and not (tmp_path / "evil-results").exists() and not (tmp_path / "runs").exists()
    assert not list((tmp_path / "results").rglob("manifest.json"))  # not even the registered study ran
    refused = [line for line in stdout.splitlines() if " REFUSED: " in line]
    assert any("no study named 'not-registered' is registered" in line for line in refused), stdout
    assert sum("the registered study has" in line for line in refused) == 2, stdout
    # patched after serve started: a restarted serve finds the change and restores the registration
    assert read_deployment(real_server, "two-dof").json()["parameters"]["study_sha256"] == "f" * 64
    restarted = subprocess.Popen([sys.executable, "-m", "nlupdate", "serve"], cwd=tmp_path, env=env, text=True,
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
    try:
        deadline = time.monotonic() + 300  # only ends a hang
        while read_deployment(real_server, "two-dof").json()["parameters"]["study_sha256"] != sha:
            assert restarted.poll() is None, restarted.communicate()
            assert time.monotonic() < deadline
            time.sleep(0.5)
        restarted.send_signal(signal.SIGTERM)  # as a service manager stops it
        stdout, stderr = restarted.communicate(timeout=HANG_S)
    finally:
        stop_group(restarted)
    assert "two-dof: the server's deployment was changed: parameters" in stdout and "restoring" in stdout, stdout
    assert restarted.returncode == 143 and "never awaited" not in stderr and "Traceback" not in stderr, stderr
    assert stderr.strip().splitlines()[-1].startswith("nlupdate serve: interrupted (SIGTERM); stopped serving"), stderr


def test_a_server_with_authentication_is_used_with_its_password_and_refused_without(tmp_path, study):
    """The README's advice for a shared server: basic authentication. Without the password
    nlupdate says in one line what to set; with it, scheduling works."""
    with prefect_server_process(tmp_path, PREFECT_SERVER_API_AUTH_STRING="alice:s3cret") as url:
        refused = nlupdate("schedule", "list", cwd=tmp_path, env=api_env(url))
        assert refused.returncode == 1 and len(refused.stderr.strip().splitlines()) == 1, refused.stderr
        assert "refused the request (401 Unauthorized)" in refused.stderr and "PREFECT_API_AUTH_STRING" in refused.stderr
        env = api_env(url, PREFECT_API_AUTH_STRING="alice:s3cret")
        registered = nlupdate("schedule", study, "--cron", "0 2 * * *", cwd=tmp_path, env=env)
        assert registered.returncode == 0, registered.stderr
        listed = nlupdate("schedule", "list", cwd=tmp_path, env=env)
        assert listed.returncode == 0 and listed.stdout.startswith("two-dof: cron"), listed.stderr
