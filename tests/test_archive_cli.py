"""``nlupdate archive list/show/compare/rerun`` on real runs of a small study.

The study is the small 2-DOF study (:func:`studies.small_two_dof_study`) with its
optimisation candidate kept. Run A reads its measured data from a file (simulated once with
the 2-DOF truth, 1 % noise); run B is the same study with another Monte-Carlo seed. The
archives must be self-contained: A is rerun after its data file was deleted. Expected values come from
the archives' own tables read independently (parquet), from the study files, and from
what the test changed, never from the code under test.
"""
from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from nlupdate.app.cli import main
from nlupdate.files import HOST
from nlupdate.study import study_from_text
from nlupdate.study.steps.measured import measured_table

from cli_runs import run_cli
from studies import TWO_DOF_STUDY, small_two_dof_study, study_text, two_dof_study


def simulated_study() -> dict:
    """The small 2-DOF study with the full study's optimisation candidate (the best-ranked run)."""
    study = small_two_dof_study()
    study["optimisation"] = two_dof_study()["optimisation"]
    return study


def study_from_file(monte_carlo_seed: int, candidates: object = "best") -> str:
    """The study's text with its measured data read from the file, the given Monte-Carlo
    seed and prediction candidates."""
    study = simulated_study()
    study["measured"] = {"file": "data/measured.parquet"}
    study["identification"]["seed"] = monte_carlo_seed
    study["prediction"]["candidates"] = candidates
    return study_text(study)


@pytest.fixture(scope="module")
def runs(prefect_server, tmp_path_factory):
    """Two runs A (Monte-Carlo seed 1) and B (seed 2) of a file-based study."""
    folder = tmp_path_factory.mktemp("archive-cli")
    (folder / "data").mkdir()
    simulated = study_from_text(study_text(simulated_study()), TWO_DOF_STUDY)
    measured_table(simulated).to_parquet(folder / "data" / "measured.parquet", index=False)
    (folder / "a.toml").write_text(study_from_file(1))
    (folder / "b.toml").write_text(study_from_file(2))
    (folder / "c.toml").write_text(study_from_file(1, ["no such run"]))
    results = folder / "results"
    archives = {}
    for name, code in (("a", 0), ("b", 0), ("c", 2)):
        assert main(["run", str(folder / f"{name}.toml"), "--out", str(results), "--cache-dir", str(folder / "cache"),
                     "--quiet", "--workers", "2"]) == code
        archives[name] = max((results / "two-dof").iterdir(), key=lambda p: p.stat().st_mtime)
    return folder, results, archives


def test_a_study_that_fails_leaves_a_failed_archive(runs, capsys):
    _, results, archives = runs
    manifest = json.loads((archives["c"] / "manifest.json").read_text())
    assert manifest["status"] == "failed" and "'no such run'" in manifest["error"]
    assert (archives["c"] / "study.toml").is_file() and (archives["c"] / "report.md").is_file()
    code, out, _ = run_cli(capsys, "archive", "list", "--root", results)
    line = next(line for line in out.splitlines() if archives["c"].name in line)
    assert " failed " in line and "[prediction] candidates ['no such run']" in line


def test_archive_holds_a_copy_of_every_input_file(runs):
    folder, _, archives = runs
    manifest = json.loads((archives["a"] / "manifest.json").read_text())
    (entry,) = manifest["inputs"]["files"]
    assert entry["as_written"] == "data/measured.parquet"
    copy = archives["a"] / entry["archived"]
    assert copy.read_bytes() == (folder / "data" / "measured.parquet").read_bytes()
    assert manifest["study"]["file"] == str(folder / "a.toml")
    assert (archives["a"] / "study.toml").read_text() == (folder / "a.toml").read_text()


def test_list_shows_every_run_with_status_and_key_results(runs, capsys):
    _, results, archives = runs
    study_folder = results / "two-dof"
    dead = study_folder / f".tmp-20260101T000000Z-deadbeef-{HOST}-999999999-0123abcd"
    live = study_folder / f".tmp-20260101T000001Z-deadbeef-{HOST}-{os.getpid()}-4567abcd"
    dead.mkdir(), live.mkdir()
    try:
        code, out, _ = run_cli(capsys, "archive", "list", "--root", results, "--json")
        assert code == 0
        entries = {e["run_id"]: e for e in json.loads(out)}
        assert entries[dead.name]["status"] == "incomplete" and entries[live.name]["status"] == "writing"
        assert entries[archives["c"].name]["status"] == "failed"
        for name in ("a", "b"):
            entry = entries[archives[name].name]
            assert entry["status"] == "complete" and entry["study"] == "two-dof"
            ranking = pd.read_parquet(archives[name] / "tables" / "ranking.parquet")
            best = ranking.loc[ranking["rank"] == 1, "candidate"].item()
            runs_table = pd.read_parquet(archives[name] / "tables" / "runs.parquet").set_index("candidate")
            correlation = pd.read_parquet(archives[name] / "tables" / "correlation.parquet")
            assert entry["best"] == best
            assert entry["updated"]["k1"][0] == pytest.approx(runs_table.loc[best, "p:k1"], rel=1e-12)
            assert entry["min_frac"] == pytest.approx(correlation.loc[correlation["model"] != "initial", "frac"].min())
        code, out, _ = run_cli(capsys, "archive", "list", "--root", results)
        lines = out.strip().splitlines()
        assert len(lines) == len(entries)
        line_a = next(line for line in lines if archives["a"].name in line)
        assert "complete" in line_a and "best 'optimisation {k1}'" in line_a and "min FRAC" in line_a
        assert "incomplete" in next(line for line in lines if dead.name in line)
        code, out, _ = run_cli(capsys, "archive", "list", "--root", results, "--study", "no-such-study")
        assert code == 0 and out.startswith("no runs under")
        code, _, err = run_cli(capsys, "archive", "list", "--root", results / "nowhere")
        assert code == 2 and err.strip() == f"nlupdate archive: error: no results folder {results / 'nowhere'}"
    finally:
        dead.rmdir(), live.rmdir()


def test_show_prints_the_summary_and_where_the_files_are(runs, capsys):
    _, results, archives = runs
    code, out, _ = run_cli(capsys, "archive", "show", archives["a"].name[:20], "--root", results)
    assert code == 0
    assert "Identified (physical elements: cubic + jenkins, PRD)" in out
    assert f"report:   {archives['a'] / 'report.md'}" in out
    assert "inputs/" in out and "measured.parquet" in out
    code, _, err = run_cli(capsys, "archive", "show", "2026", "--root", results)
    assert code == 2 and "give more of the id" in err
    code, _, err = run_cli(capsys, "archive", "show", "1999", "--root", results)
    assert code == 2 and "no run id under" in err


def test_compare_names_exactly_what_differs(runs, capsys, tmp_path):
    _, results, archives = runs
    plot = tmp_path / "compare.png"
    code, out, _ = run_cli(capsys, "archive", "compare", archives["a"], archives["b"], "--json", "--plot", plot)
    assert code == 0
    report = json.loads(out)
    changed_inputs = {(r["section"], r["field"]) for r in report["inputs"] if r["status"] != "same"}
    assert changed_inputs == {("study", "identification.seed"), ("seeds", "monte_carlo")}
    changed_results = {(r["section"], r["field"]) for r in report["results"] if r["status"] != "same"}
    # another Monte-Carlo seed changes the spreads, not the estimates, so every changed
    # field is one with a standard deviation, and the identified values themselves agree
    identified = {r["field"]: r for r in report["results"] if r["section"] == "identified"}
    table_a = pd.read_parquet(archives["a"] / "tables" / "identification.parquet").set_index("parameter")
    table_b = pd.read_parquet(archives["b"] / "tables" / "identification.parquet").set_index("parameter")
    for name, row in identified.items():
        assert row["a"] == pytest.approx([table_a.loc[name, "value"], table_a.loc[name, "std"]])
        assert row["a"][0] == row["b"][0]
        assert (row["status"] == "changed") == (table_a.loc[name, "std"] != table_b.loc[name, "std"])
    assert ("identified", "k3") in changed_results
    assert all(section in ("identified", "linear modes", "updated") for section, _ in changed_results)
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    code, out, _ = run_cli(capsys, "archive", "compare", archives["a"].name, archives["b"].name, "--root", results)
    assert "inputs: 2 of" in out and "identification.seed" in out and "monte_carlo" in out
    default_plot = results / "comparisons" / f"{archives['a'].name}-vs-{archives['b'].name}.png"
    assert f"plot: {default_plot}" in out and default_plot.is_file()


def test_rerun_from_the_archive_alone_reproduces_the_run(runs, capsys):
    folder, results, archives = runs
    (folder / "data" / "measured.parquet").unlink()  # the original data are gone
    code, out, _ = run_cli(capsys, "archive", "rerun", archives["a"].name, "--root", results, "--quiet")
    assert code == 0, out
    assert "inputs: the same study, data, seeds, package and solver versions" in out
    assert "REPRODUCED: all" in out
    verdict_path = Path(out.split("verdict: ")[1].strip())
    verdict = json.loads(verdict_path.read_text())
    tables = {name: pd.read_parquet(archives["a"] / "tables" / f"{name}.parquet")
              for name in ("identification", "runs", "correlation")}
    # at least every identified parameter, every run's updated values and every FRAC compared
    assert verdict["reproduced"] and verdict["fields_compared"] >= sum(map(len, tables.values()))
    assert verdict["input_changes"] == []
    rerun = verdict_path.parent
    manifest = json.loads((rerun / "manifest.json").read_text())
    assert manifest["run"]["rerun_of"] == f"two-dof/{archives['a'].name}"
    assert all(counts["cached"] == 0 for counts in manifest["run"]["tasks"].values())  # recomputed, not read back
    for name, table in tables.items():  # independent check of the verdict
        a = table.select_dtypes("number")
        b = pd.read_parquet(rerun / "tables" / f"{name}.parquet").select_dtypes("number")
        a = a.drop(columns=[c for c in a if "wall_time" in c or "evaluations" in c])
        np.testing.assert_allclose(a.to_numpy(), b[a.columns].to_numpy(), rtol=1e-6)


def copy_archive(archive: Path, name: str) -> Path:
    copy = archive.parent / name
    shutil.copytree(archive, copy)
    return copy


def test_rerun_reports_a_package_version_change(runs, capsys):
    _, results, archives = runs
    older = copy_archive(archives["a"], "20000101T000000Z-versions")
    manifest = json.loads((older / "manifest.json").read_text())
    manifest["environment"]["packages"]["numpy"] = "1.0.0"
    (older / "manifest.json").write_text(json.dumps(manifest))
    code, out, _ = run_cli(capsys, "archive", "rerun", older, "--root", results, "--json", "--quiet")
    verdict = json.loads(out[out.index("{"):])
    changes = {(r["section"], r["field"]): (r["a"], r["b"]) for r in verdict["input_changes"]}
    assert changes == {("versions", "package numpy"): ("1.0.0", np.__version__)}
    assert code == 0 and verdict["reproduced"]  # the text form of a changed input: the edited-data test


def test_rerun_reports_edited_data_instead_of_matching(runs, capsys):
    _, results, archives = runs
    edited = copy_archive(archives["a"], "20000101T000000Z-edited")
    entry = json.loads((edited / "manifest.json").read_text())["inputs"]["files"][0]
    data = pd.read_parquet(edited / entry["archived"])
    data.loc[data["force_level_n"] == 60, "h_real"] *= 1.05
    data.to_parquet(edited / entry["archived"], index=False)
    code, out, _ = run_cli(capsys, "archive", "rerun", edited, "--root", results, "--quiet")
    assert code == 1
    assert "was edited after the run" in out
    assert "NOT REPRODUCED" in out and "measured data sha256" in out
    assert "inputs that differ from the original run (" in out
