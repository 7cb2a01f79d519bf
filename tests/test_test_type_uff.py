"""Response-controlled runs and phase-resonance points from universal files (UFF 58), as test
systems export them (docs/ring-down.md states the layouts).

Every file is written here with pyuff from known values — the reader must return them — and,
once per test type, from an independent truth: a perfectly held sweep of the Jenkins SDOF
(the force's first harmonic integrated from the element's time-domain law,
tests/test_response_controlled.py) and phase-locked points of the Duffing SDOF by the
multi-harmonic balance (tests/test_phase_resonance.py), against the describing-function
backbone within those modules' bounds.

pyuff 2.5 writes function types 0–4, 6 and 9 only: a spectrum (function type 12) is written
as a cross spectrum (3) and its record 6 field 1 then set to 12, as a test system writes it.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import pyuff

from nlupdate.app.cli import main
from nlupdate.core.identification.phase_resonance import read_phase_resonance, samples_from_phase_resonance
from nlupdate.core.identification.response_controlled import read_response_controlled, samples_from_held_runs
from nlupdate.core.measurement.frf_files import read_frf_tables
from nlupdate.core.measurement.frf_table import MeasurementTableError
from nlupdate.core.measurement.run_levels import held_amplitudes_in_text
from nlupdate.core.measurement.units import ReadOptions
from nlupdate.notices import NlupdateWarning

from test_phase_resonance import DUFFING, FORCES, PHI, assert_amplitude_fits_the_backbone, df_backbone, locked_points
from test_response_controlled import JENKINS, K, M, C, held_sweep

G = 9.80665
F_HZ = np.linspace(9.5, 10.5, 41)


def record(values, frequency, run: str, func_type: int = 4, quantity: str = "acceleration", node: int = 1,
           direction: int = 3, **fields) -> dict:
    """A dataset 58 as an analyser writes it: the function in ID line 1, the run in line 2, the
    date in line 3; an FRF per N, or a spectrum of a response (``quantity``) or of the force."""
    ordinate = {"acceleration": (12, "m/s^2"), "displacement": (8, "m"), "force": (13, "N"),
                "force2": (13, "N^2")}[quantity]
    frequency = np.atleast_1d(np.asarray(frequency, dtype=float))
    base = dict(binary=0, func_type=func_type, rsp_node=node, rsp_dir=direction, ref_node=1, ref_dir=3,
                data=np.atleast_1d(values), x=frequency if frequency.size > 1 else np.repeat(frequency, 2),
                id1=f"{'FRF' if func_type == 4 else 'Spectrum'} {node}:+Z", id2=run, id3="29-Nov-26 10:00:00",
                id4="NONE", id5="NONE", abscissa_spacing=1, abscissa_spec_data_type=18, abscissa_axis_units_lab="Hz",
                ordinate_spec_data_type=ordinate[0], ordinate_axis_units_lab=ordinate[1],
                orddenom_spec_data_type=13 if func_type == 4 else 0,
                orddenom_axis_units_lab="N" if func_type == 4 else "NONE", z_axis_spec_data_type=0, z_axis_value=0.0)
    base.update(fields)
    return base


def export(path: Path, datasets: list[dict]) -> Path:
    """Write with pyuff; a spectrum (12) goes through pyuff as a cross spectrum and is retyped."""
    spectra = [d["func_type"] == 12 for d in datasets]
    pyuff.UFF(str(path)).write_sets([pyuff.prepare_58(**{**d, "func_type": 3 if s else d["func_type"]})
                                     for d, s in zip(datasets, spectra)], mode="add")
    lines = path.read_text().split("\n")
    headers = [i for i, line in enumerate(lines) if line.rstrip() == "    58"]
    for header, spectrum in zip(headers, spectra):
        if spectrum:  # record 6 field 1 (I5), after the five ID lines
            assert lines[header + 6].startswith("    3")
            lines[header + 6] = "   12" + lines[header + 6][5:]
    path.write_text("\n".join(lines))
    return path


def accelerance(h: np.ndarray, frequency: np.ndarray) -> np.ndarray:
    return -((2 * np.pi * frequency) ** 2) * h


def one_mode(frequency, stiffness):
    """m = 2 kg, loss factor 0.01: a receptance (m/N)."""
    return 1 / (stiffness * (1 + 0.01j) - M * (2 * np.pi * frequency) ** 2)


# ------------------------------------------------------------------ response-controlled runs
NAMES = [("ResponseControl 20 m/s2", 20.0), ("Rc5ms2", 5.0), ("a=0.5 g", 0.5 * G)]


@pytest.mark.parametrize("text, held", NAMES + [("Target_0p1mm", 1e-4)])
def test_held_amplitudes_in_run_names(text, held):
    (value, power), = held_amplitudes_in_text(text)
    assert value == pytest.approx(held, rel=1e-12) and power == (0 if "mm" in text else 2)


def test_frf_runs_with_the_target_in_the_run_name(tmp_path):
    """One accelerance FRF per run, each held at the acceleration its name states: the receptance,
    held displacement (median of A/Ω²) and achieved force (A/(Ω²|H|)) come back."""
    curves = {name: one_mode(F_HZ, K * (1 - 0.02 * i)) for i, (name, _) in enumerate(NAMES)}
    path = export(tmp_path / "rc.uff", [record(accelerance(h, F_HZ), F_HZ, name) for name, h in curves.items()])
    runs = {run.name: run for run in read_response_controlled(path)}
    assert set(runs) == set(curves)
    for name, held in NAMES:
        run, target = runs[name], held / (2 * np.pi * F_HZ) ** 2
        np.testing.assert_allclose(run.h, curves[name], rtol=1e-9)
        assert run.held_m == pytest.approx(np.median(target), rel=1e-12)
        np.testing.assert_allclose(run.force_n, target / np.abs(curves[name]), rtol=1e-9)
        assert (run.response_dof, run.input_dof) == ("1:uz", "1:uz")


def test_frf_with_the_force_auto_spectrum_gives_the_achieved_force(tmp_path):
    """An FRF and the force's auto spectrum (N², squared peak amplitudes) per run: the force per
    line is the spectrum's; an RMS-scaled spectrum (F²/2) is warned about as 0.707 × the target."""
    h = one_mode(F_HZ, K)
    force = 20.0 / ((2 * np.pi * F_HZ) ** 2 * np.abs(h)) * (1 + 0.01 * np.sin(F_HZ))  # the controller's residual
    path = export(tmp_path / "rc.uff", [record(accelerance(h, F_HZ), F_HZ, "Rc20ms2"),
                                        record(force**2, F_HZ, "Rc20ms2", func_type=2, quantity="force2")])
    run, = read_response_controlled(path)
    np.testing.assert_allclose(run.force_n, force, rtol=1e-9)
    rms = export(tmp_path / "rms.uff", [record(accelerance(h, F_HZ), F_HZ, "Rc20ms2"),
                                        record(force**2 / 2, F_HZ, "Rc20ms2", func_type=2, quantity="force2")])
    with pytest.warns(NlupdateWarning, match=r"rms\.uff, run 'Rc20ms2': the response the force spectrum implies is "
                                             r"0\.70\d × the held amplitude"):
        read_response_controlled(rms)


def test_spectra_of_response_and_force_make_the_frf(tmp_path):
    """Complex spectra of the response (an accelerometer along −z) and of the force per run, no
    FRF: H = X/F with the sensor's sign applied, the force the spectrum's amplitude."""
    h = one_mode(F_HZ, K)
    force = 0.5 * G / ((2 * np.pi * F_HZ) ** 2 * np.abs(h)) * np.exp(1j * 0.4) * (1 + 0.02 * np.cos(3 * F_HZ))
    x = h * force
    path = export(tmp_path / "rc.uff", [
        record(-accelerance(x, F_HZ), F_HZ, "a=0.5 g", func_type=12, direction=-3),
        record(force, F_HZ, "a=0.5 g", func_type=12, quantity="force", node=1, direction=3)])
    with warnings.catch_warnings():
        warnings.simplefilter("error", NlupdateWarning)  # the response is the 0.5 g named, within 2 %
        run, = read_response_controlled(path)
    np.testing.assert_allclose(run.h, h, rtol=1e-9)
    np.testing.assert_allclose(run.force_n, np.abs(force), rtol=1e-9)
    assert run.held_m == pytest.approx(np.median(0.5 * G / (2 * np.pi * F_HZ) ** 2), rel=1e-12)


def test_held_amplitude_given_per_run(tmp_path):
    """Runs named only 'Run 1', 'Run 2': the held amplitude from --level FILE#RUN=VALUE, in the
    unit of the response record (m/s² of the accelerance)."""
    curves = {"Run 1": one_mode(F_HZ, K), "Run 2": one_mode(F_HZ, 0.97 * K)}
    path = export(tmp_path / "rc.uff", [record(accelerance(h, F_HZ), F_HZ, name) for name, h in curves.items()])
    options = ReadOptions(levels={"rc.uff#Run 1": 2.0, "Run 2": 8.0})
    runs = {run.name: run for run in read_response_controlled(path, options)}
    for name, held in (("Run 1", 2.0), ("Run 2", 8.0)):
        target = held / (2 * np.pi * F_HZ) ** 2
        assert runs[name].held_m == pytest.approx(np.median(target), rel=1e-12)
        np.testing.assert_allclose(runs[name].force_n, target / np.abs(curves[name]), rtol=1e-9)


def test_amplitude_command_takes_held_amplitudes_and_names_the_run_without_one(tmp_path, capsys):
    """``--held-amplitude`` reaches the reader; a run it leaves out is named in one line."""
    path = export(tmp_path / "rc.uff", [record(accelerance(one_mode(F_HZ, k), F_HZ), F_HZ, name)
                                        for name, k in (("Run 1", K), ("Run 2", 0.97 * K))])
    assert main(["amplitude", "--response-controlled", str(path), "--held-amplitude", f"{path}#Run 1=2",
                 "--backbone", "polynomial", "--out", str(tmp_path / "out")]) != 0
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and "rc.uff, dataset 1 (run 'Run 2'): no held response amplitude" in error



def test_a_held_amplitude_without_response_controlled_runs_is_refused(tmp_path, capsys):
    """``--held-amplitude`` beside the Brake–Reuss beam's force-controlled levels alone: nothing
    reads it (it was accepted and the model written as if it had been used)."""
    brb = Path(__file__).parent / "data" / "brb" / "ForcedFrequencyResponses.mat"
    assert main(["amplitude", "--measured", str(brb), "--coordinates", f"{brb}=acc3:-y,acc3:y", "--shape",
                 "acc3:y=0.7271", "--held-amplitude", "Rc5=20", "--out", str(tmp_path / "out")]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and "--held-amplitude Rc5=20: expected nothing without --response-controlled" in error


@pytest.mark.parametrize("name, expected", [
    ("Run 1", r"rc\.uff, dataset 0 \(run 'Run 1'\): no held response amplitude: expected the controller's target "
              r"with a response unit .* \('ResponseControl 20 m/s2', 'Rc5ms2', 'a=0\.5 g', 'Target_0p1mm'\), or "
              r"--held-amplitude rc\.uff#Run 1=VALUE in the unit of the response record \(m/s\^2\)"),
    ("ResponseControl 20 N", r"rc\.uff, dataset 0 \(run 'ResponseControl 20 N'\): no held response amplitude: .*; "
                             r"they name the force level 20 N: a force-controlled run is read with --measured"),
])
def test_a_run_without_a_held_amplitude_is_refused_in_one_line(tmp_path, name, expected):
    path = export(tmp_path / "rc.uff", [record(accelerance(one_mode(F_HZ, K), F_HZ), F_HZ, name),
                                        record(accelerance(one_mode(F_HZ, K), F_HZ), F_HZ, name + " b")])
    with pytest.raises(MeasurementTableError, match=expected) as error:
        read_response_controlled(path)
    assert "\n" not in str(error.value)


def test_measured_refuses_a_response_controlled_file_and_says_where_it_goes(tmp_path):
    """``--measured`` (force-controlled runs) finds no force level in 'Rc5ms2' and says what the run is."""
    path = export(tmp_path / "rc.uff", [record(accelerance(one_mode(F_HZ, K), F_HZ), F_HZ, "Rc5ms2")])
    with pytest.raises(MeasurementTableError, match=r"rc\.uff, dataset 0: no level: .*; the ID lines name a held "
                                                    r"response amplitude \(5 m/s²\): a response-controlled run, read "
                                                    r"with 'nlupdate amplitude --response-controlled FILE'"):
        read_frf_tables([path])


def test_jenkins_held_sweeps_from_uff_give_the_describing_function_backbone(tmp_path, capsys):
    """The truth: held sweeps of the Jenkins SDOF (stuck, just slipping, macroslip) written as
    accelerance FRFs, each run named by its held displacement ('Target_0p5mm'). Their samples
    are within tests/test_response_controlled.py's bounds of the describing-function backbone
    (2e-4 in frequency, 1e-3 in ζ), and ``nlupdate amplitude --response-controlled`` fits them."""
    amplitudes = (0.5e-3, 2e-3, 8e-3)
    datasets = []
    for amplitude in amplitudes:
        nu = JENKINS.describing_function(amplitude)
        f = np.sqrt((K + nu.real) / M) / (2 * np.pi) * np.linspace(0.97, 1.03, 61)
        sweep = held_sweep(amplitude, f)
        datasets.append(record(accelerance(sweep.h, f), f, f"Target_{amplitude * 1e3:g}mm".replace(".", "p")))
    path = export(tmp_path / "rc.uff", datasets)
    runs = read_response_controlled(path)
    np.testing.assert_allclose([run.held_m for run in runs], amplitudes, rtol=1e-12)
    samples = samples_from_held_runs(runs)
    nu = JENKINS.describing_function(np.array(amplitudes))
    w = np.sqrt((K + nu.real) / M)
    # the shape from the lowest run's modal constant: φ² = 1/m within 1e-4, as in that module
    np.testing.assert_allclose(samples.amplitude, np.array(amplitudes) * np.sqrt(M), rtol=1e-4)
    np.testing.assert_allclose(samples.frequency_hz, w / (2 * np.pi), rtol=2e-4)
    np.testing.assert_allclose(samples.damping_ratio, (C * w + nu.imag) / (2 * M * w**2), rtol=1e-3)
    out = tmp_path / "amm"
    assert main(["amplitude", "--response-controlled", str(path), "--backbone", "polynomial", "--out", str(out)]) == 0
    points = pd.read_csv(out / "backbone_points.csv")
    np.testing.assert_allclose(points["damping_ratio"], samples.damping_ratio, rtol=1e-12)
    assert "3 response-controlled run(s) at 1:uz, held 500–8e+03 µm" in capsys.readouterr().out


# ------------------------------------------------------------------ phase-resonance points
@pytest.fixture(scope="module")
def duffing_points():
    return locked_points(DUFFING, FORCES[::2])


def spectra_file(path: Path, omega, force, x, force_phase=0.7) -> Path:
    """One run per level, named by its force: one-line complex spectra of the acceleration and
    of the force (the force at an arbitrary phase: what counts is the response's relative to it)."""
    datasets = []
    for w, f, x1 in zip(omega, force, x):
        run, rotation = f"PLL level {f:.4f} N", np.exp(1j * force_phase)
        datasets.append(record(-w**2 * x1 * rotation, w / (2 * np.pi), run, func_type=12))
        datasets.append(record(f * rotation, w / (2 * np.pi), run, func_type=12, quantity="force"))
    return export(path, datasets)


def test_phase_resonance_spectra_at_one_line_per_level(tmp_path, duffing_points):
    """The points come back as written, and on the Duffing SDOF's describing-function backbone
    within tests/test_phase_resonance.py's bounds (1e-4, 2e-3); ``nlupdate amplitude
    --phase-resonance`` fits them within the issue's 0.2 % / 5 %."""
    omega, force, x = duffing_points
    path = spectra_file(tmp_path / "pr.uff", omega, force, x)
    points = read_phase_resonance(path)
    # an ASCII record 7 holds the frequency to 6 digits (E13.5): the displacement A/Ω² to 1e-5
    np.testing.assert_allclose(points.frequency_hz, omega / (2 * np.pi), rtol=5e-6)
    np.testing.assert_allclose(points.force_n, force, rtol=1e-9)
    np.testing.assert_allclose(points.x, x, rtol=1e-5)
    assert (points.response_dof, points.input_dof) == ("1:uz", "1:uz")
    samples = samples_from_phase_resonance(points, PHI)
    f, z = df_backbone(DUFFING, samples.amplitude * PHI)
    assert np.max(np.abs(samples.frequency_hz / f - 1)) < 1e-4 and np.max(np.abs(samples.damping_ratio / z - 1)) < 2e-3
    assert_amplitude_fits_the_backbone(path, "1:uz", DUFFING, tmp_path / "amm")


def test_phase_resonance_one_line_frfs_with_the_force_in_the_run_name(tmp_path, duffing_points):
    """One-line accelerance FRFs, the force level in the run name ('F=0.0100N') as for --measured."""
    omega, force, x = duffing_points
    path = export(tmp_path / "pr.uff", [record(-w**2 * x1 / f, w / (2 * np.pi), f"PR F={f:.6f}N")
                                        for w, f, x1 in zip(omega, force, x)])
    points = read_phase_resonance(path)
    np.testing.assert_allclose(points.force_n, np.round(force, 6), rtol=1e-12)
    np.testing.assert_allclose(points.x, x / force * np.round(force, 6), rtol=1e-5)
    np.testing.assert_allclose(points.frequency_hz, omega / (2 * np.pi), rtol=5e-6)
    with pytest.raises(MeasurementTableError, match=r"pr\.uff: holds several levels \(runs\); a level given for the "
                                                    r"file fits a file of one: give each with --level pr\.uff#RUN"):
        read_phase_resonance(path, ReadOptions(levels={"pr.uff": 0.1}))


def test_records_that_cannot_be_phase_resonance_points_are_refused_in_one_line(tmp_path, duffing_points):
    omega, force, x = duffing_points
    w, f, x1 = omega[0], force[0], x[0]
    cases = [
        ([record(np.sin(np.arange(64.0)), np.arange(64) / 100, "PR 1", func_type=1, abscissa_spec_data_type=17,
                 abscissa_axis_units_lab="s", orddenom_spec_data_type=0, orddenom_axis_units_lab="NONE")],
         r"pr\.uff, dataset 0 \(run 'PR 1'\): function type 1 \(time response\); a phase-resonance point is one "
         r"frequency line, the locked frequency, per level \(run\)"),
        ([record(accelerance(one_mode(F_HZ, K), F_HZ), F_HZ, "PR F=0.1N")],
         r"pr\.uff, dataset 0 \(run 'PR F=0\.1N'\): 41 frequency lines; a phase-resonance point is one frequency line"),
        ([record(-w**2 * x1, w / (2 * np.pi), "PR 1", func_type=12)],
         r"pr\.uff, dataset 0 \(run 'PR 1'\): a response spectrum without the force's complex spectrum \(type 12\) "
         r"in its run"),
        ([record(-w**2 * x1 / f, w / (2 * np.pi), "PR 1")],
         r"pr\.uff, dataset 0 \(run 'PR 1'\): no level: expected an ID line 'force_level_n=<amplitude>'"),
        ([record(-w**2 * x1, w / (2 * np.pi), "PR 1", func_type=12),
          record(f, w / (2 * np.pi), "PR 1", func_type=12, ordinate_spec_data_type=0, ordinate_axis_units_lab="V")],
         r"pr\.uff, dataset 1 \(run 'PR 1'\): a spectrum in volts \(label 'V'\); expected the force"),
    ]
    for datasets, expected in cases:
        path = export(tmp_path / "pr.uff", datasets)
        with pytest.raises(MeasurementTableError, match=expected) as error:
            read_phase_resonance(path)
        assert "\n" not in str(error.value)
        path.unlink()
