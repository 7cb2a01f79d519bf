"""Response-controlled stepped sine: one linear one-mode FRF per held amplitude.

References: the Brake–Reuss beam's own force-controlled runs at equal amplitude, and a
simulated perfectly controlled test of a Jenkins SDOF — harmonic motion X cos Ωt imposed and
the first harmonic of the force it takes computed by a Fourier integral over a steady cycle
of the element's time-domain law (not its describing function) — against the
describing-function backbone ``ω² = (k + Re ν(X))/m``, ``ζ = (cω + Im ν(X))/(2mω²)``.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
import scipy.io

from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.modal_samples import samples_from_frfs
from nlupdate.core.identification.response_controlled import HeldRun, read_response_controlled, samples_from_held_runs
from nlupdate.core.measurement.frf_files import read_frf_tables
from nlupdate.core.measurement.frf_table import MeasurementTableError
from nlupdate.core.measurement.units import ReadOptions
from nlupdate.core.model.elements import JenkinsFriction

BRB = Path(__file__).parent / "data" / "brb" / "ForcedFrequencyResponses.mat"
BRB_OPTIONS = ReadOptions(coordinates={str(BRB): ("acc3:-y", "acc3:y")})

M, F0, ZETA = 2.0, 10.0, 0.005
K = M * (2 * np.pi * F0) ** 2
C = 2 * ZETA * np.sqrt(K * M)
JENKINS = JenkinsFriction((0,), kf=0.1 * K, slip_force=0.1 * K * 1e-3)


def held_sweep(amplitude: float, frequency_hz: np.ndarray, points: int = 2048, element=JENKINS) -> HeldRun:
    """x = X cos Ωt imposed; F = first harmonic of m ẍ + c ẋ + k x + g(x) over the second cycle."""
    forces = []
    phase = 2 * np.pi * np.arange(2 * points) / points
    x = amplitude * np.cos(phase)
    state = element.initial_state(())
    g = np.empty_like(x)
    for i, xi in enumerate(x):  # the slider's history, two cycles from rest
        g[i], state = element.force(np.array(xi), np.array(0.0), state)
    g = g[points:]
    for f in frequency_hz:
        w = 2 * np.pi * f
        total = (K - M * w**2) * x[points:] - C * w * amplitude * np.sin(phase[points:]) + g
        forces.append(2 * np.mean(total * np.exp(-1j * phase[points:])))  # F with x = Re(X e^{iΩt})
    force = np.array(forces)
    return HeldRun("sim", "0", "0", frequency_hz, amplitude / force, amplitude, np.abs(force))


@pytest.mark.parametrize("amplitude", [0.5e-3, 2e-3, 8e-3])  # stuck, just slipping, macroslip
def test_a_held_amplitude_sweep_gives_the_describing_function_backbone_there(amplitude):
    nu = JENKINS.describing_function(amplitude)
    w = np.sqrt((K + nu.real) / M)
    zeta = (C * w + nu.imag) / (2 * M * w**2)
    f = w / (2 * np.pi) * np.linspace(0.97, 1.03, 61)
    samples = samples_from_held_runs([held_sweep(amplitude, f)])
    # measured ≤ 4e-5, 1e-4 and 2.2e-4: the fit's structural damping against the viscous c, O(ζ²)
    assert samples.input_shape == pytest.approx(1 / np.sqrt(M), rel=1e-4)  # φ² = 1/m from the modal constant
    assert samples.amplitude[0] == pytest.approx(amplitude * np.sqrt(M), rel=1e-4)
    assert samples.frequency_hz[0] == pytest.approx(w / (2 * np.pi), rel=2e-4)
    assert samples.damping_ratio[0] == pytest.approx(zeta, rel=1e-3)


def test_brb_response_controlled_runs_against_its_force_controlled_runs():
    runs = read_response_controlled(BRB, BRB_OPTIONS)
    assert len(runs) == 8 and [r.held_m for r in runs] == sorted(r.held_m for r in runs)
    assert runs[0].held_m == pytest.approx(19.7e-6, rel=0.01) and runs[-1].held_m == pytest.approx(316e-6, rel=0.01)
    held = samples_from_held_runs(runs)
    assert held.damping_ratio[-1] > 4 * held.damping_ratio[0]  # the joint's damping grows with amplitude
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the reader's notes on the runs it leaves out
        table = read_frf_tables([str(BRB)], None, BRB_OPTIONS)
    forced = samples_from_frfs(FRFLevels.from_table(table, "acc3:y", "acc3:y"), held.input_shape)
    order = np.argsort(held.amplitude)
    log_a = np.log(held.amplitude[order])
    f_held = np.interp(np.log(forced.amplitude), log_a, held.frequency_hz[order])
    z_held = np.interp(np.log(forced.amplitude), log_a, held.damping_ratio[order])
    # each level at the amplitude its achieved force drove (2026-11-29): 0.07, 0.10, 0.13, 0.21 Hz
    # (0.4886 N resonates 0.2 Hz below its neighbours) and -7.3, -0.6, +0.9, -1.1 % in damping; at
    # the levels' mean forces the two lower levels sat 1.3 and 1.25 x too high and missed by -19, -20 %
    assert np.max(np.abs(forced.frequency_hz - f_held)) < 0.25
    assert np.max(np.abs(forced.damping_ratio / z_held - 1)) < 0.1


def test_a_file_without_held_runs_is_refused(tmp_path):
    f = np.linspace(79, 81, 41)
    run = {"frequency": f, "force": np.full(f.size, 0.2), "amplitude": 1 + f / 100, "phase": -f / 81,
           "units": "Hz, N, m/s^2, rad"}
    scipy.io.savemat(tmp_path / "fc.mat", {"FRdata": {"ForceControl": np.array([run], dtype=object)}})
    with pytest.raises(MeasurementTableError, match=r"fc\.mat: holds no response-controlled run"):
        read_response_controlled(tmp_path / "fc.mat", ReadOptions(coordinates={str(tmp_path / "fc.mat"): ("a", "a")}))


def test_amplitude_command_fits_the_held_runs_alone(tmp_path, capsys):
    import pandas as pd

    from nlupdate.app.cli import main

    out = tmp_path / "out"
    assert main(["amplitude", "--response-controlled", str(BRB), "--coordinates", f"{BRB}=acc3:-y,acc3:y",
                 "--backbone", "polynomial", "--out", str(out)]) == 0
    points = pd.read_csv(out / "backbone_points.csv")
    held = samples_from_held_runs(read_response_controlled(BRB, BRB_OPTIONS))
    assert np.allclose(points["modal_amplitude"], held.amplitude) and np.allclose(points["damping_ratio"],
                                                                                  held.damping_ratio)
    assert "8 response-controlled run(s) at acc3:y, held 19.7–316 µm" in capsys.readouterr().out


def test_a_ring_down_read_without_a_shape_is_not_put_on_the_runs_modal_scale(tmp_path, capsys):
    """The BRB's hammer ring-down at acc3 read without --shape has amplitudes in m (φ = 1
    assumed); the response-controlled runs at the same accelerometer are modal, their shape the
    lowest run's modal constant — √φ² = 0.73 1/√kg by a one-mode fit of the published run
    (scipy alone) — so the two scales differ by 1/0.73. Joining them was fitted silently
    (one source then "disagreed"), an FRF at a force used φ = 1 (|H| 1/0.53 × too large), and
    the summary called the record's amplitudes modal m·√kg. Now: refused with the option to
    give, and the summary says what the amplitudes are."""
    from nlupdate.app.cli import main
    from test_real_measurements import brb_runs, sdof_fit

    f, h, _ = brb_runs("ResponseControl")[0]
    phi = np.sqrt(abs(sdof_fit(f, h)[2]))
    assert 0.65 < phi < 0.8  # 0.716 (nlupdate reads 0.7271): not the 1 a record without a shape is read at
    record = Path(__file__).parent / "data" / "brb" / "HammerImpact_1600Hz.mat"
    ring_down = ["amplitude", "--ring-down", str(record), "--channel", "acc3", "--band", "60:100", "--response-unit",
                 "m/s^2", "--backbone", "polynomial", "--bootstrap", "0"]
    joined = main([*ring_down, "--response-controlled", str(BRB), "--coordinates", f"{BRB}=acc3:-y,acc3:y",
                   "--out", str(tmp_path / "joined")])
    assert joined == 2 and "--shape acc3=VALUE" in capsys.readouterr().err
    predicted = main([*ring_down, "--forces", "0.5", "--freqs", "79:82:31", "--out", str(tmp_path / "predicted")])
    assert predicted == 2 and "--shape acc3=VALUE" in capsys.readouterr().err
    assert main([*ring_down, "--out", str(tmp_path / "alone")]) == 0
    (summary,) = [line for line in capsys.readouterr().out.splitlines() if line.startswith("mode 1:")]
    assert "not modal" in summary and "m·√kg" not in summary
    assert main([*ring_down, "--shape", f"acc3={phi:.4f}", "--response-controlled", str(BRB), "--coordinates",
                 f"{BRB}=acc3:-y,acc3:y", "--out", str(tmp_path / "shaped")]) == 0
