"""``nlupdate validate --hold-out-type impact``: the impact's linear limit predicted by the
amplitude model fitted on the other test types, with its band, beside the measured one.

Truth, independent of the code under test (tests/test_test_type_truth.py): the SDOF and the
2-DOF with a Jenkins joint, their records by RK4 time integration of the joint's own force
law (a ring-down from 30 × the slip amplitude, a tap, 2 % noise) and phase-resonance points
by the multi-harmonic balance at 90°. Below its slip amplitude a Jenkins joint is stuck, so
the linear limit is the stuck system's mode in closed form: ω₀ from the eigenproblem of
(K + k_t e₀e₀ᵀ, M), ζ₀ = 0.5 % (C = (2ζ₀/ω₀)·K_stuck). The joint's own backbone
(``amplitude-jenkins``) is fitted to the ring-down and the phase resonance, each from 1 × the
slip amplitude up, and its 95 % band (20 bootstrap refits) must hold that linear limit; the
tap lies below every kept sample, so the prediction is the model's at zero amplitude and the
output says first that it is an extrapolation. With a stuck phase-resonance point below the
tap kept as well, the tap lies within the kept amplitudes: predicted at its own amplitude,
no extrapolation stated.
"""
from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from cli_runs import run_cli
from test_test_type_truth import ZETA0, band, free_decay, noisy, phase_resonance_csv, system, truth


def stuck_force(s: dict, ratio: float) -> float:
    """The force (N) at dof 0 that holds the stuck mode at ``ratio`` × the slip amplitude at
    phase resonance: 2ζ₀ω₀²a/φ₀."""
    return 2 * ZETA0 * s["w0"] ** 2 * ratio * s["slip"] / s["phi"][0]


@pytest.fixture(scope="module", params=[1, 2], ids=["sdof", "2dof"])
def jenkins_tests(request, tmp_path_factory):
    """A Jenkins system's ring-down, a tap at half its slip amplitude and phase-resonance
    points from 1.01 to 100 × its slip amplitude (stuck at the first: the force that holds
    the stuck mode there)."""
    s, folder = system(request.param, "jenkins"), tmp_path_factory.mktemp(f"jenkins{request.param}")
    t, x = free_decay(s, 30 * s["slip"], 80)
    pd.DataFrame({"time_s": t, "m1": noisy(x, 0)}).to_csv(folder / "decay.csv", index=False)
    t, x = free_decay(s, 0.5 * s["slip"], 40)
    pd.DataFrame({"time_s": t, "m1": noisy(x, 1)}).to_csv(folder / "tap.csv", index=False)
    phase_resonance_csv(s, stuck_force(s, 1.01) * np.geomspace(1, 100, 6), folder / "pr.csv")
    return s, folder


def hold_out_impact(capsys, s, folder, phase_resonance="pr.csv"):
    out = folder / "held_impact"
    code, printed, errors = run_cli(
        capsys, "validate", "--ring-down", folder / "decay.csv", "--ring-down-fit", "segments", "--impact",
        folder / "tap.csv", "--phase-resonance", folder / phase_resonance, "--shape", f"m1={s['phi'][0]}", "--band",
        "{}:{}".format(*band(s)), "--model", "amplitude-jenkins", "--bootstrap", "20", "--hold-out-type", "impact",
        "--out", out, "--overwrite")
    assert code == 0
    (entry,) = json.loads((out / "validation.json").read_text())["held_out_type"]["samples"]
    return entry, printed, errors


def table_row(printed: str, quantity: str) -> str:
    """The printed table's row of one quantity (the rows below the header ``impact  quantity ...``)."""
    lines = printed.splitlines()
    header = next(k for k, line in enumerate(lines) if line.startswith("impact ") and "quantity" in line)
    return next(line for line in lines[header + 1:] if f"  {quantity}  " in line)


def assert_holds_truth(entry: dict, frequency_hz: float, damping_ratio: float) -> None:
    """The prediction within the issue's 0.2 % and 5 % of the truth, its 95 % band and the
    impact's own band holding it."""
    for name, true in (("natural_frequency_hz", frequency_hz), ("damping_ratio", damping_ratio)):
        c = entry[name]
        assert c["low"] <= true <= c["high"], (name, c, true)
        assert c["measured_low"] <= true <= c["measured_high"], (name, c, true)
        assert abs(c["predicted"] / true - 1) < (2e-3 if name == "natural_frequency_hz" else 0.05), (name, c, true)
        assert c["error"] == pytest.approx(c["predicted"] - c["measured"])
        assert c["inside"] == (c["low"] <= c["measured"] <= c["high"])


def test_impact_below_the_kept_samples_is_the_predicted_linear_limit(jenkins_tests, capsys):
    """Measured: the tap at 0.27 × the slip amplitude, below the kept samples (1.0 × up); the
    SDOF's 10.4881 Hz [10.3814, 10.5126] and 0.499 % [0.487, 0.985] against the truth
    10.48809 Hz, 0.5 %; the 2-DOF's 745.079 Hz [744.43, 745.51], 0.502 % [0.490, 0.552]
    against 745.0815 Hz."""
    s, folder = jenkins_tests
    entry, printed, errors = hold_out_impact(capsys, s, folder)
    assert entry["modal_amplitude"] < 0.6 * s["slip"] and not entry["within_fit"]
    assert entry["predicted_at_modal_amplitude"] == 0.0
    assert "extrapolation" in entry["extrapolation"]
    assert_holds_truth(entry, s["w0"] / (2 * np.pi), ZETA0)
    output = errors + printed  # the warnings (stderr) are printed before the numbers (stdout)
    first = output.index("warning: impact held out:")
    assert "below every kept sample" in output[first:].splitlines()[0]
    assert "compared with the model's at zero amplitude, an extrapolation" in output[first:].splitlines()[0]
    row = table_row(printed, "natural frequency")
    assert "0 (linear limit)" in row and f"{entry['natural_frequency_hz']['predicted']:.4f} Hz" in row
    assert f"{entry['natural_frequency_hz']['measured']:.4f} Hz [" in row


def test_impact_within_the_kept_samples_is_predicted_at_its_amplitude(jenkins_tests, capsys):
    """A stuck phase-resonance point at 0.1 × the slip amplitude kept too: the tap (0.27 ×)
    lies within the kept amplitudes and is predicted there, the stuck truth (the linear
    limit) inside the band; no extrapolation is stated."""
    s, folder = jenkins_tests
    frame = pd.read_csv(folder / "pr.csv")
    phase_resonance_csv(s, [stuck_force(s, 0.1)], folder / "low.csv")
    pd.concat([pd.read_csv(folder / "low.csv"), frame]).to_csv(folder / "pr_low.csv", index=False)
    entry, printed, errors = hold_out_impact(capsys, s, folder, "pr_low.csv")
    assert entry["within_fit"] and "extrapolation" not in entry
    assert entry["predicted_at_modal_amplitude"] == pytest.approx(entry["modal_amplitude"])
    f, z = truth(s, entry["modal_amplitude"])
    assert_holds_truth(entry, float(f), float(z))
    assert "extrapolation" not in errors + printed.split("impact held out;")[0]
    row = table_row(printed, "damping ratio")
    assert "linear limit" not in row and f"{100 * entry['damping_ratio']['predicted']:.4f} %" in row


def test_amplitude_hold_out_compares_the_impact_with_the_linear_limit(jenkins_tests, tmp_path, capsys):
    """``nlupdate amplitude --hold-out impact`` reads the prediction where validate does
    (held_out.csv's ``predicted_at_amplitude`` 0: the model's linear limit) and says so;
    measured: within 4e-6 and 0.4 % of the stuck truth."""
    s, folder = jenkins_tests
    code, printed, _ = run_cli(
        capsys, "amplitude", "--ring-down", folder / "decay.csv", "--ring-down-fit", "segments", "--impact",
        folder / "tap.csv", "--phase-resonance", folder / "pr.csv", "--shape", f"m1={s['phi'][0]}", "--band",
        "{}:{}".format(*band(s)), "--backbone", "jenkins", "--bootstrap", "0", "--hold-out", "impact", "--out",
        tmp_path / "amm")
    assert code == 0
    (row,) = pd.read_csv(tmp_path / "amm" / "held_out.csv").to_dict("records")
    assert row["predicted_at_amplitude"] == 0 and not row["within_fit"]
    assert abs(row["predicted_frequency_hz"] / (s["w0"] / (2 * np.pi)) - 1) < 2e-3
    assert abs(row["predicted_damping_ratio"] / ZETA0 - 1) < 0.05
    assert "against the model's linear limit (a = 0), an extrapolation" in printed


def test_a_damping_curve_held_at_zero_has_no_bootstrap_band():
    """A fitted damping curve that falls to 0 (ζ is kept ≥ 0) leaves no relative misfit to
    draw there: one line naming the amplitude, where it was an SVD failure of the refits
    ('SVD did not converge', exit 2: the polynomial fit of the 2-DOF Jenkins truth above with
    --bootstrap 20). ζ(a) = 1 % − 2 %·a/(1e-3 m·√kg) is 0 from 5e-4 m·√kg."""
    from nlupdate.core.identification.modal_samples import ModalSamples
    from nlupdate.core.identification.backbone_samples import bootstrap_bands
    from nlupdate.core.model.amplitude_modal import AmplitudeModalModel, AmplitudeModelError

    model = AmplitudeModalModel(10.0, 0.01, (("x", 1.0),), damping_coefficients=(-0.02,), reference_amplitude=1e-3)
    a = np.array([1e-4, 2e-4, 3e-4, 4e-4, 6e-4])
    samples = ModalSamples(a, np.full(5, 10.0), np.full(5, 0.005), np.ones(5), 1.0)
    assert model.damping(6e-4) == 0 and model.damping(4e-4) > 0
    with pytest.raises(AmplitudeModelError, match=r"damping curve is 0 at modal amplitude 0.0006 m·√kg"):
        bootstrap_bands(model, samples, a, lambda draw: model, 5)


def test_a_predicted_damping_band_stops_at_zero(tmp_path, capsys):
    """The BRB's hammer pole held out from its four force-controlled levels alone: the
    polynomial's damping curve reaches ζ₀ = 0.096 % by extrapolation, its bootstrap and the
    impact's scatter widen that in quadrature, and the band's lower end came out at −0.032 %,
    a negative damping ratio. A damping ratio is not negative: the band stops at 0."""
    from test_real_measurements import BRB, BRB_COORDINATES

    code, _, err = run_cli(capsys, "validate", "--measured", BRB, "--coordinates", BRB_COORDINATES,
                           "--impact", BRB.parent / "HammerImpact_1600Hz.mat", "--channel", "acc3",
                           "--response-unit", "m/s^2", "--shape", "acc3=0.7271", "--shape", "acc3:y=0.7271",
                           "--band", "60:100", "--model", "amplitude-polynomial", "--bootstrap", 50,
                           "--response-controlled", "off", "--hold-out-type", "impact", "--out", tmp_path / "imp")
    assert code == 0, err
    (sample,) = json.loads((tmp_path / "imp" / "validation.json").read_text())["held_out_type"]["samples"]
    zeta = sample["damping_ratio"]
    assert 0 <= zeta["low"] < zeta["predicted"] < zeta["high"]
