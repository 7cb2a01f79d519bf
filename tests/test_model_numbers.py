"""A parameter the fit leaves on its bound is printed as such — a one-sided statement, not a
confident number (issue 34 item 4; the new-user walk's items 3 and 4)."""
from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np

from nlupdate.app.cli import main
from nlupdate.core.identification.amplitude_modal_fit import fit_amplitude_model
from nlupdate.core.identification.modal_samples import ModalSamples
from nlupdate.core.model.amplitude_modal import LOWER_BOUNDED, AmplitudeModalModel
from nlupdate.core.model.elements import IwanJoint
from nlupdate.reporting.backbone_plots import model_title
from nlupdate.reporting.model_numbers import damping_text, joint_text

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


def _iwan_samples(reach: float) -> ModalSamples:
    """Six samples of a modal Iwan backbone (truth: 120 Hz, ζ₀ 0.3 %, K_T = 0.3 ω₀², χ = −0.5,
    β = 0.5, φ_max = 1e-3 m·√kg) at amplitudes up to ``reach`` × φ_max, with 0.01 % and 1 %
    relative noise (seed 3) on the frequencies and damping ratios."""
    w0 = 2 * np.pi * 120.0
    joint = IwanJoint((0,), slip_force=1e-3 * 0.3 * w0**2 * (0.5 + 0.5 / 1.5) / 1.5, kt=0.3 * w0**2, chi=-0.5, beta=0.5)
    truth = AmplitudeModalModel(120.0, 0.003, (("x", 1.0),), joint=joint)
    a = np.geomspace(0.02, reach, 6) * joint.phi_max
    omega, zeta = truth.omega_zeta(a)
    noise = np.random.default_rng(3).standard_normal((2, a.size))
    return ModalSamples(a, omega / (2 * np.pi) * (1 + 1e-4 * noise[0]), zeta * (1 + 1e-2 * noise[1]), np.ones_like(a), 1.0)


def test_the_fits_lower_bounds_are_a_field_the_terminal_and_the_file_read():
    """Samples all in microslip (≤ 0.3 φ_max): the fit fixes β = 0 and φ_max at the largest
    amplitude, and its ``lower_bounds`` names K_T and F_S, which the joint's line prints '≥' with
    the reason; into macroslip (8 φ_max) it fits all four and names none. The line follows the
    field, not the note's words, and the field survives amplitude_model.json."""
    micro = fit_amplitude_model(_iwan_samples(0.3), [("x", 1.0)], "iwan", frequency_std=1e-4, damping_std=1e-2)
    assert micro.lower_bounds == LOWER_BOUNDED == ("kt", "slip_force") and micro.joint.beta == 0
    line = joint_text(micro)
    assert line.startswith(f"kt ≥ {micro.joint.kt:.6g} rad²/s², slip_force ≥ {micro.joint.slip_force:.6g} N/√kg "
                           "(lower bounds: beta fixed at 0, no sample reaches macroslip), "), line
    reread = AmplitudeModalModel.from_dict(json.loads(json.dumps(micro.to_dict())))
    assert reread.lower_bounds == micro.lower_bounds and joint_text(reread) == line
    assert joint_text(replace(micro, lower_bounds=())).startswith(f"kt = {micro.joint.kt:.6g} rad²/s², slip_force = ")
    macro = fit_amplitude_model(_iwan_samples(8.0), [("x", 1.0)], "iwan", frequency_std=1e-4, damping_std=1e-2)
    assert macro.lower_bounds == () and "lower bounds" not in joint_text(macro) and macro.joint.beta > 0
