"""Part 1a: the single-harmonic balance like for like against pyHarm-os (see benchmarks/frf/__init__.py)."""
from __future__ import annotations

import time

import numpy as np

from nlupdate.core.response.continuation import trace_frequency_response
from nlupdate.core.response.stepped_sine import stepped_sine

from benchmarks.frf.common import (
    DAMPING, FORCE, K3, MASS, STIFFNESS, BAND, N_GRID, PROJECT_MAX_STEP_283, PYHARM_STEP_78, PYHARM_STEP_FORMER,
    duffing, exact_accuracy, exact_folds, fmt_cpu_wall, fmt_list, fmt_ms, fmt_ratio, fmt_time, interleaved,
    load_average, newton_sweep, print_table, timed,
)
from benchmarks.frf.pyharm import (
    pyharm_constant_step, pyharm_continuation, pyharm_grid_sweep, pyharm_run, pyharm_version, with_cpu,
)


# --------------------------------------------------------------------------------------
# part 1a: harmonic balance, like for like
# --------------------------------------------------------------------------------------
def harmonic_balance_benchmark(quick: bool) -> dict:
    repeats = 3 if quick else 7
    system = duffing()
    forcing = {0: FORCE}
    grid = np.linspace(*BAND, N_GRID)
    folds = exact_folds()
    fold_low, fold_high = folds.min(), folds.max()
    grid_up = grid[grid < fold_high]  # a fixed-ω sweep up stays on the resonant branch until its fold
    grid_down = grid[grid > fold_low][::-1]
    n_grid_points = grid_up.size + grid_down.size
    ph_version = pyharm_version()

    print(
        f"\nPart 1a: harmonic balance like for like — Duffing m={MASS}, c={DAMPING}, k={STIFFNESS}, k3={K3}, "
        f"F={FORCE}, ω ∈ [{BAND[0]}, {BAND[1]}] rad/s\n"
        f"  single-harmonic folds (exact): {fmt_list(folds)} rad/s; every time is the median of {repeats} interleaved "
        f"repeats, the same for every tool:\n  CPU time (process and children; pyHarm: its operate()) / wall time; "
        f"ratios and the goal on CPU time. Load average now {load_average()}"
    )

    # ---- (a) fixed grid ----------------------------------------------------------------
    def project_newton():
        return newton_sweep(system, forcing, grid_up), newton_sweep(system, forcing, grid_down)

    def project_newton_tight():
        return (newton_sweep(system, forcing, grid_up, tolerance=1e-12),
                newton_sweep(system, forcing, grid_down, tolerance=1e-12))

    def project_trace_grid():
        curve = trace_frequency_response(system, forcing, *BAND)
        return stepped_sine(curve, grid_up, "up"), stepped_sine(curve, grid_down, "down")

    tasks = {
        "newton": timed(project_newton),
        "newton_tight": timed(project_newton_tight),
        "trace_grid": timed(project_trace_grid),
    }
    if ph_version:
        first_start = time.perf_counter()
        pyharm_run(pyharm_grid_sweep(grid_up))  # first call: numba JIT compilation
        first_call = time.perf_counter() - first_start

        def pyharm_grid():
            t_up, up = pyharm_run(pyharm_grid_sweep(grid_up))
            t_down, down = pyharm_run(pyharm_grid_sweep(grid_down))
            return t_up + t_down, (up, down), up["cpu"] + down["cpu"]

        tasks["pyharm"] = pyharm_grid
    for task in tasks.values():  # warm-up, not timed
        task()
    grid_timing = interleaved(tasks, repeats)

    sweep_up, sweep_down = grid_timing["trace_grid"].result
    omega_grid = np.concatenate([grid_up, grid_down])
    accuracy = {
        "trace_grid": exact_accuracy(  # SweepResult holds increasing ω for either direction
            np.concatenate([sweep_up.omega, sweep_down.omega]),
            np.concatenate([sweep_up.x_nonlinear[:, 0], sweep_down.x_nonlinear[:, 0]]),
        ),
    }
    points = {"trace_grid": n_grid_points}
    for key in ("newton", "newton_tight"):
        (x_up, ok_up), (x_down, ok_down) = grid_timing[key].result
        accuracy[key] = exact_accuracy(omega_grid, np.concatenate([x_up, x_down]))
        points[key] = int(ok_up.sum() + ok_down.sum())
    names = {
        "newton": "this project: Newton at each grid ω from the previous solution",
        "newton_tight": "this project: the same, tolerance 1e-12 (default 1e-10)",
        "trace_grid": "this project: trace, then stepped_sine on the grid (its grid API)",
        "pyharm": f"pyHarm-os {ph_version}: previous-solution predictor, fixed ω, constant step",
    }
    if ph_version:
        ph_up, ph_down = grid_timing["pyharm"].result
        ph_omega = np.concatenate([ph_up["omega"], ph_down["omega"]])
        accuracy["pyharm"] = exact_accuracy(ph_omega, np.concatenate([ph_up["x"], ph_down["x"]]))
        points["pyharm"] = ph_up["accepted"] + ph_down["accepted"]
        off_grid = max(np.max(np.abs(ph_up["omega"] - grid_up)), np.max(np.abs(ph_down["omega"] - grid_down)))
    reference = grid_timing["pyharm"] if ph_version else None
    rows = []
    for key in (["pyharm"] if ph_version else []) + ["newton", "newton_tight", "trace_grid"]:
        timing = grid_timing[key]
        rows.append(
            [
                names[key],
                f"{points[key]}",
                fmt_cpu_wall(timing),
                fmt_ms(timing.cpu_median / points[key]),
                f"{fmt_ratio(reference.cpu_median / timing.cpu_median)} ({fmt_ratio(reference.median / timing.median)})"
                if reference
                else "—",
                f"{accuracy[key][0]:.1e}",
                f"{accuracy[key][1]:.1e}",
            ]
        )
    print_table(
        f"(a) Same fixed grid: the {N_GRID}-point grid swept up over {grid_up.size} frequencies "
        f"({grid_up[0]:.4f}–{grid_up[-1]:.4f}) and down over {grid_down.size} ({grid_down[0]:.4f}–{grid_down[-1]:.4f} rad/s)",
        ["method", "points", "CPU / wall up+down (s)", "CPU per point (ms)", "pyHarm ÷ this, CPU (wall)", "max |a| error",
         "max distance"],
        rows,
    )
    # where the fixed-ω sweeps stop when asked for the whole grid (not timed)
    full_up, full_down = newton_sweep(system, forcing, grid)[1], newton_sweep(system, forcing, grid[::-1])[1]
    stall = (
        f"  Over the whole grid, the project's Newton sweep converges at {full_up.sum()}/{N_GRID} frequencies up"
        f" (first failure ω = {grid[np.argmin(full_up)]:.4f}) and {full_down.sum()}/{N_GRID} down"
        f" (first failure ω = {grid[::-1][np.argmin(full_down)]:.4f}) — damped Newton from the branch that ended does\n"
        f"  not find the other branch everywhere"
    )
    if ph_version:
        _, whole_up = pyharm_run(pyharm_grid_sweep(grid))
        _, whole_down = pyharm_run(pyharm_grid_sweep(grid[::-1]))
        stall += (
            f"; pyHarm-os accepts {whole_up['accepted']}/{N_GRID} up (last ω = {whole_up['omega'][-1]:.4f}) and"
            f" {whole_down['accepted']}/{N_GRID} down (last ω = {whole_down['omega'][-1]:.4f}):\n"
            f"  hybr fails at the next grid frequency and the constant step retries it until the solution count is reached"
        )
    print(stall + ". stepped_sine on the traced curve jumps to the other branch (Part 1b).")
    if ph_version:
        print(
            f"  pyHarm's grid frequencies are ω0 ± k·h accumulated: within {off_grid:.1e} rad/s of the grid. "
            f"First pyHarm call (numba JIT): {first_call:.2f} s, not in the table."
        )

    # ---- (b) continuation, equal point counts ------------------------------------------
    tasks = {
        "trace_default": timed(lambda: trace_frequency_response(system, forcing, *BAND)),
        "trace_fine": timed(lambda: trace_frequency_response(system, forcing, *BAND, max_step=PROJECT_MAX_STEP_283)),
    }
    if ph_version:
        tasks["pyharm_78"] = lambda: with_cpu(pyharm_run(pyharm_constant_step(PYHARM_STEP_78)))
        tasks["pyharm_former"] = lambda: with_cpu(pyharm_run(pyharm_continuation(**PYHARM_STEP_FORMER)))
    for task in tasks.values():
        task()
    cont = interleaved(tasks, repeats)
    curves = {key: cont[key].result for key in ("trace_default", "trace_fine")}
    info = {}
    for key, curve in curves.items():
        info[key] = (curve.omega.size, exact_accuracy(curve.omega, curve.x_nonlinear[:, 0]), curve.omega[curve.turning_point])
    if ph_version:
        for key in ("pyharm_78", "pyharm_former"):
            r = cont[key].result
            info[key] = (r["accepted"], exact_accuracy(r["omega"], r["x"]), r["folds"])
    labels = {
        "trace_default": "this project: trace, default steps (step 0.02, max_step 0.05)",
        "trace_fine": f"this project: trace, max_step {PROJECT_MAX_STEP_283}",
        "pyharm_78": f"pyHarm-os {ph_version}: constant step ds = {PYHARM_STEP_78}",
        "pyharm_former": f"pyHarm-os {ph_version}: ds0 {PYHARM_STEP_FORMER['ds0']}, ds_max {PYHARM_STEP_FORMER['ds_max']}, on acceptance",
    }
    pairs = [("pyharm_78", "trace_default"), ("pyharm_former", "trace_fine")]
    rows, goal = [], []
    for ph_key, project_key in pairs:
        for key in ((ph_key,) if ph_version else ()) + (project_key,):
            timing, (n, (err, res), _) = cont[key], info[key]
            if ph_version:
                ph_t, ph_n = cont[ph_key], info[ph_key][0]
                per_curve = f"{fmt_ratio(ph_t.cpu_median / timing.cpu_median)} ({fmt_ratio(ph_t.median / timing.median)})"
                per_point = fmt_ratio((ph_t.cpu_median / ph_n) / (timing.cpu_median / n))
            else:
                per_curve = per_point = "—"
            rows.append(
                [labels[key], f"{n}", fmt_cpu_wall(timing), fmt_ms(timing.cpu_median / n),
                 per_curve, per_point, f"{err:.1e}", f"{res:.1e}"]
            )
        if ph_version:
            goal.append((info[project_key][0], info[ph_key][0], cont[ph_key].cpu_median / cont[project_key].cpu_median,
                         cont[ph_key].median / cont[project_key].median,
                         (cont[ph_key].cpu_median / info[ph_key][0]) / (cont[project_key].cpu_median / info[project_key][0])))
    print_table(
        "(b) Continuation over the band with equal point counts (pyHarm's last point lies one step beyond 3.5 rad/s)",
        ["method", "points", "CPU / wall per curve (s)", "CPU per point (ms)", "pyHarm ÷ this, curve CPU (wall)",
         "per point CPU", "max |a| error",
         "max distance"],
        rows,
    )
    print(
        "  max |a| error: relative to the exact single-harmonic amplitude at the point's ω (ill-conditioned at a fold,\n"
        "  where the project places a refined point); max distance: relative distance from the exact curve."
    )
    if ph_version:
        builds = [cont[key].result["build"] for key in ("pyharm_78", "pyharm_former")]
        trace_curve = curves["trace_default"]
        problem = trace_curve.problem
        r = cont["pyharm_former"].result
        ph_residual = np.array(
            [np.max(np.abs(problem.residual(problem.to_real(np.array([x])), w))) * problem.x_scale / abs(x)
             for w, x in zip(r["omega"], r["x"])]
        )
        print(
            f"  pyHarm times are operate(); building Maestro(...) adds {fmt_time(min(builds))}–{fmt_time(max(builds))} s"
            f" per curve (last run).\n"
            f"  Folds: exact {fmt_list(folds)}; project (refined) {fmt_list(info['trace_default'][2])};"
            f" pyHarm ({info['pyharm_former'][0]} points) {fmt_list(info['pyharm_former'][2])},"
            f" ({info['pyharm_78'][0]} points) {fmt_list(info['pyharm_78'][2])} (its turning curve points, not refined).\n"
            f"  pyHarm-os points satisfy this project's DF equation X − H·(F − ν(|X|)X) = 0 to a relative residual of"
            f" {ph_residual.max():.1e}\n  (max over {ph_residual.size} points): both solve the same single-harmonic balance."
        )
        grid_ratio = grid_timing["pyharm"].cpu_median / grid_timing["newton_tight"].cpu_median
        grid_median = grid_timing["pyharm"].median / grid_timing["newton_tight"].median
        closer = accuracy["newton_tight"][1] <= accuracy["pyharm"][1]
        print(
            "  Goal (≥ 20× faster than pyHarm-os per curve at equal accuracy and equal point count; CPU medians): continuation "
            + "; ".join(f"{p} vs {q} points {c:.2f}× (wall {m:.2f}×, per point {pp:.2f}×)" for p, q, c, m, pp in goal)
            + f"; fixed grid, {points['newton_tight']} vs {points['pyharm']} points at tolerance 1e-12"
            + f" ({'at least as close to the exact curve as pyHarm' if closer else 'NOT as close as pyHarm'})"
            + f" {grid_ratio:.2f}× (wall {grid_median:.2f}×) — "
            + ("met." if min([g[2] for g in goal] + [grid_ratio]) >= 20 else "NOT met.")
        )
    else:
        print("  pyHarm-os is not installed here: pip install -e '.[benchmark]' in a separate venv (it pins pandas < 3).")
    return {"pyharm_version": ph_version}


