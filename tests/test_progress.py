"""Long work shows progress on a terminal (what, i/N, elapsed, estimate) and nothing in logs."""
from __future__ import annotations

import os
import pty
import subprocess
import sys
from pathlib import Path

import pytest

MODEL = """
[model]
kind = "lumped"
mass = [[1.0]]
stiffness = [[1e4]]
loss_factor = 0.05

[[nonlinear]]
type = "cubic"
dofs = [0]
k3 = 1e8
"""


@pytest.fixture
def command(tmp_path) -> list[str]:
    """A time-domain simulation of a damped Duffing SDOF: 4 frequencies × 2 levels, two
    bars that count (the time, not the count, is what a test pays for)."""
    (tmp_path / "sdof.toml").write_text(MODEL)
    return [sys.executable, "-m", "nlupdate", "simulate", str(tmp_path / "sdof.toml"), "--input-dof", "0",
            "--freqs", "10:20:4", "--forces", "1,100", "--method", "time", "--out", str(tmp_path / "frf.csv")]


def on_a_terminal(command: list[str], cwd: Path | None = None) -> str:
    """What ``command`` draws on stderr when stderr is a terminal (it must succeed)."""
    leader, follower = pty.openpty()
    process = subprocess.Popen(command, stdin=subprocess.DEVNULL, cwd=cwd,
                               stdout=subprocess.DEVNULL, stderr=follower, env={**os.environ, "COLUMNS": "160"})
    os.close(follower)
    chunks = []
    while True:
        try:
            chunk = os.read(leader, 65536)
        except OSError:  # the terminal closed with the process
            break
        if not chunk:
            break
        chunks.append(chunk)
    assert process.wait(timeout=300) == 0
    return b"".join(chunks).decode(errors="replace")


def test_progress_bars_on_a_terminal(command):
    screen = on_a_terminal(command)
    assert "1 N: time-domain stepped sine" in screen and "100 N: time-domain stepped sine" in screen
    assert "4/4" in screen and "force levels (time)" in screen and "2/2" in screen
    assert "elapsed" in screen and "left" in screen


def test_no_progress_when_stderr_is_not_a_terminal(command):
    result = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0 and result.stderr == ""


BRB = Path(__file__).parent / "data" / "brb" / "ForcedFrequencyResponses.mat"
REAL = ["--measured", str(BRB), "--coordinates", f"{BRB}=acc3:-y,acc3:y"]


def test_real_data_runs_with_samples_show_them_on_a_terminal(tmp_path):
    """The Brake–Reuss beam (real data): identify's Monte-Carlo samples, amplitude's
    bootstrap refits and validate's held-out levels are counted on the terminal as they
    finish — every sample, up to the total asked for (issue 39)."""
    nlupdate = [sys.executable, "-m", "nlupdate"]
    screen = on_a_terminal([*nlupdate, "identify", *REAL, "--elements", "cubic", "--samples", "7",
                            "--out", str(tmp_path / "identify")])
    assert "Monte-Carlo samples" in screen and "7/7" in screen and "elapsed" in screen
    screen = on_a_terminal([*nlupdate, "amplitude", *REAL, "--backbone", "polynomial", "--bootstrap", "9",
                            "--out", str(tmp_path / "amplitude")])
    assert "bootstrap refits" in screen and "9/9" in screen
    screen = on_a_terminal([*nlupdate, "validate", *REAL, "--hold-out", "each", "--model", "lines",
                            "--out", str(tmp_path / "validate")])
    assert "held-out levels" in screen and "4/4" in screen
    assert "response-controlled runs: models" in screen and "1/1" in screen
