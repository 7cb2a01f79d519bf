"""The demo: ``nlupdate demo`` as a user runs it, and its numbers against the hidden truth.

The demo study simulates the T-beam with E = 195 GPa, h2 = 1.45 mm, a cubic spring
(3e9 N/m³) and Jenkins friction (kf = 3e4 N/m, slip force 0.5 N) at the tip, 5 % noise,
tested at 0.01 N and at 0.5…50 N through the stick–slip transition.
Its archive states every identified and updated value with a standard deviation; the
report's "3σ" claim is checked here for eight noise seeds, including the 0.01 N level
in the prediction check.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from nlupdate.app.cli.demo import demo_study_text
from nlupdate.study import run_study, study_from_text

TRUTH = {"k3": 3e9, "kf": 3e4, "slip_force": 0.5, "E": 195e9, "h2": 1.45e-3}


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(1, 9))
def test_identified_and_updated_values_are_within_three_sigma_of_the_truth(seed):
    result = run_study(study_from_text(demo_study_text(seed), Path("demo.toml")))
    stats = result.identification.uncertainty.parameters
    for name in ("k3", "kf", "slip_force"):
        assert abs(stats[name].value - TRUTH[name]) <= 3 * stats[name].std, (name, stats[name])
    best = result.ranking[result.ranking["candidate"] != "initial"].iloc[0]["candidate"]
    assert set(next(r for r in result.runs if r.name == best).parameters) == {"E", "h2"}  # the right set wins
    run = next(r for r in result.runs if r.name == best)
    for name, value in run.parameters.items():
        assert abs(value - TRUTH[name]) <= 3 * result.uncertainties[best].std[name], (name, value)
    # the {E}-only runs cannot meet both modes: their mode errors are larger than the {E, h2} runs'
    ranking = result.ranking.set_index("candidate")
    assert ranking.loc["eigensensitivity central O(h²) {E}", "weighted_abs_error_pct"] > 10 * ranking.loc[best, "weighted_abs_error_pct"]
    # ... and are said to miss them: their E lies further from the truth than their ± says (the ± of the
    # targets' noise alone); the {E, h2} runs meet them and carry no warning; the {E} run fitted to mode 2
    # alone is said to miss mode 1, which it was not fitted to
    said = {run.name: {w.kind for w in result.warnings if w.source == run.name} for run in result.runs}
    for run in result.runs:
        if set(run.parameters) == {"E", "h2"}:
            assert said[run.name] == set(), (run.name, said[run.name])
        elif run.method == "eigensensitivity":
            assert said[run.name] == {"targets_missed"}, (run.name, said[run.name])
            assert abs(run.parameters["E"] - TRUTH["E"]) > 3 * result.uncertainties[run.name].std["E"]
    assert said["optimisation {E} mode 2 only"] == {"unfitted_target_missed"}
    prediction = next(p for p in result.predictions if p.name == best).correlation.set_index("force_level_n")
    initial = next(p for p in result.predictions if p.name == "initial").correlation.set_index("force_level_n")
    # FRAC at every level above 0.9: the minimum over seeds 1-8 was 0.926 (2026-11-28, seed 5
    # at 1 N, in the stick-slip transition, where the response is most sensitive to every
    # parameter). A broken chain lands far below: with the linear FRF from the 0.01 N level
    # alone the minima were 0.70 at 1 N; a slip force that let the 0.01 N level slip gave 0.04
    frac = prediction["frac"]
    assert frac.min() > 0.9, frac
    assert (prediction["frac"] > initial["frac"]).all()  # updating improves every level, 0.01 N included


@pytest.mark.slow
def test_nlupdate_demo_runs_and_a_rerun_is_all_cached(tmp_path):
    """As a user runs it, from a shell: it starts its own Prefect server. Its times are
    benchmarks/demo_timing.py's to measure and print; a test asserts no machine's speed
    (it bounded the run at 180 s and the rerun at 0.3 of the first's wall time, two wall
    times under whatever load the machine had)."""
    env = {k: v for k, v in os.environ.items() if k != "PREFECT_API_URL"}
    env["PREFECT_HOME"] = str(tmp_path / "prefect-home")
    command = [sys.executable, "-m", "nlupdate", "demo", "--results", str(tmp_path / "results"),
               "--cache-dir", str(tmp_path / "cache")]
    first = subprocess.run(command, capture_output=True, text=True, env=env, cwd=tmp_path, timeout=1800)  # a hang
    assert first.returncode == 0, first.stderr[-3000:]
    assert "Identified" in first.stdout and "report:" in first.stdout
    archive = Path(first.stdout.split("archive:")[1].split()[0])
    assert len(list((archive / "tables").glob("*.parquet"))) >= 3 and len(list((archive / "plots").glob("*.png"))) >= 3
    assert (archive / "report.md").stat().st_size > 2000
    second = subprocess.run(command, capture_output=True, text=True, env=env, cwd=tmp_path, timeout=1800)
    assert second.returncode == 0, second.stderr[-3000:]
    again = Path(second.stdout.split("archive:")[1].split()[0])
    manifests = [json.loads((a / "manifest.json").read_text())["run"] for a in (archive, again)]
    assert all(c["computed"] == 0 for c in manifests[1]["tasks"].values()), manifests[1]["tasks"]
    assert sum(c["cached"] for c in manifests[1]["tasks"].values()) > 0  # none computed: read from the cache
