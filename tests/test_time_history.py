"""Time histories → first-harmonic FRFs, against references the estimator did not make.

* stepped sine: dwells of an analytic linear SDOF started from rest (closed-form
  transient + steady state, with noise and a 2nd harmonic), and of a Duffing oscillator
  integrated by scipy's DOP853 from rest, whose steady first harmonic comes from the
  project's own time integration (``steady_state_response``);
* sine sweep: a linear SDOF swept through its resonance (scipy ``lsim``), against its
  analytic FRF, at two sweep rates: the documented limit and 16 × faster;
* random: H1 of a linear SDOF driven by noise, against its analytic FRF.
"""
from __future__ import annotations

import subprocess
import sys
import warnings

import numpy as np
import pandas as pd
import pytest
import scipy.integrate
import scipy.signal

from nlupdate.core.measurement.frf_table import select_frf

from nlupdate.core.measurement.frf_files import read_frf_table
from nlupdate.core.measurement.time_history import SWEEP_RATE_LIMIT, TimeRecord, estimate_frf, read_time_record
from nlupdate.core.model.model_file import system_from_dict
from nlupdate.core.response.time_integration import steady_state_response

M, K = 1.0, (2 * np.pi * 20.0) ** 2  # 20 Hz
ZETA = 0.01
C = 2 * ZETA * np.sqrt(K * M)


def sdof_receptance(f):
    w = 2 * np.pi * np.asarray(f, float)
    return 1.0 / (K - M * w**2 + 1j * C * w)


def analytic_dwell(t, f, amplitude):
    """x(t) of m ẍ + c ẋ + k x = F cos ωt from rest: steady state plus the free decay that
    cancels it at t = 0 (closed form)."""
    w = 2 * np.pi * f
    x_ss = amplitude * sdof_receptance(f)
    wn = np.sqrt(K / M)
    wd = wn * np.sqrt(1 - ZETA**2)
    a = -x_ss.real
    b = (w * x_ss.imag + ZETA * wn * a) / wd  # v(0) = 0: v_ss(0) = Re(iωX) = −ω Im X
    return (x_ss * np.exp(1j * w * t)).real + np.exp(-ZETA * wn * t) * (a * np.cos(wd * t) + b * np.sin(wd * t))


def stepped_record(frequencies, levels, fs=2000.0, dwell_s=8.0, noise=0.005, seed=0, distortion=0.02):
    rng = np.random.default_rng(seed)
    parts = []
    for level in levels:
        for f in frequencies:
            t = np.arange(int(dwell_s * fs)) / fs
            force = level * np.cos(2 * np.pi * f * t)
            x = analytic_dwell(t, f, level)
            size = level * abs(sdof_receptance(f))
            x = x + distortion * size * np.cos(2 * 2 * np.pi * f * t + 0.3)
            parts.append(pd.DataFrame({"force": force + noise * level * rng.standard_normal(t.size),
                                       "tip": x + noise * size * rng.standard_normal(t.size),
                                       "frequency_hz": f, "level": level}))
    frame = pd.concat(parts, ignore_index=True)
    frame.insert(0, "time_s", np.arange(len(frame)) / fs)
    return frame


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_stepped_sine_dwells_of_an_analytic_sdof(seed):
    frequencies = [15.0, 18.0, 19.6, 20.0, 20.4, 22.0, 26.0]
    frame = stepped_record(frequencies, levels=[0.5, 2.0], seed=seed)
    record = TimeRecord("analytic", frame["time_s"].to_numpy(), frame["force"].to_numpy(), "N",
                        {"tip": frame["tip"].to_numpy()}, frame["frequency_hz"].to_numpy(), frame["level"].to_numpy())
    estimate = estimate_frf([record], "drive")
    table = estimate.table
    assert estimate.excitation == "stepped_sine" and set(table["excitation"]) == {"stepped_sine"}
    levels = sorted(set(table["force_level_n"]))
    np.testing.assert_allclose(levels, [0.5, 2.0], rtol=2e-3)  # the achieved first-harmonic amplitude
    for level in levels:
        f, h = select_frf(table, "tip", "drive", level)
        error = np.abs(h / sdof_receptance(f) - 1)
        assert error.max() < 0.005, error  # the bound: 0.5 %
        rows = table[np.isclose(table["force_level_n"], level)]
        np.testing.assert_allclose(rows["harmonic_distortion"], 0.02, rtol=0.1)
        assert np.all(rows["h_std"] / np.abs(h) < 0.002)


def duffing_system(k3):
    return system_from_dict({"model": {"kind": "lumped", "mass": [[M]], "stiffness": [[K]], "damping": [[C]]},
                             "nonlinear": [{"type": "cubic", "dofs": [0], "k3": k3}]})


def test_stepped_sine_against_the_projects_time_integration():
    """A hardening Duffing oscillator (4 % peak shift) below and above resonance: dwells
    integrated by scipy from rest, first harmonic against the project's steady state."""
    k3, amplitude, fs = 4e7, 1.0, 1500.0
    frequencies = np.array([17.0, 19.0, 20.5, 23.0])
    steady = steady_state_response(duffing_system(k3), {0: amplitude}, 2 * np.pi * frequencies, tolerance=1e-9)
    assert steady.converged.all()
    parts = []
    for f in frequencies:
        t = np.arange(int(8.0 * fs)) / fs
        w = 2 * np.pi * f

        def rhs(time, y):
            return [y[1], (amplitude * np.cos(w * time) - C * y[1] - K * y[0] - k3 * y[0] ** 3) / M]

        solution = scipy.integrate.solve_ivp(rhs, (0, t[-1]), [0.0, 0.0], method="DOP853", t_eval=t, rtol=1e-10,
                                             atol=1e-13)
        parts.append(pd.DataFrame({"force": amplitude * np.cos(w * t), "x": solution.y[0], "frequency_hz": f}))
    frame = pd.concat(parts, ignore_index=True)
    record = TimeRecord("duffing", np.arange(len(frame)) / fs, frame["force"].to_numpy(), "N",
                        {"x": frame["x"].to_numpy()}, frame["frequency_hz"].to_numpy())
    table = estimate_frf([record], "0").table
    f, h = select_frf(table, "x", "0", table["force_level_n"].iloc[0])
    reference = steady.x[:, 0] / amplitude
    error = np.abs(h / reference - 1)
    assert error.max() < 0.005, error
    assert np.abs(h / sdof_receptance(f) - 1).max() > 0.05  # the nonlinearity matters at these points


SWEEP_ZETA = 0.05  # a 1 Hz half bandwidth keeps the sweeps short (60 s at the limit)


def sweep_record(rate_hz_s, f0=17.0, f1=23.0, fs=2000.0):
    duration = (f1 - f0) / rate_hz_s
    t = np.arange(int(duration * fs)) / fs
    phase = 2 * np.pi * (f0 * t + 0.5 * rate_hz_s * t**2)
    force = np.cos(phase)
    damping = 2 * SWEEP_ZETA * np.sqrt(K * M)
    _, x, _ = scipy.signal.lsim(scipy.signal.lti([1.0], [M, damping, K]), force, t)
    return TimeRecord(f"sweep {rate_hz_s:g} Hz/s", t, force, "N", {"x": x})


def sweep_error(rate_coefficient):
    """Largest relative error of the swept complex FRF in 18–22 Hz against the
    steady-state (stepped-sine) FRF, for a sweep at rate_coefficient·(ζ f_r)² Hz/s."""
    rate = rate_coefficient * (SWEEP_ZETA * 20.0) ** 2
    estimate = estimate_frf([sweep_record(rate)], "0")
    f, h = select_frf(estimate.table, "x", "0", estimate.table["force_level_n"].iloc[0])
    inside = (f > 18.0) & (f < 22.0)
    w = 2 * np.pi * f[inside]
    steady = 1.0 / (K - M * w**2 + 2j * SWEEP_ZETA * np.sqrt(K * M) * w)
    assert estimate.excitation == "sine_sweep" and set(estimate.table["sweep_direction"]) == {"up"}
    return float(np.max(np.abs(h[inside] / steady - 1)))


def test_slow_sine_sweep_measures_the_stepped_sine_frf_and_the_rate_limit():
    """At the documented limit r = SWEEP_RATE_LIMIT·(ζ f_r)² the swept FRF is within 2 %
    of the stepped-sine (steady-state) FRF; 8 × faster it is not."""
    slow, fast = sweep_error(SWEEP_RATE_LIMIT), sweep_error(8 * SWEEP_RATE_LIMIT)
    assert slow < 0.02, slow
    assert fast > 0.02, fast


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_random_excitation_h1_with_coherence(seed):
    rng = np.random.default_rng(seed)
    fs, n = 1000.0, 2**18
    t = np.arange(n) / fs
    # band-limited noise (to 60 Hz) sampled far above its band, so lsim's interpolation of the input is exact enough
    force = scipy.signal.sosfiltfilt(scipy.signal.butter(8, 60.0, fs=fs, output="sos"), rng.standard_normal(n))
    force /= force.std()
    _, x, _ = scipy.signal.lsim(scipy.signal.lti([1.0], [M, C, K]), force, t)
    x = x + 0.02 * np.std(x) * rng.standard_normal(n)
    estimate = estimate_frf([TimeRecord("random", t, force, "N", {"x": x})], "0", resolution_hz=0.1)
    table = estimate.table
    assert estimate.excitation == "random"
    f, h = select_frf(table, "x", "0", table["force_level_n"].iloc[0])
    band = (f > 10) & (f < 40) & (np.abs(f - 20) > 1.0)  # away from the peak, where leakage biases H1
    error = np.abs(h[band] / sdof_receptance(f[band]) - 1)
    assert np.median(error) < 0.01, np.median(error)
    assert table["coherence"].between(0, 1).all() and (table["averages"] >= 8).all()
    np.testing.assert_allclose(table["force_level_n"].iloc[0], 1.0, rtol=0.05)  # RMS of a unit normal


def test_frf_command_from_csv_to_identify_ready_table(tmp_path):
    frame = stepped_record([18.0, 19.0, 20.0, 21.0, 22.0], levels=[0.1])
    frame = frame.rename(columns={"force": "voltage"})
    frame.to_csv(tmp_path / "dwells.csv", index=False)
    out = tmp_path / "frf.parquet"
    result = subprocess.run([sys.executable, "-m", "nlupdate", "frf", tmp_path / "dwells.csv", "--out", out,
                             "--input-dof", "drive"], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert "reference in V, FRFs in m/V" in result.stdout and "harmonic distortion" in result.stdout
    table = read_frf_table(out)
    assert set(table["reference_unit"]) == {"V"}
    f, h = select_frf(table, "tip", "drive", table["force_level_n"].iloc[0])
    np.testing.assert_allclose(h, sdof_receptance(f), rtol=0.005)


def test_time_records_from_uff_and_mat(tmp_path):
    import pyuff
    import scipy.io

    fs, f = 1000.0, 20.0
    t = np.arange(8000) / fs
    force = np.cos(2 * np.pi * f * t)
    x = analytic_dwell(t, f, 1.0)
    common = dict(binary=0, func_type=1, abscissa_spacing=1, orddenom_spec_data_type=0, abscissa_spec_data_type=17, abscissa_axis_units_lab="s",
                  x=t, ref_node=1, ref_dir=3)
    pyuff.UFF(str(tmp_path / "rec.uff")).write_sets([
        pyuff.prepare_58(data=force, rsp_node=1, rsp_dir=3, ordinate_spec_data_type=13, ordinate_axis_units_lab="N",
                         **common),
        pyuff.prepare_58(data=x, rsp_node=7, rsp_dir=-3, ordinate_spec_data_type=8, ordinate_axis_units_lab="m",
                         **common)], mode="add")
    record = read_time_record(tmp_path / "rec.uff")
    assert record.reference_unit == "N" and list(record.responses) == ["7:uz"]
    np.testing.assert_allclose(record.responses["7:uz"], -x, rtol=1e-5, atol=1e-12)  # −z: the sign is applied
    scipy.io.savemat(tmp_path / "rec.mat", {"time_s": t, "voltage": force, "tip": x, "frequency_hz": np.full(t.size, f)})
    record = read_time_record(tmp_path / "rec.mat")
    assert record.reference_unit == "V" and list(record.responses) == ["tip"]
    table = estimate_frf([record], "drive").table
    _, h = select_frf(table, "tip", "drive", table["force_level_n"].iloc[0])
    np.testing.assert_allclose(h, sdof_receptance([f]), rtol=0.005)


def test_a_dwell_too_short_to_settle_is_warned_about():
    """3 s at resonance is under four time constants: the estimate would hold the transient."""
    from nlupdate.notices import NlupdateWarning

    frame = stepped_record([20.0], levels=[1.0], dwell_s=3.0, noise=0.0, distortion=0.0)
    record = TimeRecord("short", frame["time_s"].to_numpy(), frame["force"].to_numpy(), "N",
                        {"tip": frame["tip"].to_numpy()}, frame["frequency_hz"].to_numpy())
    with pytest.warns(NlupdateWarning, match="short: the dwell at 20 Hz had not settled"):
        estimate_frf([record], "drive")


def test_dwells_too_short_for_the_transient_rule_are_warned_about():
    """Dwells of 10 periods at ζ = 1 % (0.5 s, a fifth of one time constant 1/(ζω_r) =
    0.8 s): the estimate is far from the steady state (analytic), and the settling check
    used to call such a dwell settled because it had too few blocks to tell."""
    from nlupdate.notices import NlupdateWarning

    frequencies = [18.0, 19.0, 20.0, 21.0, 22.0]
    frame = stepped_record(frequencies, levels=[1.0], dwell_s=0.5, noise=0.0, distortion=0.0)
    record = TimeRecord("short", frame["time_s"].to_numpy(), frame["force"].to_numpy(), "N",
                        {"tip": frame["tip"].to_numpy()}, frame["frequency_hz"].to_numpy())
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        table = estimate_frf([record], "drive").table
    f, h = select_frf(table, "tip", "drive", table["force_level_n"].iloc[0])
    assert np.max(np.abs(h / sdof_receptance(f) - 1)) > 0.2  # the premise: these FRFs hold the transient
    notes = [str(w.message) for w in caught if issubclass(w.category, NlupdateWarning)]
    for frequency in frequencies:
        assert any(note.startswith(f"short: the dwell at {frequency:g} Hz lasts ") and "fewer than the 16 periods"
                   in note for note in notes), notes


def test_a_time_column_in_milliseconds_is_refused():
    """Times in ms make the sample rate look 1000 × lower: 2 Hz for dwells at 18–22 Hz, far
    above its Nyquist frequency. The fit aliased and gave levels of 1e5–1e6 N for a 1 N test."""
    from nlupdate.core.measurement.time_history import TimeHistoryError

    frame = stepped_record([18.0, 20.0, 22.0], levels=[1.0], dwell_s=2.0)
    record = TimeRecord("ms.csv", 1000 * frame["time_s"].to_numpy(), frame["force"].to_numpy(), "N",
                        {"tip": frame["tip"].to_numpy()}, frame["frequency_hz"].to_numpy())
    with pytest.raises(TimeHistoryError) as error:
        estimate_frf([record], "drive")
    message = str(error.value)
    assert message.startswith("ms.csv: the dwell at 18 Hz needs a sample rate above 108 Hz") and \
        "'time_s' gives 2 Hz" in message and "in seconds?" in message and "\n" not in message, message


def test_a_benchmark_style_sweep_file(tmp_path):
    """The F-16 benchmark's CSV layout: Force, Voltage, Acceleration1…, a constant Fs column,
    no time column and zero padding at the end; acceleration responses."""
    record = sweep_record(SWEEP_RATE_LIMIT * (SWEEP_ZETA * 20.0) ** 2, fs=1000.0)
    damping = 2 * SWEEP_ZETA * np.sqrt(K * M)
    system = scipy.signal.lti([1.0, 0.0, 0.0], [M, damping, K])  # acceleration per force
    _, acceleration, _ = scipy.signal.lsim(system, record.reference, record.time_s)
    pad = 500
    frame = pd.DataFrame({"Force": np.r_[record.reference, np.zeros(pad)],
                          "Voltage": np.r_[0.1 * record.reference, np.zeros(pad)],
                          "Acceleration1": np.r_[acceleration, np.zeros(pad)], "Fs": 1000.0})
    frame.to_csv(tmp_path / "F16Data_SineSw_Level1.csv", index=False)
    out = tmp_path / "frf.parquet"
    result = subprocess.run([sys.executable, "-m", "nlupdate", "frf", tmp_path / "F16Data_SineSw_Level1.csv",
                             "--response-quantity", "acceleration", "--out", out], capture_output=True, text=True,
                            timeout=120)
    assert result.returncode == 0, result.stderr
    assert "excitation: sine sweep; reference in N" in result.stdout and "sweep rate" in result.stderr
    table = read_frf_table(out)
    f, h = select_frf(table, "Acceleration1", "force", table["force_level_n"].iloc[0])
    inside = (f > 18.0) & (f < 22.0)
    w = 2 * np.pi * f[inside]
    steady = 1.0 / (K - M * w**2 + 1j * damping * w)
    assert np.max(np.abs(h[inside] / steady - 1)) < 0.02
