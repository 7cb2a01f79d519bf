"""Speed and accuracy of the nonlinear frequency-response solvers.

Run from the repository root::

    python benchmarks/frf_speed.py            # full run (several minutes)
    python benchmarks/frf_speed.py --quick    # short run; slow references extrapolated

Part 1 — the reference Duffing oscillator ``m ẍ + c ẋ + k x + k3 x³ = F cos ωt`` with
m = 1 kg, c = 0.05 N·s/m, k = 1 N/m, k3 = 1 N/m³, F = 0.5 N, ω ∈ [0.5, 3.5] rad/s on a grid of
200 frequencies, swept up and down. Wall times of

* the pseudo-arclength continuation (trace; trace + stepped-sine emulation up and down),
* the seed fixed-point iteration on the grid,
* this project's vectorised time integration (all frequencies at once) and its sequential
  time-domain stepped sine ``time_sweep`` (full run only),
* scipy ``solve_ivp`` (DOP853, rtol 1e-9) as a sequential stepped sine: at each frequency
  the state of the previous one is carried over and one period after the other is
  integrated until the first harmonic changes by less than 1e-6 (relative) in three
  consecutive periods (at most 2000 periods),
* pyHarm-os (harmonic balance with one harmonic plus the constant term), when installed.

Timings are the best of a few repeats for the fast solvers; ratios are to the continuation
trace measured in the same run (the machine is shared). Accuracy: relative first-harmonic
amplitude error at the grid frequencies against the time-domain stepped sine
``time_sweep`` up and down (state carried from frequency to frequency, so it follows the
true multi-harmonic branches like a test); a stable DF point is compared with the sweep of
the same direction, other results with the nearer of the two. Two responses differing by
more than 10 % are on different branches (this happens only inside the grid cells between
a single-harmonic fold and the multi-harmonic one) and are counted, not compared. With
``--quick`` the reference is the vectorised integration started from the DF points.

Part 2 — condensed-solve scaling: a fixed–free spring–mass chain (total mass 1 kg, static
tip stiffness 1e4 N/m, loss factor 0.01) with a cubic spring (1e8 N/m³) and a Jenkins
element (kf = 2e3 N/m, Fs = 0.5 N) from the tip to ground, 5 N at the tip, traced over
[0.7, 2] × its first natural frequency; 10 dofs (dense) against 10,000 dofs (sparse, and
its 20-mode modal model at the tip).
"""
from __future__ import annotations

import argparse
import contextlib
import io
import logging
import time
import warnings
from typing import Callable

import numpy as np
import scipy.sparse
from scipy.integrate import solve_ivp

from nlupdate.response.continuation import trace_frequency_response
from nlupdate.model.elements import CubicStiffness, JenkinsFriction
from nlupdate.response.fixed_point import fixed_point_response
from nlupdate.model.linear import LumpedModel
from nlupdate.response.stepped_sine import stepped_sine
from nlupdate.model.system import NonlinearSystem
from nlupdate.response.time_integration import steady_state_response, time_sweep

MASS, DAMPING, STIFFNESS, K3, FORCE = 1.0, 0.05, 1.0, 1.0, 0.5
BAND = (0.5, 3.5)
N_GRID = 200
BRANCH = 0.10  # relative amplitude difference beyond which two responses are on different branches


# --------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------
def best_of(function: Callable[[], object], repeats: int) -> tuple[float, object]:
    """Best wall time (s) of ``repeats`` calls and the last result."""
    best, result = np.inf, None
    for _ in range(repeats):
        start = time.perf_counter()
        result = function()
        best = min(best, time.perf_counter() - start)
    return best, result


def print_table(title: str, header: list[str], rows: list[list[str]]) -> None:
    widths = [max(len(str(row[i])) for row in [header] + rows) for i in range(len(header))]
    print(f"\n{title}")
    print("  ".join(h.ljust(w) for h, w in zip(header, widths)))
    print("  ".join("-" * w for w in widths))
    for row in rows:
        print("  ".join(str(cell).ljust(w) for cell, w in zip(row, widths)))


def fmt_time(seconds: float) -> str:
    return f"{seconds:.4f}" if seconds < 1 else f"{seconds:.2f}"


def fmt_list(values) -> str:
    values = list(values)
    return ", ".join(f"{v:.4f}" for v in values) if values else "—"


def duffing() -> NonlinearSystem:
    return NonlinearSystem(LumpedModel([[MASS]], [[STIFFNESS]], [[DAMPING]]), (CubicStiffness((0,), K3),))


def relative_error(a: np.ndarray, reference: np.ndarray) -> np.ndarray:
    return np.abs(np.abs(a) - np.abs(reference)) / np.abs(reference)


def nearest_branch(a: np.ndarray, up: np.ndarray, down: np.ndarray) -> np.ndarray:
    """Per point, the reference amplitude (up- or down-sweep branch) closest to ``a``."""
    a, up, down = np.abs(a), np.abs(up), np.abs(down)
    return np.where(np.abs(up - a) <= np.abs(down - a), up, down)


def simple_jumps(omega: np.ndarray, amplitude: np.ndarray, threshold: float = 0.25) -> list[float]:
    """Frequencies (rad/s, sweep order) where the amplitude changes by more than ``threshold``."""
    return [
        float(omega[i])
        for i in range(1, omega.size)
        if abs(amplitude[i] - amplitude[i - 1]) > threshold * max(amplitude[i], amplitude[i - 1])
    ]


# --------------------------------------------------------------------------------------
# scipy solve_ivp sequential stepped sine
# --------------------------------------------------------------------------------------
def dop853_sweep(omega_sweep: np.ndarray, tolerance: float = 1e-6, max_periods: int = 2000) -> np.ndarray:
    """Complex first harmonics along a sequential stepped sine (frequencies in sweep order)."""
    samples = 64
    theta = 2 * np.pi * np.arange(samples) / samples
    kernel = np.exp(-1j * theta) * 2 / samples
    state = None
    out = np.empty(omega_sweep.size, complex)
    for index, w in enumerate(omega_sweep):
        period = 2 * np.pi / w

        def rhs(t, y, w=w):
            return [y[1], FORCE * np.cos(w * t) - DAMPING * y[1] - STIFFNESS * y[0] - K3 * y[0] ** 3]

        if state is None:  # linear response at the first frequency
            x_lin = FORCE / (STIFFNESS - MASS * w**2 + 1j * DAMPING * w)
            state = np.array([x_lin.real, -w * x_lin.imag])
        previous, streak = None, 0
        for _ in range(max_periods):
            t_eval = np.linspace(0.0, period, samples + 1)
            sol = solve_ivp(rhs, (0.0, period), state, method="DOP853", t_eval=t_eval, rtol=1e-9, atol=1e-12)
            state = sol.y[:, -1]
            first = kernel @ sol.y[0, :-1]
            if previous is not None and abs(first - previous) < tolerance * abs(first):
                streak += 1
                if streak >= 3:
                    break
            else:
                streak = 0
            previous = first
        out[index] = first
    return out


# --------------------------------------------------------------------------------------
# pyHarm-os
# --------------------------------------------------------------------------------------
def pyharm_duffing(repeats: int):
    """Trace the Duffing curve with pyHarm (nh = 1); returns a dict, or a reason string."""
    try:
        from pyHarm.Maestro import Maestro
    except Exception as exc:  # pragma: no cover - depends on the optional install
        return f"pyHarm-os not importable ({type(exc).__name__}: {exc}); install with pip install pyHarm-os"

    def make_input():
        return {
            "system": {"type": "Base", "nh": 1, "nti": 64},
            "substructures": {
                "sub": {
                    "type": "substructure",
                    "ndofs": 1,
                    "matrix": {"M": np.array([[MASS]]), "K": np.array([[STIFFNESS]]), "C": np.array([[DAMPING]])},
                }
            },
            "connectors": {
                "cubic": {"type": "CubicSpring", "connect": {"sub": [0]}, "dirs": [0], "k": K3},
                "force": {"type": "CosinusForcing", "connect": {"sub": [0]}, "dirs": [0], "amp": FORCE},
            },
            "analysis": {
                "frf": {
                    "study": "frf",
                    "puls_inf": BAND[0],
                    "puls_sup": BAND[1],
                    "ds0": 0.01,
                    "ds_max": 0.05,
                    "ds_min": 1e-6,
                    "verbose": False,
                }
            },
        }

    def run():
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            maestro = Maestro(make_input())
            start = time.perf_counter()
            maestro.operate()
            solve = time.perf_counter() - start
        return maestro, solve

    logging.disable(logging.CRITICAL)
    try:
        start = time.perf_counter()
        maestro, first_solve = run()
        first_total = time.perf_counter() - start
        best_solve, best_total = np.inf, np.inf
        for _ in range(repeats):
            start = time.perf_counter()
            maestro, solve = run()
            best_total = min(best_total, time.perf_counter() - start)
            best_solve = min(best_solve, solve)
    except Exception as exc:  # pragma: no cover - depends on the optional install
        return f"pyHarm-os failed on the Duffing case ({type(exc).__name__}: {exc})"
    finally:
        logging.disable(logging.NOTSET)
    edf = maestro.system.expl_dofs
    cos_index = int(edf.index[(edf["harm"] == 1) & (edf["cs"] == "c")][0])
    sin_index = int(edf.index[(edf["harm"] == 1) & (edf["cs"] == "s")][0])
    points = np.array([s.x for s in maestro.nls["frf"].SolList if s.flag_accepted])
    omega = points[:, -1]
    x = points[:, cos_index] - 1j * points[:, sin_index]  # x = c cos ωt + s sin ωt
    turn = np.flatnonzero(np.diff(np.sign(np.diff(omega))) != 0) + 1
    return {
        "omega": omega,
        "x": x,
        "folds": omega[turn],
        "first_total": first_total,
        "first_solve": first_solve,
        "best_total": best_total,
        "best_solve": best_solve,
    }


# --------------------------------------------------------------------------------------
# part 1: the reference Duffing case
# --------------------------------------------------------------------------------------
def duffing_benchmark(quick: bool) -> None:
    repeats = 3 if quick else 7
    system = duffing()
    grid = np.linspace(*BAND, N_GRID)
    forcing = {0: FORCE}
    band_margin = 0.02 * (BAND[1] - BAND[0])

    t_trace, curve = best_of(lambda: trace_frequency_response(system, forcing, *BAND), repeats)
    folds = curve.omega[curve.turning_point]

    def trace_and_sweeps():
        c = trace_frequency_response(system, forcing, *BAND)
        return c, stepped_sine(c, grid, "up"), stepped_sine(c, grid, "down")

    t_sweeps, (_, up, down) = best_of(trace_and_sweeps, repeats)
    t_fixed, fixed = best_of(lambda: fixed_point_response(system, forcing, grid), repeats)
    x_df = np.concatenate([up.x_nonlinear, down.x_nonlinear])
    omega2 = np.concatenate([grid, grid])
    t_ti_lin, ti_lin = best_of(lambda: steady_state_response(system, forcing, grid), 1 if quick else 2)
    t_ti_df, ti_df = best_of(
        lambda: steady_state_response(system, forcing, omega2, initial=x_df), 1 if quick else 2
    )

    # Reference: the time-domain stepped sine (state carried, follows the true branches); in
    # --quick the vectorised integration started from the continuation's stable points.
    if quick:
        reference_name = "vectorised TI from the DF points (128 steps, tol 1e-8)"
        ref = steady_state_response(
            system, forcing, omega2, initial=x_df, tolerance=1e-8, steps_per_period=128, max_periods=4000
        )
        ref_up, ref_down = ref.x[:N_GRID, 0], ref.x[N_GRID:, 0]
        ratio_up, ratio_down = ref.harmonic_ratio[:N_GRID, 0], ref.harmonic_ratio[N_GRID:, 0]
    else:
        reference_name = "time_sweep up and down (64 steps, tol 1e-6, state carried)"
        start = time.perf_counter()
        ts_up = time_sweep(system, forcing, grid, "up")
        ts_down = time_sweep(system, forcing, grid, "down")
        t_ts = time.perf_counter() - start
        ref_up, ref_down = ts_up.x[:, 0], ts_down.x[:, 0]
        ratio_up, ratio_down = ts_up.harmonic_ratio[:, 0], ts_down.harmonic_ratio[:, 0]
    reference = np.concatenate([ref_up, ref_down])

    # continuation: stable stepped-sine points against the reference of the same sweep direction
    err_cont = relative_error(x_df[:, 0], reference)
    same_branch = err_cont < BRANCH
    away = np.all(np.abs(omega2[:, None] - folds[None, :]) > band_margin, axis=1)
    other = omega2[~same_branch]
    # vectorised integration from the DF points: did the start stay on its branch?
    left = relative_error(ti_df.x[:, 0], x_df[:, 0]) >= BRANCH

    conv = fixed.converged
    err_fp = relative_error(fixed.x_nonlinear[conv, 0], nearest_branch(fixed.x_nonlinear[conv, 0], ref_up[conv], ref_down[conv]))
    err_ti = relative_error(ti_lin.x[:, 0], nearest_branch(ti_lin.x[:, 0], ref_up, ref_down))

    # scipy DOP853 sequential sweeps
    subset = 20 if quick else N_GRID
    start = time.perf_counter()
    dop_up = dop853_sweep(grid[:subset])
    dop_down = dop853_sweep(grid[::-1][:subset])[::-1]
    t_dop = time.perf_counter() - start
    t_dop_full = t_dop * N_GRID / subset
    err_dop = np.concatenate(
        [relative_error(dop_up, ref_up[:subset]), relative_error(dop_down, ref_down[N_GRID - subset :])]
    )
    dop_label = "solve_ivp DOP853 sweeps up+down"
    if quick:
        dop_label += f" (extrapolated from {subset} of {N_GRID} freq./direction)"

    # pyHarm: residual of this project's condensed DF equation at pyHarm's points
    ph = pyharm_duffing(1 if quick else 3)
    if isinstance(ph, dict):
        problem = curve.problem
        ph_residual = np.array(
            [
                np.max(np.abs(problem.residual(problem.to_real(np.array([x])), w))) * problem.x_scale / abs(x)
                for w, x in zip(ph["omega"], ph["x"])
            ]
        )

    print(
        f"\nPart 1: Duffing m={MASS}, c={DAMPING}, k={STIFFNESS}, k3={K3}, F={FORCE}, "
        f"ω ∈ [{BAND[0]}, {BAND[1]}] rad/s, {N_GRID} frequencies; best of {repeats} for the fast solvers"
    )
    rows = [
        ["continuation trace", fmt_time(t_trace), "1.0", f"{curve.omega.size} curve points"],
        ["trace + stepped sine up + down", fmt_time(t_sweeps), f"{t_sweeps / t_trace:.1f}", f"{N_GRID} frequencies × 2"],
        ["fixed-point iteration", fmt_time(t_fixed), f"{t_fixed / t_trace:.1f}", f"{conv.sum()}/{N_GRID} converged"],
        [
            "vectorised TI, linear start",
            fmt_time(t_ti_lin),
            f"{t_ti_lin / t_trace:.0f}",
            f"{N_GRID} cases, ≤{ti_lin.periods.max()} periods, {ti_lin.converged.sum()} converged",
        ],
        ["vectorised TI, from DF up+down", fmt_time(t_ti_df), f"{t_ti_df / t_trace:.0f}", f"{2 * N_GRID} cases"],
    ]
    if not quick:
        rows.append(["time_sweep (numpy TI) up+down", fmt_time(t_ts), f"{t_ts / t_trace:.0f}", "sequential, state carried"])
    rows.append(
        [
            dop_label,
            fmt_time(t_dop_full),
            f"{t_dop_full / t_trace:.0f}",
            f"measured {fmt_time(t_dop)} s" if quick else "sequential, state carried",
        ]
    )
    if isinstance(ph, dict):
        rows.append(
            [
                "pyHarm-os FRF (solve, warm)",
                fmt_time(ph["best_solve"]),
                f"{ph['best_solve'] / t_trace:.1f}",
                f"{ph['omega'].size} points; first run {ph['first_total']:.2f} s incl. numba JIT",
            ]
        )
        rows.append(
            [
                "pyHarm-os FRF (build + solve, warm)",
                fmt_time(ph["best_total"]),
                f"{ph['best_total'] / t_trace:.1f}",
                "Maestro(...) + operate()",
            ]
        )
    print_table("Wall time", ["method", "time (s)", "× trace", "notes"], rows)

    acc = [
        [
            "continuation, stable stepped-sine points",
            f"{same_branch.sum()}",
            f"{100 * err_cont[same_branch].max():.3f}",
            f"{100 * err_cont[same_branch & away].max():.3f}",
            f"{(~same_branch).sum()} ({fmt_list(sorted({other.min(), other.max()})) if other.size else '—'})",
        ],
        ["fixed-point, converged points", f"{conv.sum()}", f"{100 * err_fp.max():.3f}", "—", "—"],
        ["vectorised TI, linear start, defaults", f"{N_GRID}", f"{100 * err_ti.max():.4f}", "—", "—"],
        [
            f"solve_ivp DOP853 sweeps{' (subset)' if quick else ''}",
            f"{err_dop.size}",
            f"{100 * err_dop.max():.4f}",
            "—",
            f"{(err_dop >= BRANCH).sum()}",
        ],
    ]
    print_table(
        f"Accuracy of the first-harmonic amplitude; reference: {reference_name}",
        ["method", "points", "max error (%)", "away from folds (%)", "on another branch (ω range, rad/s)"],
        acc,
    )
    worst = np.argmax(np.where(same_branch, err_cont, -1.0))
    ratios = np.concatenate([ratio_up, ratio_down])
    print(
        f"  'away from folds' = farther than 2 % of the band ({band_margin:.2f} rad/s) from a turning point.\n"
        f"  The continuation's largest error is at ω = {omega2[worst]:.4f} rad/s, where the time-domain motion has a\n"
        f"  harmonic ratio (RMS of harmonics ≥ 2 / first) of {ratios[worst]:.3f}: the single-harmonic DF error."
    )
    if not quick:
        print(
            f"  Vectorised TI started from the DF points: {left.sum()} of {2 * N_GRID} left their branch"
            + (
                f" (ω {fmt_list(sorted({omega2[left].min(), omega2[left].max()}))} rad/s: near the fold the single-harmonic"
                " start lies outside the branch's thin basin of attraction)."
                if left.any()
                else "."
            )
        )
    if isinstance(ph, dict):
        print(
            f"  pyHarm-os points satisfy this project's DF equation X − H·(F − ν(|X|)X) = 0 to a relative residual of\n"
            f"  {ph_residual.max():.1e} (max over {ph_residual.size} points): both solve the same single-harmonic balance."
        )

    fold_rows = [
        ["continuation turning points", fmt_list(folds)],
        [
            "stepped sine jumps (up; down), grid",
            f"{fmt_list(2 * np.pi * np.array(up.jumps_hz))}; {fmt_list(2 * np.pi * np.array(down.jumps_hz))}",
        ],
        ["fixed point: not converged between", fmt_list([grid[~conv].min(), grid[~conv].max()]) if (~conv).any() else "—"],
    ]
    if not quick:
        fold_rows.append(
            [
                "time_sweep jumps (up; down)",
                f"{fmt_list(2 * np.pi * np.array(ts_up.jumps_hz))}; {fmt_list(2 * np.pi * np.array(ts_down.jumps_hz))}",
            ]
        )
        dop_jumps = simple_jumps(grid, np.abs(dop_up)), simple_jumps(grid[::-1], np.abs(dop_down[::-1]))
        fold_rows.append(["solve_ivp sweep jumps (up; down)", f"{fmt_list(dop_jumps[0])}; {fmt_list(dop_jumps[1])}"])
    if isinstance(ph, dict):
        fold_rows.append(["pyHarm-os turning points", fmt_list(ph["folds"])])
    else:
        fold_rows.append(["pyHarm-os", "not run (see below)"])
    print_table("Folds and jumps (rad/s; single-harmonic folds ≈ 1.4416 and 3.0290)", ["method", "ω"], fold_rows)
    if isinstance(ph, str):
        print(f"\npyHarm-os not run: {ph}")


# --------------------------------------------------------------------------------------
# part 2: condensed-solve scaling
# --------------------------------------------------------------------------------------
def chain(n: int, sparse: bool) -> LumpedModel:
    """Fixed–free chain: total mass 1 kg, static tip stiffness 1e4 N/m, loss factor 0.01."""
    m, k = 1.0 / n, 1e4 * n
    main = np.full(n, 2 * k)
    main[-1] = k
    stiffness = scipy.sparse.diags([main, -k * np.ones(n - 1), -k * np.ones(n - 1)], [0, 1, -1], format="csr")
    mass = scipy.sparse.identity(n, format="csr") * m
    if not sparse:
        stiffness, mass = stiffness.toarray(), mass.toarray()
    return LumpedModel.with_loss_factor(mass, stiffness, 0.01)


def scaling_benchmark(quick: bool) -> None:
    repeats = 3 if quick else 5
    rows = []
    for n, sparse in ((10, False), (10_000, True)):
        model = chain(n, sparse)
        tip = n - 1
        start = time.perf_counter()
        w1 = float(model.modes(1)[0][0])
        t_modes = time.perf_counter() - start
        band = (0.7 * w1, 2.0 * w1)

        def elements(dof):
            return (CubicStiffness((dof,), 1e8), JenkinsFriction((dof,), kf=2e3, slip_force=0.5))

        if n == 10:
            system = NonlinearSystem(model, elements(tip))
            t, c = best_of(lambda: trace_frequency_response(system, {tip: 5.0}, *band), repeats)
            rows.append([f"{n}", "dense lumped", "—", fmt_time(t), f"{c.omega.size}", fmt_list(c.omega[c.turning_point] / w1)])
            continue
        start = time.perf_counter()
        modal = model.to_modal(20, [tip])
        t_modal = time.perf_counter() - start
        system = NonlinearSystem(modal, elements(0))
        t, c = best_of(lambda: trace_frequency_response(system, {0: 5.0}, *band), repeats)
        rows.append([f"{n}", "20-mode modal (tip)", f"{fmt_time(t_modal)} (to_modal)", fmt_time(t), f"{c.omega.size}",
                     fmt_list(c.omega[c.turning_point] / w1)])
        if not quick:
            system = NonlinearSystem(model, elements(tip))
            start = time.perf_counter()
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                c = trace_frequency_response(system, {tip: 5.0}, *band)
            t = time.perf_counter() - start
            stalled = any("stalled" in str(w.message) for w in caught)
            note = f"stalled at {c.omega[-1] / w1:.3f}·ω1" if stalled else fmt_list(c.omega[c.turning_point] / w1)
            rows.append([f"{n}", "sparse lumped (LU per ω)", "—", fmt_time(t), f"{c.omega.size}", note])
        rows.append([f"{n}", "(first eigenvalue, eigsh)", fmt_time(t_modes), "—", "—", "—"])
    print("\nPart 2: condensed solve, fixed–free chain with cubic + Jenkins at the tip, 5 N at the tip,"
          " band [0.7, 2]·ω1")
    print_table(
        "Trace time by model size (same nonlinear coordinate)",
        ["dofs", "linear model", "linear solve (s)", "trace (s)", "points", "folds / ω1"],
        rows,
    )
    if not quick:
        print(
            "  The direct sparse solve factorises the 10,000-dof dynamic stiffness at every corrector step and is\n"
            "  conditioned ~1e10 near resonance (receptance errors ~1e-7, where the corrector stops at its\n"
            "  stagnation floor); the modal model (one eigen-solution, then the condensed trace) is the intended route."
        )


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="short run; slow references timed on a subset")
    args = parser.parse_args(argv)
    duffing_benchmark(args.quick)
    scaling_benchmark(args.quick)


if __name__ == "__main__":
    main()
