"""The three commands chained as a user runs them: simulate → identify → update.

The METHODS 2-DOF (ground–m1–m2–ground, k = 1e6 N/m each, cubic + Jenkins on m1) is
"tested"; identification extracts the linear FRF at m1, and updating recovers k1 of a
lumped model that starts 20 % off, from the natural frequency of that extracted FRF.
"""
import json

import pandas as pd
import pytest

from nlupdate.app.cli import main

STUDY = """
[adapter]
kind = "lumped"
[adapter.options]
masses = [0.1, 0.5]
stiffnesses = [0.8e6, 1.0e6, 1.0e6]

[[parameters]]
name = "k1"
unit = "N/m"
start = 0.8e6
lower = 0.5e6
upper = 1.5e6

[targets]
identification = "ident"
n_modes = 1
response_dof = "0"            # measured coordinate names …
input_dof = "0"
model_response_dof = "x1"     # … and the lumped model's name for the same coordinate
model_input_dof = "x1"
model_modes = [2]             # the m1 mode (≈ 732 Hz) is the model's second mode

[eigensensitivity]
formulas = ["central2"]

[comparison]
loss_factors = 0.005
"""


def test_simulate_identify_update(tmp_path, capsys):
    measured = tmp_path / "measured.parquet"
    assert main(["simulate", "examples/two_dof.toml", "--input-dof", "0", "--freqs", "690:770:161",
                 "--forces", "0.01,20,40,60,80,100", "--out", str(measured)]) == 0
    assert main(["identify", "--measured", str(measured), "--elements", "cubic,jenkins", "--samples", "5",
                 "--out", str(tmp_path / "ident")]) == 0
    identified = json.loads((tmp_path / "ident" / "identification.json").read_text())["parameters"]
    assert identified["k3"]["value"] == pytest.approx(1e10, rel=0.01)
    assert identified["kf"]["value"] == pytest.approx(8e4, rel=0.01)

    (tmp_path / "study.toml").write_text(STUDY)
    assert main(["update", str(tmp_path / "study.toml"), "--out", str(tmp_path / "updated")]) == 0
    capsys.readouterr()
    runs = pd.read_parquet(tmp_path / "updated" / "tables" / "runs.parquet")
    run = runs[runs["method"] == "eigensensitivity"].iloc[0]
    assert run["p:k1"] == pytest.approx(1e6, rel=0.01)
    comparison = pd.read_parquet(tmp_path / "updated" / "tables" / "comparison.parquet")
    frac = comparison.set_index("candidate")["frac"]
    assert frac["initial"] < 0.5 < 0.99 < frac[run["candidate"]]  # vs the extracted linear FRF
