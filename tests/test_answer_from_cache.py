"""A rerun whose every result is in the cache is answered from it without Prefect
(:mod:`nlupdate.orchestration.flows.from_cache`), against the run under Prefect that
filled the cache: the same tables, every step and job cached, no Prefect imported; one
record missing or edited and the run goes through Prefect again.
"""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from cli_runs import run_cli
from nlupdate.orchestration.flows.from_cache import answer_from_cache
from nlupdate.orchestration.flows.run import run_study_flow
from nlupdate.orchestration.flows.status_lines import Progress
from nlupdate.orchestration.tasks.signing import RECORDS_FOLDER
from nlupdate.study import load_study
from studies import small_two_dof_study, write_study


@pytest.fixture(scope="module")
def filled(prefect_server, tmp_path_factory):
    """The small 2-DOF study (:func:`studies.small_two_dof_study`) run once under Prefect:
    (folder, its archive, its manifest, the study file)."""
    folder = tmp_path_factory.mktemp("from-cache")
    study = write_study(folder / "study.toml", small_two_dof_study())
    archive = run_study_flow(load_study(study), folder / "results", cache_dir=folder / "cache",
                             progress=Progress(quiet=True))
    return folder, archive, json.loads((archive / "manifest.json").read_text()), study


def tables(archive: Path) -> dict[str, pd.DataFrame]:
    return {path.name: pd.read_parquet(path) for path in sorted((archive / "tables").glob("*.parquet"))}


def test_a_rerun_is_answered_from_the_cache_with_the_flow_runs_results(filled, tmp_path):
    import io

    from rich.console import Console

    folder, computed, manifest, study = filled
    printed = io.StringIO()
    progress = Progress(Console(file=printed, width=400))
    answered = answer_from_cache(load_study(study), tmp_path / "results", folder / "cache", progress)
    assert answered is not None and answered.parent.parent == tmp_path / "results"
    first, again = tables(computed), tables(answered)
    assert list(first) == list(again) and "runs.parquet" in first
    for name in first:  # bookkeeping columns (times, run order) aside, the same numbers
        columns = sorted(c for c in first[name].columns if "time" not in c and not c.startswith("std:"))
        pd.testing.assert_frame_equal(first[name][columns].reset_index(drop=True),
                                      again[name][columns].reset_index(drop=True), obj=name)
    run = json.loads((answered / "manifest.json").read_text())["run"]
    assert run["flow_run_id"] is None and run["orchestration"].startswith("answered from the cache")
    # every step and job the flow ran is there, each cached (FE points: none needed)
    expected = {name for name in manifest["run"]["tasks"] if name != "FE point"}
    assert set(run["tasks"]) == expected
    assert all(counts == {"computed": 0, "cached": 1, "failed": 0} for counts in run["tasks"].values()), run["tasks"]
    assert (answered / "report.md").read_text().count("##") == (computed / "report.md").read_text().count("##")
    # the line a flow says before the updating jobs (what their names say) is said here too
    lines = printed.getvalue().splitlines()
    first_job = next(i for i, line in enumerate(lines) if line.startswith("updating: eigensensitivity"))
    assert lines[first_job - 1] == ("updating: 1 run; parameters k1 (N/m); O(h): error order of the finite-difference "
                                    "sensitivities in their step h"), lines


def test_answering_from_the_cache_imports_no_prefect(filled, tmp_path):
    folder, _, _, study = filled
    script = ("import sys; from pathlib import Path\n"
              "from nlupdate.orchestration.flows.from_cache import answer_from_cache\n"
              "from nlupdate.orchestration.flows.status_lines import Progress\n"
              "from nlupdate.study import load_study\n"
              f"archive = answer_from_cache(load_study({str(study)!r}), Path({str(tmp_path)!r}), "
              f"Path({str(folder / 'cache')!r}), Progress(quiet=True))\n"
              "print(archive is not None, sorted(m for m in sys.modules if m.split('.')[0] == 'prefect'))\n")
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr[-2000:]
    assert result.stdout.split() == ["True", "[]"], result.stdout


def test_a_missing_or_edited_record_sends_the_run_through_prefect(filled, tmp_path, prefect_server, capsys):
    folder, computed, _, study = filled
    import shutil

    cache = tmp_path / "cache"
    shutil.copytree(folder / "cache", cache)
    record = sorted((cache / RECORDS_FOLDER).iterdir(), key=lambda p: p.stat().st_mtime)[0]  # the first step's
    content = record.read_bytes()
    record.write_bytes(content.replace(b'"expiration":null', b'"expiration":nul '))  # edited: signature fails
    assert answer_from_cache(load_study(study), tmp_path / "answered", cache, Progress(quiet=True)) is None
    record.unlink()
    assert answer_from_cache(load_study(study), tmp_path / "answered", cache, Progress(quiet=True)) is None
    assert not (tmp_path / "answered").exists()  # nothing written when it cannot answer
    code, out, err = run_cli(capsys, "run", study, "--out", tmp_path / "results", "--cache-dir", cache)
    assert code == 0, err
    archive = Path(out.split("archive:")[1].split()[0])
    run = json.loads((archive / "manifest.json").read_text())["run"]
    assert run["flow_run_id"] and "Prefect flow" in run["orchestration"]
    assert sum(counts["computed"] for counts in run["tasks"].values()) >= 1  # the missing record, computed
    code, out, _ = run_cli(capsys, "run", study, "--out", tmp_path / "results", "--cache-dir", cache)
    assert code == 0 and "answered from it without Prefect" in out  # complete again: no Prefect
