"""Long work shows progress on a terminal (what, i/N, elapsed, estimate) and nothing in logs."""
from __future__ import annotations

import os
import pty
import subprocess
import sys

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


def test_progress_bars_on_a_terminal(command):
    leader, follower = pty.openpty()
    process = subprocess.Popen(command, stdin=subprocess.DEVNULL,
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
    screen = b"".join(chunks).decode(errors="replace")
    assert "1 N: time-domain stepped sine" in screen and "100 N: time-domain stepped sine" in screen
    assert "4/4" in screen and "force levels (time)" in screen and "2/2" in screen
    assert "elapsed" in screen and "left" in screen


def test_no_progress_when_stderr_is_not_a_terminal(command):
    result = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0 and result.stderr == ""
