"""Ring-down (free decay) estimator, reader and ``nlupdate amplitude --ring-down``.

References independent of the estimator: the analytic free decay of a linear SDOF, and
RK4 time integration (written here, with the elements' own time-domain force laws and
their hysteretic state committed once per step) of an SDOF with a Jenkins or an Iwan joint,
against the describing-function backbone ``ω(A)² = (k + Re ν(A))/m``,
``ζ(A) = c/(2mω) + Im ν(A)/(2mω²)`` (module docstring of nlupdate.core.identification.ring_down).
"""
from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
import scipy.io

from nlupdate.app.cli import main
from nlupdate.core.identification.ring_down import RingDownError, estimate_ring_down, read_ring_down
from nlupdate.core.model.elements import IwanJoint, JenkinsFriction

from reference_cache import session_cached

M, F0, ZETA = 2.0, 10.0, 0.005
K = M * (2 * np.pi * F0) ** 2
C = 2 * ZETA * np.sqrt(K * M)


@session_cached  # computed once per session: other modules take the same reference
def free_decay(element, x0: float, periods: float, steps: int = 200, every: int = 2):
    """RK4 of ``m ẍ + c ẋ + k x + g(x, state) = 0`` from x0 at rest; ``steps`` per period."""
    dt = 1 / F0 / steps
    state = element.initial_state(())
    y = np.array([x0, 0.0])
    out = [x0]

    def rate(y, s):
        g = float(element.force(np.array(y[0]), np.array(y[1]), s)[0])
        return np.array([y[1], -(C * y[1] + K * y[0] + g) / M])

    for i in range(int(periods * steps)):
        k1 = rate(y, state)
        k2 = rate(y + dt / 2 * k1, state)
        k3 = rate(y + dt / 2 * k2, state)
        k4 = rate(y + dt * k3, state)
        y = y + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        state = element.force(np.array(y[0]), np.array(y[1]), state)[1]
        if (i + 1) % every == 0:
            out.append(y[0])
    return np.arange(len(out)) * dt * every, np.array(out)


def df_backbone(element, amplitude):
    nu = element.describing_function(amplitude)
    omega = np.sqrt((K + nu.real) / M)
    return omega / (2 * np.pi), C / (2 * M * omega) + nu.imag / (2 * M * omega**2)


IWAN = IwanJoint((0,), slip_force=0.1 * K * 1e-3, kt=0.1 * K, chi=-0.5, beta=0.5, sliders=200)
JENKINS = JenkinsFriction((0,), kf=0.1 * K, slip_force=0.1 * K * 1e-3)


@pytest.fixture(scope="module")
def iwan_decay():
    return free_decay(IWAN, 3e-3, 60)


@pytest.fixture(scope="module")
def jenkins_decay():
    return free_decay(JENKINS, 20e-3, 80)


def errors(estimate, element):
    amplitude = estimate.amplitude / np.sqrt(M)  # A = φ·a, φ = 1/√m
    f, z = df_backbone(element, amplitude)
    return estimate.frequency_hz / f - 1, estimate.damping_ratio / z - 1, amplitude


def test_linear_decay_gives_its_natural_frequency_and_damping_ratio():
    zeta, f0 = 0.02, 12.5
    w0 = 2 * np.pi * f0
    t = np.arange(0, 8, 1 / 500)
    x = 3.0 * np.exp(-zeta * w0 * t) * np.cos(w0 * np.sqrt(1 - zeta**2) * t + 0.3)
    est = estimate_ring_down(t, x + 0.7, shape=0.5)  # an offset, as a locked slider leaves
    assert est.time_s.size > 2000  # of 4000: the filter's and window's ends trimmed
    assert np.max(np.abs(est.frequency_hz / f0 - 1)) < 1e-4  # measured 3.8e-5
    assert np.max(np.abs(est.damping_ratio / zeta - 1)) < 5e-3  # measured 2.2e-3
    envelope = 3.0 * np.exp(-zeta * w0 * est.time_s) / 0.5  # modal amplitude = |x|/|φ|
    assert np.max(np.abs(est.amplitude / envelope - 1)) < 1e-3  # measured 1.6e-4
    samples = est.samples()
    assert 5 < samples.amplitude.size < est.time_s.size / 50 and np.all(samples.force_n == 0)


def test_iwan_decay_follows_the_describing_function_backbone(iwan_decay):
    t, x = iwan_decay
    ef, ez, amplitude = errors(estimate_ring_down(t, x, shape=1 / np.sqrt(M)), IWAN)
    assert amplitude.max() / amplitude.min() > 4  # microslip, down from near macroslip
    assert np.max(np.abs(ef)) < 2e-3  # measured 4e-5
    assert np.max(np.abs(ez)) < 0.05  # measured 0.014


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_iwan_decay_with_noise_keeps_only_what_is_precise(iwan_decay, seed):
    t, x = iwan_decay
    noisy = x + 0.01 * x[0] * np.random.default_rng(seed).standard_normal(x.size)
    est = estimate_ring_down(t, noisy, shape=1 / np.sqrt(M))
    ef, ez, amplitude = errors(est, IWAN)
    assert amplitude.max() / amplitude.min() > 1.5
    assert np.max(np.abs(ef)) < 2e-3  # measured ≤ 1.4e-4
    assert np.max(np.abs(ez)) < 0.05  # measured 0.033–0.044


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_jenkins_decay_with_noise_keeps_no_window_across_the_stick_slip_change(jenkins_decay, seed):
    t, x = jenkins_decay
    noisy = x + 0.005 * x[0] * np.random.default_rng(seed).standard_normal(x.size)
    ef, ez, amplitude = errors(estimate_ring_down(t, noisy, shape=1 / np.sqrt(M)), JENKINS)
    assert amplitude.max() / amplitude.min() > 1.3
    assert np.max(np.abs(ef)) < 2e-3  # measured ≤ 3.2e-4 (0.37 % without the frequency agreement)
    assert np.max(np.abs(ez)) < 0.05  # measured 0.036–0.042 (0.26 without)


def test_jenkins_decay_in_macroslip_follows_the_describing_function_backbone(jenkins_decay):
    t, x = jenkins_decay
    ef, ez, amplitude = errors(estimate_ring_down(t, x, shape=1 / np.sqrt(M)), JENKINS)
    slipping = amplitude > 2.5 * JENKINS.slip_amplitude  # the stick–slip kink is sharper than a window
    assert amplitude[slipping].max() / amplitude[slipping].min() > 3
    assert np.max(np.abs(ef)) < 2e-3  # measured 3.6e-4
    assert np.max(np.abs(ez[slipping])) < 0.05  # measured 0.034 (0.105 within 1–2.5 × the slip amplitude)


def turning_points(t, x):
    """(time s, |x| m) of every extremum of x, refined by a parabola through its three samples."""
    i = np.nonzero((np.abs(x[1:-1]) >= np.abs(x[:-2])) & (np.abs(x[1:-1]) > np.abs(x[2:])))[0] + 1
    y0, y1, y2 = np.abs(x[i - 1]), np.abs(x[i]), np.abs(x[i + 1])
    shift = 0.5 * (y0 - y2) / (y0 - 2 * y1 + y2)
    return t[i] + shift * (t[1] - t[0]), y1 - 0.25 * (y0 - y2) * shift


def test_jenkins_decay_follows_its_own_logarithmic_decrement_where_the_describing_function_does_not(
        jenkins_decay):
    """Near the stick–slip amplitude the describing function's slow flow (first-order
    averaging) misses the true decay: the logarithmic decrement of the record's own turning
    points, one period apart, is the reference there."""
    t, x = jenkins_decay
    est = estimate_ring_down(t, x, shape=1 / np.sqrt(M))
    times, peaks = turning_points(t, x)
    zeta_turn = np.log(peaks[:-2] / peaks[2:]) / (2 * np.pi)  # over a period, centred on each turning point
    centre, amplitude = times[1:-1], peaks[1:-1]
    nearest = np.clip(np.searchsorted(est.time_s, centre), 0, est.time_s.size - 1)
    inside = (np.abs(est.time_s[nearest] - centre) < 2 * (t[1] - t[0])) & (amplitude > 0.5 * JENKINS.slip_amplitude)
    zeta_est = est.damping_ratio[nearest[inside]]  # the estimate kept nearest each turning point
    assert np.count_nonzero(inside) > 20
    assert np.max(np.abs(zeta_est / zeta_turn[inside] - 1)) < 0.03  # measured 0.023 (0.5–8.4 mm)
    _, zeta_df = df_backbone(JENKINS, amplitude[inside])
    assert np.max(np.abs(zeta_df / zeta_turn[inside] - 1)) > 0.08  # the describing function misses by 9.6 %


def test_a_record_without_a_precise_decay_is_refused():
    t = np.arange(0, 4, 1 / 500)
    noise = np.random.default_rng(0).standard_normal(t.size)
    with pytest.raises(RingDownError, match="no part of the decay is left"):
        estimate_ring_down(t, noise + np.cos(2 * np.pi * 12 * t), band_hz=(8, 16)).samples()


def test_reader_takes_csv_and_mat_and_names_the_channel(tmp_path):
    t = np.arange(0, 1, 0.01)
    pd.DataFrame({"time_s": t, "a": np.sin(t), "b": np.cos(t)}).to_csv(tmp_path / "r.csv", index=False)
    record = read_ring_down(tmp_path / "r.csv", "b")
    assert record.channel == "b" and np.allclose(record.response, np.cos(t))
    with pytest.raises(RingDownError, match=r"r\.csv: holds channels \['a', 'b'\]; choose one with --channel"):
        read_ring_down(tmp_path / "r.csv")
    scipy.io.savemat(tmp_path / "r.mat", {"time_s": t[:, None], "tip": np.sin(t)})
    record = read_ring_down(tmp_path / "r.mat")
    assert record.channel == "tip" and np.allclose(record.response, np.sin(t))
    pd.DataFrame({"t": t, "a": t}).to_csv(tmp_path / "bad.csv", index=False)
    with pytest.raises(RingDownError, match=r"bad\.csv: no 'time_s' column"):
        read_ring_down(tmp_path / "bad.csv")


def test_amplitude_command_fits_a_ring_down_alone(tmp_path, iwan_decay, capsys):
    t, x = iwan_decay
    pd.DataFrame({"time_s": t, "tip": x}).to_csv(tmp_path / "decay.csv", index=False)
    out = tmp_path / "out"
    assert main(["amplitude", "--ring-down", str(tmp_path / "decay.csv"), "--shape", f"tip={1 / np.sqrt(M)}",
                 "--backbone", "polynomial", "--order", "2", "--out", str(out)]) == 0
    model = json.loads((out / "amplitude_model.json").read_text())
    assert model["shapes"] == {"tip": pytest.approx(1 / np.sqrt(M))}
    curve = pd.read_csv(out / "backbone.csv")
    points = pd.read_csv(out / "backbone_points.csv")
    assert set(points["source"]) == {str(tmp_path / "decay.csv")}
    assert curve["modal_amplitude"].min() == pytest.approx(points["modal_amplitude"].min())
    f, z = df_backbone(IWAN, curve["modal_amplitude"].to_numpy() / np.sqrt(M))
    assert np.max(np.abs(curve["natural_frequency_hz"] / f - 1)) < 2e-3
    assert np.max(np.abs(curve["damping_ratio"] / z - 1)) < 0.05
    inside = (curve["natural_frequency_hz_low"] <= curve["natural_frequency_hz"]) & \
        (curve["natural_frequency_hz"] <= curve["natural_frequency_hz_high"])
    assert inside.all() and (curve["damping_ratio_high"] > curve["damping_ratio_low"]).all()
    assert "95 % of 200 refits of a residual bootstrap" in capsys.readouterr().out


def test_amplitude_command_finds_the_iwan_joint_of_a_ring_down(tmp_path, iwan_decay, capsys):
    t, x = iwan_decay
    pd.DataFrame({"time_s": t, "tip": x, "base": 0.1 * x}).to_csv(tmp_path / "decay.csv", index=False)
    out = tmp_path / "out"
    assert main(["amplitude", "--ring-down", str(tmp_path / "decay.csv"), "--channel", "tip", "--shape",
                 f"tip={1 / np.sqrt(M)}", "--backbone", "iwan", "--out", str(out)]) == 0
    model = json.loads((out / "amplitude_model.json").read_text())
    assert model["natural_frequency_hz"] == pytest.approx(np.sqrt(1.1) * F0, rel=1e-3)  # stuck: k + K_T
    assert model["damping_ratio"] == pytest.approx(ZETA, rel=0.1)
    assert model["joint"]["chi"] == pytest.approx(IWAN.chi, abs=0.05)
    assert pd.read_csv(out / "backbone.csv")["damping_ratio_low"].isna().all()  # no refits unless asked
    assert "--bootstrap N refits N resamples" in capsys.readouterr().out


def test_amplitude_command_joins_a_ring_down_with_a_modal_table(tmp_path, iwan_decay):
    t, x = iwan_decay
    pd.DataFrame({"time_s": t, "tip": x}).to_csv(tmp_path / "decay.csv", index=False)
    phi = 1 / np.sqrt(M)
    a = np.array([2e-4, 5e-4, 1e-3, 2e-3])  # modal amplitudes of phase-resonance tests: F = 2ζω²a/φ
    f, z = df_backbone(IWAN, a * phi)
    force = 2 * z * (2 * np.pi * f) ** 2 * a / phi
    pd.DataFrame({"force_level_n": force, "mode": 1, "natural_frequency_hz": f, "damping_ratio": z,
                  "input_dof": "tip"}).to_csv(tmp_path / "modal.csv", index=False)
    out = tmp_path / "out"
    assert main(["amplitude", "--measured", str(tmp_path / "modal.csv"), "--ring-down", str(tmp_path / "decay.csv"),
                 "--shape", f"tip={phi}", "--backbone", "polynomial", "--order", "3", "--out", str(out)]) == 0
    points = pd.read_csv(out / "backbone_points.csv")
    assert points.groupby("source").size().to_dict()[str(tmp_path / "modal.csv")] == 4
    assert len(set(points["source"])) == 2
    curve = pd.read_csv(out / "backbone.csv")
    assert curve["modal_amplitude"].min() == pytest.approx(2e-4)
    assert curve["modal_amplitude"].max() == pytest.approx(2e-3)
    f_ref, _ = df_backbone(IWAN, curve["modal_amplitude"].to_numpy() * phi)
    assert np.max(np.abs(curve["natural_frequency_hz"] / f_ref - 1)) < 2e-3


def test_amplitude_command_needs_some_data(tmp_path, capsys):
    pd.DataFrame({"time_s": np.arange(100) / 100, "a": 1.0, "b": 2.0}).to_csv(tmp_path / "two.csv", index=False)
    assert main(["amplitude", "--ring-down", str(tmp_path / "two.csv"), "--out", str(tmp_path / "out")]) != 0
    assert "two.csv: holds channels ['a', 'b']; choose one with --channel NAME" in capsys.readouterr().err
    assert main(["amplitude", "--out", str(tmp_path / "out")]) != 0
    assert "--measured FILE (FRFs or a modal table) and/or --ring-down FILE" in capsys.readouterr().err
