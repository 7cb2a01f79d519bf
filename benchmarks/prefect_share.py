"""What Prefect costs the demo, in CPU seconds of every process of the run:
``python benchmarks/prefect_share.py [--rounds N] [--python PYTHON]``.

Per round, in rotated order (load hits every contender alike), each as a fresh process:

* **in process** — the demo study run sequentially without Prefect
  (:func:`nlupdate.study.run_study`, then the archive with its figures), imports included;
* **cold demo** — ``python -m nlupdate demo`` in an empty folder (no task cache): the CLI,
  the Prefect server it starts, everything;
* **cached rerun** — the same command again in that folder (every task cached);
* **two at once** — two cold demos started together in two empty folders;
* **server start** — the run's Prefect server alone (:class:`nlupdate.orchestration.flows.server.RunServer`)
  until ``/api/health`` answers, then stopped;
* **cold / cached, server running** — the cold demo and its rerun against a server that
  was already running (``PREFECT_API_URL``, as with ``prefect server start``): what the
  runs would cost if they shared one server. That server's CPU during each run is
  counted (read from ``/proc`` before and after); its start is not.

CPU is user + system time of the benchmarked process and all its descendants, read from
``getrusage(RUSAGE_CHILDREN)`` after they were waited for (the server is a child of the
CLI, which waits for it): stable on a shared machine, unlike wall time, which is printed
beside it. The server's share of a demo is sampled from ``/proc`` every 50 ms (psutil).
Figures are medians of the rounds; the load average is printed per round.

Every process gets one BLAS thread and a fresh ``PREFECT_HOME`` for the whole benchmark
(Prefect's database made by an untimed warm-up run, which also fills a bytecode cache
under the work folder: an installed package has its bytecode, and this machine sets
``PYTHONDONTWRITEBYTECODE``). The demo's result lines (``* …``) of every demo must be the
same; the script says so. Goals (issue 39): cold ≤ 1.3 × in process, cached ≤ 0.25 × in
process, two at once ≤ 2 × one cold demo.
"""
from __future__ import annotations

import argparse
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

IN_PROCESS = """
import sys
from pathlib import Path
from nlupdate.app.cli.demo import demo_study_text
from nlupdate.reporting.archive import write_archive
from nlupdate.study import run_study, study_from_text
study = study_from_text(demo_study_text(1), Path("demo.toml"))
print(write_archive(run_study(study), Path("results") / "sequential", {"orchestration": "sequential"}))
"""

SERVER_START = """
import time
from nlupdate.orchestration.flows.environment import prepare_environment
prepare_environment()
from nlupdate.orchestration.flows.server import RunServer
started = time.perf_counter()
server = RunServer()
server.wait(120)
print(f"ready {time.perf_counter() - started:.3f}")
server.stop()
"""


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
    parser.add_argument("--python", default=sys.executable, help="interpreter with nlupdate installed")
    parser.add_argument("--keep", action="store_true", help="keep the work folder (its path is printed)")
    args = parser.parse_args(argv)
    work = Path(tempfile.mkdtemp(prefix="prefect-share-"))
    env = {key: value for key, value in os.environ.items()
           if key not in ("PREFECT_API_URL", "PYTHONDONTWRITEBYTECODE", "NLUPDATE_CACHE_DIR")}
    env.update({"PREFECT_HOME": str(work / "prefect-home"), "PYTHONPYCACHEPREFIX": str(work / "bytecode"),
                "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"})
    demo = [args.python, "-m", "nlupdate", "demo"]
    counter = iter(range(1, 10_000))

    def folder() -> Path:
        path = work / f"run-{next(counter)}"
        path.mkdir()
        return path

    print(f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, {os.cpu_count()} cores, {args.python}; "
          f"load {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    warm = folder()
    for command in (demo, demo, [args.python, "-c", IN_PROCESS], [args.python, "-c", SERVER_START]):
        measure([(command, warm)], env)  # untimed: Prefect's database, bytecode, the cache secret
    from nlupdate.orchestration.flows.environment import prepare_environment
    from nlupdate.orchestration.flows.server import RunServer

    os.environ.update(env)  # the shared server: this benchmark's Prefect home and bytecode
    prepare_environment()
    running = RunServer()
    running.wait(300)
    rows: dict[str, list[tuple[float, float]]] = {}
    extra: dict[str, list[float]] = {"server ready (s into the demo)": [], "server CPU in cold demo": [],
                                     "server CPU in cached rerun": [], "server start wall": []}
    first_results: list[str] | None = None
    same = True

    def record(name: str, cpu: float, wall: float) -> None:
        rows.setdefault(name, []).append((cpu, wall))

    def server_cpu(run: Run) -> float:
        return sum(run.descendants.values())

    def check(run: Run) -> None:
        nonlocal first_results, same
        first_results = first_results or run.results()
        same = same and run.results() == first_results and bool(first_results)

    def in_process() -> None:
        cpu, wall, _ = measure([([args.python, "-c", IN_PROCESS], folder())], env)
        record("in process (run_study + archive)", cpu, wall)

    def cold_and_cached() -> None:
        place = folder()
        cpu, wall, (run,) = measure([(demo, place)], env)
        record("cold demo (Prefect)", cpu, wall)
        extra["server CPU in cold demo"].append(server_cpu(run))
        extra["server ready (s into the demo)"].append(run.mark("Prefect server:"))
        check(run)
        cpu, wall, (run,) = measure([(demo, place)], env)
        record("cached rerun (Prefect)", cpu, wall)
        extra["server CPU in cached rerun"].append(server_cpu(run))
        check(run)

    def two_at_once() -> None:
        cpu, wall, runs = measure([(demo, folder()), (demo, folder())], env)
        record("two cold demos at once", cpu, wall)
        for run in runs:
            check(run)

    def server_start() -> None:
        cpu, wall, (run,) = measure([([args.python, "-c", SERVER_START], folder())], env)
        record("server start alone (CPU: both processes)", cpu, wall)
        extra["server start wall"].append(float(run.lines[-1][1].split()[-1]))

    def against_running_server() -> None:
        import psutil

        place, server = folder(), psutil.Process(running.process.pid)
        for name in ("cold demo, server running", "cached rerun, server running"):
            before = sum(server.cpu_times()[:2])
            cpu, wall, (run,) = measure([(demo, place)], {**env, "PREFECT_API_URL": running.api_url})
            record(name, cpu + sum(server.cpu_times()[:2]) - before, wall)
            check(run)

    contenders = [in_process, cold_and_cached, two_at_once, server_start, against_running_server]
    for number in range(args.rounds):
        order = contenders[number % len(contenders):] + contenders[:number % len(contenders)]
        load = os.getloadavg()[0]
        for contender in order:
            contender()
        print(f"round {number + 1}: load {load:.2f} → {os.getloadavg()[0]:.2f}; " + "; ".join(
            f"{name} {values[-1][0]:.1f} s CPU / {values[-1][1]:.1f} s" for name, values in rows.items()), flush=True)

    medians = {name: (statistics.median(c for c, _ in values), statistics.median(w for _, w in values))
               for name, values in rows.items()}
    base = medians["in process (run_study + archive)"][0]
    cold = medians["cold demo (Prefect)"][0]
    print(f"\nmedians of {args.rounds} rounds (CPU: every process of the run)")
    print(f"| run | CPU (s) | wall (s) | CPU ÷ in process |\n|---|---|---|---|")
    for name, (cpu, wall) in medians.items():
        print(f"| {name} | {cpu:.2f} | {wall:.2f} | {cpu / base:.2f} |")
    for name, values in extra.items():
        print(f"{name}: median {statistics.median(values):.2f} s (" + ", ".join(f"{v:.2f}" for v in values) + ")")
    cached = medians["cached rerun (Prefect)"][0]
    pair = medians["two cold demos at once"][0]
    print(f"goals: cold {cold / base:.2f} × in process (≤ 1.3: {'met' if cold <= 1.3 * base else 'NOT met'}); "
          f"cached {cached / base:.2f} × (≤ 0.25: {'met' if cached <= 0.25 * base else 'NOT met'}); "
          f"two at once {pair / cold:.2f} × one cold demo (≤ 2: {'met' if pair <= 2 * cold else 'NOT met'})")
    shared = medians["cached rerun, server running"][0]
    print(f"with one server for the runs: cold {medians['cold demo, server running'][0] / base:.2f} ×, "
          f"cached {shared / base:.2f} × in process")
    print(f"result lines of every demo: {'the same' if same else 'DIFFER'}")
    print(f"load at the end {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    running.stop()
    if args.keep:
        print(f"work folder: {work}")
    else:
        shutil.rmtree(work, ignore_errors=True)
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
