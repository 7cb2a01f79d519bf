"""What Prefect costs the demo, in CPU seconds of every process of the run:
``python benchmarks/prefect_share.py [--rounds N] [--python PYTHON [--python PYTHON2]]``
(two interpreters — two checkouts, before and after a change — are interleaved in every round).

Per round, in rotated order (load hits every contender alike), each as a fresh process:

* **in process** — the demo study run sequentially without Prefect
  (:func:`nlupdate.study.run_study`, then the archive with its figures), imports included,
  ending without the interpreter's teardown as the ``nlupdate`` program does (like for like);
* **cold demo** — ``python -m nlupdate demo`` in an empty folder (no task cache): the CLI,
  the Prefect server it uses, everything. The run's server is kept between runs
  (:mod:`nlupdate.orchestration.flows.server_lease`, ``NLUPDATE_PREFECT_SERVER_KEEP_S``
  600 s here, longer than any gap between the runs): a cold demo after another finds it running, and its CPU during the run is counted
  (read from ``/proc`` before and after; its start, made by an earlier run, is not);
* **cold demo, two threads** — the same with ``--workers 2``: its FE points on two threads
  (the default up to 2026-11-29 was a thread per core; the demo's in-process FE model now
  gets one, :func:`nlupdate.orchestration.flows.runners.default_workers`);
* **cold demo, no server running** — the same after the kept server was stopped: this run
  starts it, and its CPU from its start to the run's end is counted (the first run of a
  session; code without a kept server starts and stops one in every cold demo);
* **cached rerun** — the same command again in that folder (every result in the cache: answered
  from it without Prefect, :mod:`nlupdate.orchestration.flows.from_cache`, when the code has that);
* **two at once** — two cold demos started together in two empty folders (the kept server,
  when there is one, counted as above);
* **two in process at once** — two of the first started together: the machine's own cost of
  running two studies at once (two processes on the shared cores, no Prefect), printed beside
  the two-at-once goal so Prefect's part of it can be read;
* **server start** — the run's Prefect server alone (:class:`nlupdate.orchestration.flows.server.RunServer`)
  until ``/api/health`` answers, then stopped.

CPU is user + system time of the benchmarked process and all its descendants, read from
``getrusage(RUSAGE_CHILDREN)`` after they were waited for (a server the CLI stops with the
run is its child, waited for), plus a kept server's CPU during the run: stable on a shared
machine, unlike wall time, which is printed beside it. The server's share of a demo is sampled from ``/proc`` every 50 ms (psutil).
Figures are medians of the rounds; the load average is printed per round.

Every process gets one BLAS thread and a fresh ``PREFECT_HOME`` per interpreter for the
whole benchmark (Prefect's database made by an untimed warm-up run, which also fills a bytecode cache
under the work folder: an installed package has its bytecode, and this machine sets
``PYTHONDONTWRITEBYTECODE``). The demo's result lines (``* …``) of every demo must be the
same; the script says so. ``--write-docs``: the output becomes its block of docs/performance.md
(benchmarks/docs_block.py). Goals (issue 39): cold ≤ 1.3 × in process, cached ≤ 0.25 × in
process, two at once ≤ 2 × one cold demo.
"""
from __future__ import annotations

import argparse
import contextlib
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

if __package__ in (None, ""):  # run as a script: make the repository root importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from benchmarks import docs_block  # noqa: E402

IN_PROCESS = """
import os
import sys
from pathlib import Path
from nlupdate.app.cli.demo import demo_study_text
from nlupdate.reporting.archive import write_archive
from nlupdate.study import run_study, study_from_text
study = study_from_text(demo_study_text(1), Path("demo.toml"))
print(write_archive(run_study(study), Path("results") / "sequential", {"orchestration": "sequential"}))
sys.stdout.flush()
os._exit(0)  # ends as the nlupdate program does (app/cli/process_end.py): no interpreter teardown on either side
"""

SERVER_START = """
import tempfile, time
from pathlib import Path
from nlupdate.orchestration.flows.environment import prepare_environment
prepare_environment()
from nlupdate.orchestration.flows.server import RunServer
started = time.perf_counter()
try:  # a server kept between runs (its files in a folder of its own here; stopped below)
    server = RunServer(Path(tempfile.mkdtemp()), 600)
except TypeError:  # code whose server stops with its run
    server = RunServer()
server.wait(120)
print(f"ready {time.perf_counter() - started:.3f}")
server.stop()
"""


class KeptServer:
    """The server kept for the runs on the Prefect database of ``home``, if any: its
    record (``nlupdate-server/server.json``) names its process."""

    def __init__(self, home: Path) -> None:
        self.record = home / "nlupdate-server" / "server.json"

    def process(self):
        import json

        import psutil

        try:
            return psutil.Process(int(json.loads(self.record.read_text())["pid"]))
        except (OSError, ValueError, KeyError, psutil.Error):
            return None

    def cpu(self) -> tuple[int, float]:
        """(pid, CPU seconds so far) of the kept server; (0, 0.0) when none runs."""
        import psutil

        process = self.process()
        try:
            return (process.pid, sum(process.cpu_times()[:2])) if process else (0, 0.0)
        except psutil.Error:
            return 0, 0.0

    def during(self, before: tuple[int, float]) -> float:
        """Its CPU since ``before`` (all of it when the server was started meanwhile)."""
        pid, cpu = self.cpu()
        return cpu - before[1] if pid and pid == before[0] else cpu

    def stop(self) -> None:
        """Stop it (SIGTERM, as its idle watchdog does) and wait until it has ended."""
        import psutil

        process = self.process()
        if process is not None:
            process.terminate()
            with contextlib.suppress(psutil.Error):
                process.wait(30)


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


class Run:
    """One benchmarked process: its output lines (with the seconds at which each came),
    and the CPU of its descendants other than itself, last sampled from /proc."""

    def __init__(self, command: list[str], folder: Path, env: dict[str, str]) -> None:
        import psutil

        self.started = time.perf_counter()
        self.process = subprocess.Popen(command, cwd=folder, env=env, text=True, stdout=subprocess.PIPE,
                                        stderr=subprocess.STDOUT)
        self.lines: list[tuple[float, str]] = []
        self.descendants: dict[int, float] = {}
        self._root = psutil.Process(self.process.pid)
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        for line in self.process.stdout:
            self.lines.append((time.perf_counter() - self.started, line.rstrip("\n")))

    def sample(self) -> None:
        import psutil

        try:
            for child in self._root.children(recursive=True):
                try:
                    times = child.cpu_times()
                    self.descendants[child.pid] = times.user + times.system
                except psutil.Error:
                    pass
        except psutil.Error:
            pass

    def finish(self) -> float:
        self.process.wait()
        self._reader.join()
        self.wall = time.perf_counter() - self.started
        if self.process.returncode:
            text = "\n".join(line for _, line in self.lines[-30:])
            raise SystemExit(f"{self.process.args} exited with {self.process.returncode}:\n{text}")
        return self.wall

    def mark(self, prefix: str) -> float:
        """Seconds from the start to the first line starting with ``prefix`` (nan: none)."""
        return next((at for at, line in self.lines if line.startswith(prefix)), float("nan"))

    def results(self) -> list[str]:
        return [line for _, line in self.lines if line.startswith("* ")]


def measure(commands: list[tuple[list[str], Path]], env: dict[str, str]) -> tuple[float, float, list[Run]]:
    """Start ``commands`` together; (CPU of all their processes, wall until the last ends, runs)."""
    before = _children_cpu()
    started = time.perf_counter()
    runs = [Run(command, folder, env) for command, folder in commands]
    while any(run.process.poll() is None for run in runs):
        for run in runs:
            run.sample()
        time.sleep(0.05)
    for run in runs:
        run.finish()
    return _children_cpu() - before, time.perf_counter() - started, runs


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3, help="rounds of every contender (default 3)")
    parser.add_argument("--python", action="append",
                        help="interpreter with nlupdate installed (default: this one); given twice or more, "
                             "their contenders are interleaved in every round (before/after)")
    parser.add_argument("--keep", action="store_true", help="keep the work folder (its path is printed)")
    docs_block.add_option(parser)
    args = parser.parse_args(argv)
    with docs_block.writing_docs(args.write_docs, "prefect_share.py", argv):
        return _run(args)


def _run(args: argparse.Namespace) -> int:
    pythons = args.python or [sys.executable]
    work = Path(tempfile.mkdtemp(prefix="prefect-share-"))
    base_env = {key: value for key, value in os.environ.items()
                if key not in ("PREFECT_API_URL", "PYTHONDONTWRITEBYTECODE", "NLUPDATE_CACHE_DIR")}
    base_env.update({"PYTHONPYCACHEPREFIX": str(work / "bytecode"), "NLUPDATE_PREFECT_SERVER_KEEP_S": "600",
                     "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"})
    envs = {python: {**base_env, "PREFECT_HOME": str(work / f"prefect-home-{k}")} for k, python in enumerate(pythons)}
    kept = {python: KeptServer(Path(env["PREFECT_HOME"])) for python, env in envs.items()}
    counter = iter(range(1, 10_000))

    def folder() -> Path:
        path = work / f"run-{next(counter)}"
        path.mkdir()
        return path

    print(f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, {os.cpu_count()} cores, {', '.join(pythons)}; "
          f"load {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    for python in pythons:
        warm = folder()
        for command in ([python, "-m", "nlupdate", "demo"], [python, "-m", "nlupdate", "demo"],
                        [python, "-c", IN_PROCESS], [python, "-c", SERVER_START]):
            measure([(command, warm)], envs[python])  # untimed: Prefect's database, bytecode, the cache secret
    rows: dict[str, dict[str, list[tuple[float, float]]]] = {python: {} for python in pythons}
    extra: dict[str, dict[str, list[float]]] = {
        python: {"server ready (s into the demo)": [], "server CPU in cold demo": [],
                 "server CPU in cold demo, no server running": [], "server CPU in cached rerun": [],
                 "server start wall": []} for python in pythons}
    first_results: list[str] | None = None
    same = True

    def check(run: Run) -> None:
        nonlocal first_results, same
        first_results = first_results or run.results()
        same = same and run.results() == first_results and bool(first_results)

    def contenders(python: str) -> list:
        demo = [python, "-m", "nlupdate", "demo"]
        mine, more, env, server = rows[python], extra[python], envs[python], kept[python]

        def record(name: str, cpu: float, wall: float) -> None:
            mine.setdefault(name, []).append((cpu, wall))

        def demos(places: list[Path]) -> tuple[float, float, float, list[Run]]:
            """Demos started together: (CPU with the kept server's, wall, the server's CPU, runs)."""
            before = server.cpu()
            cpu, wall, runs = measure([(demo, place) for place in places], env)
            during, kept_pid = server.during(before), server.cpu()[0]
            for run in runs:
                check(run)
            others = sum(seconds for run in runs for pid, seconds in run.descendants.items() if pid != kept_pid)
            return cpu + during, wall, during + others, runs  # a kept server started by a run is its child too

        def in_process() -> None:
            cpu, wall, _ = measure([([python, "-c", IN_PROCESS], folder())], env)
            record("in process (run_study + archive)", cpu, wall)

        def two_in_process() -> None:
            cpu, wall, _ = measure([([python, "-c", IN_PROCESS], folder()) for _ in range(2)], env)
            record("two in process at once", cpu, wall)

        def cold_and_cached() -> None:
            place = folder()
            cpu, wall, server_cpu, (run,) = demos([place])
            record("cold demo", cpu, wall)
            more["server CPU in cold demo"].append(server_cpu)
            more["server ready (s into the demo)"].append(run.mark("Prefect server:"))
            cpu, wall, server_cpu, _ = demos([place])
            record("cached rerun", cpu, wall)
            more["server CPU in cached rerun"].append(server_cpu)

        def cold_two_threads() -> None:
            before = server.cpu()
            cpu, wall, runs = measure([(demo + ["--workers", "2"], folder())], env)
            for run in runs:
                check(run)
            record("cold demo, two threads (--workers 2)", cpu + server.during(before), wall)

        def first_cold() -> None:
            server.stop()
            cpu, wall, server_cpu, _ = demos([folder()])
            record("cold demo, no server running", cpu, wall)
            more["server CPU in cold demo, no server running"].append(server_cpu)

        def two_at_once() -> None:
            cpu, wall, _, _ = demos([folder(), folder()])
            record("two cold demos at once", cpu, wall)

        def server_start() -> None:
            cpu, wall, (run,) = measure([([python, "-c", SERVER_START], folder())], env)
            record("server start alone (CPU: both processes)", cpu, wall)
            more["server start wall"].append(float(run.lines[-1][1].split()[-1]))

        return [in_process, cold_and_cached, cold_two_threads, first_cold, two_at_once, two_in_process, server_start]

    every = [contender for python in pythons for contender in contenders(python)]
    for number in range(args.rounds):
        shift = number % len(every)
        load = os.getloadavg()[0]
        for contender in every[shift:] + every[:shift]:
            contender()
        print(f"round {number + 1}: load {load:.2f} → {os.getloadavg()[0]:.2f}; " + "; ".join(
            f"{label(python, pythons)}{name} {values[-1][0]:.1f} s CPU / {values[-1][1]:.1f} s"
            for python in pythons for name, values in rows[python].items()), flush=True)

    for python in pythons:
        report(python, rows[python], extra[python], args.rounds)
    print(f"result lines of every demo: {'the same' if same else 'DIFFER'}")
    print(f"load at the end {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    for server in kept.values():
        server.stop()
    if args.keep:
        print(f"work folder: {work}")
    else:
        shutil.rmtree(work, ignore_errors=True)
    return 0 if same else 1


def label(python: str, pythons: list[str]) -> str:
    """``python``'s name in the round lines when several are compared, else nothing."""
    return f"[{python}] " if len(pythons) > 1 else ""


def report(python: str, rows: dict[str, list[tuple[float, float]]], extra: dict[str, list[float]], rounds: int) -> None:
    """The medians of one interpreter's contenders and the goals."""
    medians = {name: (statistics.median(c for c, _ in values), statistics.median(w for _, w in values))
               for name, values in rows.items()}
    base = medians["in process (run_study + archive)"][0]
    cold = medians["cold demo"][0]
    print(f"\n{python}: medians of {rounds} rounds (CPU: every process of the run)")
    print("| run | CPU (s) | wall (s) | CPU ÷ in process |\n|---|---|---|---|")
    for name, (cpu, wall) in medians.items():
        print(f"| {name} | {cpu:.2f} | {wall:.2f} | {cpu / base:.2f} |")
    for name, values in extra.items():
        print(f"{name}: median {statistics.median(values):.2f} s (" + ", ".join(f"{v:.2f}" for v in values) + ")")
    cached = medians["cached rerun"][0]
    pair = medians["two cold demos at once"][0]
    first = medians["cold demo, no server running"][0]
    print(f"goals: cold {cold / base:.2f} × in process (≤ 1.3: {'met' if cold <= 1.3 * base else 'NOT met'}); "
          f"cached {cached / base:.2f} × (≤ 0.25: {'met' if cached <= 0.25 * base else 'NOT met'}); "
          f"two at once {pair / cold:.2f} × one cold demo (≤ 2: {'met' if pair <= 2 * cold else 'NOT met'})")
    machine = medians["two in process at once"][0] / base
    print(f"the machine's own cost of two at once (two in-process studies together ÷ one, no Prefect): "
          f"{machine:.2f}; two cold demos at once ÷ that: {pair / cold / machine:.2f} × twice one")
    two = medians["cold demo, two threads (--workers 2)"]
    print(f"the cold demo on two threads (--workers 2; the default before 2026-11-29): {two[0] / base:.2f} × in "
          f"process, {two[0] - cold:+.2f} s CPU and {two[1] - medians['cold demo'][1]:+.2f} s wall against the default")
    print(f"the first cold demo, which starts the server: {first / base:.2f} × in process "
          f"(≤ 1.3: {'met' if first <= 1.3 * base else 'NOT met'})")


if __name__ == "__main__":
    sys.exit(main())
