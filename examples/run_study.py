"""Tutorial 6 — a whole study from Python: in this process, or as Prefect flows.

A study file describes the chain once (docs/study-files.md): here a simulated test of the
docs/methods.md §8 2-DOF rig (examples/two_dof.toml) at 0.01–100 N, PRD identification of its
joint, updating of the spring chain's k1 (started 20 % low; truth 1e6 N/m) against the
extracted linear mode with two finite-difference formulas and an optimisation, and the
best-ranked model's predictions at every level (examples/two_dof_study.toml). The script runs
it and prints what the archive holds — the same archive either way:

    python examples/run_study.py [OUT_DIR]             # nlu.run_study, in order, no Prefect
    python examples/run_study.py [OUT_DIR] --prefect   # Prefect flows: cached tasks, parallel runs
"""
import argparse
import datetime as dt
import tempfile
import time
from pathlib import Path

import pandas as pd

import nlupdate as nlu

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("out", nargs="?", type=Path, help="output folder (default: a new temporary folder)")
parser.add_argument("--prefect", action="store_true", help="run as Prefect flows (starts a local Prefect server)")
args = parser.parse_args()
out = args.out or Path(tempfile.mkdtemp(prefix="nlupdate-study-"))
out.mkdir(parents=True, exist_ok=True)
study = nlu.load_study(Path(__file__).resolve().parent / "two_dof_study.toml")

started = time.perf_counter()
if args.prefect:
    from nlupdate.orchestration.flows.run import run_study_flow
    from nlupdate.orchestration.flows.runners import Execution

    archive = run_study_flow(study, out / "results", Execution(workers=2), cache_dir=out / ".nlupdate-cache")
else:
    from nlupdate.reporting.archive import write_archive

    result = nlu.run_study(study, say=print)
    archive = write_archive(result, out / "archive", {
        "started_utc": dt.datetime.now(dt.timezone.utc).isoformat(), "wall_time_s": time.perf_counter() - started,
        "orchestration": "sequential, in one process (examples/run_study.py)"})
print(f"study run in {time.perf_counter() - started:.1f} s; archive {archive} (report.md)")

runs = pd.read_parquet(archive / "tables" / "runs.parquet")
ranking = pd.read_parquet(archive / "tables" / "ranking.parquet")
correlation = pd.read_parquet(archive / "tables" / "correlation.parquet")
for name, k1, converged in zip(runs["candidate"], runs["p:k1"], runs["converged"]):
    print(f"{name}: k1 = {k1:.5g} N/m, converged: {converged}")
best = ranking["candidate"].iloc[0]
print(f"best ranked: {best}")
for model, rows in correlation.groupby("model", sort=False):
    print(f"{model:>24}: FRAC per level " + " ".join(f"{v:.3f}" for v in rows["frac"]))
