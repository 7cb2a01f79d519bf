"""What Prefect orchestration costs and buys, measured in one run on this machine.

1. The demo study (``nlupdate demo``): the plain sequential run (``nlupdate update``
   path, no Prefect) against the Prefect flow on one thread (same order of work, so the
   difference is Prefect's overhead), both writing the archive, on a cold cache; then
   the flow again on the warm cache. The Prefect server is started once beforehand and
   timed separately (a run without ``PREFECT_API_URL`` pays it once).
2. A four-formula sweep on two parameter sets, as in the demo, whose FE runs are
   CalculiX (solid C3D20R T-beam, 810 elements; {E} and {E, h2} against f1 and f2): sequentially without Prefect, and as a flow on
   1 thread, 2 threads and 2 Dask worker processes (cluster start included), each on a
   cold cache.

Usage: ``python benchmarks/orchestration.py [--skip-demo] [--skip-calculix]``
(about 6 minutes here). Targets: Prefect overhead ≤ 20 % of the demo's wall time;
parallel sweep ≤ 0.6 × sequential.
"""
from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import platform
import shutil
import tempfile
import time
from pathlib import Path

from nlupdate.orchestration.flows.environment import prepare_environment

prepare_environment()

from nlupdate.app.cli.demo import demo_study_text  # noqa: E402
from nlupdate.orchestration.flows.status_lines import Progress  # noqa: E402
from nlupdate.orchestration.flows.run import run_study_flow  # noqa: E402
from nlupdate.orchestration.flows.runners import Execution  # noqa: E402
from nlupdate.orchestration.flows.server import prefect_api  # noqa: E402
from nlupdate.reporting.archive import write_archive  # noqa: E402
from nlupdate.study import run_study, study_from_text  # noqa: E402

CALCULIX_SWEEP = """
[study]
name = "calculix-four-formulas"

[adapter]
kind = "calculix"
model = "tbeam"
options = { n_modes = 4, mesh = { n_l1 = 60, n_l2 = 30, n_h1 = 3, n_w1 = 3 } }

[[parameters]]
name = "E"
unit = "Pa"
start = 210e9
lower = 150e9
upper = 260e9

[[parameters]]
name = "h2"
unit = "m"
start = 1.5e-3
lower = 1.3e-3
upper = 1.7e-3

[targets]
frequencies_hz = [44.0, 188.0]
model_modes = [1, 2]

[eigensensitivity]
formulas = ["forward", "backward", "central2", "central4"]
parameter_sets = [["E"], ["E", "h2"]]
frequency_tolerance = 1e-5
"""


def flow_seconds(study, root: Path, cache: Path, execution: Execution) -> tuple[float, dict]:
    """Wall time of one flow run (server already up) and its manifest."""
    started = time.perf_counter()
    archive = run_study_flow(study, root, execution, cache, progress=Progress(quiet=True))
    return time.perf_counter() - started, json.loads((archive / "manifest.json").read_text())


def sequential_seconds(study, root: Path) -> float:
    started = time.perf_counter()
    result = run_study(study)
    write_archive(result, root / "sequential", {"orchestration": "sequential"})
    return time.perf_counter() - started


def computed(manifest: dict, step: str) -> int:
    return sum(c["computed"] for name, c in manifest["run"]["tasks"].items() if name.startswith(step))


def demo(work: Path) -> None:
    study = study_from_text(demo_study_text(1), Path("demo.toml"))
    sequential = sequential_seconds(study, work / "seq")
    cold, first = flow_seconds(study, work / "flow", work / "demo-cache", Execution(workers=1))
    warm, again = flow_seconds(study, work / "flow", work / "demo-cache", Execution(workers=1))
    threads, _ = flow_seconds(study, work / "flow", work / "demo-cache-2", Execution(workers=2))
    overhead = (cold - sequential) / cold
    print("\n1. demo study (T-beam surrogate, 10 force levels × 1801 frequencies, 10 updating runs, 2 predictions)")
    print(f"   sequential, no Prefect (run_study + archive) {sequential:8.1f} s")
    print(f"   Prefect flow, 1 thread, cold cache            {cold:8.1f} s   overhead {100 * overhead:.1f} % of the flow's wall time")
    print(f"   Prefect flow, 1 thread, warm cache            {warm:8.1f} s   = {100 * warm / cold:.1f} % of the cold run; "
          f"tasks computed {sum(c['computed'] for c in again['run']['tasks'].values())}, "
          f"cached {sum(c['cached'] for c in again['run']['tasks'].values())}")
    print(f"   Prefect flow, 2 threads, cold cache           {threads:8.1f} s   ({threads / cold:.2f} × 1 thread)")
    print(f"   (cold run: {computed(first, 'FE point')} FE points computed; steps {first['run']['wall_time_s']:.1f} s, "
          f"warm steps {again['run']['wall_time_s']:.1f} s = {100 * again['run']['wall_time_s'] / first['run']['wall_time_s']:.1f} %)")


def calculix(work: Path) -> None:
    if shutil.which("ccx") is None:
        print("\n2. skipped: no ccx on PATH (apt-get install -y calculix-ccx)")
        return
    study = study_from_text(CALCULIX_SWEEP, work / "calculix.toml")
    sequential = sequential_seconds(study, work / "ccx-seq")
    rows = [("sequential, no Prefect", sequential, None)]
    for label, execution in (("flow, 1 thread", Execution(workers=1)), ("flow, 2 threads", Execution(workers=2)),
                             ("flow, 2 Dask workers", Execution(workers=2, dask=True))):
        seconds, manifest = flow_seconds(study, work / "ccx-flow", work / f"ccx-cache-{len(rows)}", execution)
        rows.append((label, seconds, computed(manifest, "FE point")))
    from nlupdate.orchestration.flows.runners import task_runner

    started = time.perf_counter()
    with task_runner(Execution(workers=2, dask=True)):
        cluster_s = time.perf_counter() - started
    print("\n2. four-formula sweep, CalculiX C3D20R T-beam (810 elements), {E} and {E, h2} against f1, f2, cold caches")
    print(f"   (starting a local Dask cluster of 2 worker processes takes {cluster_s:.1f} s here; the Dask row includes it)")
    for label, seconds, points in rows:
        extra = "" if points is None else f"   {points} ccx runs"
        print(f"   {label:<26}{seconds:8.1f} s   {seconds / sequential:5.2f} × sequential{extra}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--skip-demo", action="store_true")
    parser.add_argument("--skip-calculix", action="store_true")
    args = parser.parse_args()
    print(f"{dt.date.today()}, {platform.node()}: {os.cpu_count()} cores, Python {platform.python_version()}")
    work = Path(tempfile.mkdtemp(prefix="nlupdate-orchestration-"))
    os.environ["PREFECT_HOME"] = str(work / "prefect-home")
    os.environ.pop("PREFECT_API_URL", None)
    started = time.perf_counter()
    with prefect_api(lambda message: None):
        print(f"Prefect server start (once per run, not included below): {time.perf_counter() - started:.1f} s")
        if not args.skip_demo:
            demo(work)
        if not args.skip_calculix:
            calculix(work)
    shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
