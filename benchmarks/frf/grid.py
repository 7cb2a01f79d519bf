"""Part 3: describing-function FRFs on a fine grid, and on a 1000-dof dense model.

(a) The reference Duffing on a 10,000-point grid over the band, swept up and down. Every
    figure is a median of interleaved repeats, CPU time (process and children) beside wall
    time, and counted per frequency of the grid for the same work: the sweeps up and down
    at all 10,000 frequencies against one solve of the cubic at the same 10,000 frequencies
    (the roots at a frequency serve both directions). Cheap contenders and the expensive
    ones are interleaved in two groups (many rounds of milliseconds, a few of seconds).

    * this project's route for it, ``frequency_sweep`` up and down (closed-form roots, solved
      once per call), and the DF closed form read both ways from one solve
      (``closed_form.cubic_roots`` once, ``sweep_roots`` up and down); one direction apart;
    * the limits, from precomputed coefficients (``benchmarks/frf/cubic_reference.py``): the
      vectorised trigonometric (Viète/Cardano) solve of the cubic, batched companion
      eigenvalues (``numpy.linalg.eigvals`` on 10,000 3×3 matrices), and the project's own
      polished cubic solve alone;
    * the project's traced route (continuation + every grid point polished by batched Newton)
      and pyHarm-os' fixed-frequency sweeps over the same grid (as Part 1a(a): up to the last
      grid frequency before the upper fold, down to the last before the lower one; it cannot
      pass a fold), per response;
    * like for like with pyHarm-os, the headline: general continuation over the band at
      equal point counts (the project's default trace, 78 points, against pyHarm at a constant
      step giving 78), per curve. The closed form against pyHarm's general Newton is printed
      too, labelled: it is the cubic's roots for one cubic coordinate, not a general solver.

    Accuracy against the exact relation: the relative distance from the curve at every point
    and the relative amplitude error at the points farther than 0.01 rad/s from a fold.
(b) A fixed–free chain of 1000 dense dofs (Part 2's chain, loss factor 0.01 = proportional
    damping) with cubic + Jenkins at the tip: the amplitude-scale setup (``default_x_scale`` on
    a fresh model, which includes the model's one eigenproblem) with its peak traced memory,
    and the single-harmonic trace per curve point.
"""
from __future__ import annotations

import time
import tracemalloc

import numpy as np

from nlupdate.core.model.elements import CubicStiffness, JenkinsFriction
from nlupdate.core.model.system import CondensedProblem, NonlinearSystem
from nlupdate.core.response import closed_form
from nlupdate.core.response.continuation import default_x_scale, trace_frequency_response
from nlupdate.core.response.sweep import frequency_sweep

from benchmarks.frf.common import (
    BAND, FORCE, PYHARM_STEP_78, cpu_seconds, curve_distance, duffing, exact_accuracy, exact_amplitude, exact_folds, fmt_cpu_wall,
    fmt_ms, fmt_ratio, fmt_time, interleaved, load_average, print_table, timed,
)
from benchmarks.frf.cubic_reference import companion_roots, trigonometric_roots
from benchmarks.frf.pyharm import pyharm_constant_step, pyharm_grid_sweep, pyharm_run, pyharm_version, with_cpu
from benchmarks.frf.scaling import chain

GRID_POINTS = 10_000
DF_GOAL_US = 5.0  # issue 24: ≤ 5 µs per frequency point
DF_GOAL_RATIO = 20.0  # issue 24: ≥ 20× pyHarm-os at equal points and accuracy
DF_LIMIT_GOAL = 2.0  # the DF closed form ≤ 2× the trigonometric limit per frequency, same work
DENSE_DOFS = 1000


def cubic_coefficients(problem: CondensedProblem, grid: np.ndarray) -> tuple[np.ndarray, ...]:
    """(a, b, c, d) of the closed form's cubic in u = |X|² at every frequency (not timed):
    ``c²|h|² u³ + 2c Re(h) u² + u − |X_lin|²`` with c = ¾ Σ k3."""
    linear = problem.linear_batch(grid, derivative=False)
    h, x_lin = linear.h_aa[:, 0, 0], linear.x_lin[:, 0]
    c = 0.75 * sum(element.k3 for element, _, _ in problem.element_index)
    return c**2 * np.abs(h) ** 2, 2 * c * h.real, np.ones(grid.size), -np.abs(x_lin) ** 2


def closed_form_both(problem: CondensedProblem, grid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The DF closed form read both ways from one solve: responses (P,) up and down (m)."""
    roots = closed_form.cubic_roots(problem, grid)
    up, down = closed_form.sweep_roots(roots, "up"), closed_form.sweep_roots(roots, "down")
    return roots.response(up[0]), roots.response(down[0])


def accuracy(omega: np.ndarray, x: np.ndarray, folds: np.ndarray) -> tuple[float, float]:
    """(max relative distance from the exact curve, max relative amplitude error ≥ 0.01 rad/s from a fold)."""
    a = np.abs(x)
    away = np.all(np.abs(omega[:, None] - folds[None, :]) > 0.01, axis=1)
    exact = exact_amplitude(omega[away], a[away])
    return float(curve_distance(omega, a).max()), float(np.max(np.abs(a[away] - exact) / exact))


def roots_accuracy(omega: np.ndarray, roots: np.ndarray, folds: np.ndarray) -> float:
    """Max relative amplitude error of every positive real root (P, 3) farther than 0.01 rad/s
    from a fold, against the exact relation (every 10th frequency)."""
    roots = np.asarray(roots)[::10]
    omega = omega[::10]
    real = np.where(np.abs(roots.imag) <= 1e-9 * np.abs(roots), roots.real, np.nan) if np.iscomplexobj(roots) else roots
    away = np.all(np.abs(omega[:, None] - folds[None, :]) > 0.01, axis=1)
    rows, cols = np.nonzero((real > 0) & away[:, None])
    a = np.sqrt(real[rows, cols])
    exact = exact_amplitude(omega[rows], a)
    return float(np.max(np.abs(a - exact) / exact))


def grid_benchmark(quick: bool) -> None:
    repeats, cheap_repeats = (3, 21) if quick else (5, 61)
    system, forcing = duffing(), {0: FORCE}
    grid = np.linspace(*BAND, GRID_POINTS)
    folds = exact_folds()
    version = pyharm_version()
    problem = CondensedProblem(system, forcing)
    coefficients = cubic_coefficients(problem, grid)

    def sweeps(closed: bool):
        return (frequency_sweep(system, forcing, grid, "up", closed_form_roots=closed),
                frequency_sweep(system, forcing, grid, "down", closed_form_roots=closed))

    cheap = {
        "sweeps": timed(lambda: sweeps(True)),
        "closed": timed(lambda: closed_form_both(CondensedProblem(system, forcing), grid)),
        "up": timed(lambda: frequency_sweep(system, forcing, grid, "up")),
        "trig": timed(lambda: trigonometric_roots(*coefficients)),
        "companion": timed(lambda: companion_roots(*coefficients)),
        "own": timed(lambda: closed_form._positive_cubic_roots(*coefficients)),
    }
    expensive = {"traced": timed(lambda: sweeps(False)),
                 "trace": timed(lambda: trace_frequency_response(system, forcing, *BAND))}
    grid_up, grid_down = grid[grid < folds.max()], grid[grid > folds.min()][::-1]
    if version:
        pyharm_run(pyharm_grid_sweep(grid_up[:50]))  # numba JIT, not timed

        def pyharm():
            t_up, up = pyharm_run(pyharm_grid_sweep(grid_up))
            t_down, down = pyharm_run(pyharm_grid_sweep(grid_down))
            return t_up + t_down, (up, down), up["cpu"] + down["cpu"]

        expensive["pyharm"] = pyharm
        expensive["pyharm_trace"] = lambda: with_cpu(pyharm_run(pyharm_constant_step(PYHARM_STEP_78)))
    load_start = load_average()
    for task in cheap.values():
        task()  # warm-up
    timing = interleaved(cheap, cheap_repeats)
    timing.update(interleaved(expensive, repeats))
    per_frequency = {key: t.cpu_median / GRID_POINTS for key, t in timing.items()}
    limit = per_frequency["trig"]
    rows = []
    labels = {
        "sweeps": ("this project: frequency_sweep up + down (closed-form route, roots solved in each call)", 2),
        "closed": ("this project: the DF closed form both ways, one solve (cubic_roots, sweep_roots up and down)", 2),
        "up": ("this project: frequency_sweep up only (one direction)", 1),
        "traced": ("this project: traced route (continuation + batched polish) up + down", 2),
        "trig": ("limit: trigonometric (Viète/Cardano) roots of the cubic, vectorised, one solve", 0),
        "companion": ("limit: companion eigenvalues, numpy.linalg.eigvals on 3×3 matrices, one solve", 0),
        "own": ("this project's own cubic solve alone (polished, sorted), one solve", 0),
    }
    for key, (label, directions) in labels.items():
        t = timing[key]
        if key in ("sweeps", "traced"):
            up, down = t.result
            omega = np.concatenate([up.omega, down.omega])
            dist, err = accuracy(omega, np.concatenate([up.x_nonlinear[:, 0], down.x_nonlinear[:, 0]]), folds)
            acc = f"{dist:.1e} / {err:.1e}"
        elif key == "closed":
            dist, err = accuracy(np.concatenate([grid, grid]), np.concatenate(t.result), folds)
            acc = f"{dist:.1e} / {err:.1e}"
        elif key == "up":
            dist, err = accuracy(grid, t.result.x_nonlinear[:, 0], folds)
            acc = f"{dist:.1e} / {err:.1e}"
        else:
            acc = f"roots {roots_accuracy(grid, t.result, folds):.1e}"
        rows.append([label, f"{GRID_POINTS}", f"{directions * GRID_POINTS}" if directions else "—", fmt_cpu_wall(t),
                     f"{1e6 * per_frequency[key]:.3f}", fmt_ratio(per_frequency[key] / limit), acc])
    print(f"\nPart 3a: describing-function FRF on a {GRID_POINTS}-point grid, the reference Duffing. Medians of "
          f"{cheap_repeats} interleaved repeats (the limits and the closed form) and of {repeats} (traced, pyHarm); "
          f"CPU time = process and children.\n  Load average at the start {load_start}, at the end {load_average()}.")
    print_table(
        "Per frequency of the grid, the same work for every row: both sweep directions at 10,000 frequencies, or one "
        "solve of the cubic there\n(its roots serve both directions); accuracy against the exact single-harmonic relation",
        ["method", "frequencies", "responses", "CPU / wall (s)", "CPU per frequency (µs)", "÷ trig. limit (CPU)",
         "distance max / |a| error max away from folds"],
        rows,
    )
    project, closed = per_frequency["sweeps"], per_frequency["closed"]
    print(f"  Goal (the DF closed form ≤ {DF_LIMIT_GOAL:g}× the trigonometric limit per frequency, same work, CPU): "
          f"frequency_sweep up + down {project / limit:.2f}× — {'met' if project / limit <= DF_LIMIT_GOAL else 'NOT met'}; "
          f"the closed form read both ways from one solve {closed / limit:.2f}×; one direction "
          f"{per_frequency['up'] / limit:.2f}× the limit; {project / per_frequency['companion']:.2f}× companion eigenvalues.")
    print(f"  Goal (≤ {DF_GOAL_US:g} µs per frequency, both directions, CPU): {1e6 * project:.3f} µs — "
          f"{'met' if 1e6 * project <= DF_GOAL_US else 'NOT met'} (wall {1e6 * timing['sweeps'].median / GRID_POINTS:.3f} µs).")
    if version:
        ph = timing["pyharm"]
        up, down = ph.result
        responses = up["accepted"] + down["accepted"]
        dist, err = accuracy(np.concatenate([up["omega"], down["omega"]]), np.concatenate([up["x"], down["x"]]), folds)
        ph_response = ph.cpu_median / responses
        trace, ph_trace = timing["trace"], timing["pyharm_trace"]
        n_trace, n_ph = trace.result.omega.size, ph_trace.result["accepted"]
        acc_trace = exact_accuracy(trace.result.omega, trace.result.x_nonlinear[:, 0])
        acc_ph = exact_accuracy(ph_trace.result["omega"], ph_trace.result["x"])
        like = ph_trace.cpu_median / trace.cpu_median
        print_table(
            f"Against pyHarm-os {version} (CPU / wall medians of {repeats}; per response = per frequency of one direction)",
            ["method", "points", "CPU / wall (s)", "CPU per point (µs)", "pyHarm ÷ this, CPU (wall)",
             "max |a| error / max distance"],
            [[f"like for like: pyHarm-os continuation, constant step {PYHARM_STEP_78}", f"{n_ph}", fmt_cpu_wall(ph_trace),
              f"{1e6 * ph_trace.cpu_median / n_ph:.1f}", "1", f"{acc_ph[0]:.1e} / {acc_ph[1]:.1e}"],
             ["like for like: this project's continuation (trace_frequency_response, default steps)", f"{n_trace}",
              fmt_cpu_wall(trace), f"{1e6 * trace.cpu_median / n_trace:.1f}",
              f"{fmt_ratio(like)} ({fmt_ratio(ph_trace.median / trace.median)})", f"{acc_trace[0]:.1e} / {acc_trace[1]:.1e}"],
             ["pyHarm-os: fixed-ω Newton sweeps up to / down to the folds", f"{responses}", fmt_cpu_wall(ph),
              f"{1e6 * ph_response:.2f}", "1", f"{err:.1e} / {dist:.1e}"],
             ["this project's traced route on the grid (general), up + down", f"{2 * GRID_POINTS}", fmt_cpu_wall(timing["traced"]),
              f"{1e6 * per_frequency['traced'] / 2:.2f}", fmt_ratio(ph_response / (per_frequency["traced"] / 2)), "above"],
             ["closed form for one cubic coordinate vs pyHarm's general Newton — not like for like", f"{2 * GRID_POINTS}",
              fmt_cpu_wall(timing["sweeps"]), f"{1e6 * project / 2:.3f}", fmt_ratio(ph_response / (project / 2)), "above"]],
        )
        print(f"  Goal (≥ {DF_GOAL_RATIO:g}× pyHarm-os at equal points and accuracy: general continuation, {n_trace} vs "
              f"{n_ph} points, CPU per curve): {like:.2f}× — {'met' if like >= DF_GOAL_RATIO else 'NOT met'}. "
              f"Not like for like: the closed form (one cubic coordinate only) {ph_response / (project / 2):.0f}× pyHarm's "
              f"fixed-ω Newton per response.")
    else:
        print("  pyHarm-os is not installed here: no comparison with it (pip install -e '.[benchmark]' in a separate venv).")
    print(f"  Jumps (Hz): up {timing['sweeps'].result[0].jumps_hz}, down {timing['sweeps'].result[1].jumps_hz}; "
          f"exact folds {folds / (2 * np.pi)} Hz. Traced route: {1e6 * per_frequency['traced']:.2f} µs CPU per frequency.")
    dense_benchmark(quick)


def dense_benchmark(quick: bool) -> None:
    n = DENSE_DOFS
    elements = (CubicStiffness((n - 1,), 1e8), JenkinsFriction((n - 1,), kf=2e3, slip_force=0.5))
    w1 = float(chain(n, sparse=False).modes(1)[0][0])  # on another instance: not timed
    band = (0.7 * w1, 2.0 * w1)
    model = chain(n, sparse=False)
    tracemalloc.start()
    start, cpu = time.perf_counter(), cpu_seconds()
    problem = CondensedProblem(NonlinearSystem(model, elements), {n - 1: 5.0})
    scale = default_x_scale(problem, *band)
    setup, setup_cpu = time.perf_counter() - start, cpu_seconds() - cpu
    peak = tracemalloc.get_traced_memory()[1] / 1e6
    tracemalloc.stop()
    system = NonlinearSystem(model, elements)
    timing = interleaved({"trace": timed(lambda: trace_frequency_response(system, {n - 1: 5.0}, *band))}, 3 if quick else 5)
    curve = timing["trace"].result
    per_point = timing["trace"].cpu_median / curve.omega.size
    print(f"\nPart 3b: {n} dense dofs (fixed–free chain, loss factor 0.01, cubic + Jenkins at the tip, 5 N), "
          f"band {band[0]:.1f}–{band[1]:.1f} rad/s; load average {load_average()}")
    print_table(
        "Amplitude-scale setup (fresh model: its eigenproblem included) and the trace",
        ["what", "CPU / wall (s)", "memory / points", "goal (on CPU time)"],
        [["default_x_scale (201 frequencies), once", f"{fmt_time(setup_cpu)} / {fmt_time(setup)}",
          f"peak {peak:.0f} MB traced (numpy)", "≤ 1 s, ≤ 500 MB: " + ("met" if setup_cpu <= 1 and peak <= 500 else "NOT met")],
         ["trace_frequency_response", f"{fmt_cpu_wall(timing['trace'])} (medians of {timing['trace'].times.size})",
          f"{curve.omega.size} points, {fmt_ms(per_point)} ms CPU per point",
          "≤ 5 ms per point: " + ("met" if per_point <= 5e-3 else "NOT met")]],
    )
    print(f"  x_scale {scale:.3e} m; folds {np.sort(curve.omega[curve.turning_point])} rad/s.")
