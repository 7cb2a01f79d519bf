"""Speed and accuracy of the nonlinear frequency-response solvers: ``python benchmarks/frf_speed.py``.

The parts, their set-ups and what they print are described in ``benchmarks/frf/__init__.py``;
each part is one module there. ``--parts`` picks some (``1a,1b,1c,2,3,4``), ``--quick`` takes
3 repeats and skips the sequential time integrations. Every table gives CPU time (process and
children) beside wall time, medians of interleaved repeats, and the load average; ratios and
the goals' met / NOT met are on CPU time, which other work on a shared machine does not
inflate as it does wall time. Pin to one core with one BLAS thread for stable figures:
``OPENBLAS_NUM_THREADS=1 taskset -c 0 python benchmarks/frf_speed.py``. ``--write-docs``: the
output becomes its block of docs/performance.md (benchmarks/docs_block.py).
"""
from __future__ import annotations

import argparse
import datetime
import sys
import time
from pathlib import Path

if __package__ in (None, ""):  # run as a script: make the repository root importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402
import scipy  # noqa: E402

from benchmarks import docs_block  # noqa: E402
from benchmarks.frf.common import cpu_seconds, load_average, machine_description  # noqa: E402
from benchmarks.frf.grid import grid_benchmark  # noqa: E402
from benchmarks.frf.harmonic_balance import harmonic_balance_benchmark  # noqa: E402
from benchmarks.frf.multi_harmonic import multi_harmonic_benchmark  # noqa: E402
from benchmarks.frf.predictions import prediction_benchmark  # noqa: E402
from benchmarks.frf.pyharm import pyharm_version  # noqa: E402
from benchmarks.frf.scaling import scaling_benchmark  # noqa: E402
from benchmarks.frf.time_integration import time_integration_benchmark  # noqa: E402

PARTS = {
    "1a": harmonic_balance_benchmark,
    "1b": time_integration_benchmark,
    "1c": multi_harmonic_benchmark,
    "2": scaling_benchmark,
    "3": grid_benchmark,
    "4": prediction_benchmark,
}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="short run: 3 repeats, no sequential time integration")
    parser.add_argument("--parts", default=",".join(PARTS), help="comma-separated parts to run (default: all)")
    docs_block.add_option(parser)
    args = parser.parse_args(argv)
    parts = [part.strip() for part in args.parts.split(",") if part.strip()]
    unknown = [part for part in parts if part not in PARTS]
    if unknown:
        parser.error(f"--parts: unknown {unknown}; known: {', '.join(PARTS)}")
    with docs_block.writing_docs(args.write_docs, "frf_speed.py", argv):
        started, cpu = time.perf_counter(), cpu_seconds()
        now = datetime.datetime.now(datetime.timezone.utc)
        version = pyharm_version()
        print(
            f"frf_speed.py {'--quick' if args.quick else '(full run)'} parts {', '.join(parts)} — {now:%Y-%m-%d %H:%M} UTC\n"
            f"machine: {machine_description()}; load average at start {load_average()}\n"
            f"Python {sys.version.split()[0]}, numpy {np.__version__}, scipy {scipy.__version__}, "
            f"pyHarm-os {version or 'not installed'}"
        )
        for part in parts:
            PARTS[part](args.quick)
        print(f"\nCPU time {cpu_seconds() - cpu:.0f} s (process and children), wall time {time.perf_counter() - started:.0f} s; "
              f"load average at end {load_average()}")


if __name__ == "__main__":
    main()
