"""Run archives: complete or absent, self-describing, and a report whose links resolve."""
from __future__ import annotations

import hashlib
import json
import re
from pathlib import Path

import pandas as pd
import pytest

import nlupdate.reporting.archive as archive_module
from nlupdate.reporting.archive import run_folder, write_archive
from nlupdate.files import atomic_directory
from nlupdate.fingerprints import table_hash
from nlupdate.study import load_study, run_study

STUDY = Path(__file__).parent / "data" / "studies" / "two_dof.toml"
RUN = {"started_utc": "2026-11-23T10:00:00+00:00", "wall_time_s": 1.0, "orchestration": "test"}


@pytest.fixture(scope="module")
def result():
    return run_study(load_study(STUDY))


def test_archive_holds_what_the_manifest_says_and_the_report_links_resolve(result, tmp_path):
    import datetime as dt

    folder = write_archive(result, run_folder(tmp_path, "two-dof", dt.datetime(2026, 11, 23, 10, tzinfo=dt.timezone.utc),
                                              "abcdef0123"), RUN)
    assert folder == tmp_path / "two-dof" / "20261123T100000Z-abcdef01"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["two-dof"] and len(list((tmp_path / "two-dof").iterdir())) == 1
    manifest = json.loads((folder / "manifest.json").read_text())
    assert manifest["study"]["sha256"] == hashlib.sha256(STUDY.read_bytes()).hexdigest()
    measured = pd.read_parquet(folder / "tables" / "measured.parquet")
    assert manifest["inputs"]["measured"]["sha256"] == table_hash(measured)
    assert manifest["seeds"] == {"simulated_noise": 3, "monte_carlo": 1}
    assert manifest["environment"]["packages"]["numpy"] and manifest["adapters"]["updating"]["solver"].startswith("nlupdate")
    assert set(manifest["tables"]) == {p.stem for p in (folder / "tables").iterdir()} >= {
        "measured", "identification", "linear_frf", "targets", "runs", "histories", "comparison", "ranking",
        "predictions", "correlation"}
    for png in (folder / "plots").iterdir():
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    report = (folder / "report.md").read_text()
    for section in ("## Summary", "## Identification", "## Updating", "## Prediction at every force level"):
        assert section in report
    links = re.findall(r"\]\((plots/[^)]+)\)", report)
    assert len(links) >= 6 and all((folder / link).is_file() for link in links)
    assert (folder / "study.toml").read_text() == STUDY.read_text()
    assert json.loads((folder / "identification.json").read_text())["method"] == "prd"


def test_a_failure_while_writing_leaves_no_archive(result, tmp_path, monkeypatch):
    def broken(*args, **kwargs):
        raise RuntimeError("disk full")

    monkeypatch.setattr(archive_module, "predictions_figure", broken)
    with pytest.raises(RuntimeError, match="disk full"):
        write_archive(result, tmp_path / "study" / "run", RUN)
    assert list((tmp_path / "study").iterdir()) == []



def test_failed_run_leaves_nothing_and_names_are_not_reused(tmp_path):
    with pytest.raises(RuntimeError):
        with atomic_directory(tmp_path / "run") as archive:
            (archive.path / "half.txt").write_text("partial")
            raise RuntimeError("solver died")
    assert list(tmp_path.iterdir()) == []
    with atomic_directory(tmp_path / "run") as first:
        pass
    with atomic_directory(tmp_path / "run") as second:
        pass
    assert first.final == tmp_path / "run" and second.final == tmp_path / "run-1"


def test_existing_output_is_replaced_only_when_asked(tmp_path):
    with atomic_directory(tmp_path / "out", kind="archive") as archive:
        (archive.path / "old.txt").write_text("old")
    with pytest.raises(FileExistsError):
        with atomic_directory(tmp_path / "out", on_exists="error", kind="archive"):
            pass
    with atomic_directory(tmp_path / "out", on_exists="replace", kind="archive") as archive:
        (archive.path / "new.txt").write_text("new")
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == [".nlupdate-output.json", "new.txt"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_the_hidden_truth_of_the_demo_is_what_its_study_file_states():
    """Study.hidden_truth (what the report and the convergence plot print beside every estimate):
    the demo's [measured.simulate] parameters and its elements' numbers, as src/nlupdate/data/demo.toml
    writes them; none for a study on measured data."""
    import dataclasses

    demo = load_study(Path(__file__).parents[1] / "src" / "nlupdate" / "data" / "demo.toml")
    assert demo.hidden_truth == {"E": 195e9, "h2": 1.45e-3, "k3": 3e9, "kf": 3e4, "slip_force": 0.5}
    measured = demo.measured.__class__(file="x.parquet")
    assert dataclasses.replace(demo, measured=measured).hidden_truth == {}
