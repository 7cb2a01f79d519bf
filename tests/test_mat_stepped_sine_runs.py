"""MATLAB stepped-sine runs (what a stepped-sine controller reports) read back to receptance.

The files are laid out as the public Brake–Reuss beam data (tests/data/brb) and a
controller report are: a struct ``FRdata`` whose fields are 1×n struct arrays of runs
with ``frequency``, ``force``, ``amplitude``, ``phase`` and ``units``. The runs here are
made from an analytic single-mode accelerance at forces that dip through the resonance,
so the reader must return the analytic receptance at every line, each run's mean force as
its level and each line's force as ``level_achieved`` — or refuse in one line naming the
field or the statement to give.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
import scipy.io

from nlupdate.app.cli import main
from nlupdate.core.measurement.frf_table import MeasurementTableError
from nlupdate.core.measurement.frf_files import read_frf_table
from nlupdate.core.measurement.units import ReadOptions

F_HZ = np.arange(79.0, 81.01, 0.05)
W = 2 * np.pi * F_HZ
F_R, ETA, A_R = 80.3, 0.004, 0.5  # Hz, loss factor, modal constant (1/kg)


def receptance(f_hz: np.ndarray) -> np.ndarray:
    """Single mode, m/N: H = A_r/(ω_r² − ω² + iη ω_r²)."""
    wr, w = 2 * np.pi * F_R, 2 * np.pi * np.asarray(f_hz)
    return A_R / (wr**2 - w**2 + 1j * ETA * wr**2)


def force_run(level: float, units: str = "Hz, N, m/s^2, rad", phase_scale: float = 1.0, **extra) -> dict:
    """A force-controlled run: the force dips 20 % at the resonance; acceleration amplitude and phase."""
    force = level * (1 - 0.2 * np.exp(-(((F_HZ - F_R) / 0.3) ** 2)))
    accelerance = (1j * W) ** 2 * receptance(F_HZ)
    run = {"frequency": F_HZ, "force": force, "amplitude": np.abs(accelerance) * force,
           "phase": np.angle(accelerance) * phase_scale, "units": units}
    run.update(extra)
    return run


def response_run(acceleration: float) -> dict:
    """A response-controlled run: the acceleration held, the force whatever it takes."""
    accelerance = (1j * W) ** 2 * receptance(F_HZ)
    return {"frequency": F_HZ, "force": acceleration / np.abs(accelerance), "amplitude": np.full(F_HZ.size, acceleration),
            "phase": np.angle(accelerance), "units": "Hz, N, m/s^2, rad"}


def struct_array(runs: list[dict]) -> np.ndarray:
    """A 1×n MATLAB struct array (as scipy.io writes and reads one)."""
    names = list(runs[0])
    array = np.zeros((1, len(runs)), dtype=[(name, object) for name in names])
    for k, run in enumerate(runs):
        for name in names:
            array[0, k][name] = run[name]
    return array


def write(path: Path, groups: dict[str, list[dict]]) -> Path:
    scipy.io.savemat(path, {"FRdata": {name: struct_array(runs) for name, runs in groups.items()}})
    return path


DRIVE = ReadOptions(coordinates={"runs.mat": ("tip:uz", "tip:uz")})


def read_quietly(path: Path, options: ReadOptions = DRIVE):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        table = read_frf_table(path, options=options)
    return table, [str(w.message) for w in caught]


def test_force_controlled_runs_read_back_as_receptance_with_the_achieved_force(tmp_path):
    path = write(tmp_path / "runs.mat", {"ForceControl": [force_run(0.2), force_run(1.0)],
                                         "ResponseControl": [response_run(5.0), response_run(40.0)]})
    table, messages = read_quietly(path)
    assert sorted(table["force_level_n"].unique()) == [float(f"{force_run(0.2)['force'].mean():.4g}"),
                                                       float(f"{force_run(1.0)['force'].mean():.4g}")]
    for level, nominal in zip(sorted(table["force_level_n"].unique()), (0.2, 1.0)):
        curve = table[table["force_level_n"] == level]
        h = curve["h_real"].to_numpy() + 1j * curve["h_imag"].to_numpy()
        assert np.max(np.abs(h / receptance(curve["frequency_hz"].to_numpy()) - 1)) < 1e-12
        assert curve["level_achieved"].to_numpy() == pytest.approx(force_run(nominal)["force"], rel=1e-12)
    assert set(table["excitation"]) == {"stepped_sine"}
    assert set(table["response_dof"]) == set(table["input_dof"]) == {"tip:uz"}
    assert any("left out 2 run(s) of FRdata.ResponseControl" in m and "response-controlled" in m for m in messages)
    assert any("force was not held" in m and "level_achieved" in m for m in messages)
    assert any("converted accelerance" in m for m in messages)


def test_response_controlled_runs_read_apart_are_not_reported_lost(tmp_path):
    """validate and amplitude --response-controlled read a file's response-controlled runs as
    such: the FRF table is the same (the force-controlled runs, the analytic receptance) but
    no warning says the runs were left out; the commands state which files they read apart."""
    import argparse

    from nlupdate.app.cli.measured import read_options

    path = write(tmp_path / "runs.mat", {"ForceControl": [force_run(0.2), force_run(1.0)],
                                         "ResponseControl": [response_run(5.0), response_run(40.0)]})
    alone, _ = read_quietly(path)
    apart, messages = read_quietly(path, ReadOptions(coordinates=DRIVE.coordinates, runs_read_apart=(str(path),)))
    assert apart.equals(alone)
    assert not any("left out" in m for m in messages) and any("converted accelerance" in m for m in messages)
    amplitude = argparse.Namespace(measured=[str(path)], response_controlled=[str(path)])
    assert read_options(amplitude).reads_runs_apart(str(path))
    assert not read_options(argparse.Namespace(measured=[str(path)], response_controlled=[])).reads_runs_apart(str(path))
    for setting, apart_too in ((None, True), ("auto", True), ("kept", True), ("off", False)):  # validate's option
        validate = argparse.Namespace(measured=[str(path)], response_controlled=setting)
        assert read_options(validate).reads_runs_apart(str(path)) is apart_too, setting
    assert not read_options(argparse.Namespace(measured=[str(path)])).reads_runs_apart(str(path))  # identify


def test_phase_in_degrees_and_displacement_amplitudes(tmp_path):
    degrees = force_run(0.5, units="Hz, N, m/s^2, deg", phase_scale=180 / np.pi)
    table, _ = read_quietly(write(tmp_path / "runs.mat", {"FC": [degrees]}))
    h = table["h_real"].to_numpy() + 1j * table["h_imag"].to_numpy()
    assert np.max(np.abs(h / receptance(F_HZ) - 1)) < 1e-12
    x = force_run(0.5)
    x["amplitude"] = np.abs(receptance(F_HZ)) * x["force"] * 1e3  # mm
    x["phase"], x["units"] = np.angle(receptance(F_HZ)), "Hz, N, mm, rad"
    table, messages = read_quietly(write(tmp_path / "runs.mat", {"FC": [x]}))
    h = table["h_real"].to_numpy() + 1j * table["h_imag"].to_numpy()
    assert np.max(np.abs(h / receptance(F_HZ) - 1)) < 1e-12
    assert not any("converted" in m for m in messages)


def test_a_sensor_stated_along_the_negative_direction_negates_the_frf(tmp_path):
    reversed_sensor = force_run(0.5)
    reversed_sensor["phase"] = reversed_sensor["phase"] + np.pi  # what a sensor along −z records
    path = write(tmp_path / "runs.mat", {"FC": [reversed_sensor]})
    as_published, _ = read_quietly(path)
    stated, _ = read_quietly(path, ReadOptions(coordinates={"runs.mat": ("tip:-uz", "tip:uz")}))
    h_published = as_published["h_real"].to_numpy() + 1j * as_published["h_imag"].to_numpy()
    h_stated = stated["h_real"].to_numpy() + 1j * stated["h_imag"].to_numpy()
    assert np.max(np.abs(h_published / receptance(F_HZ) + 1)) < 1e-12  # a negative modal constant
    assert np.max(np.abs(h_stated / receptance(F_HZ) - 1)) < 1e-12
    assert set(stated["response_dof"]) == {"tip:uz"}


def test_coordinates_named_in_the_runs(tmp_path):
    run = force_run(0.5, response_dof="7:uy", input_dof="7:uy")
    table, _ = read_quietly(write(tmp_path / "named.mat", {"FC": [run]}), ReadOptions())
    assert set(table["response_dof"]) == {"7:uy"}


@pytest.mark.parametrize("change, fragments", [
    ({"units": None}, ["FRdata.FC", "field 'units' missing", "Hz, N, m/s^2, rad"]),
    ({"units": "Hz, N, m/s^2"}, ["field 'units'", "frequency, force, amplitude and phase"]),
    ({"units": "Hz, N, m/s^2, grad"}, ["phase in 'grad'", "rad or deg"]),
    ({"units": "Hz, lbf, m/s^2, rad"}, ["force in 'lbf'"]),
    ({"units": "rad/s, N, m/s^2, rad"}, ["frequency in 'rad/s'", "Hz"]),
    ({"units": "Hz, N, furlong, rad"}, ["response in 'furlong'"]),
    ({"phase": np.zeros(3)}, ["field 'phase' holds 3 values", f"({F_HZ.size})"]),
    ({"units": "Hz, V, m/s^2, rad"}, ["voltage", "--reference-unit V"]),
])
def test_bad_runs_are_refused_naming_the_field(tmp_path, change, fragments):
    run = force_run(0.5)
    for name, value in change.items():
        if value is None:
            run.pop(name)
        else:
            run[name] = value
    with pytest.raises(MeasurementTableError) as error:
        read_quietly(write(tmp_path / "runs.mat", {"FC": [run]}))
    for fragment in fragments:
        assert fragment in str(error.value)


def test_per_volt_runs_when_stated(tmp_path):
    path = write(tmp_path / "runs.mat", {"FC": [force_run(0.1, units="Hz, mV, m/s^2, rad")]})
    table, _ = read_quietly(path, ReadOptions("V", coordinates=DRIVE.coordinates))
    assert set(table["reference_unit"]) == {"V"}
    h = table["h_real"].to_numpy() + 1j * table["h_imag"].to_numpy()
    assert np.max(np.abs(h / (receptance(F_HZ) * 1e3) - 1)) < 1e-12  # per mV written, per V read


def test_what_cannot_be_read_is_named(tmp_path):
    only_response = write(tmp_path / "runs.mat", {"RC": [response_run(5.0), response_run(20.0)]})
    with pytest.raises(MeasurementTableError, match="holds no force-controlled run"):
        read_quietly(only_response)
    unnamed = write(tmp_path / "runs.mat", {"FC": [force_run(0.5)]})
    with pytest.raises(MeasurementTableError, match=r"names no coordinates.*--coordinates runs\.mat=RESPONSE,INPUT"):
        read_quietly(unnamed, ReadOptions())
    csv = tmp_path / "frf.csv"
    csv.write_text("frequency_hz,force_level_n,response_dof,input_dof,h_real,h_imag\n80,1,0,0,1e-6,0\n")
    with pytest.raises(MeasurementTableError, match="names its coordinates itself"):
        read_frf_table(csv, options=ReadOptions(coordinates={"frf.csv": ("a", "b")}))


def test_cli_coordinates_statement(tmp_path, capsys):
    path = write(tmp_path / "runs.mat", {"FC": [force_run(0.2), force_run(1.0)]})
    code = main(["identify", "--measured", str(path), "--coordinates", f"{path}=tip", "--out", str(tmp_path / "id")])
    assert code == 2
    assert "--coordinates" in capsys.readouterr().err
    code = main(["identify", "--measured", str(path), "--out", str(tmp_path / "id")])
    assert code == 2
    err = capsys.readouterr().err
    assert "names no coordinates" in err and not (tmp_path / "id").exists()
