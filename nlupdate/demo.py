"""``nlupdate demo``: the whole chain on embedded defaults, archived under ``results/``.

Steps (each prints one progress line):
1. the METHODS §8 SDOF (cubic + Jenkins) at a low force and 11 high forces, traced by
   continuation and read as a stepped-sine sweep, polluted with 5 % noise;
2. the traced curves with stable/unstable branches and folds.
"""
from __future__ import annotations

import json
import time
from importlib import resources
from pathlib import Path
from typing import Callable

import numpy as np

from nlupdate.archive import atomic_directory, run_name
from nlupdate.continuation import trace_frequency_response
from nlupdate.measurements import write_frf_table
from nlupdate.model_file import system_from_dict
from nlupdate.plots import plot_continuation, plot_frf_levels
from nlupdate.simulate import simulate_frf_table

import tomllib

DEFAULT_FORCES_N = (0.01,) + tuple(np.arange(100.0, 401.0, 30.0))
DEFAULT_BAND_HZ = (600.0, 900.0, 301)


def embedded_system_text() -> str:
    return resources.files("nlupdate").joinpath("data/sdof.toml").read_text()


def run_demo(results_root: Path = Path("results"), seed: int = 1, say: Callable[[str], None] = print) -> Path:
    """Run the demo chain; returns the archive folder."""
    started = time.perf_counter()
    system = system_from_dict(tomllib.loads(embedded_system_text()), "embedded sdof.toml")
    frequency_hz = np.linspace(*DEFAULT_BAND_HZ)
    summary: dict = {"model": "METHODS §8 SDOF: m 0.1 kg, k 2e6 N/m, loss factor 0.01, k3 1e10 N/m³, Jenkins kf 3e5 N/m, Fs 1 N"}
    with atomic_directory(results_root / run_name("demo")) as archive:
        out = archive.path
        (out / "model.toml").write_text(embedded_system_text())

        say(f"[1/2] simulating {len(DEFAULT_FORCES_N)} force levels × {frequency_hz.size} frequencies (continuation, 5 % noise)")
        table, report = simulate_frf_table(
            system, 0, frequency_hz, DEFAULT_FORCES_N, method="continuation", sweep="up", noise=0.05, seed=seed
        )
        write_frf_table(table, out / "measured.parquet")
        plot_frf_levels(table, "0", "0", out / "measured_frfs.png", "simulated stepped-sine test (sweep up, 5 % noise)")
        summary["simulation"] = {
            "force_levels_n": list(DEFAULT_FORCES_N),
            "band_hz": list(DEFAULT_BAND_HZ),
            "noise_fraction": 0.05,
            "seed": seed,
            "jumps_hz": {f"{k:g}": list(v) for k, v in report.jumps_hz.items() if v},
        }

        say("[2/2] tracing the response curves through the folds")
        curves = []
        folds = {}
        for level in (0.01, 100.0, 250.0, 400.0):
            curve = trace_frequency_response(system, {0: level}, 2 * np.pi * 600, 2 * np.pi * 1300)
            curves.append((f"{level:g} N", curve))
            folds[f"{level:g}"] = [round(f, 3) for f in curve.fold_frequencies_hz]
        plot_continuation(curves, 0, out / "continuation.png")
        summary["continuation_folds_hz"] = folds

        summary["wall_time_s"] = round(time.perf_counter() - started, 2)
        (out / "summary.json").write_text(json.dumps(summary, indent=2))
    say(f"done in {summary['wall_time_s']} s: {archive.final}")
    return archive.final
