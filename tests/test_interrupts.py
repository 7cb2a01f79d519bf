"""Ctrl-C and SIGKILL: a run stops promptly with one line, and nothing half-written survives.

Every case runs the real command in a subprocess and sends it the signal a user (or the
system) would: SIGINT as Ctrl-C does, SIGKILL as an out-of-memory killer or ``kill -9``.
"""
from __future__ import annotations

import contextlib
import os
import pty
import re
import select
import signal
import socket
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

import prefect_home
from patience import HANG_S
from studies import two_dof_study, write_study

ROOT = Path(__file__).resolve().parents[1]
TWO_DOF = ROOT / "examples" / "two_dof.toml"


def long_study() -> dict:
    """The 2-DOF study with 2001 frequencies: long enough to interrupt."""
    study = two_dof_study()
    study["measured"]["simulate"]["frequencies_hz"] = [690.0, 770.0, 2001]
    return study


def start(*args: object, cwd: Path, env: dict | None = None) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "nlupdate", *map(str, args)], cwd=cwd, env=env, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)


def wait_for_line(process: subprocess.Popen, fragment: str, timeout_s: float) -> list[str]:
    """Read stdout until a line holds ``fragment``; returns the lines read."""
    lines, deadline = [], time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        line = process.stdout.readline()
        if not line:
            break
        lines.append(line)
        if fragment in line:
            return lines
    raise AssertionError(f"no line with {fragment!r} within {timeout_s} s: {lines}")


def interrupt(process: subprocess.Popen) -> tuple[int, str, float]:
    """Send SIGINT; return (exit code, stderr, seconds until the process ended)."""
    process.send_signal(signal.SIGINT)
    sent = time.monotonic()
    _, stderr = process.communicate(timeout=60)
    return process.returncode, stderr, time.monotonic() - sent


class OnATerminal:
    """A command whose stderr is a pseudo-terminal, so that it draws its progress bars: the
    first bar says the work has started (a readiness line, not a guess how long imports
    take under load). Started in its own session; :meth:`kill` ends the whole group, so no
    orphan survives a failing test."""

    def __init__(self, command: list, cwd: Path, sigint_ignored: bool = False) -> None:
        leader, follower = pty.openpty()
        self.leader, self.screen = leader, ""
        self.process = subprocess.Popen(
            command, cwd=cwd, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=follower, text=True,
            env={**os.environ, "COLUMNS": "200"}, start_new_session=True,
            preexec_fn=(lambda: signal.signal(signal.SIGINT, signal.SIG_IGN)) if sigint_ignored else None)
        os.close(follower)

    def _read(self, timeout_s: float) -> bool:
        """Read what the terminal shows within ``timeout_s``; False once it has closed."""
        if not select.select([self.leader], [], [], timeout_s)[0]:
            return True
        try:
            chunk = os.read(self.leader, 65536)
        except OSError:  # the terminal closed with the process
            return False
        self.screen += chunk.decode(errors="replace")
        return bool(chunk)

    def wait_for(self, fragment: str, timeout_s: float) -> None:
        deadline = time.monotonic() + timeout_s
        while fragment not in self.screen:
            assert time.monotonic() < deadline and self._read(0.2), (fragment, self.screen[-2000:])

    def interrupt(self, timeout_s: float = 60) -> tuple[int, list[str], float]:
        """SIGINT; (exit code, the lines it wrote besides its bars, seconds until it ended)."""
        self.process.send_signal(signal.SIGINT)
        sent = time.monotonic()
        code = self.process.wait(timeout=timeout_s)
        seconds = time.monotonic() - sent
        while self._read(0.5):
            pass
        text = re.sub(r"\x1b\[[0-9;?]*[A-Za-z]", "", self.screen)
        lines = [line.strip() for line in re.split(r"[\r\n]+", text) if line.strip().startswith("nlupdate ")]
        return code, lines, seconds

    def kill(self) -> None:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(self.process.pid, signal.SIGKILL)  # an orphan would use a core for minutes
        self.process.wait()
        os.close(self.leader)


TIME_DOMAIN = ["simulate", TWO_DOF, "--input-dof", "0", "--freqs", "600:850:400", "--forces", "0.01,100,200",
               "--method", "time"]


def test_ctrl_c_during_a_time_domain_simulation(tmp_path):
    out = tmp_path / "out" / "frf.parquet"
    run = OnATerminal([sys.executable, "-m", "nlupdate", *map(str, TIME_DOMAIN), "--out", str(out)], tmp_path)
    try:
        run.wait_for("time-domain stepped sine", timeout_s=120)  # integrating
        code, lines, seconds = run.interrupt()
    finally:
        run.kill()
    assert code == 130, (code, seconds, run.screen[-2000:])
    assert lines == [f"nlupdate simulate: interrupted; nothing was written to {out}"], run.screen[-2000:]
    assert "Traceback" not in run.screen and list((tmp_path / "out").iterdir()) == []


def test_ctrl_c_during_a_prefect_run_stops_within_seconds(tmp_path, prefect_server):
    """Tasks still running in threads do not hold the process: it ends within the grace time."""
    env = {**os.environ, "PREFECT_API_URL": prefect_server}
    study = write_study(tmp_path / "study.toml", long_study())
    process = start("run", study, "--workers", "2", "--out", tmp_path / "results", cwd=tmp_path, env=env)
    wait_for_line(process, "tasks on 2 threads", timeout_s=300)
    wait_for_line(process, "computed in", timeout_s=300)  # a step has finished: the flow's tasks are running
    code, stderr, seconds = interrupt(process)
    assert code == 130, (code, seconds, stderr)
    assert stderr.strip().splitlines() == [f"nlupdate run: interrupted; no archive was written to "
                                           f"{tmp_path / 'results'}; finished tasks stay in the cache"]
    left = list((tmp_path / "results").rglob("*"))
    assert all(p.is_dir() for p in left), left  # at most the empty study folder


def children(pid: int) -> list[int]:
    """The child processes of ``pid`` (Linux /proc)."""
    found = []
    for task in Path(f"/proc/{pid}/task").iterdir():
        found += [int(c) for c in (task / "children").read_text().split()]
    return found


def gone(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    return Path(f"/proc/{pid}/stat").read_text().split(") ")[1].startswith("Z")  # a zombie is gone too


def listening(port: int) -> bool:
    with socket.socket() as s:
        return s.connect_ex(("127.0.0.1", port)) == 0


def started_run(tmp_path: Path) -> tuple[subprocess.Popen, int, int]:
    """``nlupdate run`` of a long study with a Prefect server of its own, once its tasks
    run: (process, server pid, server port). Its own ``PREFECT_HOME`` (seeded with the
    session's migrated database), so that it starts the server rather than using the
    session's, and ``NLUPDATE_PREFECT_SERVER_KEEP_S=0``: the server is kept for no run after it."""
    home = tmp_path / "prefect-home"
    prefect_home.seed(home)
    env = {**{k: v for k, v in os.environ.items() if k != "PREFECT_API_URL"}, "PREFECT_HOME": str(home),
           "NLUPDATE_PREFECT_SERVER_KEEP_S": "0"}
    study = write_study(tmp_path / "study.toml", long_study())
    process = subprocess.Popen([sys.executable, "-m", "nlupdate", "run", str(study), "--out", str(tmp_path / "results")],
                               cwd=tmp_path, env=env, text=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               start_new_session=True)
    lines = wait_for_line(process, "Prefect server: http://127.0.0.1:", timeout_s=300)
    port = int(lines[-1].split("127.0.0.1:")[1].split("/")[0])
    wait_for_line(process, "tasks on", timeout_s=300)
    servers = children(process.pid)
    assert len(servers) == 1 and listening(port), servers
    return process, servers[0], port


def ends_soon(pid: int, port: int, timeout_s: float = HANG_S) -> bool:
    """Whether the server ``pid`` on ``port`` ends (``timeout_s`` only ends a wait for what
    will not happen)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if gone(pid) and not listening(port):
            return True
        time.sleep(0.2)
    return False


def test_sigterm_stops_a_run_like_ctrl_c_and_its_server_with_it(tmp_path):
    process, server, port = started_run(tmp_path)
    process.send_signal(signal.SIGTERM)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 143, (process.returncode, stderr)
    assert stderr.strip().splitlines() == [f"nlupdate run: interrupted (SIGTERM); no archive was written to "
                                           f"{tmp_path / 'results'}; finished tasks stay in the cache"]
    assert ends_soon(server, port), "the temporary Prefect server outlived its run"


@pytest.mark.parametrize("whom", ["group", pytest.param("server, then the run", marks=pytest.mark.slow)])
def test_sigterm_to_the_process_group_of_a_run_ends_it(tmp_path, whom):
    """``timeout``, ``kill -- -PGID`` and batch schedulers signal the whole group, or every
    process of the job. The server died with the group while Prefect's own SIGTERM handler
    (in force while a flow runs) reported the crash to it, retrying for good: the run was
    alive a minute later (whether it did depended on which of the two went first; the
    second case makes the server go first). Now the server is in a group of its own, and
    the first SIGTERM starts the deadline whoever handles it. The run is bounded generously (60 s): the test
    asserts that it ends, with its one line and 143, not how fast."""
    process, server, port = started_run(tmp_path)
    wait_for_line(process, "computed in", timeout_s=300)  # a step has finished: the flow is running
    if whom == "group":
        assert os.getpgid(server) != os.getpgid(process.pid), "the server is in the run's process group"
        os.killpg(process.pid, signal.SIGTERM)
    else:  # as a scheduler may, in any order: here the run's API is surely gone when it is told
        os.kill(server, signal.SIGTERM)
        assert ends_soon(server, port)
        process.send_signal(signal.SIGTERM)
    try:
        _, stderr = process.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(process.pid, signal.SIGKILL)
        process.communicate()
        raise AssertionError(f"the run outlived a SIGTERM to its {whom} by 60 s") from None
    assert process.returncode == 143, (process.returncode, stderr)
    assert stderr.strip().splitlines() == [f"nlupdate run: interrupted (SIGTERM); no archive was written to "
                                           f"{tmp_path / 'results'}; finished tasks stay in the cache"], stderr
    assert ends_soon(server, port), "the temporary Prefect server outlived its run"


WRAPPED_INTERRUPT = textwrap.dedent("""
    import os, signal, sys, time
    import nlupdate.app.cli as cli
    import nlupdate.app.cli.simulate as simulate
    from nlupdate.app.cli.interrupts import Interrupted

    def run(args):  # SIGTERM arrives inside a library that wraps what it raises in its own error
        try:
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(10)
        except Interrupted as error:
            raise RuntimeError(f"Error building validator: Interrupted: {error}") from None

    simulate.run = run
    sys.exit(cli.main(["simulate", sys.argv[1], "--input-dof", "0", "--freqs", "600:850:5", "--forces", "1",
                       "--out", "frf.parquet"]))
""")


def test_an_interrupt_a_library_wrapped_in_its_own_error_is_still_an_interrupt(tmp_path):
    """pydantic building a schema when SIGTERM came reported a SchemaError, and the command
    ended as an internal error (exit 1) instead of 143 (seen in test_schedule's serve restart)."""
    done = subprocess.run([sys.executable, "-c", WRAPPED_INTERRUPT, str(TWO_DOF)], capture_output=True, text=True,
                          timeout=60, cwd=tmp_path)
    assert done.returncode == 143, done.stderr
    assert done.stderr.strip().splitlines() == ["nlupdate simulate: interrupted (SIGTERM); nothing was written"]


SWALLOWED_INTERRUPT = textwrap.dedent("""
    import gc, os, signal, sys, time
    from nlupdate.app.cli import interrupts

    interrupts.install()

    class Resource:
        def __del__(self):  # SIGTERM arrives here, where Python only reports an exception
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(0.3)

    try:
        Resource()
        time.sleep(5)
        print("not interrupted")
    except interrupts.Interrupted as error:
        print(f"interrupted: {error}")
""")


def test_an_interrupt_python_swallowed_in_a_finaliser_is_delivered_again():
    """A SIGTERM that landed in a weakref callback printed "Exception ignored … Interrupted" and
    a traceback during ``nlupdate serve``'s shutdown (test_schedule); now it is raised again."""
    done = subprocess.run([sys.executable, "-c", SWALLOWED_INTERRUPT], capture_output=True, text=True, timeout=60)
    assert done.stdout.strip() == "interrupted: SIGTERM", (done.stdout, done.stderr)
    assert "Exception ignored" not in done.stderr and "Traceback" not in done.stderr, done.stderr


FOREIGN_HANDLER = textwrap.dedent("""
    import os, signal, sys, time
    import nlupdate.app.cli as cli
    import nlupdate.app.cli.simulate as simulate

    class Termination(BaseException):
        pass

    def prefects_handler(signum, frame):
        raise Termination()

    def run(args):  # as Prefect does while a flow runs: its own SIGTERM handler, and then a
        signal.signal(signal.SIGTERM, prefects_handler)  # crash report to an API that is gone
        try:
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(10)
        except Termination:
            while True:  # retrying the dead API
                time.sleep(0.1)

    simulate.run = run
    sys.exit(cli.main(["simulate", sys.argv[1], "--input-dof", "0", "--freqs", "600:850:5", "--forces", "1",
                       "--out", "frf.parquet"]))
""")


def test_a_sigterm_a_library_handled_itself_still_ends_the_command(tmp_path):
    """Prefect replaces the SIGTERM handler while a flow runs; with its API gone it kept
    retrying and the run never ended. The deadline starts whichever handler runs."""
    try:
        done = subprocess.run([sys.executable, "-c", FOREIGN_HANDLER, str(TWO_DOF)], capture_output=True, text=True,
                              timeout=60, cwd=tmp_path)
    except subprocess.TimeoutExpired:
        raise AssertionError("a SIGTERM caught by another handler left the command running for 60 s") from None
    assert done.returncode == 143, done.stderr
    assert done.stderr.strip().splitlines() == ["nlupdate simulate: interrupted (SIGTERM); nothing was written"]


def test_a_killed_run_leaves_no_server_running(tmp_path):
    """SIGKILL gives the run no chance to clean up: its lease on the server ends with its
    process, and the server, used by no run, stops (after its keep time, 0 here)."""
    process, server, port = started_run(tmp_path)
    process.send_signal(signal.SIGKILL)
    process.wait(timeout=HANG_S)
    assert ends_soon(server, port), "the temporary Prefect server outlived its killed run"


def test_ctrl_c_stops_a_command_that_inherited_sigint_ignored(tmp_path):
    """A background job of a non-interactive shell starts with SIGINT ignored; Ctrl-C (or
    kill -INT) must still stop it: the CLI installs its handler as it starts."""
    premise = subprocess.run([sys.executable, "-c", "import signal; print(int(signal.getsignal(signal.SIGINT)))"],
                             capture_output=True, text=True, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN))
    assert premise.stdout.strip() == str(int(signal.SIG_IGN))  # Python keeps an inherited "ignored" as it is
    out = tmp_path / "frf.parquet"
    run = OnATerminal([sys.executable, "-m", "nlupdate", *map(str, TIME_DOMAIN), "--out", str(out)], tmp_path,
                      sigint_ignored=True)
    try:
        run.wait_for("time-domain stepped sine", timeout_s=120)  # integrating
        code, lines, seconds = run.interrupt()
    finally:
        run.kill()
    assert code == 130, (code, seconds, run.screen[-2000:])
    assert lines == [f"nlupdate simulate: interrupted; nothing was written to {out}"] and not out.exists()


KILLED_WRITER = textwrap.dedent("""
    import sys, time
    from nlupdate.files import atomic_directory, atomic_file
    with atomic_file(sys.argv[1] + "/frf.parquet") as path:
        path.write_text("half")
        with atomic_directory(sys.argv[1] + "/ident") as folder:
            (folder.path / "identification.json").write_text("{")
            print("writing", flush=True)
            time.sleep(600)  # killed by the test: it must outlive the command run beside it
""")


def test_leftovers_of_a_killed_run_are_removed_and_reported_by_the_next(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    writer = subprocess.Popen([sys.executable, "-c", KILLED_WRITER, str(out)], stdout=subprocess.PIPE, text=True)
    assert writer.stdout.readline().strip() == "writing"
    writer.send_signal(signal.SIGKILL)
    writer.wait(timeout=HANG_S)
    leftovers = sorted(p.name for p in out.iterdir())
    assert len(leftovers) == 2 and all(name.startswith(".") and f"-{writer.pid}-" in name for name in leftovers)

    result = subprocess.run([sys.executable, "-m", "nlupdate", "simulate", str(TWO_DOF), "--input-dof", "0",
                             "--freqs", "650:800:6", "--forces", "1", "--out", str(out / "new.csv")],
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    reported = [line for line in result.stderr.splitlines() if "unfinished output of an interrupted run" in line]
    assert len(reported) == 2 and all(f"(process {writer.pid})" in line for line in reported), result.stderr
    assert sorted(p.name for p in out.iterdir()) == ["new.csv"]


def test_output_of_a_run_still_in_progress_is_left_alone(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    writer = subprocess.Popen([sys.executable, "-c", KILLED_WRITER, str(out)], stdout=subprocess.PIPE, text=True)
    try:
        assert writer.stdout.readline().strip() == "writing"
        result = subprocess.run([sys.executable, "-m", "nlupdate", "simulate", str(TWO_DOF), "--input-dof", "0",
                                 "--freqs", "650:800:6", "--forces", "1", "--out", str(out / "new.csv")],
                                capture_output=True, text=True, timeout=120)
        assert result.returncode == 0 and "warning" not in result.stderr, result.stderr
        assert len([p for p in out.iterdir() if p.name.startswith(".")]) == 2
    finally:
        writer.kill()
        writer.wait()


@pytest.mark.parametrize("require, outcome", [("", "skipped"), ("1", "error")])
def test_calculix_tests_skip_without_ccx_unless_ci_requires_them(tmp_path, require, outcome):
    """The README's test command passes on a machine without ccx; under .ci/run it cannot."""
    python_only = tmp_path / "bin"
    python_only.mkdir()
    (python_only / "python").symlink_to(sys.executable)
    env = {**os.environ, "PATH": str(python_only), "NLUPDATE_REQUIRE_CCX": require}
    result = subprocess.run([sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "-n", "0", "-q", "-rs",
                             str(ROOT / "tests" / "test_calculix.py"), "-k", "test_single_c3d20_element_matches_quadratic_rod", "--no-header"],
                            capture_output=True, text=True, env=env, cwd=ROOT, timeout=300)
    summary = result.stdout.strip().splitlines()[-1]
    assert outcome in summary and ("passed" not in summary), result.stdout[-2000:]
    if outcome == "skipped":
        assert result.returncode == 0 and "needs CalculiX (ccx): apt-get install -y calculix-ccx" in result.stdout
    else:
        assert result.returncode != 0 and "NLUPDATE_REQUIRE_CCX=1" in result.stdout
