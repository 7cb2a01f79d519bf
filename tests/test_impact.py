"""The linear limit from an impact / low-level free decay (nlupdate.core.identification.impact).

References independent of the fit: the exact response of two modal oscillators to a
half-sine hammer pulse (scipy's LTI simulation), the RK4 free decay of an SDOF with an Iwan
joint against its describing-function backbone (tests/test_ring_down.py), and, on the
Brake–Reuss beam's public hammer-impact record (tests/data/brb/HammerImpact_1600Hz.mat,
a decimated excerpt of HammerImpact.mat), the ring-down estimator's envelope method on the
same record (a different method: its lowest-amplitude samples must lie on the same backbone).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import scipy.signal

from nlupdate.app.cli import main
from nlupdate.core.identification.impact import decay_segments, fit_linear_limit, split_force
from nlupdate.core.identification.ring_down import RingDownError, estimate_ring_down, read_channels
from test_ring_down import IWAN, M, df_backbone, free_decay

BRB = Path(__file__).parent / "data" / "brb"
F1, Z1, F2, Z2 = 80.4, 0.002, 297.0, 0.004


def hammer_record(noise: float, seed: int, fs: float = 2000.0, seconds: float = 8.0):
    """Three accelerometer channels and the force of two modes hit by a 1 ms half-sine pulse
    at t = 0.1 s (unit modal masses; modal participations per channel below), white noise of
    ``noise`` × each channel's peak."""
    t = np.arange(0, seconds, 1 / fs)
    force = np.where((t >= 0.1) & (t < 0.101), 100 * np.sin(np.pi * (t - 0.1) / 1e-3), 0.0)
    modes = []
    for f, z in ((F1, Z1), (F2, Z2)):
        w = 2 * np.pi * f  # acceleration of q̈ + 2ζωq̇ + ω²q = F: s²/(s² + 2ζωs + ω²)
        modes.append(scipy.signal.lsim(([1.0, 0.0, 0.0], [1.0, 2 * z * w, w**2]), force, t)[1])
    rng = np.random.default_rng(seed)
    channels = {}
    for name, (p1, p2) in {"a1": (1.0, 0.5), "a2": (-0.7, 0.8), "a3": (0.4, -0.3)}.items():
        x = p1 * modes[0] + p2 * modes[1]
        channels[name] = x + noise * np.max(np.abs(x)) * rng.standard_normal(t.size)
    return t, channels, force


@pytest.mark.parametrize("noise", [0.005, 0.02])
def test_hammer_record_gives_the_linear_modes_pole(noise):
    """White noise of 0.5 % and 2 % of each channel's peak, 8 seeds each: every seed's ζ within
    the issue's 5 % (measured over 16 seeds: ≤ 1.0 % and ≤ 2.0 %; the linear prediction alone
    was 0.4–8.6 % high at 2 %, biased by the noise in its regressors), the frequency within
    0.01 %, and each within 3 of its stated standard errors."""
    for seed in range(8):
        t, channels, force = hammer_record(noise, seed)
        fit = fit_linear_limit(t, channels, (60, 100), force=force)
        assert fit.window_s[0] > 0.101  # after the blow
        error_f, error_z = fit.frequency_hz / F1 - 1, fit.damping_ratio / Z1 - 1
        assert abs(error_f) < 1e-4 and abs(error_z) < 0.05, seed
        assert abs(error_f) < 3 * fit.frequency_std_hz / F1 and abs(error_z) < 3 * fit.damping_std / Z1, seed
        assert fit.channels == ("a1", "a2", "a3")


def test_without_a_force_channel_the_fit_starts_at_the_largest_response():
    t, channels, _ = hammer_record(0.005, 3)
    fit = fit_linear_limit(t, {"a1": channels["a1"]}, (60, 100), shape=0.5)
    assert fit.frequency_hz == pytest.approx(F1, rel=1e-4)
    assert fit.damping_ratio == pytest.approx(Z1, rel=0.03)
    low, high = fit.amplitude_range
    assert low <= fit.amplitude <= high
    # the quiet part: a factor 3 of envelope, widened by 1.5 until ζ is known within 1 % (noise
    # alone; the stated error is from the residual) — not the whole decay
    assert fit.damping_std < 0.015 * fit.damping_ratio and high < 0.5 * np.abs(channels["a1"]).max()


def test_iwan_decay_gives_the_backbone_at_its_quietest_part(iwan_record):
    """A joint's decay is not linear: the fit is of its quietest part, and lands on the
    describing-function backbone between that part's amplitudes."""
    t, x = iwan_record
    fit = fit_linear_limit(t, {"x": x}, (7, 13), shape=1 / np.sqrt(M))
    a = np.array(fit.amplitude_range) / np.sqrt(M)  # displacement amplitudes A = φa
    f, z = df_backbone(IWAN, a)
    assert min(f) * (1 - 1e-4) <= fit.frequency_hz <= max(f) * (1 + 1e-4)
    assert min(z) * 0.97 <= fit.damping_ratio <= max(z) * 1.03
    f_mid, z_mid = df_backbone(IWAN, fit.amplitude / np.sqrt(M))
    assert fit.frequency_hz == pytest.approx(f_mid, rel=2e-4)
    assert fit.damping_ratio == pytest.approx(z_mid, rel=0.05)


def test_brb_hammer_impact_continues_the_ring_down_backbone():
    columns = read_channels(BRB / "HammerImpact_1600Hz.mat")
    assert list(columns) == ["time_s", "acc1", "acc2", "acc3"]
    t, responses, force = split_force(columns, "acc3")
    assert force is None and t[0] == pytest.approx(-0.01)
    fit = fit_linear_limit(t, responses, (60, 100))
    start = int(np.argmax(np.abs(responses["acc3"])))
    ring = estimate_ring_down(t[start:], responses["acc3"][start:], (60, 100))
    lowest = np.argmin(ring.amplitude)
    # quieter than every ring-down sample, so stiffer and less damped (the joint sticks)
    assert fit.amplitude_range[1] < ring.amplitude.min()
    assert ring.frequency_hz[lowest] < fit.frequency_hz < ring.frequency_hz[lowest] * 1.002
    assert 0.7 * ring.damping_ratio[lowest] < fit.damping_ratio < ring.damping_ratio[lowest]
    assert fit.frequency_std_hz < 0.01 and fit.damping_std < 1e-4
    # all channels (acc2's decay ends early: left out): their quietest common part is no
    # quieter than acc3's alone, so it sits on the same softening backbone at or below
    # acc3's linear limit and above the ring-down's quietest sample
    every = fit_linear_limit(*split_force(columns, None)[:2], (60, 100))
    assert every.amplitude_range[1] >= fit.amplitude_range[1]
    assert ring.frequency_hz[lowest] < every.frequency_hz <= fit.frequency_hz + 3 * fit.frequency_std_hz


def test_bad_impact_records_are_refused(tmp_path):
    t, channels, force = hammer_record(0.0, 0, seconds=1.0)
    with pytest.raises(RingDownError, match="band 100–60 Hz"):
        fit_linear_limit(t, channels, (100, 60), force=force)
    pd.DataFrame({"t": t, "a1": channels["a1"]}).to_csv(tmp_path / "r.csv", index=False)
    with pytest.raises(RingDownError, match="no 'time_s'"):
        split_force(read_channels(tmp_path / "r.csv"), None)
    with pytest.raises(RingDownError, match="nothing of the decay is left"):
        fit_linear_limit(t, {"a1": np.random.default_rng(0).standard_normal(t.size)}, (60, 100))


@pytest.fixture(scope="module")
def iwan_record():
    return free_decay(IWAN, 3e-3, 60)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_noisy_ring_down_read_in_segments(seed, tmp_path, iwan_record):
    """White noise of 2 % of the initial amplitude leaves the envelope method one sample at
    most (docs/ring-down.md); fitted part by part, the Iwan decay still gives samples over a
    factor 3 of amplitude, each within its stated standard errors of the describing-function
    backbone."""
    t, x = iwan_record
    noisy = x + 0.02 * x[0] * np.random.default_rng(seed).standard_normal(x.size)
    assert estimate_ring_down(t, noisy, (7, 13), shape=1 / np.sqrt(M)).samples().amplitude.size <= 1
    parts = decay_segments(t, {"x": noisy}, (7, 13), shape=1 / np.sqrt(M))
    a = np.array([p.amplitude for p in parts]) / np.sqrt(M)
    f, z = df_backbone(IWAN, a)
    assert len(parts) >= 4 and a.max() / a.min() > 3
    for part, f_true, z_true in zip(parts, f, z):
        assert abs(part.frequency_hz / f_true - 1) < 2e-3  # measured ≤ 1.1e-3
        # measured (seeds 1–8, 33 parts): ≤ 13 %, at most 3.3 stated standard errors
        assert abs(part.damping_ratio / z_true - 1) < 3.5 * part.damping_std / part.damping_ratio
    if seed != 1:
        return
    pd.DataFrame({"time_s": t, "x": noisy}).to_csv(tmp_path / "decay.csv", index=False)
    assert main(["amplitude", "--ring-down", str(tmp_path / "decay.csv"), "--ring-down-fit", "segments", "--band",
                 "7:13", "--shape", f"x={1 / np.sqrt(M)}", "--backbone", "polynomial", "--order", "1",
                 "--bootstrap", "0", "--out", str(tmp_path / "amm")]) == 0
    assert len(pd.read_csv(tmp_path / "amm" / "backbone_points.csv")) == len(parts)


def test_an_impact_alone_gives_a_linear_limit_model_with_its_band(tmp_path):
    """``nlupdate amplitude --impact`` alone: the model is the linear limit (no amplitude
    dependence, usable as an updating target), backbone.csv carries the pole's 95 % interval."""
    out = tmp_path / "amm"
    assert main(["amplitude", "--impact", str(BRB / "HammerImpact_1600Hz.mat"), "--channel", "acc3", "--band", "60:100",
                 "--response-unit", "m/s^2", "--shape", "acc3=0.7271", "--out", str(out)]) == 0
    columns = read_channels(BRB / "HammerImpact_1600Hz.mat")
    fit = fit_linear_limit(*split_force(columns, "acc3")[:2], (60, 100))
    model = json.loads((out / "amplitude_model.json").read_text())
    assert model["natural_frequency_hz"] == pytest.approx(fit.frequency_hz, rel=1e-12)
    assert model["damping_ratio"] == pytest.approx(fit.damping_ratio, rel=1e-12)
    row = pd.read_csv(out / "backbone.csv").iloc[0]
    assert row["natural_frequency_hz_low"] < fit.frequency_hz < row["natural_frequency_hz_high"]
    assert row["damping_ratio_high"] - row["damping_ratio_low"] == pytest.approx(2 * 1.96 * fit.damping_std, rel=1e-6)
    # the amplitude is displacement: acceleration / ω², over the shape
    assert row["modal_amplitude"] == pytest.approx(fit.amplitude / (2 * np.pi * fit.frequency_hz) ** 2 / 0.7271,
                                                   rel=1e-9)


def test_impact_and_ring_down_read_from_a_universal_file(tmp_path, iwan_record):
    """A test system's export: UFF datasets 58 of function type 1 written by pyuff — the hammer's
    force (ordinate type 13, N) and three accelerometers (type 12, m/s², one along −z) — read into
    the same table as CSV and MAT (a response named NODE:DIR, the hammer's record ``force``):
    the linear mode's pole; and a ring-down through ``nlupdate amplitude --ring-down FILE.uff``."""
    import pyuff

    t, channels, force = hammer_record(0.005, 0)
    common = dict(binary=0, func_type=1, abscissa_spacing=1, orddenom_spec_data_type=0, abscissa_spec_data_type=17,
                  abscissa_axis_units_lab="s", x=t, ref_node=1, ref_dir=3)
    sets = [pyuff.prepare_58(data=force, rsp_node=1, rsp_dir=3, ordinate_spec_data_type=13,
                             ordinate_axis_units_lab="N", **common)]
    for node, (name, values) in enumerate(channels.items(), start=2):
        direction = -3 if name == "a2" else 3  # a2 mounted along −z: its record holds −a2
        sets.append(pyuff.prepare_58(data=np.sign(direction) * values, rsp_node=node, rsp_dir=direction,
                                     ordinate_spec_data_type=12, ordinate_axis_units_lab="m/s^2", **common))
    pyuff.UFF(str(tmp_path / "hammer.uff")).write_sets(sets, mode="add")
    columns = read_channels(tmp_path / "hammer.uff", "impact file")
    assert list(columns) == ["time_s", "force", "2:uz", "3:uz", "4:uz"]
    np.testing.assert_allclose(columns["3:uz"], channels["a2"], rtol=1e-5, atol=1e-5 * np.abs(channels["a2"]).max())
    time_s, responses, hammer = split_force(columns, None)
    fit = fit_linear_limit(time_s, responses, (60, 100), force=hammer)
    assert fit.channels == ("2:uz", "3:uz", "4:uz") and fit.window_s[0] > 0.101
    assert abs(fit.frequency_hz / F1 - 1) < 1e-4 and abs(fit.damping_ratio / Z1 - 1) < 0.05
    t, x = iwan_record  # and a ring-down: the Iwan SDOF's displacement (ordinate type 8, m)
    common.update(x=t)
    pyuff.UFF(str(tmp_path / "decay.uff")).write_sets(
        [pyuff.prepare_58(data=x, rsp_node=5, rsp_dir=3, ordinate_spec_data_type=8, ordinate_axis_units_lab="m",
                          **common)], mode="add")
    out = tmp_path / "amm"
    assert main(["amplitude", "--ring-down", str(tmp_path / "decay.uff"), "--band", "7:13", "--shape",
                 f"5:uz={1 / np.sqrt(M)}", "--backbone", "polynomial", "--bootstrap", "0", "--out", str(out)]) == 0
    points = pd.read_csv(out / "backbone_points.csv")
    f, z = df_backbone(IWAN, points["modal_amplitude"].to_numpy() / np.sqrt(M))
    assert len(points) >= 5
    assert np.abs(points["natural_frequency_hz"] / f - 1).max() < 2e-3
    assert np.abs(points["damping_ratio"] / z - 1).max() < 0.05


def test_the_brb_example_targets_are_the_impact_records_linear_limits():
    """examples/brb/brb.toml types its updating targets; they must be what this estimator
    gives on the record it names (acc3 in 72–88 Hz, acc2 in 280–315 Hz), each within its
    stated standard deviation, and that deviation the fit's own (to the typed rounding)."""
    import tomllib

    targets = tomllib.loads((BRB.parents[2] / "examples" / "brb" / "brb.toml").read_text())["targets"]
    columns = read_channels(BRB / "HammerImpact_1600Hz.mat")
    for (channel, band), typed, std in zip((("acc3", (72.0, 88.0)), ("acc2", (280.0, 315.0))),
                                           targets["frequencies_hz"], targets["std_hz"]):
        fit = fit_linear_limit(columns["time_s"], {channel: columns[channel]}, band_hz=band)
        assert abs(fit.frequency_hz - typed) <= std, channel
        assert fit.frequency_std_hz == pytest.approx(std, abs=5e-5), channel
