"""How well the damping ratio of one stepped-sine curve is measured: four estimators on
simulated curves with the Brake–Reuss beam's lines, noise and damping, truth known.

    python benchmarks/damping_estimators.py [--seeds 24]

``nlupdate validate`` reads the damping ratio of a measured and of a predicted curve with
one estimator (:mod:`nlupdate.core.validation.resonance`): the circle fit below, chosen on
these figures (issue 34); before, the half-power crossings interpolated linearly in |H|
between the lines. Is that estimator the noisy part of the BRB's measured damping (its
repeatability: 23 % about a parabola in log amplitude, as first measured)? Compared here:

* ``half-power`` — the tool's estimator before (``Resonance.half_power_damping_ratio``);
* ``half-power 1/|H|²`` — the crossings interpolated in 1/|H|² (a parabola in Ω near an SDOF's
  resonance, so exact there to first order);
* ``SDOF fit`` — least squares of ``A/(ω_n² − Ω² + 2iζω_nΩ) + B + C(Ω − ω_n)/ω_n`` (complex A, B,
  C: the other modes' share) to the complex H over the lines with |H| ≥ 0.3 max|H| around the peak;
* ``circle fit`` — the tool's estimator (:mod:`nlupdate.core.validation.circle_fit`): the
  mobility iΩH over the lines with |H| ≥ 0.4 max|H|: an algebraic circle, then
  ``ψ − ψ_r = 2 atan((ω_r² − Ω²)/(2ζω_rΩ))`` for the angle ψ about its centre (an SDOF's
  mobility is exactly that circle).

The simulated test (truth known): one nonlinear mode (:class:`AmplitudeModalModel`, φ = 0.7271
1/√kg at the driving point) whose natural frequency and damping ratio are the quadratics in
amplitude through the BRB's eight response-controlled runs (each run is one amplitude and
fits an SDOF to 0.05–0.4 % of its peak), measured on the BRB's 41 lines (79.2–81.2 Hz, 0.05 Hz)

* force-controlled at the BRB's four levels, each line at the force the BRB's shaker
  achieved there (:func:`~nlupdate.core.validation.models.frf_at_forces`): the truth is ζ(a)
  at the amplitude of the peak line; the same estimator on the noise-free curve is what a
  prediction would be read as (both columns below);
* response-controlled at the runs' eight amplitudes (linear at each: truth ζ(a) exactly), and
  two linear curves at ζ = 0.10 % and 0.13 % (3–4 lines in the half-power band, as the BRB's
  0.1947 N level);

each seed moving the mode by a uniform −0.025 … +0.025 Hz against the lines and adding complex
Gaussian noise of 0.3 % or 1 % of the peak (RMS |e|; the BRB's runs fit an SDOF to 0.05–0.4 %).
Then every estimator on the BRB's own twelve curves: the scatter of ln ζ about a parabola in
log amplitude (the repeatability's trend, :func:`~nlupdate.core.validation.held_out.repeatability`),
pooled and per test type; and the four force-controlled levels predicted from the mode through the
eight runs (the two test types at equal amplitude); and, in this process only, ``auto``'s rows of
the BRB table with every curve's damping read by the half-power estimator and by the circle fit.
docs/validation.md, "How the damping ratio is measured", holds the output.
"""
from __future__ import annotations

import argparse
import contextlib
import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

if __package__ in (None, ""):  # run as a script: make the repository root importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from nlupdate.core.model.amplitude_modal import AmplitudeModalModel  # noqa: E402
from nlupdate.core.validation.models import frf_at_forces  # noqa: E402
from nlupdate.core.validation.circle_fit import circle_window  # noqa: E402
from nlupdate.core.validation.resonance import resonance  # noqa: E402

PHI = 0.7271
LINES = np.round(np.arange(79.2, 81.2001, 0.05), 4)
#: the BRB's response-controlled runs: held amplitude (m), SDOF-fit natural frequency (Hz) and damping ratio
RUNS_X = np.array([19.7, 79.4, 115.4, 158.7, 198.6, 238.2, 276.8, 316.4]) * 1e-6
RUNS_F = np.array([80.367, 80.186, 80.183, 80.121, 80.267, 80.362, 80.448, 80.504])
RUNS_ZETA = np.array([0.1527, 0.1977, 0.2388, 0.3004, 0.3824, 0.4597, 0.5552, 0.6404]) * 1e-2


def brb_like_model(shift_hz: float = 0.0) -> AmplitudeModalModel:
    """The mode whose ω(a), ζ(a) are the quadratics through the BRB's runs, moved by ``shift_hz``."""
    reference = RUNS_X[-1] / PHI
    x = RUNS_X / PHI / reference
    cf = np.polyfit(x, RUNS_F + shift_hz, 2)[::-1]
    cz = np.polyfit(x, RUNS_ZETA, 2)[::-1]
    return AmplitudeModalModel(cf[0], cz[0], (("0", PHI),), frequency_coefficients=(cf[1] / cf[0], cf[2] / cf[0]),
                               damping_coefficients=(cz[1], cz[2]), reference_amplitude=reference,
                               beyond_reference="continued")


# ------------------------------------------------------------------------------ estimators
def half_power(f, h) -> float:
    return resonance(f, h).half_power_damping_ratio


def half_power_inverse_square(f, h) -> float:
    r = resonance(f, h)
    g, target = 1 / np.abs(h) ** 2, 2 / r.peak_abs**2
    k = int(np.argmax(np.abs(h)))
    below, above = np.flatnonzero(g[:k] > target), np.flatnonzero(g[k:] > target) + k
    if below.size == 0 or above.size == 0:
        return float("nan")
    i, j = int(below[-1]), int(above[0])
    f1 = np.interp(target, g[[i + 1, i]], f[[i + 1, i]])
    f2 = np.interp(target, g[[j - 1, j]], f[[j - 1, j]])
    return float((f2 - f1) / (2 * r.resonance_hz))


def _start(f, h) -> tuple[float, float]:
    r = resonance(f, h)
    zeta = r.half_power_damping_ratio
    return 2 * np.pi * r.resonance_hz, (zeta if np.isfinite(zeta) else 0.003)


def sdof_fit(f, h, fraction: float = 0.3) -> float:
    window = circle_window(h, fraction)
    w, hh = 2 * np.pi * f[window], h[window]
    wn, z = _start(f, h)
    a = h[int(np.argmax(np.abs(h)))] * 2j * z * wn**2
    scale = float(np.abs(h).max())

    def misfit(p):
        e = ((p[2] + 1j * p[3]) / (p[0]**2 - w**2 + 2j * p[1] * p[0] * w) + p[4] + 1j * p[5]
             + (p[6] + 1j * p[7]) * (w - p[0]) / p[0] - hh) / scale
        return np.concatenate([e.real, e.imag])

    fit = least_squares(misfit, [wn, z, a.real, a.imag, 0, 0, 0, 0],
                        x_scale=[wn * 1e-3, z, abs(a), abs(a), scale, scale, scale, scale])
    return float(fit.x[1])


def circle_fit(f, h) -> float:
    """The tool's estimator (:func:`~nlupdate.core.validation.circle_fit.circle_fit_damping`)."""
    return resonance(f, h).damping_ratio


ESTIMATORS = {"half-power": half_power, "half-power 1/|H|²": half_power_inverse_square,
              "SDOF fit": sdof_fit, "circle fit": circle_fit}


# ------------------------------------------------------------------------------ simulated curves
def simulated_curves(achieved, shift_hz: float) -> list[tuple[str, np.ndarray, float]]:
    """(name, noise-free receptance on LINES, true damping ratio) of one simulated test."""
    model = brb_like_model(shift_hz)
    out = []
    for name, force in achieved:
        h = frf_at_forces(model, LINES, force, "0")
        k = int(np.argmax(np.abs(h)))
        out.append((name, h, float(model.damping(np.abs(h[k]) * force[k] / PHI))))
    for x in RUNS_X:
        out.append((f"RC {1e6 * x:.0f} µm", model.held_frf(LINES, x, "0", "0"), float(model.damping(x / PHI))))
    for zeta in (0.0010, 0.0013):
        w, wn = 2 * np.pi * LINES, 2 * np.pi * (80.3 + shift_hz)
        out.append((f"linear ζ {100 * zeta:.2f} %", PHI**2 / (wn**2 - w**2 + 2j * zeta * wn * w), zeta))
    return out


def simulate(achieved, seeds: int, noise: float):
    """Per curve: its half-power lines (unshifted), truth, and per estimator the RMS relative
    error against the truth over the seeds, the RMS relative error of the noisy against the
    noise-free curve's value (the noise's part alone), and the noise-free value's mean bias."""
    rng = np.random.default_rng(0)
    rows: dict[str, dict] = {}
    for seed in range(seeds):
        shift = rng.uniform(-0.025, 0.025)
        for name, h, truth in simulated_curves(achieved, shift):
            row = rows.setdefault(name, {"lines": resonance(LINES, h).half_power_lines, "truth": [],
                                         **{e: {"total": [], "noise": [], "clean": []} for e in ESTIMATORS}})
            row["truth"].append(truth)
            e = noise * np.abs(h).max() * (rng.standard_normal(LINES.size) + 1j * rng.standard_normal(LINES.size))
            noisy = h + e / np.sqrt(2)
            for est_name, est in ESTIMATORS.items():
                clean, value = est(LINES, h), est(LINES, noisy)
                row[est_name]["total"].append(value / truth - 1)
                row[est_name]["noise"].append(value / clean - 1)
                row[est_name]["clean"].append(clean / truth - 1)
    return rows


def rms(values) -> float:
    v = np.asarray(values, dtype=float)
    return float(np.sqrt(np.nanmean(v**2)))


def print_simulated(rows, seeds: int, noise: float) -> None:
    print(f"\nsimulated, noise {100 * noise:.1f} % of the peak, {seeds} seeds: per estimator the RMS error against "
          "the truth (%) / the noise's part alone, RMS of noisy against noise-free (%) / the noise-free curve's bias "
          "against the truth (%, mean)")
    print("| curve | half-power lines | truth ζ (%) | " + " | ".join(ESTIMATORS) + " |")
    print("|---|---|---|" + "---|" * len(ESTIMATORS))
    for name, row in rows.items():
        cells = [f"{100 * rms(row[e]['total']):.1f} / {100 * rms(row[e]['noise']):.1f} / "
                 f"{100 * np.mean(row[e]['clean']):+.1f}" for e in ESTIMATORS]
        print(f"| {name} | {row['lines']} | {100 * np.mean(row['truth']):.3f} | " + " | ".join(cells) + " |")
    for kind, pick in (("force-controlled", lambda n: n.startswith("FC")),
                       ("response-controlled and linear", lambda n: not n.startswith("FC"))):
        cells = []
        for e in ESTIMATORS:
            total = [v for n, r in rows.items() if pick(n) for v in r[e]["total"]]
            part = [v for n, r in rows.items() if pick(n) for v in r[e]["noise"]]
            cells.append(f"{100 * rms(total):.1f} / {100 * rms(part):.1f}")
        print(f"| all {kind} (RMS) | | | " + " | ".join(cells) + " |")


# ------------------------------------------------------------------------------ the BRB itself
def print_brb(data, runs) -> None:
    from nlupdate.core.validation.held_out import resonance_amplitudes

    curves = [(f"{lv:g} N", f, h) for lv, f, h in zip(data.levels, data.frequencies, data.receptances)]
    curves += [(r.name.split(".")[-1], r.frequency_hz, r.h) for r in runs]
    x = np.log(np.concatenate([resonance_amplitudes(data), [r.held_m for r in runs]]))
    n_fc = data.levels.size

    def scatter(y, xs, degree):
        residual = y - np.polyval(np.polyfit(xs, y, degree), xs)
        return float(np.sqrt(np.sum(residual**2) / (y.size - degree - 1)))

    print("\nthe BRB's twelve curves (amplitude: the response reached at resonance, a run's held one): ζ (%) per "
          "estimator, then the scatter of ln ζ about the repeatability's trend")
    print("| curve | " + " | ".join(ESTIMATORS) + " |")
    print("|---|" + "---|" * len(ESTIMATORS))
    values = {e: np.array([est(f, h) for _, f, h in curves]) for e, est in ESTIMATORS.items()}
    for k, (name, _, _) in enumerate(curves):
        print(f"| {name} | " + " | ".join(f"{100 * values[e][k]:.3f}" for e in ESTIMATORS) + " |")
    for label, sel, degree in (("all twelve, parabola (9 dof)", slice(None), 2),
                               ("force-controlled four, line (2 dof)", slice(0, n_fc), 1),
                               ("response-controlled eight, parabola (5 dof)", slice(n_fc, None), 2)):
        print(f"| scatter of ln ζ, {label} | " + " | ".join(
            f"{100 * scatter(np.log(values[e][sel]), x[sel], degree):.1f} %" for e in ESTIMATORS) + " |")


def print_levels_from_runs(data) -> None:
    """The BRB's force-controlled levels predicted by the mode through its eight runs
    (:func:`brb_like_model`, unshifted), each at the forces its lines achieved, read by the
    tool's estimator: do the two test types agree at equal amplitude?"""
    from nlupdate.core.validation.held_out import resonance_amplitudes

    model = brb_like_model()
    print(f"\nthe force-controlled levels predicted from the mode through the eight runs (f0 "
          f"{model.natural_frequency_hz:.3f} Hz, ζ0 {100 * model.damping_ratio:.4f} %), the tool's estimator (circle fit)")
    print("| level (N) | reached at resonance (µm) | resonance (Hz): measured, error | damping (%): measured, error | "
          "peak: error |\n|---|---|---|---|---|")
    for k, (level, f, h) in enumerate(zip(data.levels, data.frequencies, data.receptances)):
        measured, predicted = resonance(f, h), resonance(f, frf_at_forces(model, f, data.achieved[k], "0"))
        print(f"| {level:g} | {1e6 * resonance_amplitudes(data)[k]:.0f} | {measured.resonance_hz:.3f}, "
              f"{predicted.resonance_hz - measured.resonance_hz:+.3f} | {100 * measured.damping_ratio:.3f}, "
              f"{100 * (predicted.damping_ratio / measured.damping_ratio - 1):+.1f} % | "
              f"{100 * (predicted.peak_abs / measured.peak_abs - 1):+.1f} % |")


@contextlib.contextmanager
def damping_read_by(estimator):
    """What-if, in this process only: every curve ``validate`` compares (measured, predicted,
    and the baseline's kept levels) read with ``estimator``'s damping ratio instead of the
    tool's; resonance, peak and the half-power line count unchanged."""
    import nlupdate.core.validation.baseline as baseline
    import nlupdate.core.validation.held_out as held_out
    from nlupdate.core.validation.resonance import Resonance

    def read(f, h):
        r = resonance(f, h)
        try:
            zeta = estimator(np.asarray(f, dtype=float), np.asarray(h)) if np.isfinite(r.resonance_hz) else np.nan
        except (ValueError, np.linalg.LinAlgError):
            zeta = float("nan")
        return Resonance(r.resonance_hz, float(zeta), r.peak_abs, r.half_power_lines, r.half_power_damping_ratio)

    for module in (held_out, baseline):
        module.resonance = read
    try:
        yield
    finally:
        for module in (held_out, baseline):
            module.resonance = resonance


def print_goal_rows(data, runs) -> None:
    """``auto``'s rows of docs/validation.md's BRB table with each curve's damping read by the
    half-power estimator and by the circle fit (measured, predicted and baseline alike)."""
    import dataclasses

    from benchmarks.validation_brb import impact_limit
    from nlupdate.core.validation.held_out import Validation, repeatability, validate
    from nlupdate.core.validation.held_response import with_held_runs

    with_impact = dataclasses.replace(data, linear_limit=impact_limit())
    print("\nauto's errors (resonance Hz, damping %, peak %; baseline's damping %) with the damping read by each "
          "estimator on every curve")
    print("| evidence kept | held out | half-power | circle fit |\n|---|---|---|---|")
    rows: dict[tuple[str, str], list[str]] = {}
    for name, estimator in (("half-power", half_power), ("circle fit", circle_fit)):
        with damping_read_by(estimator):
            for label, kept, kept_runs in (("levels", data, ()), ("levels + runs", data, runs),
                                           ("levels + impact", with_impact, ())):
                result = validate(kept, "each", ["auto"], runs=kept_runs)
                for r in result.held_out:
                    c, b = r.compared, r.baseline
                    rows.setdefault((label, f"{r.level:g} N"), []).append(
                        f"{c['resonance_hz'].error:+.3f}, {100 * c['damping_ratio'].relative_error:+.1f}, "
                        f"{100 * c['peak_abs'].relative_error:+.1f} (baseline ζ "
                        f"{100 * b['damping_ratio'].relative_error:+.1f})")
                rows.setdefault((label, "repeatability of ζ"), []).append(
                    f"{100 * result.repeatability.damping_relative:.0f} %")
            for label, kept in (("runs from levels", data), ("runs from levels + impact", with_impact)):
                result = with_held_runs(Validation((), repeatability(kept)), kept, runs, ["auto"])
                for r in result.response_controlled:
                    c = r.compared
                    rows.setdefault((label, r.run.split(".")[-1]), []).append(
                        f"{c['resonance_hz'].error:+.3f}, {100 * c['damping_ratio'].relative_error:+.1f}, "
                        f"{100 * c['peak_abs'].relative_error:+.1f}")
    for (label, held), cells in rows.items():
        print(f"| {label} | {held} | " + " | ".join(cells) + " |")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=24)
    args = parser.parse_args(argv)
    from benchmarks.validation_brb import _runs, brb_levels

    started, cpu = time.perf_counter(), time.process_time()
    print(f"load {os.getloadavg()[0]:.1f} (1 min) on {os.cpu_count()} cores; "
          f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        data = brb_levels()
        runs = _runs(data)
        achieved = [(f"FC {lv:g} N", data.achieved[k]) for k, lv in enumerate(data.levels)]
        for noise in (0.003, 0.01):
            print_simulated(simulate(achieved, args.seeds, noise), args.seeds, noise)
        print_brb(data, runs)
        print_levels_from_runs(data)
        print_goal_rows(data, runs)
    print(f"\n{time.perf_counter() - started:.1f} s wall, {time.process_time() - cpu:.1f} s CPU")
    return 0


if __name__ == "__main__":
    sys.exit(main())
