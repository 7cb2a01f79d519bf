"""Where ``nlupdate demo`` spends its time: ``python benchmarks/demo_timing.py [--rounds N]``.

Each round runs the demo cold (an empty folder: no task cache; Prefect's own database is
whatever ``PREFECT_HOME`` holds) and then again in the same folder (every task cached), each
as ``python -m nlupdate demo`` with one BLAS thread, and prints from the time stamps of its
output lines: when the Prefect server answered, when the flow started, when the steps were
done, when the archive was written (its summary printed), the total, the predictions' own
lines, and the load average at the start. ``--python`` runs another interpreter (a venv
without pyHarm-os: its Jupyter dependencies add ~1.7 s of imports to every process that
imports Prefect). The demo's result lines (``* …``) of every run are compared with the first.
Nothing is extrapolated; the folders are made under a new temporary directory and removed.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

MARKS = {"server": "Prefect server:", "flow": "study ", "steps": "steps done", "archive": "Warnings"}


def run_demo(python: str, folder: Path) -> dict:
    """One ``nlupdate demo`` in ``folder``: seconds from its start to each mark, total, lines."""
    env = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    load = os.getloadavg()[0]
    started = time.perf_counter()
    process = subprocess.Popen([python, "-m", "nlupdate", "demo"], cwd=folder, env=env, text=True,
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    marks: dict[str, float] = {}
    results, predictions = [], []
    for line in process.stdout:
        now = time.perf_counter() - started
        for mark, prefix in MARKS.items():
            if line.startswith(prefix) or (mark == "archive" and line.startswith("*")):
                marks.setdefault(mark, now)
        if line.startswith("*"):
            results.append(line.rstrip())
        if line.startswith("prediction: "):  # "prediction: <model> (k/n) — computed in X s"
            predictions.append(line.strip())
    process.wait()
    return {"load": load, "total": time.perf_counter() - started, "marks": marks, "results": results,
            "predictions": predictions, "returncode": process.returncode}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=1, help="cold + cached pairs (default 1)")
    parser.add_argument("--python", default=sys.executable, help="interpreter with nlupdate installed")
    args = parser.parse_args(argv)
    first = None
    print(f"{'run':<12}{'load':>6}{'server':>9}{'flow':>8}{'steps':>8}{'archive':>9}{'total':>8}  (s from start)")
    with tempfile.TemporaryDirectory(prefix="demo-timing-") as root:
        for number in range(1, args.rounds + 1):
            folder = Path(root) / f"round-{number}"
            folder.mkdir()
            for kind in ("cold", "cached"):
                run = run_demo(args.python, folder)
                if run["returncode"]:
                    print(f"round {number} {kind}: the demo exited with {run['returncode']}", file=sys.stderr)
                    return 1
                first = first or run["results"]
                m = run["marks"]
                cells = "".join(f"{m.get(k, float('nan')):>{w}.1f}" for k, w in
                                (("server", 9), ("flow", 8), ("steps", 8), ("archive", 9)))
                print(f"{f'{number} {kind}':<12}{run['load']:>6.2f}{cells}{run['total']:>8.1f}  "
                      f"{'; '.join(run['predictions'])}; result lines {'same' if run['results'] == first else 'DIFFER'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
