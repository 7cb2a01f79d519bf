"""Part 1b: the single-harmonic results against time integration (see benchmarks/frf/__init__.py)."""
from __future__ import annotations

import time

import numpy as np
from scipy.integrate import solve_ivp

from nlupdate.core.response.continuation import trace_frequency_response
from nlupdate.core.response.fixed_point import fixed_point_response
from nlupdate.core.response.stepped_sine import stepped_sine
from nlupdate.core.response.time_integration import steady_state_response, time_sweep

from benchmarks.frf.common import (
    DAMPING, FORCE, K3, MASS, STIFFNESS, BAND, BRANCH, N_GRID, duffing, fmt_list, fmt_ms, fmt_ratio, fmt_time,
    cpu_seconds, interleaved, load_average, nearest_branch, print_table, relative_error, simple_jumps, timed,
)


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
# part 1b: the single-harmonic results against time integration (equal output)
# --------------------------------------------------------------------------------------
def time_integration_benchmark(quick: bool) -> None:
    repeats = 3 if quick else 7
    dop_repeats = 2
    system = duffing()
    grid = np.linspace(*BAND, N_GRID)
    forcing = {0: FORCE}
    band_margin = 0.02 * (BAND[1] - BAND[0])
    n_out = 2 * N_GRID

    def trace_and_sweeps():
        c = trace_frequency_response(system, forcing, *BAND)
        return c, stepped_sine(c, grid, "up"), stepped_sine(c, grid, "down")

    curve, up, down = trace_and_sweeps()
    folds = curve.omega[curve.turning_point]
    x_df = np.concatenate([up.x_nonlinear, down.x_nonlinear])
    omega2 = np.concatenate([grid, grid])
    fast = {
        "project": timed(trace_and_sweeps),
        "fixed": timed(lambda: fixed_point_response(system, forcing, grid)),
        "ti_lin": timed(lambda: steady_state_response(system, forcing, grid)),
        "ti_df": timed(lambda: steady_state_response(system, forcing, omega2, initial=x_df)),
    }
    timing = interleaved(fast, repeats)
    t_project, w_project = timing["project"].cpu_median, timing["project"].median
    fixed, ti_lin, ti_df = timing["fixed"].result, timing["ti_lin"].result, timing["ti_df"].result

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
        start, cpu = time.perf_counter(), cpu_seconds()
        ts_up = time_sweep(system, forcing, grid, "up")
        ts_down = time_sweep(system, forcing, grid, "down")
        t_ts, w_ts = cpu_seconds() - cpu, time.perf_counter() - start
        ref_up, ref_down = ts_up.x[:, 0], ts_down.x[:, 0]
        ratio_up, ratio_down = ts_up.harmonic_ratio[:, 0], ts_down.harmonic_ratio[:, 0]
        # scipy DOP853 sequential sweeps, interleaved with the project's figure
        dop_times, dop_walls, dop_project, dop_ratios = [], [], [], []
        for _ in range(dop_repeats):
            t_near = interleaved({"project": fast["project"]}, repeats)["project"].cpu_median
            start, cpu = time.perf_counter(), cpu_seconds()
            dop_up = dop853_sweep(grid)
            dop_down = dop853_sweep(grid[::-1])[::-1]
            dop_times.append(cpu_seconds() - cpu)
            dop_walls.append(time.perf_counter() - start)
            dop_project.append(t_near)
            dop_ratios.append(dop_times[-1] / t_near)
        err_dop = np.concatenate([relative_error(dop_up, ref_up), relative_error(dop_down, ref_down)])
    reference = np.concatenate([ref_up, ref_down])

    # continuation: stable stepped-sine points against the reference of the same sweep direction
    err_cont = relative_error(x_df[:, 0], reference)
    same_branch = err_cont < BRANCH
    away = np.all(np.abs(omega2[:, None] - folds[None, :]) > band_margin, axis=1)
    other = omega2[~same_branch]
    left = relative_error(ti_df.x[:, 0], x_df[:, 0]) >= BRANCH

    conv = fixed.converged
    err_fp = relative_error(fixed.x_nonlinear[conv, 0], nearest_branch(fixed.x_nonlinear[conv, 0], ref_up[conv], ref_down[conv]))
    err_ti = relative_error(ti_lin.x[:, 0], nearest_branch(ti_lin.x[:, 0], ref_up, ref_down))

    print(
        f"\nPart 1b: the single-harmonic results against time integration — same Duffing, {N_GRID} grid frequencies"
        f" swept up and down\n  (= {n_out} responses); medians of {repeats} interleaved repeats for the rows marked so,"
        f" CPU time (process and children) / wall, ratios on CPU; load average {load_average()}"
        + ("" if quick else "; the two sequential time integrations take minutes each (repeats as marked)")
    )

    def row(name, n, seconds, wall, repeats_label, notes, t_ref=t_project):
        """``seconds``: CPU time; ``wall``: wall time."""
        per_point_ratio = (seconds / n) / (t_ref / n_out)
        return [name, f"{n}", repeats_label, f"{fmt_time(seconds)} / {fmt_time(wall)}", fmt_ms(seconds / n),
                fmt_ratio(per_point_ratio), notes]

    rows = [
        row("this project: trace + stepped_sine up + down", n_out, t_project, w_project, f"median of {repeats}",
            f"{curve.omega.size}-point trace, then Newton-polished grid points"),
        row("fixed-point iteration (source method)", N_GRID, timing["fixed"].cpu_median, timing["fixed"].median,
            f"median of {repeats}",
            f"{conv.sum()}/{N_GRID} converged"),
        row("vectorised TI (numpy RK4), linear start", N_GRID, timing["ti_lin"].cpu_median, timing["ti_lin"].median,
            f"median of {repeats}",
            f"all at once, ≤{ti_lin.periods.max()} periods, {ti_lin.converged.sum()} converged"),
        row("vectorised TI, from the DF points up + down", n_out, timing["ti_df"].cpu_median, timing["ti_df"].median,
            f"median of {repeats}",
            "all at once"),
    ]
    if not quick:
        rows.append(row("time_sweep (numpy RK4) up + down", n_out, t_ts, w_ts, "1 run (the reference)",
                        "sequential, state carried"))
        rows.append(
            row(
                "scipy solve_ivp DOP853 sweeps up + down",
                n_out,
                min(dop_times),
                dop_walls[int(np.argmin(dop_times))],
                f"best of {dop_repeats}",
                f"sequential; runs {', '.join(fmt_time(t) for t in dop_times)} s CPU, each ÷ the project's median of "
                f"{repeats} just before it: {', '.join(f'{r:.0f}×' for r in dop_ratios)}",
                t_ref=min(dop_project),
            )
        )
    print_table(
        "Time at equal output (not equal accuracy: the time integrations include the higher harmonics)",
        ["method", "responses", "repeats", "CPU / wall (s)", "CPU per response (ms)", "× project per response (CPU)",
         "notes"],
        rows,
    )
    if quick:
        print("  --quick: the sequential time integrations (time_sweep, scipy solve_ivp) are not run; run without --quick.")

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
    ]
    if not quick:
        acc.append(["solve_ivp DOP853 sweeps", f"{err_dop.size}", f"{100 * err_dop.max():.4f}", "—", f"{(err_dop >= BRANCH).sum()}"])
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
            f"  Vectorised TI started from the DF points: {left.sum()} of {n_out} left their branch"
            + (
                f" (ω {fmt_list(sorted({omega2[left].min(), omega2[left].max()}))} rad/s: near the fold the single-harmonic"
                " start lies outside the branch's thin basin of attraction)."
                if left.any()
                else "."
            )
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
    print_table("Folds and jumps (rad/s; single-harmonic folds ≈ 1.4416 and 3.0290)", ["method", "ω"], fold_rows)


