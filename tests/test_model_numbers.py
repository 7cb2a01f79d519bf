"""A parameter the fit leaves on its bound is printed as such — a one-sided statement, not a
confident number (issue 34 item 4; the new-user walk's items 3 and 4)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from nlupdate.app.cli import main
from nlupdate.core.identification.amplitude_modal_fit import fit_amplitude_model
from nlupdate.core.identification.modal_samples import ModalSamples
from nlupdate.reporting.backbone_plots import model_title
from nlupdate.reporting.model_numbers import damping_text

BRB = Path(__file__).parent / "data" / "brb"


def test_a_linear_damping_at_its_bound_zero_is_printed_as_the_bound():
    """Truth ζ(a) = 0.04 % · a/a₁ (all of the damping the joint's: ζ₀ = 0), f falling 0.1 %: the
    polynomial fit's ζ₀ ends on its bound 0 (numerically 1e-22 on the transmitter beam, printed
    "1.377e-20 %"); terminal, warnings (the JSON's) and the figure's title say "at its bound"."""
    a = np.array([1.0, 1.5, 2.0, 2.4]) * 1e-3
    samples = ModalSamples(a, 42.8 * (1 - 1e-3 * a / a.max()), 4e-4 * a / a[0], np.ones_like(a), 1.0)
    model = fit_amplitude_model(samples, [("x", 1.0)], "polynomial")
    assert model.damping_ratio < 1e-9  # the truth's 0, on the fit's bound
    for text in (damping_text(model), model_title(model), *[w for w in model.warnings if "ζ₀" in w]):
        assert "0 (at its bound ζ₀ ≥ 0" in text and "e-" not in text.split("ζ₀")[1][:40], text


def test_brb_default_iwan_prints_its_bounded_parameters_one_sided(tmp_path, capsys):
    """The BRB's four levels, Iwan default: f₀ on its upper bound (its warning), χ on its bound 0,
    β fixed at 0 with K_T and F_S lower bounds (the fit's note): printed '≥' / 'at its bound',
    never 'chi = -1e-09'."""
    runs = BRB / "ForcedFrequencyResponses.mat"
    assert main(["amplitude", "--measured", str(runs), "--coordinates", f"{runs}=acc3:-y,acc3:y",
                 "--out", str(tmp_path / "out")]) == 0
    out = capsys.readouterr().out
    joint = json.loads((tmp_path / "out" / "amplitude_model.json").read_text())["joint"]
    assert joint["chi"] > -1e-6 and joint["beta"] == 0  # the fit's own bounds, read from its file
    mode = next(line for line in out.splitlines() if line.startswith("mode 1:"))
    joint_line = next(line for line in out.splitlines() if line.startswith("modal joint:"))
    assert "linear limit ≥ " in mode and "upper physical bound" in mode, mode
    assert "chi = 0 (at its bound" in joint_line and "e-09" not in joint_line, joint_line
    assert "kt ≥" in joint_line and "slip_force ≥" in joint_line, joint_line
