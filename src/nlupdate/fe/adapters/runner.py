"""Run an external FE executable in a fresh working directory of its own.

Used by every file-based adapter (CalculiX, MAPDL). One run = one directory: FE codes
write scratch files into their working directory (ccx writes ``spooles.out``, MAPDL
writes ``job.*`` files), so two runs must never share one. :meth:`ProcessRunner.new_run_dir`
creates ``work_root/<name>`` atomically (``<name>-2``, ``<name>-3``, … when that name
is taken, e.g. by an earlier failed run of the same evaluation key or by a concurrent
run of the same point), hence runs in different threads or processes never collide.

:meth:`ProcessRunner.run` starts the command in that directory with stdout and stderr
both written to one log file. On timeout (or when the caller is interrupted) the
program and everything it started are killed:

* POSIX: the program leads a new session (``start_new_session``), so its process group
  holds its children too; the group gets SIGTERM, then SIGKILL after
  :data:`KILL_GRACE_S` seconds.
* Windows (no ``os.killpg``/SIGKILL): the program starts in a new process group
  (``CREATE_NEW_PROCESS_GROUP``) and ``taskkill /F /T /PID <pid>`` kills its process
  tree; when ``taskkill`` is unavailable or fails, ``Popen.kill()`` kills the program
  itself (children it started may then survive).

Every failure raises :class:`~nlupdate.fe.adapters.base.AdapterError` whose message names
the run directory, the log file and the last lines of the log.
"""
from __future__ import annotations

import atexit
import os
import shutil
import signal
import subprocess
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator, Mapping, Sequence

from nlupdate.fe.adapters.base import AdapterError
from nlupdate.files import process_running

LOG_TAIL_LINES = 20
KILL_GRACE_S = 2.0


class ExecutableNotFoundError(AdapterError):
    """The FE executable is not installed or not configured."""


class RunTimeoutError(AdapterError):
    """The FE run exceeded its time limit and was killed."""


@dataclass(frozen=True)
class RunResult:
    """Outcome of one successful process run (return code 0)."""

    returncode: int
    wall_time_s: float
    log_path: Path
    run_dir: Path


def resolve_executable(executable: str | os.PathLike[str], install_hint: str) -> str:
    """Absolute path of ``executable`` (a name on PATH or a path to a file).

    Raises :class:`ExecutableNotFoundError` with ``install_hint`` appended when it is
    missing or not executable.
    """
    candidate = os.fspath(executable)
    if not candidate:
        raise ExecutableNotFoundError(f"no FE executable configured. {install_hint}")
    if os.sep in candidate or (os.altsep is not None and os.altsep in candidate):
        path = Path(candidate).expanduser()
        if path.is_file() and os.access(path, os.X_OK):
            return str(path.resolve())
        raise ExecutableNotFoundError(f"FE executable {candidate!r} does not exist or is not executable. {install_hint}")
    found = shutil.which(candidate)
    if found is None:
        raise ExecutableNotFoundError(f"FE executable {candidate!r} was not found on PATH. {install_hint}")
    return found


#: Bounds of what a log contributes to messages, reports and manifests: a program that
#: writes one 1.5 GB line must not make a 1.5 GB report.
TAIL_SCAN_BYTES = 65_536
EXCERPT_LINE_CHARS = 240
EXCERPT_CHARS = 4_096
SCAN_LINE_BYTES = 1_000


def _cut(line: str, limit: int) -> str:
    return line if len(line) <= limit else line[:limit - 1] + "…"


def log_tail(path: Path, n_lines: int = LOG_TAIL_LINES) -> str:
    """The last ``n_lines`` lines of a log ('' when it does not exist), read from its last
    :data:`TAIL_SCAN_BYTES` only, each cut to :data:`EXCERPT_LINE_CHARS` characters and the
    whole to :data:`EXCERPT_CHARS`."""
    try:
        with open(path, "rb") as stream:
            size = stream.seek(0, os.SEEK_END)
            stream.seek(max(0, size - TAIL_SCAN_BYTES))
            data = stream.read(TAIL_SCAN_BYTES)
    except OSError:
        return ""
    lines = data.decode("utf-8", errors="replace").rstrip().splitlines()
    if size > TAIL_SCAN_BYTES and lines:
        lines = lines[1:]  # the first one is a part of a line
    excerpt = "\n".join(_cut(line, EXCERPT_LINE_CHARS) for line in lines[-n_lines:])
    return excerpt if len(excerpt) <= EXCERPT_CHARS else "…" + excerpt[-(EXCERPT_CHARS - 1):]


def log_lines(path: Path, max_line_bytes: int = SCAN_LINE_BYTES) -> Iterator[str]:
    """The lines of a log, each cut to ``max_line_bytes`` bytes: the rest of a longer line
    is skipped without being held in memory, so a log of any size can be scanned."""
    with open(path, "rb") as stream:
        while True:
            chunk = stream.readline(max_line_bytes)
            if not chunk:
                return
            if not chunk.endswith(b"\n"):
                while True:
                    rest = stream.readline(1 << 16)
                    if not rest or rest.endswith(b"\n"):
                        break
                chunk += b"..."
            yield chunk.decode("utf-8", errors="replace").rstrip("\r\n")


def run_failure(reason: str, run_dir: Path, log_path: Path) -> AdapterError:
    """An :class:`AdapterError` naming the run directory, the log and its last lines."""
    return AdapterError(_failure_message(reason, run_dir, log_path))


def _failure_message(reason: str, run_dir: Path, log_path: Path) -> str:
    tail = log_tail(log_path)
    indented = "\n".join("    " + line for line in tail.splitlines()) if tail else "    (log is empty or missing)"
    return f"{reason}\n  run directory: {run_dir}\n  log: {log_path}\n  last lines of the log:\n{indented}"


#: True where processes can be killed by process group (POSIX); False on Windows.
PROCESS_GROUPS = hasattr(os, "killpg") and hasattr(signal, "SIGKILL")
#: Seconds to wait for ``taskkill`` on Windows.
TASKKILL_TIMEOUT_S = 30.0


def _spawn_options() -> dict[str, object]:
    """Keyword arguments of ``Popen`` that put the program in a group of its own."""
    if PROCESS_GROUPS:
        return {"start_new_session": True}
    # 0x200 is CREATE_NEW_PROCESS_GROUP; POSIX Pythons lack the name and only accept 0.
    return {"creationflags": getattr(subprocess, "CREATE_NEW_PROCESS_GROUP", 0)}


def descendants(pid: int) -> list[int]:
    """Every process ``pid`` started and that still runs, children first (Linux ``/proc``;
    [] where it is not available). A process that left the program's group or session
    (``setsid``) is found here while its parent lives."""
    found, todo = [], [pid]
    while todo:
        parent = todo.pop()
        try:
            tasks = list(Path(f"/proc/{parent}/task").iterdir())
        except OSError:
            continue
        for task in tasks:
            try:
                children = [int(c) for c in (task / "children").read_text().split()]
            except (OSError, ValueError):
                continue
            found += children
            todo += children
    return found


def _kill_group(process: subprocess.Popen[bytes]) -> list[int]:
    """POSIX: terminate the process group of ``process`` (it leads its own session) and
    every process it started that left the group; returns those still running after."""
    started = descendants(process.pid)
    for sig, wait_s in ((signal.SIGTERM, KILL_GRACE_S), (signal.SIGKILL, None)):
        try:
            os.killpg(process.pid, sig)
        except ProcessLookupError:
            break
        try:
            process.wait(timeout=wait_s)
            # The leader is gone; members of the group may linger, make sure they die.
            os.killpg(process.pid, signal.SIGKILL)
            break
        except subprocess.TimeoutExpired:
            continue
        except ProcessLookupError:
            break
    process.wait()
    for pid in started:  # also those in another group or session
        try:
            os.kill(pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass
    deadline = time.monotonic() + KILL_GRACE_S
    while time.monotonic() < deadline and any(process_running(pid) for pid in started):
        time.sleep(0.05)
    return [pid for pid in started if process_running(pid)]


def _kill_tree_windows(process: subprocess.Popen[bytes]) -> None:
    """Windows: ``taskkill /F /T /PID <pid>`` (the whole tree), else ``Popen.kill()``."""
    if process.poll() is None:
        try:
            subprocess.run(
                ["taskkill", "/F", "/T", "/PID", str(process.pid)],
                stdin=subprocess.DEVNULL,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
                timeout=TASKKILL_TIMEOUT_S,
                check=False,
            )
        except (OSError, subprocess.TimeoutExpired):
            pass
        try:
            process.wait(timeout=KILL_GRACE_S)
        except subprocess.TimeoutExpired:
            process.kill()
    process.wait()


def kill_process_tree(process: subprocess.Popen[bytes]) -> list[int]:
    """Kill ``process`` and what it started, and reap it (see the module docstring);
    returns the processes it started that could not be stopped (POSIX)."""
    if PROCESS_GROUPS:
        return _kill_group(process)
    _kill_tree_windows(process)
    return []


#: The version probe reads at most this much of the program's output …
VERSION_READ_BYTES = 4_096
#: … and keeps at most this many characters of its first non-empty line.
VERSION_LINE_CHARS = 200


def _read_first_line(stream, head: bytearray) -> None:
    """Append ``stream``'s bytes to ``head`` until a non-empty line is complete, the output
    ends or :data:`VERSION_READ_BYTES` are read; the rest is never read."""
    while len(head) < VERSION_READ_BYTES:
        try:
            chunk = stream.read1(VERSION_READ_BYTES - len(head))
        except (OSError, ValueError):  # closed meanwhile
            return
        if not chunk:
            return
        head += chunk
        if any(line.strip() for line in bytes(head).split(b"\n")[:-1]):
            return


def _killed(escaped: list[int]) -> str:
    if not escaped:
        return "it was killed with the processes it started"
    return (f"it was killed, but {len(escaped)} process(es) it started could not be stopped (pid "
            f"{', '.join(map(str, escaped))}): stop them yourself")


_SCRATCH: dict[tuple[int, str], Path] = {}
_SCRATCH_LOCK = threading.Lock()


def scratch_folder(prefix: str) -> Path:
    """This process's private temporary folder for runs (``<tmp>/<prefix>XXXX``, 0700),
    made on first use; one per process and prefix. Removed when the process exits if it is
    empty then (adapters that delete their successful runs leave only failed ones in it)."""
    key = (os.getpid(), prefix)
    with _SCRATCH_LOCK:
        if key not in _SCRATCH:
            _SCRATCH[key] = Path(tempfile.mkdtemp(prefix=prefix))
            atexit.register(_remove_if_empty, _SCRATCH[key])
        return _SCRATCH[key]


def _remove_if_empty(folder: Path) -> None:
    try:
        folder.rmdir()
    except OSError:  # not empty (a failed run's folder, named in its error) or already gone
        pass


@dataclass
class ProcessRunner:
    """Runs one FE executable, one fresh directory per run.

    executable: name on PATH or path of the program (resolved at each run, so a
        missing program is reported when it is needed, with ``install_hint``).
    work_root: directory under which the run directories are created; None: one private
        temporary folder per process and ``scratch_prefix``, made at the first run
        (:func:`scratch_folder`), so an adapter that is only built (to check a study) leaves
        nothing behind and a run leaves one folder, not one per adapter.
    timeout_s: wall-clock limit per run in seconds (None: no limit).
    env: extra environment variables for the child (merged over ``os.environ``).
    install_hint: sentence telling the user how to install/configure the program.
    log_name: file name of the combined stdout/stderr log inside the run directory.
    """

    executable: str
    work_root: Path | None = None
    timeout_s: float | None = None
    env: Mapping[str, str] = field(default_factory=dict)
    install_hint: str = ""
    log_name: str = "run.log"
    scratch_prefix: str = "nlupdate-run-"

    def __post_init__(self) -> None:
        self.work_root = None if self.work_root is None else Path(self.work_root)
        if self.timeout_s is not None and not self.timeout_s > 0:
            raise ValueError(f"timeout_s must be positive seconds or None, got {self.timeout_s}")

    def resolve(self) -> str:
        """Absolute path of the executable, or :class:`ExecutableNotFoundError`."""
        return resolve_executable(self.executable, self.install_hint)

    def version(self, arguments: Sequence[str] = ("-v",), timeout_s: float = 10.0) -> str:
        """``<path>: <first non-empty line the program prints for arguments>``, or why not.

        The line is read from the first :data:`VERSION_READ_BYTES` of the program's output
        (stdout and stderr together) and cut to :data:`VERSION_LINE_CHARS` characters. The
        program runs in a group of its own, as :meth:`run` does; when it has not ended
        within ``timeout_s`` it is killed with everything it started
        (:func:`kill_process_tree`), and the answer says whether that succeeded."""
        try:
            executable = self.resolve()
        except ExecutableNotFoundError as error:
            return f"not available ({error})"
        try:
            process = subprocess.Popen([executable, *arguments], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                       stdin=subprocess.DEVNULL, **_spawn_options())  # type: ignore[arg-type]
        except OSError as error:
            return f"{executable}: version unknown ({error.strerror or error})"
        deadline = time.monotonic() + timeout_s
        head = bytearray()
        reader = threading.Thread(target=_read_first_line, args=(process.stdout, head), daemon=True)
        reader.start()
        reader.join(timeout_s)
        if not reader.is_alive():
            process.stdout.close()  # a program still writing ends on the broken pipe
        escaped: list[int] | None = None
        try:
            process.wait(timeout=max(deadline - time.monotonic(), 0.0))
        except subprocess.TimeoutExpired:
            escaped = kill_process_tree(process)
        reader.join(KILL_GRACE_S)
        if not process.stdout.closed and not reader.is_alive():
            process.stdout.close()
        lines = [line.strip() for line in bytes(head).decode("utf-8", errors="replace").splitlines() if line.strip()]
        if lines:
            return f"{executable}: {_cut(lines[0], VERSION_LINE_CHARS)}"
        if escaped is not None:
            return (f"{executable}: version unknown (no answer to {' '.join(arguments)} within {timeout_s:g} s; "
                    f"{_killed(escaped)})")
        return f"{executable}: version unknown"

    def new_run_dir(self, name: str) -> Path:
        """Create and return a directory ``work_root/name`` that no other run uses."""
        if not name or "/" in name or name in {".", ".."}:
            raise ValueError(f"run directory name must be a plain file name, got {name!r}")
        root = self.work_root if self.work_root is not None else scratch_folder(self.scratch_prefix)
        root.mkdir(parents=True, exist_ok=True)
        for attempt in range(1, 10_000):
            candidate = root / (name if attempt == 1 else f"{name}-{attempt}")
            try:
                candidate.mkdir()
            except FileExistsError:
                continue
            return candidate
        raise AdapterError(f"could not create a fresh run directory for {name!r} under {root}")

    def run(self, arguments: Sequence[str], run_dir: Path) -> RunResult:
        """Run ``executable arguments…`` with ``run_dir`` as working directory.

        Raises :class:`ExecutableNotFoundError` (before starting), :class:`RunTimeoutError`
        (program and its children killed) or :class:`AdapterError` (non-zero exit or signal).
        """
        executable = self.resolve()
        run_dir = Path(run_dir)
        log_path = run_dir / self.log_name
        environment = {**os.environ, **self.env}
        command = [executable, *arguments]
        start = time.perf_counter()
        with open(log_path, "wb") as log:
            process = subprocess.Popen(
                command,
                cwd=run_dir,
                stdout=log,
                stderr=subprocess.STDOUT,
                stdin=subprocess.DEVNULL,
                env=environment,
                **_spawn_options(),  # type: ignore[arg-type]
            )
            try:
                returncode = process.wait(timeout=self.timeout_s)
            except subprocess.TimeoutExpired:
                escaped = kill_process_tree(process)
                raise RunTimeoutError(_failure_message(
                    f"{Path(executable).name} timed out after {self.timeout_s} s; {_killed(escaped)}",
                    run_dir, log_path)) from None
            except BaseException:
                kill_process_tree(process)
                raise
        wall_time = time.perf_counter() - start
        if returncode != 0:
            how = f"was killed by signal {-returncode}" if returncode < 0 else f"exited with code {returncode}"
            raise run_failure(f"{Path(executable).name} {how} (command: {' '.join(command)})", run_dir, log_path)
        return RunResult(returncode=returncode, wall_time_s=wall_time, log_path=log_path, run_dir=run_dir)


def write_text_atomic(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file and ``os.replace``."""
    path = Path(path)
    handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(handle, "w") as stream:
            stream.write(text)
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise
