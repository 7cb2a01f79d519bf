"""``discover`` names a place as the model does (``m2–m3``, ``m1 (to ground)``), not by
coordinate index (issue "rough edges a new user hit")."""
from __future__ import annotations

import json
import tomllib

import pytest

from nlupdate.app.cli import main
from nlupdate.core.discovery.places import place_name

LINEAR = """
[model]
kind = "lumped"
dof_names = ["m1", "m2", "m3"]
mass = [[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]]          # kg
stiffness = [[2e4, -1e4, 0], [-1e4, 2e4, -1e4], [0, -1e4, 1e4]]  # N/m: ground–m1–m2–m3
loss_factor = 0.01
"""
CUBIC_M2_M3 = """
[[nonlinear]]
type = "cubic"
dofs = ["m2", "m3"]
k3 = 2e9  # N/m³
"""


def test_place_names():
    names = ("m1", "m2", "m3")
    assert place_name((1, 2), names) == "m2–m3"
    assert place_name((0,), names) == "m1 (to ground)"
    assert place_name((1, 2), ("0", "1", "2")) == "dofs [1, 2]"  # a model without dof_names
    assert place_name((1,), ()) == "dofs [1]"


def test_discover_names_the_place_as_the_model_does(tmp_path, capsys):
    """The measurement is simulated with the cubic spring between m2 and m3 (the truth);
    discover finds it there and says so by name, in its output, its JSON and its report."""
    (tmp_path / "linear.toml").write_text(LINEAR)
    (tmp_path / "truth.toml").write_text(LINEAR + CUBIC_M2_M3)
    measured = tmp_path / "frf.csv"
    assert main(["simulate", str(tmp_path / "truth.toml"), "--input-dof", "m1", "--freqs", "5.5:8.5:21",
                 "--forces", "0.1,0.7,1.5", "--noise", "0.01", "--seed", "1", "--out", str(measured)]) == 0
    capsys.readouterr()
    out = tmp_path / "found"
    assert main(["discover", "--model", str(tmp_path / "linear.toml"), "--measured", str(measured), "--out", str(out),
                 "--effects", "cubic_stiffness", "--max-effects", "1"]) == 0
    printed = capsys.readouterr().out
    assert "effects found: cubic_stiffness on m2–m3 (k3 = " in printed, printed
    assert "dofs [" not in printed
    found = json.loads((out / "discovery.json").read_text())
    assert found["dofs"] == [1, 2] and found["place"] == "m2–m3"
    assert [e["place"] for e in found["effects"]] == ["m2–m3"]
    assert found["parameters"]["k3"] == pytest.approx(2e9, rel=0.05)


def test_a_discovery_result_prints_one_line(tmp_path):
    """``print(nlu.discover(…))`` printed every measured point (90 kB); now one line with the
    effects found, where (by name), the gap and the fit."""
    import nlupdate as nlu

    truth = nlu.model_from_dict(tomllib.loads(LINEAR + CUBIC_M2_M3))
    measured = nlu.simulate(truth, "m1", [6.0, 6.5, 7.0, 7.1, 7.2, 7.3, 7.5, 8.0], [0.1, 0.7, 1.5], noise=0.01, seed=1)
    found = nlu.discover(nlu.model_from_dict(tomllib.loads(LINEAR)), measured, effects=("cubic_stiffness",),
                         max_effects=1)
    text = repr(found)
    assert str(found) == text and "\n" not in text and len(text) < 300, text
    assert text.startswith("<DiscoveryResult: cubic_stiffness on m2–m3 (k3 = "), text
    assert "gap " in text and "fit: good" in text
