"""Part 4: the prediction step of the demo study (``src/nlupdate/data/demo.toml``).

The demo's measured table and identification are computed once (not timed); then
``predict_model`` — the low-force loss-factor fit and the prediction at the ten force levels,
correlated with the measurement — is timed for the two models the demo predicts with: the
initial FE model and the README's best updated one (E = 196.8 GPa, h2 = 1.419 mm), by
interleaved repeats, each alone; then both at once in two threads, as the Prefect flow runs
them.
"""
from __future__ import annotations

import threading
import time
from pathlib import Path

from nlupdate.app.cli.demo import demo_study_text
from nlupdate.study.loading import study_from_text
from nlupdate.study.steps.measured import identification_step, measured_table
from nlupdate.study.steps.prediction import predict_model, prediction_adapter
from nlupdate.fe.adapters.registry import build_adapter
from nlupdate.core.updating.evaluation import MemoisedEvaluator

from benchmarks.frf.common import fmt_cpu_wall, fmt_time, interleaved, load_average, print_table, timed

POINTS = {"initial": {"E": 210e9, "h2": 1.5e-3}, "best updated": {"E": 1.968e11, "h2": 1.419e-3}}
GOAL_S = 1.0  # issue 24: each prediction ≤ 1 s


def prediction_benchmark(quick: bool) -> None:
    repeats = 3 if quick else 5
    study = study_from_text(demo_study_text(1), Path("demo.toml"))
    start = time.perf_counter()
    measured = measured_table(study)
    identification = identification_step(study, measured)
    evaluator = MemoisedEvaluator(build_adapter(prediction_adapter(study)))
    modes = {name: evaluator([point])[0] for name, point in POINTS.items()}
    setup = time.perf_counter() - start

    def run(name):
        return predict_model(study, name, POINTS[name], modes[name], identification, measured)

    timing = interleaved({name: timed(lambda name=name: run(name)) for name in POINTS}, repeats)
    together = []
    for _ in range(repeats):
        times = {}

        def worker(name):
            t0 = time.perf_counter()
            run(name)
            times[name] = time.perf_counter() - t0

        threads = [threading.Thread(target=worker, args=(name,)) for name in POINTS]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
        together.append(times)
    rows = []
    for name in POINTS:
        t, p = timing[name], timing[name].result
        both = min(times[name] for times in together)
        rows.append([name, fmt_cpu_wall(t), fmt_time(both), f"{p.loss_factor:.4f}",
                     f"{p.correlation['frac'].min():.3f}", "met" if t.cpu_median <= GOAL_S else "NOT met"])
    print(f"\nPart 4: the demo's prediction step (setup — measured data, identification, FE modes — {setup:.1f} s, not "
          f"timed); medians of {repeats} interleaved repeats, CPU time (process and children) / wall, the goal on CPU; "
          f"load average {load_average()}")
    print_table("predict_model: loss-factor fit at 0.01 N + prediction at 10 levels + correlation",
                ["model", "alone, CPU / wall (s)", "both at once in 2 threads, each, best wall (s)", "loss factor", "FRAC min",
                 f"≤ {GOAL_S:g} s alone"], rows)
