"""How long ``nlupdate --version`` and ``nlupdate --help`` take to start:
``python benchmarks/startup.py [--repeats N]``.

Each command runs ``N`` times as ``python -m nlupdate …`` (after one unmeasured run, so the
files are in the page cache); prints the median and the fastest wall time, and the load
average at the start, and the CPU time of the runs (the child's user + system time): the
target (issue 24) is ≤ 0.3 s, decided on the median CPU time (wall time on a shared machine
counts the other work too). ``--write-docs``: the output becomes its block of
docs/performance.md (benchmarks/docs_block.py).
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

if __package__ in (None, ""):  # run as a script: make the repository root importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks import docs_block  # noqa: E402

GOAL_S = 0.3


def run_times(argv: list[str], repeats: int) -> tuple[list[float], list[float]]:
    """Wall and CPU seconds of ``repeats`` runs of ``python -m nlupdate ARGV`` (each must exit 0)."""
    command = [sys.executable, "-m", "nlupdate", *argv]
    subprocess.run(command, check=True, capture_output=True)
    walls, cpus = [], []
    for _ in range(repeats):
        started, cpu = time.perf_counter(), docs_block.children_cpu()
        subprocess.run(command, check=True, capture_output=True)
        walls.append(time.perf_counter() - started)
        cpus.append(docs_block.children_cpu() - cpu)
    return walls, cpus


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=10, help="runs per command (default 10)")
    docs_block.add_option(parser)
    args = parser.parse_args(argv)
    with docs_block.writing_docs(args.write_docs, "startup.py", argv):
        print(f"load average at start {os.getloadavg()[0]:.2f}; {args.repeats} runs each")
        for command in (["--version"], ["--help"]):
            walls, cpus = run_times(command, args.repeats)
            cpu = statistics.median(cpus)
            print(f"nlupdate {command[0]:<10} median {statistics.median(walls):.3f} s, fastest {min(walls):.3f} s "
                  f"(wall); CPU median {cpu:.3f} s; ≤ {GOAL_S} s on CPU: {'met' if cpu <= GOAL_S else 'NOT met'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
