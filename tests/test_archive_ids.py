"""A whole run id names its run although ``<id>-1`` starts with it, and ``archive list``
puts an original before the runs that got ``-1``, ``-2``, … ``-10`` for the same second
and inputs (issue "rough edges a new user hit")."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from nlupdate.app.cli import main
from nlupdate.reporting.catalogue import ArchiveError, find_runs, resolve_run

ID = "20261128T181505Z-18ac07f8"


def make_run(root: Path, run_id: str, started: str) -> Path:
    folder = root / "tbeam" / run_id
    folder.mkdir(parents=True)
    manifest = {"run_id": run_id, "status": "complete", "study": {"name": "tbeam"},
                "run": {"started_utc": started}, "inputs": {"files": []}, "failures": []}
    (folder / "manifest.json").write_text(json.dumps(manifest))
    return folder


@pytest.fixture
def root(tmp_path):
    """The original and three runs of the same second and inputs; ``-1`` started 0.4 s
    before the original (it finished later, so the original took the plain name)."""
    root = tmp_path / "results"
    make_run(root, ID, "2026-11-28T18:15:05.700000+00:00")
    make_run(root, f"{ID}-1", "2026-11-28T18:15:05.300000+00:00")
    make_run(root, f"{ID}-2", "2026-11-28T18:15:05.900000+00:00")
    make_run(root, f"{ID}-10", "2026-11-28T18:15:05.950000+00:00")
    make_run(root, "20261128T181504Z-00000000", "2026-11-28T18:15:04.990000+00:00")
    return root


def test_a_whole_id_names_its_run(root):
    assert resolve_run(ID, root).run_id == ID
    assert resolve_run(f"{ID}-1", root).run_id == f"{ID}-1"
    with pytest.raises(ArchiveError, match="names 4 runs"):
        resolve_run(ID[:-2], root)


def test_compare_takes_whole_ids(root, capsys):
    assert main(["archive", "compare", ID, f"{ID}-1", "--root", str(root),
                 "--plot", str(root.parent / "cmp.png")]) == 0
    out = capsys.readouterr().out
    assert ID in out and f"{ID}-1" in out and "give more of the id" not in out


def test_list_puts_the_original_before_its_suffixed_runs(root, capsys):
    expected = ["20261128T181504Z-00000000", ID, f"{ID}-1", f"{ID}-2", f"{ID}-10"]
    assert [run.run_id for run in find_runs(root)] == expected
    assert main(["archive", "list", "--root", str(root)]) == 0
    assert [line.split()[1] for line in capsys.readouterr().out.splitlines()] == expected
