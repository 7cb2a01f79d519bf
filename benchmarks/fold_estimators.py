"""A folding curve's damping ratio: today's reading against a circle fitted on the branch through the peak.

    python benchmarks/fold_estimators.py

``nlupdate validate`` reads a curve with a jump inside its circle run (a fold of a
stepped-sine sweep) by the half-power width, and reads the curve it is compared with the
same way (:mod:`nlupdate.core.validation.resonance`, ``read_alike``). The BRB's 0.4886 N
level jumps at its lower half-power point (|H| × 1.49 between 79.95 and 80.00 Hz) and is
missed by +21.9 % in damping from the levels alone (docs/validation.md, "The goals"). Is the
reading to blame? Compared, on truth known:

* ``today`` — the tool's reading (half-power at a jump; a pair read alike);
* ``circle across`` — the circle fit over the whole run, across the jump;
* ``branch circle`` — the circle fit (:func:`~nlupdate.core.validation.circle_fit.circle_fit_damping`,
  its rules: NaN with the peak at the end of its lines) restricted to the lines of the run
  between the jumps that hold the peak (:func:`peak_branch`): a modal circle holds along one
  branch, the lines beyond a jump belong to another; for a pair, each curve on its own
  branch (``per curve``) or both on the jumping curve's branch (``same lines``);
* ``half-band`` — the half-power half-width on the side without the jump, (f₂ − f_r)/f_r or
  (f_r − f₁)/f_r.

The truth: the single-harmonic closed form of ``x'' + 2ζω_n x' + ω_n² x + k3 x³ = F cos Ωt``
(ζ = 0.3 % at every amplitude) swept up over the BRB's 41 lines — hardening (k3 > 0: the
upper branch until its fold after the peak, then the one root left) and softening (k3 < 0:
the lower branch until its fold, then a jump *up* onto the upper branch, the BRB's kind), the
backbone moving 0.3–0.6 Hz by the linear peak amplitude, the mode at four offsets against the
lines; the curves the tool calls jumps are kept. Pairs: such a folding curve beside the same
mode less bent (it does not jump) — a prediction exact in damping, whose error is the
reading's. Then the BRB-like simulated curves of ``benchmarks/damping_estimators.py`` (its
mode through the runs, at the BRB's achieved forces): how many jump. Then the BRB's 0.4886 N
level and ``lines-background``'s prediction of it from the three other levels (``auto``'s
choice): each reading, where the two half-power widths differ, and the prediction at the
force the shaker achieved per line (what ``validate`` does) against the nominal force.
"""
from __future__ import annotations

import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np

if __package__ in (None, ""):  # run as a script: make the repository root importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from nlupdate.core.correlation.metrics import peak  # noqa: E402
from nlupdate.core.validation.circle_fit import circle_fit_damping, circle_window, jump_steps  # noqa: E402
from nlupdate.core.validation.resonance import read_alike, resonance  # noqa: E402

LINES = np.round(np.arange(79.2, 81.2001, 0.05), 4)  # the BRB's 41 lines
ZETA = 0.003
SHIFTS = (0.0, 0.02, 0.04, 0.06)  # Hz, the mode against the lines
BENDS = (0.3, 0.35, 0.4, 0.5, 0.6)  # Hz, the backbone's move by the linear peak amplitude


def duffing_sweep_up(f: np.ndarray, fn: float, bend_hz: float, hardening: bool) -> np.ndarray:
    """Receptance X/F (F = 1) of the closed-form Duffing mode (module docstring) swept up:
    on each line the largest amplitude root (hardening) or the smallest (softening) of
    ``[(ω_n² − Ω² + ¾k3a²)² + (2ζω_nΩ)²] a² = F²``, k3 set so the backbone moves ``bend_hz``
    by the linear peak amplitude."""
    wn = 2 * np.pi * fn
    k3 = (1 if hardening else -1) * 2 * wn * 2 * np.pi * bend_hz / (0.75 * (1 / (2 * ZETA * wn**2)) ** 2)
    out = []
    for w in 2 * np.pi * f:
        d, c = wn**2 - w**2, 2 * ZETA * wn * w
        roots = np.roots([(0.75 * k3) ** 2, 1.5 * k3 * d, d**2 + c**2, -1.0])
        real = [r.real for r in roots if abs(r.imag) <= 1e-9 * abs(r) and r.real > 0]
        out.append(1 / (d + 0.75 * k3 * (max(real) if hardening else min(real)) + 1j * c))
    return np.array(out)


def peak_branch(f: np.ndarray, h: np.ndarray) -> slice:
    """The lines of the circle's run (:func:`circle_window`) between the jumps
    (:func:`jump_steps`, at the curve's half-power ζ) that hold the peak."""
    window, k = circle_window(h), int(np.argmax(np.abs(h)))
    low, high = window.start, window.stop
    for i in jump_steps(f, h, resonance(f, h).half_power_damping_ratio):
        low, high = (max(low, i + 1), high) if i < k else (low, min(high, i + 1))
    return slice(low, high)


def branch_circle(f: np.ndarray, h: np.ndarray, lines: slice | None = None) -> float:
    lines = peak_branch(f, h) if lines is None else lines
    return circle_fit_damping(f[lines], h[lines])


def half_band(f: np.ndarray, h: np.ndarray, side: str) -> float:
    m = np.abs(h)
    k = int(np.argmax(m))
    f_r, top = peak(f, m)
    half = top / np.sqrt(2)
    if side == "right":
        j = int(np.flatnonzero(m[k:] < half)[0] + k)
        return float((np.interp(half, m[j - 1:j + 1][::-1], f[j - 1:j + 1][::-1]) - f_r) / f_r)
    i = int(np.flatnonzero(m[:k] < half)[-1])
    return float((f_r - np.interp(half, m[i:i + 2], f[i:i + 2])) / f_r)


def closed_form_cases():
    """(kind, fn, bend, curve) of every closed-form sweep the tool calls a jump."""
    for hardening, base in ((True, 79.6), (False, 80.4)):
        for shift in SHIFTS:
            for bend in BENDS:
                h = duffing_sweep_up(LINES, base + shift, bend, hardening)
                if resonance(LINES, h).jump:
                    yield ("hardening" if hardening else "softening"), base + shift, bend, h


def summary(errors) -> str:
    v = np.asarray(errors, dtype=float)
    ok = v[np.isfinite(v)]
    if not ok.size:
        return f"no value ({v.size})"
    return (f"{100 * ok.min():+.1f} … {100 * ok.max():+.1f} (RMS {100 * np.sqrt(np.mean(ok**2)):.1f})"
            + (f", {v.size - ok.size} no value" if ok.size < v.size else ""))


def print_single() -> None:
    print("closed-form folds, one curve each: error against ζ = 0.3 % (%), range (RMS)")
    print("| fold | curves | today (half-power) | circle across | branch circle | half-band (side without the jump) |")
    print("|---|---|---|---|---|---|")
    for kind in ("hardening", "softening"):
        rows = [(resonance(LINES, h).damping_ratio, circle_fit_damping(LINES, h), branch_circle(LINES, h),
                 half_band(LINES, h, "left" if kind == "hardening" else "right"))
                for k, _, _, h in closed_form_cases() if k == kind]
        cells = [summary([r[i] / ZETA - 1 for r in rows]) for i in range(4)]
        print(f"| {kind} swept up | {len(rows)} | " + " | ".join(cells) + " |")


def print_pairs() -> None:
    print("\nclosed-form pairs: a folding curve (bend b) beside the same mode bent 0.05–0.1 Hz less, which does "
          "not jump (a prediction exact in damping): the prediction's damping error (%)")
    print("| fold | pairs | today (alike: both half-power) | branch circle, per curve | branch circle, same lines |")
    print("|---|---|---|---|---|")
    for kind in ("hardening", "softening"):
        rows = []
        for _, fn, bend, measured in (c for c in closed_form_cases() if c[0] == kind):
            for less in (0.05, 0.1):
                predicted = duffing_sweep_up(LINES, fn, bend - less, kind == "hardening")
                rm, rp = resonance(LINES, measured), resonance(LINES, predicted)
                if rp.jump:
                    continue
                lines = peak_branch(LINES, measured)
                zm = branch_circle(LINES, measured, lines)
                rows.append((read_alike(rp, rm).damping_ratio / read_alike(rm, rp).damping_ratio - 1,
                             rp.damping_ratio / zm - 1, branch_circle(LINES, predicted, lines) / zm - 1))
        print(f"| {kind} | {len(rows)} | " + " | ".join(summary([r[i] for r in rows]) for i in range(3)) + " |")


def print_simulated_brb(achieved) -> None:
    from benchmarks.damping_estimators import simulated_curves

    rng = np.random.default_rng(0)
    curves = jumps = 0
    for _ in range(12):
        shift = rng.uniform(-0.025, 0.025)
        for _, h, _ in simulated_curves(achieved, shift)[:len(achieved)]:
            for noise in (0.0, 0.003, 0.01):
                e = noise * np.abs(h).max() * (rng.standard_normal(h.size) + 1j * rng.standard_normal(h.size))
                curves += 1
                jumps += resonance(LINES, h + e / np.sqrt(2)).jump
    print(f"\nbenchmarks/damping_estimators.py's force-controlled curves (12 seeds × {len(achieved)} levels × noise "
          f"0, 0.3, 1 %): {jumps} of {curves} jump — a rule for jumping curves leaves its figures as they are")


def print_brb(data) -> None:
    from nlupdate.core.validation.models import model_fitter

    level = 0.4886
    f, measured = data.curve(level)
    fitted = model_fitter("lines-background")(data.subset([lv for lv in data.levels if lv != level]))
    curves = {"measured": measured, "predicted (force achieved per line, as validate)":
              fitted(f, level, data.force_at(level, f)), "predicted at the nominal force": fitted(f, level)}
    lines = peak_branch(f, measured)
    print(f"\nthe BRB's {level:g} N level and lines-background's prediction from the other three levels; the measured "
          f"curve's branch through the peak: {f[lines.start]:.2f}–{f[lines.stop - 1]:.2f} Hz")
    print("| curve | jump | today ζ (%) | half-power ζ (%) | circle across (%) | branch circle, same lines (%) "
          "| f₁, f_r, f₂ (Hz) |")
    print("|---|---|---|---|---|---|---|")
    shown = resonance(f, measured)
    for name, h in curves.items():
        r = resonance(f, h)
        today = read_alike(r, shown if name != "measured" else resonance(f, curves[
            "predicted (force achieved per line, as validate)"]))
        m = np.abs(h)
        k = int(np.argmax(m))
        half = r.peak_abs / np.sqrt(2)
        i, j = int(np.flatnonzero(m[:k] < half)[-1]), int(np.flatnonzero(m[k:] < half)[0] + k)
        f1 = np.interp(half, m[i:i + 2], f[i:i + 2])
        f2 = np.interp(half, m[j - 1:j + 1][::-1], f[j - 1:j + 1][::-1])
        print(f"| {name} | {'yes' if r.jump else 'no'} | {100 * today.damping_ratio:.4f} | "
              f"{100 * r.half_power_damping_ratio:.4f} | {100 * circle_fit_damping(f, h):.4f} | "
              f"{100 * branch_circle(f, h, lines):.4f} | {f1:.3f}, {r.resonance_hz:.3f}, {f2:.3f} |")
    p = curves["predicted (force achieved per line, as validate)"]
    right = (f >= 80.2) & (f <= 80.45)
    print(f"predicted/measured |H| over 80.20–80.45 Hz: "
          f"{', '.join(f'{v:.3f}' for v in np.abs(p[right]) / np.abs(measured[right]))}")


def main() -> int:
    from benchmarks.validation_brb import brb_levels

    started, cpu = time.perf_counter(), time.process_time()
    print(f"load {os.getloadavg()[0]:.1f} (1 min) on {os.cpu_count()} cores; "
          f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}\n")
    print_single()
    print_pairs()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        data = brb_levels()
        print_simulated_brb([(f"FC {lv:g} N", data.achieved[k]) for k, lv in enumerate(data.levels)])
        print_brb(data)
    print(f"\n{time.perf_counter() - started:.1f} s wall, {time.process_time() - cpu:.1f} s CPU")
    return 0


if __name__ == "__main__":
    sys.exit(main())
