"""Tutorial 6 — a whole study from Python: in this process, or as Prefect flows.

A study file describes the chain once (docs/study-files.md): here a simulated test of the
docs/methods.md §8 2-DOF rig (examples/two_dof.toml) at 0.01–100 N, PRD identification of its
joint, updating of the spring chain's k1 (started 20 % low; truth 1e6 N/m) against the
extracted linear mode with two finite-difference formulas and an optimisation, and the
best-ranked model's predictions at every level. The script writes the study file, runs it
and prints what the archive holds — the same archive either way:

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
model_file = (Path(__file__).resolve().parent / "two_dof.toml").as_posix()

STUDY = f"""
[study]
name = "two-dof-python"

[measured.simulate]          # the "test": the rig of two_dof.toml, 1 % noise
model = "{model_file}"
input_dof = "0"
forces_n = [0.01, 20, 40, 60, 80, 100]
frequencies_hz = [690.0, 770.0, 161]   # start, stop, count (Hz)
noise = 0.01
seed = 3

[identification]
response_dof = "0"
input_dof = "0"
elements = ["cubic", "jenkins"]
samples = 8

[adapter]                    # the FE model: ground -k1- 0.1 kg -k2- 0.5 kg -k3- ground
kind = "lumped"
options = {{ masses = [0.1, 0.5], stiffnesses = [0.8e6, 1.0e6, 1.0e6] }}

[[parameters]]
name = "k1"
unit = "N/m"
start = 0.8e6
lower = 0.5e6
upper = 1.5e6

[targets]                    # mode 1 of the extracted linear FRF is the model's mode 2
from_identification = true
modes = [1]
model_response_dof = "x1"
model_input_dof = "x1"
model_modes = [2]

[eigensensitivity]
formulas = ["forward", "central2"]
parameter_sets = [["k1"]]

[optimisation]
formula = "central2"

[[optimisation.candidates]]
name = "optimisation {{k1}}"
parameters = ["k1"]

[prediction]
candidates = "best"
"""
study_file = out / "two_dof_study.toml"
study_file.write_text(STUDY)
study = nlu.load_study(study_file)

started = time.perf_counter()
if args.prefect:
    from nlupdate.flows.run import run_study_flow
    from nlupdate.flows.runners import Execution

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
