"""examples/calculix_tbeam.toml runs as its header says and leaves nothing behind but its
archive: no ``ccx_runs/`` or other scratch in the working folder, no scratch folder in the
temporary folder (issue 25, rough edges). Needs ccx (skipped with the reason without it,
unless NLUPDATE_REQUIRE_CCX=1).

The command is run as a user runs it, in a fresh process (its scratch folder is removed
when the process ends), with TMPDIR pointing at an empty folder the test watches. The
answer is checked against the √E scaling of every frequency of a homogeneous solid:
E = E₀ · (f_target / f₀)², f₀ the archived initial frequency.
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from test_examples import EXAMPLES, header_commands, absolute

pytestmark = pytest.mark.calculix
EXAMPLE = EXAMPLES / "calculix_tbeam.toml"


def files_under(folder: Path) -> set[str]:
    return {p.relative_to(folder).as_posix() for p in folder.rglob("*")}


def test_calculix_example_leaves_only_its_archive(tmp_path):
    (argv,) = header_commands(EXAMPLE)
    work, temporary = tmp_path / "work", tmp_path / "tmp"
    work.mkdir(), temporary.mkdir()
    done = subprocess.run([sys.executable, "-m", "nlupdate", *[absolute(a) for a in argv]], cwd=work,
                          env={**os.environ, "TMPDIR": str(temporary)}, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout + done.stderr
    out = argv[argv.index("--out") + 1]
    assert out == "results/calculix_tbeam/update"
    assert {p.split("/")[0] for p in files_under(work)} == {"results"}
    assert all(p.startswith(out) or out.startswith(p) for p in files_under(work)), files_under(work)
    assert not [p for p in files_under(temporary) if "ccx" in p], files_under(temporary)
    comparison = pd.read_parquet(work / out / "tables" / "comparison.parquet")
    initial = comparison[comparison["candidate"] == "initial"].iloc[0]
    runs = pd.read_parquet(work / out / "tables" / "runs.parquet")
    (updated,) = runs["p:E"]
    assert updated == pytest.approx(210e9 * (initial["target_hz"] / initial["f_hz"]) ** 2, rel=2e-5)
    report = (work / out / "report.md").read_text()  # no target std: the value and why, never "± –"
    assert "± –" not in report and "(no uncertainty: the targets state no std_hz)" in report
