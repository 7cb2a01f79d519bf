"""How long ``nlupdate --version`` and ``nlupdate --help`` take to start:
``python benchmarks/startup.py [--repeats N]``.

Each command runs ``N`` times as ``python -m nlupdate …`` (after one unmeasured run, so the
files are in the page cache); prints the median and the fastest wall time, and the load
average at the start. The target (issue 24) is ≤ 0.3 s.
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time


def wall_times(argv: list[str], repeats: int) -> list[float]:
    """Seconds of ``repeats`` runs of ``python -m nlupdate ARGV`` (each must exit 0)."""
    command = [sys.executable, "-m", "nlupdate", *argv]
    subprocess.run(command, check=True, capture_output=True)
    times = []
    for _ in range(repeats):
        started = time.perf_counter()
        subprocess.run(command, check=True, capture_output=True)
        times.append(time.perf_counter() - started)
    return times


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=10, help="runs per command (default 10)")
    args = parser.parse_args(argv)
    print(f"load average at start {os.getloadavg()[0]:.2f}; {args.repeats} runs each")
    for command in (["--version"], ["--help"]):
        times = wall_times(command, args.repeats)
        print(f"nlupdate {command[0]:<10} median {statistics.median(times):.3f} s, fastest {min(times):.3f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
