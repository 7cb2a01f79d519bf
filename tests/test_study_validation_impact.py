"""A study's ``[validation] impact`` and ``nlupdate validate --impact``: one validation.

The key is declared once (:class:`nlupdate.study.spec.ValidationSpec`) and read by the same
function as the option (:func:`nlupdate.core.validation.impact_limit.impact_linear_limit`):
on the public Brake–Reuss beam (tests/data/brb: its four force-controlled levels and the
hammer-impact excerpt, acc3) the study's archive and the command write the same
validation.json, the impact's linear limit in it — the reference being the command, whose
limit tests/test_validate_linear_limit.py checks against an exact free decay.
"""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from cli_runs import run_cli
from test_real_measurements import BRB, BRB_COORDINATES
from test_validate import _brb_study

IMPACT = Path(__file__).parent / "data" / "brb" / "HammerImpact_1600Hz.mat"


def test_a_study_keeps_the_impact_as_the_command_does(tmp_path, capsys):
    validation = {"hold_out": "top", "models": ["auto"], "response_controlled": "off", "impact": str(IMPACT),
                  "channel": "acc3"}
    code, _, err = run_cli(capsys, "update", _brb_study(tmp_path, validation), "--out", tmp_path / "run", "--quiet")
    assert code == 0, err
    code, out, err = run_cli(capsys, "validate", "--measured", BRB, "--coordinates", BRB_COORDINATES, "--impact",
                             IMPACT, "--channel", "acc3", "--hold-out", "top", "--model", "auto",
                             "--response-controlled", "off", "--out", tmp_path / "cli")
    assert code == 0, err
    study = json.loads((tmp_path / "run" / "validation.json").read_text())
    command = json.loads((tmp_path / "cli" / "validation.json").read_text())
    assert study == command
    limit = study["linear_limit"]
    assert Path(limit["source"]).resolve() == IMPACT.resolve()
    # the mode's linear limit, the hammer's (80.58 Hz, 0.14 %), below every level's resonance (80.05-80.37 Hz
    # measured, a softening joint) and less damped than the quietest level (0.119 %, docs/validation.md)
    assert 80.4 < limit["frequency_hz"] < 80.7 and 0.0012 < limit["damping_ratio"] < 0.0016
    (held,) = study["held_out"]
    assert held["level"] == 1.46 and held["model"] in ("lines", "lines-background")  # the models that keep it
    assert set(study["auto_choices"]["1.46"]["scores"]) <= {"lines", "lines-background"}


@pytest.mark.parametrize("validation, expected", [
    ({"impact": "hammer.mat", "models": ["amplitude-polynomial"]}, "[validation] key 'models': expected with impact"),
    ({"channel": "acc3"}, "[validation] key 'channel': expected nothing unless impact is given"),
    ({"impact": "hammer.mat", "hold_out_type": "stepped-sine", "models": ["amplitude-iwan"], "shapes": {"x": 1.0}},
     "[validation] key 'impact': expected nothing with hold_out_type"),
    # a file that is not there is named with its key before any work (it read 'nope.mat: no such file
    # (input file)', without the study or the key), as [amplitude]'s files are
    ({"impact": "nope.mat", "channel": "acc3"}, "study.toml: [validation] key 'impact': expected an existing file"),
    ({"hold_out_type": "stepped-sine", "models": ["amplitude-iwan"], "shapes": {"acc3:y": 0.73},
      "ring_down": ["nope.mat"]}, "study.toml: [validation] key 'ring_down': expected existing files"),
    # an unknown element of a prd: model (it was an internal error, IndexError)
    ({"models": ["prd:jenkinz"]}, "study.toml: [validation] key 'models': expected prd:ELEMENTS"),
])
def test_the_impact_key_is_refused_where_the_command_refuses_it(tmp_path, capsys, validation, expected):
    code, _, err = run_cli(capsys, "update", _brb_study(tmp_path, validation), "--out", tmp_path / "run", "--quiet")
    assert code == 2 and expected in err and len(err.strip().splitlines()) == 1, err
