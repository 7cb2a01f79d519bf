"""Process runner: fresh directories, logs, failures, timeouts, parallel runs."""
from __future__ import annotations

import os
import re
import signal
import stat
import sys
import textwrap
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
from patience import HANG_S, timed_out_once_ready, written

from nlupdate.fe.adapters import runner as runner_module
from nlupdate.fe.adapters.base import AdapterError
from nlupdate.fe.adapters.runner import (
    ExecutableNotFoundError,
    ProcessRunner,
    RunTimeoutError,
    resolve_executable,
    write_text_atomic,
)


def make_script(path: Path, body: str) -> Path:
    """An executable Python script at ``path``."""
    path.write_text(f"#!{sys.executable}\n" + textwrap.dedent(body))
    path.chmod(path.stat().st_mode | stat.S_IXUSR | stat.S_IXGRP | stat.S_IXOTH)
    return path


@pytest.fixture
def echo_exe(tmp_path: Path) -> Path:
    return make_script(
        tmp_path / "fake_solver",
        """
        import os, sys
        print("stdout line", " ".join(sys.argv[1:]))
        print("stderr line", file=sys.stderr)
        open("cwd.txt", "w").write(os.getcwd() + "\\n" + os.environ.get("RUNNER_TEST_VAR", ""))
        """,
    )


def failure_of(exe: Path, tmp_path: Path) -> tuple[str, Path]:
    """Run ``exe`` once through a :class:`ProcessRunner`; (its error message, the run directory)."""
    runner = ProcessRunner(str(exe), tmp_path / "runs")
    run_dir = runner.new_run_dir("k1")
    with pytest.raises(AdapterError) as info:
        runner.run([], run_dir)
    return str(info.value), run_dir


def test_run_writes_log_in_fresh_directory(tmp_path: Path, echo_exe: Path) -> None:
    runner = ProcessRunner(str(echo_exe), tmp_path / "runs", env={"RUNNER_TEST_VAR": "xyz"}, log_name="solver.log")
    run_dir = runner.new_run_dir("abc123")
    result = runner.run(["-i", "job"], run_dir)
    assert result.returncode == 0
    assert result.run_dir == run_dir == tmp_path / "runs" / "abc123"
    assert result.log_path == run_dir / "solver.log"
    log = result.log_path.read_text()
    assert "stdout line -i job" in log and "stderr line" in log
    cwd, variable = (run_dir / "cwd.txt").read_text().splitlines()
    assert Path(cwd).resolve() == run_dir.resolve()
    assert variable == "xyz"
    assert result.wall_time_s > 0


def test_run_directories_are_never_reused(tmp_path: Path) -> None:
    runner = ProcessRunner("true", tmp_path)
    first, second, third = (runner.new_run_dir("key") for _ in range(3))
    assert [p.name for p in (first, second, third)] == ["key", "key-2", "key-3"]
    with pytest.raises(ValueError, match="plain file name"):
        runner.new_run_dir("../escape")


def test_nonzero_exit_names_directory_log_and_last_lines(tmp_path: Path) -> None:
    exe = make_script(
        tmp_path / "failing",
        """
        import sys
        for i in range(100):
            print(f"progress line {i}")
        print("fatal: matrix is singular", file=sys.stderr)
        sys.exit(3)
        """,
    )
    message, run_dir = failure_of(exe, tmp_path)
    assert "exited with code 3" in message
    assert str(run_dir) in message and str(run_dir / "run.log") in message
    assert "fatal: matrix is singular" in message and "progress line 99" in message
    assert "progress line 10\n" not in message  # only the tail of the log is quoted


def test_a_crash_by_signal_names_the_signal_directory_and_log(tmp_path: Path) -> None:
    """A solver that dies of a segmentation fault (or is killed) has no exit code: the
    signal is named, with the run directory and the end of its log."""
    exe = make_script(
        tmp_path / "crashing",
        """
        import os, signal
        print("assembling the stiffness matrix", flush=True)
        os.kill(os.getpid(), signal.SIGSEGV)
        """,
    )
    message, run_dir = failure_of(exe, tmp_path)
    assert "crashing was killed by signal 11" in message
    assert f"run directory: {run_dir}" in message and f"log: {run_dir / 'run.log'}" in message
    assert "assembling the stiffness matrix" in message


def test_missing_executable_explains_how_to_install(tmp_path: Path) -> None:
    hint = "Install it with `apt-get install something`."
    with pytest.raises(ExecutableNotFoundError, match="was not found on PATH.*apt-get install something"):
        resolve_executable("surely-not-an-installed-solver-7f3a", hint)
    with pytest.raises(ExecutableNotFoundError, match="does not exist or is not executable"):
        resolve_executable(str(tmp_path / "missing" / "solver"), hint)
    with pytest.raises(ExecutableNotFoundError, match="no FE executable configured"):
        resolve_executable("", hint)
    not_executable = tmp_path / "plain.txt"
    not_executable.write_text("x")
    with pytest.raises(ExecutableNotFoundError):
        resolve_executable(str(not_executable), hint)
    runner = ProcessRunner("surely-not-an-installed-solver-7f3a", tmp_path, install_hint=hint)
    with pytest.raises(ExecutableNotFoundError, match="apt-get install something"):
        runner.run([], runner.new_run_dir("k"))


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    # A zombie (exited, not yet reaped by its parent) counts as dead.
    try:
        with open(f"/proc/{pid}/stat") as handle:
            return handle.read().split(")")[-1].split()[0] != "Z"
    except FileNotFoundError:
        return False


def ended(pid: int) -> bool:
    """Whether process ``pid`` ends (polled for :data:`patience.HANG_S`: killed processes end at once;
    the wait only lets a loaded machine reap them)."""
    deadline = time.monotonic() + HANG_S
    while _alive(pid) and time.monotonic() < deadline:
        time.sleep(0.05)
    return not _alive(pid)


def test_timeout_kills_the_whole_process_group(tmp_path: Path) -> None:
    exe = make_script(
        tmp_path / "hanging",
        f"""
        import subprocess, time
        child = subprocess.Popen([{sys.executable!r}, "-c", "import time; time.sleep(600)"])
        print("started child", flush=True)
        open("child.pid", "w").write(str(child.pid))
        time.sleep(600)
        """,
    )
    run_dir, message = time_out(exe, tmp_path, "child.pid", "timed out after {timeout} s")
    assert str(run_dir) in message and "started child" in message
    assert ended(int((run_dir / "child.pid").read_text())), "the solver's child process survived the timeout"


def test_timeout_kills_a_process_the_solver_started_in_a_session_of_its_own(tmp_path: Path) -> None:
    """A solver whose helper leaves the process group (setsid): killing the group alone
    missed it, and the message said it was killed."""
    exe = make_script(
        tmp_path / "daemonising",
        f"""
        import subprocess, time
        helper = subprocess.Popen([{sys.executable!r}, "-c", "import time; time.sleep(600)"], start_new_session=True)
        print("started helper", flush=True)
        open("helper.pid", "w").write(str(helper.pid))
        time.sleep(600)
        """,
    )
    run_dir, _ = time_out(exe, tmp_path, "helper.pid",
                          "timed out after {timeout} s; it was killed with the processes it started")
    assert ended(int((run_dir / "helper.pid").read_text())), "the helper in its own session survived the timeout"


def test_a_process_that_cannot_be_stopped_is_named(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import nlupdate.fe.adapters.runner as runner_module

    exe = make_script(tmp_path / "daemonising", f"""
        import subprocess, time
        helper = subprocess.Popen([{sys.executable!r}, "-c", "import time; time.sleep(600)"], start_new_session=True)
        open("helper.pid", "w").write(str(helper.pid))
        time.sleep(600)
        """)
    real_kill = os.kill

    def helpers() -> set[int]:  # of every run (a run killed before its helper started is run again)
        return {int(path.read_text()) for path in (tmp_path / "runs").glob("*/helper.pid") if written(path)}

    def refuses_for_the_helper(pid: int, sig: int) -> None:
        if sig == signal.SIGKILL and pid in helpers():
            raise PermissionError(1, "Operation not permitted")  # as for a process of another user
        real_kill(pid, sig)

    monkeypatch.setattr(runner_module.os, "kill", refuses_for_the_helper)
    monkeypatch.setattr(runner_module, "KILL_GRACE_S", 0.2)  # how long it waits for the helper to die
    try:
        time_out(exe, tmp_path, "helper.pid", r"could not be stopped \(pid \d+\): stop them yourself")
    finally:
        monkeypatch.undo()
        for helper in helpers():
            real_kill(helper, signal.SIGKILL)


FAKE_TASKKILL = """
import os, signal, sys
args = sys.argv[1:]
with open(LOG, "a") as log:
    log.write(" ".join(args) + "\\n")
root = int(args[args.index("/PID") + 1])

def children(pid):
    found = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as handle:
                    parent = int(handle.read().rsplit(")", 1)[1].split()[1])
            except (OSError, ValueError, IndexError):
                continue
            if parent == pid:
                found.append(int(entry))
    return found

tree, todo = [], [root]
while todo:  # /T: the process and every descendant
    pid = todo.pop()
    tree.append(pid)
    if "/T" in args:
        todo += children(pid)
for pid in tree:
    try:
        os.kill(pid, signal.SIGKILL)  # /F
    except ProcessLookupError:
        pass
"""


def time_out(exe: Path, tmp_path: Path, ready: str, message: str = "timed out after {timeout} s") -> tuple[Path, str]:
    """Run ``exe`` (which sleeps 600 s once it has written ``ready`` in its run folder) with
    a 1 s timeout, longer while it was killed before it wrote ``ready`` (a slow start-up:
    patience.timed_out_once_ready); check that it timed out saying ``message`` (a regular
    expression; ``{timeout}``: the timeout); (its run folder, the message)."""
    def attempt(timeout_s: float) -> tuple[Path, str]:
        runner = ProcessRunner(str(exe), tmp_path / "runs", timeout_s=timeout_s)
        run_dir = runner.new_run_dir("slow")
        # the program would have ended with 0 after its 600 s sleep: a runner that waited for it
        # raises nothing, so the timeout error is the behaviour, with no bet on the clock
        with pytest.raises(RunTimeoutError) as info:
            runner.run([], run_dir)
        return run_dir, str(info.value)

    timeout_s, (run_dir, text) = timed_out_once_ready(attempt, lambda outcome: written(outcome[0] / ready), 1.0)
    assert re.search(message.format(timeout=re.escape(str(timeout_s))), text), text
    return run_dir, text


def test_timeout_on_windows_kills_the_process_tree_with_taskkill(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Windows has no os.killpg: the runner calls taskkill /F /T /PID (a stand-in on PATH here,
    killing the tree through /proc like taskkill does through the Windows process list)."""
    monkeypatch.setattr(runner_module, "PROCESS_GROUPS", False)
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    log = tmp_path / "taskkill.log"
    make_script(bin_dir / "taskkill", f"LOG = {str(log)!r}\n" + FAKE_TASKKILL)
    monkeypatch.setenv("PATH", f"{bin_dir}{os.pathsep}{os.environ.get('PATH', '')}")
    exe = make_script(
        tmp_path / "hanging",
        f"""
        import os, subprocess, time
        child = subprocess.Popen([{sys.executable!r}, "-c", "import time; time.sleep(600)"])
        print("started child", flush=True)
        open("pids.txt", "w").write(f"{{os.getpid()}} {{child.pid}}")
        time.sleep(600)
        """,
    )
    run_dir, _ = time_out(exe, tmp_path, "pids.txt", "timed out after {timeout} s; it was killed with the processes it started")
    program, child = (int(v) for v in (run_dir / "pids.txt").read_text().split())
    calls = log.read_text().splitlines()  # one per run (one more run per start-up too slow for its timeout)
    assert calls[-1] == f"/F /T /PID {program}" and len(calls) == len(list((tmp_path / "runs").iterdir())), calls
    assert all(re.fullmatch(r"/F /T /PID \d+", call) for call in calls), calls
    assert not _alive(program)
    assert ended(child), "the program's child survived taskkill /T"


def test_timeout_on_windows_without_taskkill_kills_the_program(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """No taskkill on PATH (or it fails): Popen.kill() still ends the program itself."""
    monkeypatch.setattr(runner_module, "PROCESS_GROUPS", False)
    monkeypatch.setattr(runner_module, "KILL_GRACE_S", 0.2)  # the wait before Popen.kill()
    monkeypatch.setenv("PATH", str(tmp_path / "empty"))
    exe = make_script(
        tmp_path / "sleeper",
        """
        import os, time
        open("pid.txt", "w").write(str(os.getpid()))
        time.sleep(600)
        """,
    )
    run_dir, _ = time_out(exe, tmp_path, "pid.txt")
    assert not _alive(int((run_dir / "pid.txt").read_text()))


def test_parallel_runs_use_separate_directories(tmp_path: Path) -> None:
    """Four runs at once, each in its own directory: every run writes its scratch file and
    then waits until all four have (they are in flight together: a runner that ran them in
    turn fails them), then checks no other run overwrote it."""
    started = tmp_path / "started"
    started.mkdir()
    exe = make_script(
        tmp_path / "scratch_writer",
        f"""
        import os, sys, time
        me = sys.argv[1]
        if os.path.exists("scratch.out"):
            sys.exit(f"scratch.out already exists in {{os.getcwd()}}")
        open("scratch.out", "w").write(me)   # like ccx's spooles.out
        open(os.path.join({str(started)!r}, me), "w").close()
        patience = time.monotonic() + {HANG_S}
        while len(os.listdir({str(started)!r})) < 4:
            if time.monotonic() > patience:
                sys.exit("the four runs were not in flight together")
            time.sleep(0.01)
        if open("scratch.out").read() != me:
            sys.exit("another run overwrote scratch.out")
        open("result.txt", "w").write(me)
        """,
    )
    runner = ProcessRunner(str(exe), tmp_path / "runs")

    def one(tag: str):
        run_dir = runner.new_run_dir("same-key")  # even the same key gets its own directory
        return runner.run([tag], run_dir)

    tags = [f"run{i}" for i in range(4)]
    with ThreadPoolExecutor(max_workers=4) as pool:
        results = list(pool.map(one, tags))
    assert len({r.run_dir for r in results}) == 4
    for tag, result in zip(tags, results):
        assert (result.run_dir / "result.txt").read_text() == tag


def test_write_text_atomic_leaves_no_temporary_files(tmp_path: Path) -> None:
    target = tmp_path / "job.inp"
    write_text_atomic(target, "first")
    write_text_atomic(target, "second")
    assert target.read_text() == "second"
    assert [p.name for p in tmp_path.iterdir()] == ["job.inp"]


def test_invalid_timeout_is_rejected(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="timeout_s"):
        ProcessRunner("true", tmp_path, timeout_s=0)


def test_a_huge_log_line_gives_a_bounded_message(tmp_path: Path) -> None:
    """A program that prints one 50 MB line and fails: the error (which goes into the
    report and the manifest) holds a bounded excerpt, read without loading the log."""
    from nlupdate.fe.adapters.runner import EXCERPT_CHARS
    from nlupdate.fe.adapters.mapdl_files import find_errors

    exe = make_script(tmp_path / "chatty", """
        import sys
        sys.stdout.write("x" * 50_000_000 + "\\n*** ERROR ***  CP = 1.0 TIME= 2.0\\n" + "y" * 5_000_000)
        sys.exit(3)
        """)
    runner = ProcessRunner(str(exe), tmp_path / "runs")
    run_dir = runner.new_run_dir("loud")
    with pytest.raises(AdapterError) as info:
        runner.run([], run_dir)
    message = str(info.value)
    assert "exited with code 3" in message and len(message) < EXCERPT_CHARS + 1000, len(message)
    [(line, text)] = find_errors(run_dir / runner.log_name)
    assert line == 2 and len(text) < 2000


def test_an_adapter_only_built_leaves_no_folder_and_runs_share_one(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                                    echo_exe: Path) -> None:
    """Without work_root, building adapters (a study is checked by building its adapter)
    made a temporary folder each: three per run were left in /tmp."""
    import tempfile

    import nlupdate.fe.adapters.runner as runner_module

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    monkeypatch.setattr(runner_module, "_SCRATCH", {})
    runners = [ProcessRunner(str(echo_exe), scratch_prefix="nlupdate-test-") for _ in range(3)]
    assert [p for p in tmp_path.iterdir() if p.name.startswith("nlupdate-test-")] == []
    folders = {runner.new_run_dir(f"run{i}").parent for i, runner in enumerate(runners)}
    assert len(folders) == 1 and next(iter(folders)).name.startswith("nlupdate-test-")


def test_the_version_probe_keeps_a_bounded_first_line(tmp_path: Path) -> None:
    """A program whose ``-v`` printed 1.5 GB on one line put all of it into manifest.json
    (4.6 GB RSS); here 20 MB stand for it: the probe keeps the line's start only."""
    from nlupdate.fe.adapters.runner import VERSION_LINE_CHARS

    exe = make_script(tmp_path / "loud_solver", """
        import sys
        sys.stdout.write("Version 2.21 " + "x" * 20_000_000 + "\\nsecond line\\n")
        """)
    version = ProcessRunner(str(exe), tmp_path / "runs").version()
    assert version.startswith(f"{exe}: Version 2.21 xxx") and version.endswith("…"), version[:300]
    assert len(version) == len(f"{exe}: ") + VERSION_LINE_CHARS, len(version)


def test_a_version_probe_that_times_out_kills_what_it_started(tmp_path: Path) -> None:
    """``-v`` that starts a child and a ``setsid`` grandchild and sleeps: on timeout all
    three are stopped, and the message says so only because it is true."""
    exe = make_script(tmp_path / "hanging_solver", f"""
        import subprocess, sys, time
        child = subprocess.Popen([{sys.executable!r}, "-c", "import time; time.sleep(600)"])
        helper = subprocess.Popen(["setsid", {sys.executable!r}, "-c", "import time; time.sleep(600)"],
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        open(sys.argv[2], "w").write(f"{{child.pid}} {{helper.pid}}")
        time.sleep(600)
        """)

    def probe(timeout_s: float) -> tuple[str, Path]:  # each probe writes its own pids
        pids = tmp_path / f"pids-{timeout_s:g}"
        version = ProcessRunner(str(exe), tmp_path / "runs").version(("-v", str(pids)), timeout_s=timeout_s)
        return version, pids

    timeout_s, (version, pids) = timed_out_once_ready(probe, lambda outcome: written(outcome[1]), 2.0)
    pids = [int(pid) for pid in pids.read_text().split()]
    assert all(ended(pid) for pid in pids), "a process the version probe started outlived its timeout"
    assert version == (f"{exe}: version unknown (no answer to -v {tmp_path / f'pids-{timeout_s:g}'} within "
                       f"{timeout_s:g} s; it was killed with the processes it started)"), version
