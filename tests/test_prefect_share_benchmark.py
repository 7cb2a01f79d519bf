"""benchmarks/prefect_share.py counts the CPU of every process of a run, not only the one it
started: a grandchild's CPU, as the grandchild itself reads it (``getrusage(RUSAGE_SELF)``),
is inside the figure :func:`measure` gives, and the grandchild is among the descendants it
sampled (how the benchmark tells the Prefect server's share of a demo)."""
from __future__ import annotations

import os
import sys
from pathlib import Path

from benchmarks.prefect_share import measure

GRANDCHILD = """
import resource, time
started = time.process_time()
total = 0
while time.process_time() - started < 0.4:
    total += sum(range(1000))
usage = resource.getrusage(resource.RUSAGE_SELF)
print(f"grandchild {usage.ru_utime + usage.ru_stime:.6f}")
"""

CHILD = f"""
import subprocess, sys
done = subprocess.run([sys.executable, "-c", {GRANDCHILD!r}], capture_output=True, text=True, check=True)
print(done.stdout.strip())
"""


def test_the_cpu_of_a_grandchild_is_counted_and_the_grandchild_is_sampled(tmp_path: Path):
    cpu, wall, (run,) = measure([([sys.executable, "-c", CHILD], tmp_path)], env=dict(os.environ))
    line = next(line for _, line in run.lines if line.startswith("grandchild "))
    grandchild_cpu = float(line.split()[1])
    assert grandchild_cpu >= 0.4
    assert cpu >= grandchild_cpu  # the child's own start-up on top
    assert run.descendants and max(run.descendants.values()) > 0, "the grandchild was never sampled"
