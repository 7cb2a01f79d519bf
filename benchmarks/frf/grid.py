"""Part 3: describing-function FRFs on a fine grid, and on a 1000-dof dense model.

(a) The reference Duffing on a 10,000-point grid over the band, swept up and down
    (``frequency_sweep``): the project's route for it (closed-form roots), its traced route
    (continuation + every grid point polished by batched Newton), the closed-form limit (the
    cubic's roots for all frequencies from precomputed coefficients, nothing else), and
    pyHarm-os' fixed-frequency sweeps over the same grid (as Part 1a(a): up to the last grid
    frequency before the upper fold, down to the last before the lower one; it cannot pass a
    fold). Time per frequency point = time of both sweeps ÷ the points they return. Accuracy
    against the exact relation: the relative distance from the curve at every point and the
    relative amplitude error at the points farther than 0.01 rad/s from a fold.
(b) A fixed–free chain of 1000 dense dofs (Part 2's chain, loss factor 0.01 = proportional
    damping) with cubic + Jenkins at the tip: the amplitude-scale setup (``default_x_scale`` on
    a fresh model, which includes the model's one eigenproblem) with its peak traced memory,
    and the single-harmonic trace per curve point.
"""
from __future__ import annotations

import time
import tracemalloc

import numpy as np

from nlupdate.model.elements import CubicStiffness, JenkinsFriction
from nlupdate.model.system import CondensedProblem, NonlinearSystem
from nlupdate.response import closed_form
from nlupdate.response.continuation import default_x_scale, trace_frequency_response
from nlupdate.response.sweep import frequency_sweep

from benchmarks.frf.common import (
    BAND, FORCE, curve_distance, duffing, exact_amplitude, exact_folds, fmt_ms, fmt_ratio, fmt_time, interleaved,
    print_table, timed,
)
from benchmarks.frf.pyharm import pyharm_grid_sweep, pyharm_run, pyharm_version
from benchmarks.frf.scaling import chain

GRID_POINTS = 10_000
DF_GOAL_US = 5.0  # issue 24: ≤ 5 µs per frequency point
DF_GOAL_RATIO = 20.0  # issue 24: ≥ 20× pyHarm-os
DENSE_DOFS = 1000


def closed_form_limit(problem: CondensedProblem, grid: np.ndarray, lead, quadratic, constant):
    """The cubic's positive roots at every frequency from precomputed coefficients: the floor."""
    return closed_form._positive_cubic_roots(lead, quadratic, np.ones_like(lead), constant)


def accuracy(omega: np.ndarray, x: np.ndarray, folds: np.ndarray) -> tuple[float, float]:
    """(max relative distance from the exact curve, max relative amplitude error ≥ 0.01 rad/s from a fold)."""
    a = np.abs(x)
    away = np.all(np.abs(omega[:, None] - folds[None, :]) > 0.01, axis=1)
    exact = exact_amplitude(omega[away], a[away])
    return float(curve_distance(omega, a).max()), float(np.max(np.abs(a[away] - exact) / exact))


def grid_benchmark(quick: bool) -> None:
    repeats = 3 if quick else 5
    system, forcing = duffing(), {0: FORCE}
    grid = np.linspace(*BAND, GRID_POINTS)
    folds = exact_folds()
    version = pyharm_version()
    problem = CondensedProblem(system, forcing)
    linear = problem.linear_batch(grid, derivative=False)
    h, x_lin, c = linear.h_aa[:, 0, 0], linear.x_lin[:, 0], 0.75 * 1.0
    coefficients = (c**2 * np.abs(h) ** 2, 2 * c * h.real, -np.abs(x_lin) ** 2)

    def sweeps(closed: bool):
        return (frequency_sweep(system, forcing, grid, "up", closed_form_roots=closed),
                frequency_sweep(system, forcing, grid, "down", closed_form_roots=closed))

    tasks = {
        "project": timed(lambda: sweeps(True)),
        "traced": timed(lambda: sweeps(False)),
        "limit": timed(lambda: closed_form_limit(problem, grid, *coefficients)),
    }
    grid_up, grid_down = grid[grid < folds.max()], grid[grid > folds.min()][::-1]
    if version:
        pyharm_run(pyharm_grid_sweep(grid_up[:50]))  # numba JIT, not timed

        def pyharm():
            t_up, up = pyharm_run(pyharm_grid_sweep(grid_up))
            t_down, down = pyharm_run(pyharm_grid_sweep(grid_down))
            return t_up + t_down, (up, down)

        tasks["pyharm"] = pyharm
    for task in ("project", "traced", "limit"):
        tasks[task]()  # warm-up
    timing = interleaved(tasks, repeats)
    rows, per_point = [], {}
    for key, label in (("project", "this project: frequency_sweep up + down (closed-form roots)"),
                       ("traced", "this project: traced route (continuation + batched polish) up + down"),
                       ("limit", "closed-form limit: the cubic's roots only, one pass")):
        t = timing[key]
        points = GRID_POINTS if key == "limit" else 2 * GRID_POINTS
        per_point[key] = t.best / points
        if key == "limit":
            acc = "—"
        else:
            up, down = t.result
            omega = np.concatenate([up.omega, down.omega])
            dist, err = accuracy(omega, np.concatenate([up.x_nonlinear[:, 0], down.x_nonlinear[:, 0]]), folds)
            acc = f"{dist:.1e} / {err:.1e}"
        rows.append([label, f"{points}", f"{fmt_time(t.best)} ({fmt_time(t.median)})", f"{1e6 * per_point[key]:.2f}", acc])
    if version:
        t = timing["pyharm"]
        up, down = t.result
        points = up["accepted"] + down["accepted"]
        per_point["pyharm"] = t.best / points
        dist, err = accuracy(np.concatenate([up["omega"], down["omega"]]), np.concatenate([up["x"], down["x"]]), folds)
        rows.insert(0, [f"pyHarm-os {version}: fixed-ω sweeps up to / down to the folds", f"{points}",
                        f"{fmt_time(t.best)} ({fmt_time(t.median)})", f"{1e6 * per_point['pyharm']:.2f}",
                        f"{dist:.1e} / {err:.1e}"])
    for row, key in zip(rows[-3:], ("project", "traced", "limit")):
        row += [fmt_ratio(per_point["pyharm"] / per_point[key]) if version else "—",
                fmt_ratio(per_point[key] / per_point["limit"])]
    if version:
        rows[0] += ["1", fmt_ratio(per_point["pyharm"] / per_point["limit"])]
    print(f"\nPart 3a: describing-function FRF on a {GRID_POINTS}-point grid, the reference Duffing; best of {repeats} "
          f"interleaved repeats (median in brackets)")
    print_table(
        "Time per frequency point (µs) and accuracy against the exact single-harmonic relation",
        ["method", "points", "time (s)", "per point (µs)", "distance max / |a| error max away from folds",
         "pyHarm ÷ this, per point", "÷ closed-form limit"],
        rows,
    )
    project = per_point["project"]
    verdict = f"{1e6 * project:.2f} µs per point (goal ≤ {DF_GOAL_US:g}: {'met' if 1e6 * project <= DF_GOAL_US else 'NOT met'})"
    if version:
        ratio = per_point["pyharm"] / project
        verdict += f"; {ratio:.0f}× pyHarm-os per point (goal ≥ {DF_GOAL_RATIO:g}×: {'met' if ratio >= DF_GOAL_RATIO else 'NOT met'})"
    print(f"  Goal: {verdict}; {project / per_point['limit']:.1f}× the closed-form limit. Traced route: "
          f"{1e6 * per_point['traced']:.2f} µs per point.")
    print(f"  Jumps (Hz): up {timing['project'].result[0].jumps_hz}, down {timing['project'].result[1].jumps_hz}; "
          f"exact folds {folds / (2 * np.pi)} Hz.")
    dense_benchmark(quick)


def dense_benchmark(quick: bool) -> None:
    n = DENSE_DOFS
    elements = (CubicStiffness((n - 1,), 1e8), JenkinsFriction((n - 1,), kf=2e3, slip_force=0.5))
    w1 = float(chain(n, sparse=False).modes(1)[0][0])  # on another instance: not timed
    band = (0.7 * w1, 2.0 * w1)
    model = chain(n, sparse=False)
    tracemalloc.start()
    start = time.perf_counter()
    problem = CondensedProblem(NonlinearSystem(model, elements), {n - 1: 5.0})
    scale = default_x_scale(problem, *band)
    setup = time.perf_counter() - start
    peak = tracemalloc.get_traced_memory()[1] / 1e6
    tracemalloc.stop()
    system = NonlinearSystem(model, elements)
    timing = interleaved({"trace": timed(lambda: trace_frequency_response(system, {n - 1: 5.0}, *band))}, 3 if quick else 5)
    curve = timing["trace"].result
    per_point = timing["trace"].best / curve.omega.size
    print(f"\nPart 3b: {n} dense dofs (fixed–free chain, loss factor 0.01, cubic + Jenkins at the tip, 5 N), "
          f"band {band[0]:.1f}–{band[1]:.1f} rad/s")
    print_table(
        "Amplitude-scale setup (fresh model: its eigenproblem included) and the trace",
        ["what", "time", "memory / points", "goal"],
        [["default_x_scale (201 frequencies)", f"{fmt_time(setup)} s", f"peak {peak:.0f} MB traced (numpy)",
          "≤ 1 s, ≤ 500 MB: " + ("met" if setup <= 1 and peak <= 500 else "NOT met")],
         ["trace_frequency_response", f"{fmt_time(timing['trace'].best)} s (best of {timing['trace'].times.size})",
          f"{curve.omega.size} points, {fmt_ms(per_point)} ms per point",
          "≤ 5 ms per point: " + ("met" if per_point <= 5e-3 else "NOT met")]],
    )
    print(f"  x_scale {scale:.3e} m; folds {np.sort(curve.omega[curve.turning_point])} rad/s.")
