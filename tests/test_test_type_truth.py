"""Time-integration truth for the test types of issue 37: an SDOF and a 2-DOF, each with a
Jenkins and with an Iwan joint, measured by ring-down and impact records with white noise
of 2 % of each record's peak, by phase-resonance points, and fitted jointly with each type
held out in turn.

Records: RK4 time integration, written here, of ``M ẍ + C ẋ + K x + g(x₀, state) = 0`` with
the joint g from dof 0 to ground evaluated by its element's own time-domain force law
(hysteretic state committed once per step, 200 steps a period), started at rest in the
stuck system's mode. Truth: the single-nonlinear-mode backbone of that mode (φ mass-normalised,
the joint's relative displacement ψq with ψ = φ₀), its describing function ν in closed form::

    ω(a)² = ω₀² − ψ²k_t + ψ² Re ν(ψa),      ζ(a) = (2ζ₀ω₀ + ψ² Im ν(ψa)/ω(a)) / (2ω(a)),

(C = (2ζ₀/ω₀)·K_stuck: a constant modal damping coefficient 2ζ₀ω₀). For a Jenkins joint
``Im ν(A) = W(A)/(πA²)`` with the closed-form energy of one closed hysteresis loop
``W = 4F_s(A − F_s/k_t)`` (A > F_s/k_t; checked below): the damping of the periodic motion.
SDOF: m = 2 kg, k = m(2π·10 Hz)², ζ₀ = 0.5 %, k_t = 0.1k, F_s = k_t·1 mm; 2-DOF: the METHODS.md
masses and springs (m1 = 0.1, m2 = 0.5 kg, 1e6 N/m), k_t = 8e4 N/m, F_s = 1 N, its 745 Hz mode.
"""
from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import scipy.linalg

from nlupdate.app.cli import main
from nlupdate.core.identification.impact import decay_segments, fit_linear_limit
from nlupdate.core.model.elements import IwanJoint, JenkinsFriction
from nlupdate.core.model.linear import LumpedModel
from nlupdate.core.model.system import NonlinearSystem
from nlupdate.core.response.harmonic_balance import HarmonicTruncationWarning, trace_harmonic_balance

from reference_cache import session_cached

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

SYSTEMS = [(1, "jenkins"), (1, "iwan"), (2, "jenkins"), (2, "iwan")]
ZETA0 = 0.005


def system(dofs: int, kind: str) -> dict:
    """Mass, stiffness, damping, joint, and the stuck system's mode (ω₀, φ) (module docstring)."""
    if dofs == 1:
        masses, springs = np.array([[2.0]]), np.array([[2.0 * (2 * np.pi * 10.0) ** 2]])
        kt = 0.1 * springs[0, 0]
        slip_force = kt * 1e-3
    else:
        masses, springs = np.diag([0.1, 0.5]), 1e6 * np.array([[2.0, -1.0], [-1.0, 2.0]])
        kt, slip_force = 8e4, 1.0
    joint = (JenkinsFriction((0,), kf=kt, slip_force=slip_force) if kind == "jenkins"
             else IwanJoint((0,), slip_force=slip_force, kt=kt, chi=-0.5, beta=0.5, sliders=200))
    stuck = springs + np.diag([kt] + [0.0] * (dofs - 1))
    w2, shapes = scipy.linalg.eigh(stuck, masses)  # mass-normalised
    mode = dofs - 1  # 2-DOF: the upper mode, where m1 (the joint) moves most
    w0, phi = np.sqrt(w2[mode]), shapes[:, mode] * np.sign(shapes[0, mode])
    return {"M": masses, "K": springs, "C": 2 * ZETA0 / w0 * stuck, "joint": joint, "kt": kt, "w0": w0, "phi": phi,
            "slip": slip_force / kt / phi[0]}  # modal amplitude at which a Jenkins joint starts to slip


def truth(s: dict, a) -> tuple[np.ndarray, np.ndarray]:
    """(natural frequency Hz, damping ratio) of the single-nonlinear-mode backbone at modal amplitude a."""
    psi = s["phi"][0]
    nu = s["joint"].describing_function(np.abs(psi * np.asarray(a, float)))
    w = np.sqrt(s["w0"] ** 2 - psi**2 * s["kt"] + psi**2 * nu.real)
    return w / (2 * np.pi), (2 * ZETA0 * s["w0"] + psi**2 * nu.imag / w) / (2 * w)


@session_cached  # computed once per session: other modules take the same reference
def free_decay(s: dict, a0: float, periods: float, steps: int = 200, every: int = 2):
    """RK4 from modal amplitude ``a0`` in the mode, at rest: (time s, displacement of dof 0, m)."""
    minv, k, c, joint = np.linalg.inv(s["M"]), s["K"], s["C"], s["joint"]
    n, dt = k.shape[0], 2 * np.pi / s["w0"] / steps
    state = joint.initial_state(())
    y = np.concatenate([a0 * s["phi"], np.zeros(n)])
    out = [y[0]]

    def rate(y, st):
        g = np.zeros(n)
        g[0] = float(joint.force(np.array(y[0]), np.array(y[n]), st)[0])
        return np.concatenate([y[n:], -minv @ (c @ y[n:] + k @ y[:n] + g)])

    for i in range(int(periods * steps)):
        k1 = rate(y, state)
        k2 = rate(y + dt / 2 * k1, state)
        k3 = rate(y + dt / 2 * k2, state)
        k4 = rate(y + dt * k3, state)
        y = y + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        state = joint.force(np.array(y[0]), np.array(y[n]), state)[1]
        if (i + 1) % every == 0:
            out.append(y[0])
    return np.arange(len(out)) * dt * every, np.array(out)


def phase_resonance_point(curve) -> tuple[float, complex]:
    """Where a traced curve's first harmonic at dof 0 lags its force by 90°: (Ω in rad/s, the
    complex first harmonic), linearly interpolated between the two points either side."""
    x = curve.response([0])[:, 0]
    phase = np.unwrap(np.angle(x)) + np.pi / 2
    i = int(np.flatnonzero(np.sign(phase[:-1]) != np.sign(phase[1:]))[0])
    w = phase[i] / (phase[i] - phase[i + 1])
    return curve.omega[i] + w * (curve.omega[i + 1] - curve.omega[i]), x[i] + w * (x[i + 1] - x[i])


def noisy(x: np.ndarray, seed: int, level: float = 0.02) -> np.ndarray:
    return x + level * np.abs(x).max() * np.random.default_rng(seed).standard_normal(x.size)


def band(s: dict) -> tuple[float, float]:
    f0 = s["w0"] / (2 * np.pi)
    return 0.7 * f0, 1.3 * f0


def test_jenkins_damping_is_the_closed_form_energy_of_its_loop():
    """The reference's damping for a Jenkins joint: Im ν(A) = W/(πA²), W = 4F_s(A − F_s/k_t)."""
    s = system(1, "jenkins")
    joint, amplitude = s["joint"], np.geomspace(1.01, 50, 40) * 1e-3
    energy = 4 * joint.slip_force * (amplitude - joint.slip_force / s["kt"])
    assert np.allclose(joint.describing_function(amplitude).imag, energy / (np.pi * amplitude**2), rtol=1e-10)


def test_jenkins_reference_is_the_periodic_solution_with_many_harmonics():
    """The closed-form reference is the periodic motion's: phase-resonance points of the Jenkins
    SDOF by harmonic balance with 15 harmonics (AFT from the element's law; the exact periodic
    solution as the harmonics grow) lie on it within 1e-4 in frequency and 1 % in damping from
    0.9 to 15 × the slip amplitude, across stick–slip (measured 8.4e-5 and 0.69 %)."""
    s = system(1, "jenkins")
    psi, amplitude = s["phi"][0], np.array([0.9, 1.1, 1.3, 1.6, 2.0, 3.0, 5.0, 15.0]) * s["slip"]
    f, z = truth(s, amplitude)
    model = NonlinearSystem(LumpedModel(s["M"], s["K"], s["C"]), (s["joint"],))
    for force in 2 * z * (2 * np.pi * f) ** 2 * amplitude / psi:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", HarmonicTruncationWarning)
            curve = trace_harmonic_balance(model, {0: force}, 0.85 * s["w0"], 1.1 * s["w0"], harmonics=15,
                                           stability=False)
        omega, x1 = phase_resonance_point(curve)
        a = abs(x1) / psi
        f_true, z_true = truth(s, a)
        assert abs(omega / (2 * np.pi) / f_true - 1) < 1e-4
        assert abs(psi * force / (2 * omega**2 * a) / z_true - 1) < 0.01  # ζ = φF/(2Ω²a) at 90°


def test_a_jenkins_free_decay_near_stick_slip_dissipates_more_than_the_periodic_motion():
    """A test-type effect, not an estimator's: the noise-free RK4 record's own logarithmic
    decrement (turning points a period apart, 400 steps a period) lies above the periodic
    truth at their geometric-mean amplitude by up to 9 % within 1–2 × the slip amplitude
    (measured +5.9 % at 1.7 ×, +8.9 % at 1.0 ×) and approaches it as the joint slips more
    (+1.2 % at 5.5 ×); stuck, they agree. Its frequency is the truth's within 1e-4."""
    s = system(1, "jenkins")
    t, x = free_decay(s, 30 * s["slip"], 80, steps=400, every=1)
    i = np.flatnonzero((x[1:-1] > x[:-2]) & (x[1:-1] >= x[2:])) + 1
    y0, y1, y2 = x[i - 1], x[i], x[i + 1]
    shift = 0.5 * (y0 - y2) / (y0 - 2 * y1 + y2)
    peak, at = (y1 - 0.25 * (y0 - y2) * shift) / s["phi"][0], t[i] + shift * (t[1] - t[0])
    sigma, omega_d = np.log(peak[:-1] / peak[1:]) / np.diff(at), 2 * np.pi / np.diff(at)
    amplitude = np.sqrt(peak[:-1] * peak[1:])
    f, z = truth(s, amplitude)
    omega = np.hypot(sigma, omega_d)
    ratio, excess = amplitude / s["slip"], sigma / omega / z - 1
    assert np.all(np.abs(omega / (2 * np.pi) / f - 1) < 1e-4)
    assert np.all(np.abs(excess[ratio < 0.95]) < 0.005)  # stuck: linear
    assert 0.05 < excess[(ratio > 1.0) & (ratio < 2.0)].max() < 0.10
    assert np.all(excess[(ratio > 1.0) & (ratio < 6.0)] > 0)
    assert 0 < excess[(ratio > 5.0) & (ratio < 6.0)].max() < 0.02


@pytest.mark.parametrize("dofs, kind", SYSTEMS)
def test_impact_gives_the_linear_limit_of_each_system(dofs, kind):
    """A light tap (the Jenkins joint stuck: 0.5 × its slip amplitude; the Iwan joint at 0.05 ×),
    2 % noise, 8 seeds: every seed within 1e-4 in frequency and the issue's 5 % in damping of the
    backbone at the fit's amplitude (measured ≤ 6.6e-5 and ≤ 0.9 %)."""
    s = system(dofs, kind)
    t, x = free_decay(s, (0.5 if kind == "jenkins" else 0.05) * s["slip"], 40)
    for seed in range(8):
        fit = fit_linear_limit(t, {"x": noisy(x, seed)}, band(s), shape=s["phi"][0])
        f, z = truth(s, fit.amplitude)
        assert abs(fit.frequency_hz / f - 1) < 1e-4 and abs(fit.damping_ratio / z - 1) < 0.05, seed


@pytest.fixture(scope="module")
def two_dof_jenkins_records(tmp_path_factory):
    """The 2-DOF Jenkins system tested three ways, written as an instrument would: a ring-down
    from 30 × the slip amplitude and a tap (CSV, 2 % noise), and phase-resonance points by the
    multi-harmonic balance (5 harmonics, AFT from the element's law) at 90° (0.3–30 N)."""
    s, folder = system(2, "jenkins"), tmp_path_factory.mktemp("jenkins2")
    t, x = free_decay(s, 30 * s["slip"], 80)
    pd.DataFrame({"time_s": t, "m1": noisy(x, 0)}).to_csv(folder / "decay.csv", index=False)
    t, x = free_decay(s, 0.5 * s["slip"], 40)
    pd.DataFrame({"time_s": t, "m1": noisy(x, 1)}).to_csv(folder / "tap.csv", index=False)
    phase_resonance_csv(s, np.geomspace(0.3, 30, 6), folder / "pr.csv")
    return s, folder


def phase_resonance_csv(s: dict, forces, path) -> None:
    """Phase-resonance points of system ``s`` at ``forces`` (N) at dof 0, by the multi-harmonic
    balance (5 harmonics) at 90°, written as `nlupdate amplitude --phase-resonance` reads them."""
    model = NonlinearSystem(LumpedModel(s["M"], s["K"], s["C"]), (s["joint"],))
    rows = []
    for force in forces:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", HarmonicTruncationWarning)
            curve = trace_harmonic_balance(model, {0: force}, 0.9 * s["w0"], 1.1 * s["w0"], harmonics=5,
                                           stability=False)
        omega, x1 = phase_resonance_point(curve)
        rows.append({"frequency_hz": omega / (2 * np.pi), "force_n": force, "response_amplitude": abs(x1),
                     "response_phase_deg": np.degrees(np.angle(x1)), "response_unit": "m", "response_dof": "m1",
                     "input_dof": "m1"})
    pd.DataFrame(rows).to_csv(path, index=False)


def run_amplitude(s, folder, out, *extra, backbone="polynomial"):
    assert main(["amplitude", "--ring-down", str(folder / "decay.csv"), "--ring-down-fit", "segments", "--impact",
                 str(folder / "tap.csv"), "--phase-resonance", str(folder / "pr.csv"), "--shape",
                 f"m1={s['phi'][0]}", "--band", "{}:{}".format(*band(s)), "--backbone", backbone,
                 "--bootstrap", "0", "--out", str(out), *extra]) == 0


def relative_errors(s, frame, prefix=""):
    f, z = truth(s, frame["modal_amplitude"].to_numpy())
    return (frame[prefix + "natural_frequency_hz"].to_numpy() / f - 1,
            frame[prefix + "damping_ratio"].to_numpy() / z - 1)


@pytest.mark.parametrize("dofs, kind", SYSTEMS)
def test_noise_free_ring_down_in_segments_of_each_system(dofs, kind):
    """The ring-down read in segments (each a complex exponential over a factor 1.5 of decay),
    no noise: within 0.2 % and 5 % of the truth wherever a segment's stated damping error is at
    most 5 % — the rule that drops a segment straddling the Jenkins joint's stick–slip change
    (its decay is no exponential there: the fit's residual, and so its stated error, grows;
    measured 8.2 % off at 1.3 × the slip amplitude, stated 7.6 %)."""
    s = system(dofs, kind)
    t, x = free_decay(s, (30 * s["slip"] if kind == "jenkins" else 3e-3 * np.sqrt(2) if dofs == 1
                          else 240 * s["slip"]), 80)
    parts = [p for p in decay_segments(t, {"x": x}, band(s), shape=s["phi"][0])
             if p.damping_std <= 0.05 * p.damping_ratio]
    amplitude = np.array([p.amplitude for p in parts])
    f, z = truth(s, amplitude)
    assert len(parts) >= 4 and amplitude.max() / amplitude.min() > 3
    assert np.max(np.abs(np.array([p.frequency_hz for p in parts]) / f - 1)) < 2e-3
    assert np.max(np.abs(np.array([p.damping_ratio for p in parts]) / z - 1)) < 0.05


def test_two_dof_jenkins_each_test_type_on_the_truth(two_dof_jenkins_records, tmp_path):
    """Each type's own samples of the 2-DOF Jenkins system against the truth over the amplitudes
    each covers (measured: impact 1.2e-5 / 0.26 % at 0.27 × the slip amplitude; phase resonance
    4.2e-5 / 0.51 % over 1.0–100 ×; ring-down with 2 % noise, seed 0, 9.4e-4 / 3.8 % over 2.3–17 ×)."""
    s, folder = two_dof_jenkins_records
    run_amplitude(s, folder, tmp_path / "amm")
    points = pd.read_csv(tmp_path / "amm" / "backbone_points.csv")
    assert set(points["test_type"]) == {"ring-down", "impact", "phase-resonance"}
    for kind, rows in points.groupby("test_type"):
        ef, ez = relative_errors(s, rows)
        assert np.abs(ef).max() < 2e-3 and np.abs(ez).max() < 0.05, kind


@pytest.mark.slow  # two modal Iwan fits: 8–27 s (load 4–15); the fast version is the per-type test above
def test_two_dof_jenkins_held_out_types_predicted_by_the_joint_fit(two_dof_jenkins_records, tmp_path):
    """The modal Iwan backbone fitted to two types predicts the third (held_out.csv, the samples
    within the fitted amplitudes): the ring-down within 9.5e-4 / 4.2 % and the tap within
    3.4e-4 / 4.9 % (measured). The phase-resonance points are not: 26 % in damping at 1.0–2.3 ×
    the slip amplitude, below the ring-down's lowest sample and across the stick–slip change
    (docs/ring-down.md, "Time-integration truth"), so only the two are asserted."""
    s, folder = two_dof_jenkins_records
    for held, bounds in (("ring-down", (2e-3, 0.05)), ("impact", (2e-3, 0.05))):
        out = tmp_path / held
        run_amplitude(s, folder, out, "--hold-out", held, backbone="iwan")
        frame = pd.read_csv(out / "held_out.csv")
        assert set(frame["test_type"]) == {held}
        assert frame["frequency_error"].abs().max() < bounds[0] and frame["damping_error"].abs().max() < bounds[1]


def _benchmark():
    """benchmarks/test_type_truth.py (imported here: it imports this module's systems and truth)."""
    import test_type_truth

    return test_type_truth


def test_sdof_iwan_own_fits_on_the_benchmark_design():
    """Issue 37's bounds on the benchmark's design (docs/ring-down.md, "More levels"): the SDOF
    Iwan system's phase resonance and stepped sine at sixteen levels over 0.3–6 a_s
    (``ISSUE_LEVELS``), its ring-down from 3 a_s read by the decay fit, 2 % noise, seed 0:
    each type's own modal Iwan backbone within 0.2 % in frequency and 5 % in damping of the
    closed-form truth at 60 amplitudes over its samples' range — the ring-down's fitted on its
    decay curve (``CURVE_POINTS``; measured 2.2e-4 / 2.5 %, 1.9e-4 / 3.3 %, 5.0e-5 / 2.7 %).
    The eight seeds of both systems, held out and joint too: the slow test below."""
    bench, s = _benchmark(), system(1, "iwan")
    every, _, curve = bench.samples(s, bench.records(s, "iwan"), 0)
    assert every["phase-resonance"][0].amplitude.size == bench.ISSUE_LEVELS == 16
    for name in ("phase-resonance", "stepped-sine", "ring-down"):
        smp, stated = every[name]
        model = bench.fit(s, {name: (curve if name == "ring-down" else smp, stated)}, "iwan")
        f_error, z_error = bench.curve_errors(s, model, smp.amplitude.min(), smp.amplitude.max())
        assert f_error < 2e-3 and z_error < 0.05, (name, f_error, z_error)


@pytest.mark.slow  # 8 seeds × 8 Iwan fits (and their sources' own): 122 and 92 s wall, 156 s CPU for both (load 1-3)
@pytest.mark.parametrize("dofs", [1, 2])
def test_iwan_every_type_own_held_out_and_joint_on_the_benchmark_design(dofs):
    """Issue 37's "What must be shown" on the Iwan systems at the benchmark's design (the fast
    test above), seeds 0–7, against the closed-form truth: every type's own backbone (the
    phase resonance, the stepped sine, the ring-down on its decay curve), every type held out
    and predicted by the fit of the others at its samples' amplitudes, the impact's linear
    limit, and the joint fit of all four types over the whole span and over each type's range —
    each within 0.2 % in frequency and 5 % in damping on every seed (measured, largest over
    the seeds: docs/ring-down.md, "More levels")."""
    bench, s = _benchmark(), system(dofs, "iwan")
    made = bench.records(s, "iwan")
    for seed in range(8):
        every, _, curve = bench.samples(s, made, seed)
        rows, _ = bench.seed_rows(s, every, None, curve, "iwan")
        for name, row in rows["all"].items():
            checked = {"own fit": row[2:4], "held out": row[6:8]}
            if name == "impact":
                checked["linear limit"] = row[0:2]
            for what, (f_error, z_error) in checked.items():
                if np.isfinite(f_error):
                    assert f_error < 2e-3 and z_error < 0.05, (seed, name, what, f_error, z_error)


#: the Jenkins systems' kink band, × a_s (docs/ring-down.md, "Near the stick–slip kink")
KINK_BAND = (1.03, 1.5)


def test_sdof_jenkins_fits_with_the_lines_on_the_benchmark_design():
    """Issue 37's bounds on the SDOF Jenkins system at the benchmark's one design (sixteen
    phase-resonance and stepped-sine levels over 0.3–6 a_s, ``ISSUE_LEVELS``), 2 % noise, seed 0,
    against the closed-form truth at 60 amplitudes over each fit's range: the stepped sine's own
    fit (refined on its lines) and the joint fit of all four types within 0.2 % / 5 % over the
    whole range, the stick–slip kink included (measured 3.5e-5 / 1.2 % and 3.3e-5 / 0.8 %), and
    the phase resonance's own fit off the kink band [a_s/1.03, 1.5 a_s] (2.1e-4 / 0.6 %; inside it
    the damping follows its slip amplitude, which sixteen points with 2 % noise place to about
    1.3 %: docs/ring-down.md, "The Jenkins systems at sixteen levels"). The eight seeds of both
    systems: the slow test below."""
    bench, s = _benchmark(), system(1, "jenkins")
    every, lines, _ = bench.samples(s, bench.records(s, "jenkins"), 0)
    assert every["stepped-sine"][0].amplitude.size == bench.ISSUE_LEVELS
    joined = bench.join_samples([smp for smp, _ in every.values()])
    smp = every["stepped-sine"][0]
    for model, low, high in ((bench.fit(s, {"stepped-sine": every["stepped-sine"]}, "jenkins", lines),
                              smp.amplitude.min(), smp.amplitude.max()),
                             (bench.fit(s, every, "jenkins", lines), joined.amplitude.min(), joined.amplitude.max())):
        f_error, z_error = bench.curve_errors(s, model, low, high)
        assert f_error < 2e-3 and z_error < 0.05, (f_error, z_error)
    smp = every["phase-resonance"][0]
    model = bench.fit(s, {"phase-resonance": every["phase-resonance"]}, "jenkins", lines)
    a = np.geomspace(smp.amplitude.min(), smp.amplitude.max(), 60)
    off = a[(a <= s["slip"] / KINK_BAND[0]) | (a >= KINK_BAND[1] * s["slip"])]
    f, z = truth(s, off)
    assert np.max(np.abs(model.frequency_hz(off) / f - 1)) < 2e-3
    assert np.max(np.abs(model.damping(off) / z - 1)) < 0.05


@pytest.mark.slow  # 8 seeds × 9 Jenkins fits, most on 16 levels' lines: 45–48 s wall a system (load 5–7)
@pytest.mark.parametrize("dofs", [1, 2])
def test_jenkins_every_type_own_held_out_and_joint_on_the_benchmark_design(dofs, monkeypatch):
    """Issue 37's "What must be shown" on the Jenkins systems at the benchmark's design, seeds
    0–7, against the closed-form truth (docs/ring-down.md, "The Jenkins systems at sixteen
    levels"): every own, held-out and joint fit within 0.2 % in frequency everywhere and 5 % in
    damping off the kink band [a_s/1.03, 1.5 a_s]; inside it every fit that has the stepped sine's
    lines (its own, the joint one, the other types held out) and the ring-down and impact
    (no samples there). Not asserted, because not met: inside the band, the phase resonance's own
    fit and the stepped sine held out (predicted without its lines) — the slip amplitude placed by
    phase-resonance points alone, at their Cramér–Rao bound (benchmarks/kink_information.py
    --levels 16)."""
    bench, s = _benchmark(), system(dofs, "jenkins")
    monkeypatch.setattr(bench, "KINK", KINK_BAND[1])
    monkeypatch.setattr(bench, "KINK_BELOW", KINK_BAND[0])
    monkeypatch.setattr(bench, "PARTS", ("off", "in"))
    made = bench.records(s, "jenkins")
    unmet = {("in", "phase-resonance", "own fit"), ("in", "stepped-sine", "held out")}
    for seed in range(8):
        every, lines, curve = bench.samples(s, made, seed)
        rows, _ = bench.seed_rows(s, every, lines, curve, "jenkins")
        for part, named in rows.items():
            for name, row in named.items():
                checked = {"own fit": row[2:4], "held out": row[6:8]}
                if name == "impact":
                    checked["linear limit"] = row[0:2]
                for what, (f_error, z_error) in checked.items():
                    if np.isfinite(f_error):
                        assert f_error < 2e-3, (seed, part, name, what, f_error)
                        assert (part, name, what) in unmet or z_error < 0.05, (seed, part, name, what, z_error)
