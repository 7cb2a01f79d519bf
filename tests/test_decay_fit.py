"""The ring-down's decay fit (nlupdate.core.identification.decay_fit) against time-integration truth.

Records and truth are those of tests/test_test_type_truth.py: RK4 time integration of an SDOF
and a 2-DOF, each with a Jenkins and with an Iwan joint, from rest in the stuck mode (a
ring-down from 30 × the Jenkins slip amplitude; Iwan: SDOF 3 mm, 2-DOF 240 ×), with white noise
of 2 % of the record's peak; the truth is the closed-form single-nonlinear-mode backbone
(describing function), computed without the estimator. Also an analytic linear decay.
"""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import scipy.integrate

from nlupdate.app.cli import main
from nlupdate.core.identification.decay_fit import PRECISION, _flow, fit_decay, noise_correlation
from nlupdate.core.identification.ring_down import RingDownError, analytic_band_pass
from test_test_type_truth import SYSTEMS, band, free_decay, noisy, system, truth


def ring_down(dofs: int, kind: str):
    s = system(dofs, kind)
    start = 30 * s["slip"] if kind == "jenkins" else 3e-3 * np.sqrt(2) if dofs == 1 else 240 * s["slip"]
    return s, *free_decay(s, start, 80)


def sample_errors(s: dict, fit) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(modal amplitudes, frequency and damping errors against the truth, damping errors in
    stated standard errors) of the fit's samples."""
    samples = fit.samples()
    f, zeta = truth(s, samples.amplitude)
    _, _, _, zeta_std = fit.curves(samples.amplitude)
    ez = samples.damping_ratio / zeta - 1
    return samples.amplitude, samples.frequency_hz / f - 1, ez, ez * samples.damping_ratio / zeta_std


def test_linear_decay_is_its_pole_and_its_stated_error_holds():
    """e^{−ζωt}cos(ω_d t) (ζ = 0.5 %, 10 Hz) with white noise of 2 % of its start, 10 seeds:
    every sample within 1e-4 in frequency and 2 % in damping of the pole, over a factor 5 or
    more of amplitude, the damping within 3.5 of its stated standard errors (measured: 1.6e-5,
    0.43 %, 2.25; a factor 7.6–11: the F-test keeps one term, a constant σ and ω_d)."""
    zeta, f0 = 0.005, 10.0
    w0 = 2 * np.pi * f0
    t = np.arange(0, 12, 1 / 1000)
    x = 2.0 * np.exp(-zeta * w0 * t) * np.cos(w0 * np.sqrt(1 - zeta**2) * t + 0.4)
    for seed in range(10):
        fit = fit_decay(t, noisy(x, seed), (7, 13), shape=0.5)
        samples = fit.samples()
        _, z, _, z_std = fit.curves(samples.amplitude)
        assert samples.amplitude.max() / samples.amplitude.min() > 5, seed
        assert np.max(np.abs(samples.frequency_hz / f0 - 1)) < 1e-4, seed
        assert np.max(np.abs(samples.damping_ratio / zeta - 1)) < 0.02, seed
        assert np.max(np.abs(z - zeta) / z_std) < 3.5, seed
        assert np.all(z_std <= PRECISION * z) and np.all(samples.force_n == 0)


def test_the_flow_is_the_slow_flow_integrated():
    """The fitted model, ``_flow``'s RK4 of d ln r/dt = −σ(r), dφ/dt = ω_d(r) − ω_c with all four
    terms, for several parameter sets at once: within 1e-11 of DOP853 at rtol 1e-12 (an
    independent integration) over a decay by a factor 3 (measured 5e-13)."""
    step, count = 1e-3, 200
    params = np.array([[0.7, 0.3, 5.0, 0.5, 0.05, 0.5, 2.0, -0.5, 0.1, 0.2],
                       [-0.2, -1.0, 3.0, 1.0, 0.0, -0.4, -1.0, 0.3, -0.05, 0.4]])
    got = _flow(params, step, count, 0.0, 4)
    t = step * np.arange(count)
    for row, p in zip(got, params):
        def slow_flow(_, y, c=p[2:6], b=p[6:10]):
            g = np.exp(y[0]) ** np.array([0.0, -1.0, -2.0, 1.0])
            return [-(g @ c), g @ b]

        exact = scipy.integrate.solve_ivp(slow_flow, (0, t[-1]), p[:2], method="DOP853", t_eval=t, rtol=1e-12,
                                          atol=1e-14)
        assert exact.success
        assert np.max(np.abs(row - np.exp(exact.y[0] + 1j * exact.y[1]))) < 1e-11


def check_seeds(dofs: int, kind: str, seeds: range, covered: float | None = None) -> None:
    """Every sample the fit reports (where its damping is known to 1.5 %) within 0.2 % in
    frequency and 5 % in damping of the truth, at least two samples a seed, and an amplitude
    range like the measured one (a / the Jenkins slip amplitude, seeds 0–39: 2.9–15.2,
    0.45–1.04, 3.2–16.9, 27.5–141) over the seeds, at least a factor ``covered`` (default 4,
    2 on the SDOF Iwan record)."""
    s, t, x = ring_down(dofs, kind)
    lowest, highest = [], []
    for seed in seeds:
        a, ef, ez, _ = sample_errors(s, fit_decay(t, noisy(x, seed), band(s), s["phi"][0]))
        assert a.size >= 2, seed
        assert np.max(np.abs(ef)) < 2e-3, seed
        assert np.max(np.abs(ez)) < 0.05, seed
        lowest.append(a.min() / s["slip"])
        highest.append(a.max() / s["slip"])
    covered = covered or {(1, "jenkins"): 4, (1, "iwan"): 2, (2, "jenkins"): 4, (2, "iwan"): 4}[dofs, kind]
    assert max(highest) / min(lowest) > covered


@pytest.mark.parametrize("dofs, kind", SYSTEMS)
def test_noisy_ring_down_within_the_issue_bounds_of_the_truth(dofs, kind):
    """2 % noise, seeds 0–2 (the slow test below: 0–11): :func:`check_seeds`. The 2-DOF Iwan
    record's lowest sample (27 × a_s) is dropped in these three seeds since the standard errors
    carry the F-test's choice of terms (1.7–3.4 % there; 41–141 × kept, a factor 3.4): a factor
    3 here, 4 over the twelve seeds of the slow test."""
    check_seeds(dofs, kind, range(3), 3 if (dofs, kind) == (2, "iwan") else None)


@pytest.mark.slow  # 12 seeds × 4 systems: 15 s CPU, 45 s at load 7 on 2 cores
@pytest.mark.parametrize("dofs, kind", SYSTEMS)
def test_noisy_ring_down_within_the_issue_bounds_over_twelve_seeds(dofs, kind):
    """2 % noise, seeds 0–11: :func:`check_seeds` (measured over seeds 0–39: ≤ 8.1e-4 in
    frequency and 3.7–6.0 % in damping; over 0–79 five samples above 5 %, 5.4–6.0 %, all on the
    SDOF records, whose noise-free record itself dissipates 1–2 % more than the periodic truth;
    docs/ring-down.md)."""
    check_seeds(dofs, kind, range(12))


@pytest.mark.parametrize("dofs", [1, 2])
def test_the_stated_noise_holds_every_samples_error(dofs):
    """The Jenkins records, 2 % noise, seeds 0–7: the samples' errors against the truth, in the
    source's stated noise (``stated_noise``: one value for all its samples, as a joint fit weighs
    a source), have an rms between 0.5 and 1.5 in frequency and in damping — a noise consistent
    with the errors gives about 1. The median standard error gave 2.72 (SDOF) and 2.03 (2-DOF) in
    frequency, the record's low end, nearest the slip amplitude, weighted 3–4 × beyond its own
    error (docs/ring-down.md, "Efficient at the kink"); the largest gives 1.11 and 0.88
    (damping 0.94 and 0.73; median 1.36 and 1.10)."""
    s, t, x = ring_down(dofs, "jenkins")
    in_noise = []
    for seed in range(8):
        fit = fit_decay(t, noisy(x, seed), band(s), s["phi"][0])
        _, ef, ez, _ = sample_errors(s, fit)
        f_std, z_std = fit.stated_noise()
        in_noise.append(np.column_stack([ef / f_std, ez / z_std]))
    rms = np.sqrt(np.mean(np.vstack(in_noise) ** 2, axis=0))
    assert np.all(rms < 1.5), rms
    assert np.all(rms > 0.5), rms  # nor far too large: a noise 2 × the errors would be 0.5 (measured 0.73–1.11)


def test_the_fit_averages_where_segments_scatter():
    """The cause of the segments' 12–33 % (docs/ring-down.md): scatter, not bias — each part
    over a factor 1.5 of decay holds a few independent values. 2-DOF Jenkins record, 2 %
    noise, seeds 0–9, at the segment nearest 4 × the slip amplitude: the segments' damping
    scatters by 6.2 % about the truth (mean −0.9 %), the decay fit's at the same amplitudes by
    1.3 % (measured)."""
    from nlupdate.core.identification.impact import decay_segments

    s, t, x = ring_down(2, "jenkins")
    segment_errors, fit_errors = [], []
    for seed in range(10):
        record = noisy(x, seed)
        parts = decay_segments(t, {"x": record}, band(s), shape=s["phi"][0])
        near = min(parts, key=lambda p: abs(np.log(p.amplitude / (4 * s["slip"]))))
        zeta = truth(s, near.amplitude)[1]
        segment_errors.append(near.damping_ratio / zeta - 1)
        fit_errors.append(fit_decay(t, record, band(s), s["phi"][0]).curves(near.amplitude)[1] / zeta - 1)
    assert np.std(segment_errors) > 0.04 and abs(np.mean(segment_errors)) < 0.03
    assert np.std(fit_errors) < 0.02


def test_a_record_too_short_to_fit_is_refused():
    t = np.arange(0, 3.0, 1 / 1000)
    with pytest.raises(RingDownError, match="short.csv: 28 values 1/.*apart are left of the decay"):
        fit_decay(t, np.exp(-0.3 * t) * np.cos(2 * np.pi * 10 * t), (7, 13), source="short.csv")


def test_amplitude_command_reads_a_ring_down_by_the_decay_fit(tmp_path, capsys):
    """``nlupdate amplitude --ring-down-fit decay``: the 2-DOF Jenkins record (2 % noise, CSV)
    alone; backbone_points.csv holds the fit's samples, each within the issue's bounds."""
    s, t, x = ring_down(2, "jenkins")
    pd.DataFrame({"time_s": t, "m1": noisy(x, 0)}).to_csv(tmp_path / "decay.csv", index=False)
    assert main(["amplitude", "--ring-down", str(tmp_path / "decay.csv"), "--ring-down-fit", "decay", "--shape",
                 f"m1={s['phi'][0]}", "--band", "{}:{}".format(*band(s)), "--backbone", "polynomial",
                 "--bootstrap", "0", "--out", str(tmp_path / "amm")]) == 0
    assert "decay fit over" in capsys.readouterr().out
    points = pd.read_csv(tmp_path / "amm" / "backbone_points.csv")
    f, zeta = truth(s, points["modal_amplitude"].to_numpy())
    assert len(points) >= 3
    assert np.max(np.abs(points["natural_frequency_hz"] / f - 1)) < 2e-3
    assert np.max(np.abs(points["damping_ratio"] / zeta - 1)) < 0.05


def test_noise_correlation_is_the_filtered_noise_own():
    """The factor the fit's covariance takes for its correlated values against white noise
    band-passed by the ring-down's filter and taken every ``step`` samples at baseband (Monte
    Carlo, 300 records of 20 s at 1 kHz, band 7–13 Hz): the variance of their mean times their
    count over one value's variance (measured 4.54 against 4.42, the sampling error of 300
    variances about 8 %; 1 for values far apart)."""
    fs, band_hz, step = 1000.0, (7.0, 13.0), 42
    rng = np.random.default_rng(5)
    means, values = [], []
    t = np.arange(20000) / fs
    for _ in range(300):  # at baseband, as the fit takes them
        z = (analytic_band_pass(t, rng.standard_normal(t.size), band_hz, fs)[0]
             * np.exp(-2j * np.pi * np.mean(band_hz) * t))[3000:-3000:step]
        means.append(z.real.mean())
        values.append(z.real)
    measured = np.var(means) * len(values[0]) / np.var(np.concatenate(values))
    assert abs(noise_correlation(band_hz, fs, step) / measured - 1) < 0.15
    assert abs(noise_correlation(band_hz, fs, 1000) - 1) < 0.01


@pytest.mark.parametrize("dofs", [1, 2])
def test_ring_down_alone_gives_the_jenkins_backbone_over_its_amplitudes(tmp_path, dofs):
    """Issue 37: ``nlupdate amplitude --ring-down FILE --backbone jenkins``, the Jenkins record
    alone (2 % noise, seed 1), its fitted curve (backbone.csv) within 0.2 % in frequency and 5 %
    in damping of the truth over the amplitudes its samples cover (2.98–15.1 and 3.3–16.8 ×
    the slip amplitude). Its samples all lie in macroslip, where a cap on the linear limit at the
    softening measured over them excluded the truth and the fit missed by 13–21 %
    (docs/ring-down.md; measured here 2.6 % and 0.5 %)."""
    s, t, x = ring_down(dofs, "jenkins")
    pd.DataFrame({"time_s": t, "m1": noisy(x, 1)}).to_csv(tmp_path / "decay.csv", index=False)
    assert main(["amplitude", "--ring-down", str(tmp_path / "decay.csv"), "--ring-down-fit", "decay", "--shape",
                 f"m1={s['phi'][0]}", "--band", "{}:{}".format(*band(s)), "--backbone", "jenkins",
                 "--bootstrap", "0", "--out", str(tmp_path / "amm")]) == 0
    points = pd.read_csv(tmp_path / "amm" / "backbone_points.csv")["modal_amplitude"]
    curve = pd.read_csv(tmp_path / "amm" / "backbone.csv")
    covered = curve[(curve["modal_amplitude"] >= points.min()) & (curve["modal_amplitude"] <= points.max())]
    f, zeta = truth(s, covered["modal_amplitude"].to_numpy())
    assert len(covered) >= 10 and points.max() / points.min() > 3
    assert np.max(np.abs(covered["natural_frequency_hz"] / f - 1)) < 2e-3
    assert np.max(np.abs(covered["damping_ratio"] / zeta - 1)) < 0.05
