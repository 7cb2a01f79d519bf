"""Part 1c: the multi-harmonic balance like for like against pyHarm-os and time integration."""
from __future__ import annotations

import time
import warnings
from typing import Callable

import numpy as np

from nlupdate.core.model.system import NonlinearSystem
from nlupdate.core.response.continuation import trace_frequency_response
from nlupdate.core.response.harmonic_balance import HarmonicTruncationWarning, trace_harmonic_balance
from nlupdate.core.response.stepped_sine import stepped_sine
from nlupdate.core.response.time_integration import steady_state_response

from benchmarks.frf.common import (
    FORCE, N_GRID, BAND, BRANCH, HB_GOAL, HB_HILL_GOAL, HB_HARMONICS, HB_REFERENCE_HARMONICS, HB_RESOLVED, HB_SAMPLES, HB_STEP,
    PYHARM_HB_STEP, duffing, fmt_cpu_wall, fmt_list, fmt_ms, fmt_ratio, fmt_time, interleaved, load_average,
    print_table, timed,
)
from benchmarks.frf.pyharm import pyharm_constant_step, pyharm_grid_sweep, pyharm_run, pyharm_version, with_cpu


# --------------------------------------------------------------------------------------
# part 1c: multi-harmonic balance, like for like, against time integration
# --------------------------------------------------------------------------------------
def hb_trace(system: NonlinearSystem, harmonics: int, stability: bool, step: float = HB_STEP):
    """The project's multi-harmonic trace of the Duffing reference at constant step (see HB_STEP)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HarmonicTruncationWarning)  # the share is printed instead
        return trace_harmonic_balance(
            system, {0: FORCE}, *BAND, harmonics=harmonics, samples=HB_SAMPLES, stability=stability,
            step=step, max_step=step,
        )


def time_reference(
    system: NonlinearSystem, omega: np.ndarray, states: np.ndarray, quick: bool
) -> tuple[np.ndarray, np.ndarray]:
    """Harmonics X₀ … X_{HB_REFERENCE_HARMONICS} (n_points, …) and convergence flags of the steady
    state reached by time integration started from each point's full harmonic-balance state
    ``states`` (n_points, H+1): ``steady_state_response`` (RK4, all points at once; 512 steps
    per period and tolerance 1e-10, with ``quick`` 256 and 1e-9).

    ``steady_state_response`` starts from x(0) = Re X, ẋ(0) = Re(iωX) for a complex X, so the
    state x(0) = X₀ + Σ Re X_k, ẋ(0) = Σ Re(ikωX_k) of all harmonics is passed as
    X = x(0) − i ẋ(0)/ω.
    """
    steps, tolerance = (256, 1e-9) if quick else (512, 1e-10)
    states = np.asarray(states)
    k = np.arange(states.shape[1])
    x0 = states[:, 0].real + np.sum(states[:, 1:].real, axis=1)
    v0 = np.sum((1j * k * omega[:, None] * states).real, axis=1)
    result = steady_state_response(
        system, {0: FORCE}, omega, initial=(x0 - 1j * v0 / omega)[:, None], tolerance=tolerance,
        steps_per_period=steps, max_periods=5000, keep_history=True,
    )
    out = np.empty((omega.size, HB_REFERENCE_HARMONICS + 1), complex)
    for index, history in enumerate(result.history):
        spectrum = np.fft.rfft(history[0, 0]) / history.shape[-1]
        out[index, 0] = spectrum[0].real
        out[index, 1:] = 2 * spectrum[1 : HB_REFERENCE_HARMONICS + 1]
    return out, result.converged


def harmonic_errors(states: np.ndarray, reference: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per point: relative first-harmonic amplitude error; the amplitude error of harmonics
    2 … HB_REFERENCE_HARMONICS relative to their reference norm (harmonics above H count as 0);
    and whether that norm is resolved (≥ HB_RESOLVED × |X₁|)."""
    amplitude = np.zeros(reference.shape)
    count = min(states.shape[1], reference.shape[1])
    amplitude[:, :count] = np.abs(states[:, :count])
    ref = np.abs(reference)
    first = np.abs(amplitude[:, 1] - ref[:, 1]) / ref[:, 1]
    higher_ref = np.linalg.norm(ref[:, 2:], axis=1)
    higher = np.linalg.norm(amplitude[:, 2:] - ref[:, 2:], axis=1) / np.maximum(higher_ref, 1e-300)
    return first, higher, higher_ref >= HB_RESOLVED * ref[:, 1]


def hill_contradictions(hill_curve, determinant_curve) -> int:
    """Points (off the folds) that Hill's method calls stable while the Jacobian determinant of
    the same curve has the unstable sign (det ∂R/∂y < 0: an odd number of real multipliers > 1)."""
    det_unstable = ~determinant_curve.stable & ~determinant_curve.turning_point
    return int(np.sum(hill_curve.stable & det_unstable))


def multi_harmonic_benchmark(quick: bool) -> None:
    repeats = 3 if quick else 7
    system = duffing()
    version = pyharm_version()
    band_margin = 0.02 * (BAND[1] - BAND[0])
    print(
        f"\nPart 1c: multi-harmonic balance like for like — the same Duffing, H ∈ {set(HB_HARMONICS)}, "
        f"{HB_SAMPLES} time samples per period for both tools\n"
        f"  (pyHarm nti = the project's samples); constant-step continuation over the band: the project step = max_step ="
        f" {HB_STEP}\n  (scaled arc length; continuation steps up to 4× that, the points between corrected together —"
        f" docs/harmonic-balance.md), pyHarm stepsizer\n  'constant', ds = {PYHARM_HB_STEP} (its default"
        f" tangent predictor, arc-length corrector, scipy root hybr);"
        f" every time is the median of {repeats} interleaved repeats, CPU time (process and children) / wall;"
        f" ratios and goals on CPU time; load average {load_average()}"
    )
    tasks: dict[str, Callable[[], tuple[float, object]]] = {}
    for h in HB_HARMONICS:
        tasks[f"hb{h}"] = timed(lambda h=h: hb_trace(system, h, stability=False))
        tasks[f"hill{h}"] = timed(lambda h=h: hb_trace(system, h, stability=True))
        if version:
            tasks[f"ph{h}"] = lambda h=h: with_cpu(pyharm_run(pyharm_constant_step(PYHARM_HB_STEP), h, HB_SAMPLES))
    tasks["df"] = timed(lambda: trace_frequency_response(system, {0: FORCE}, *BAND, step=HB_STEP, max_step=HB_STEP))
    for task in tasks.values():  # warm-up (pyHarm's numba JIT), not timed
        task()
    timing = interleaved(tasks, repeats)

    # accuracy: stable points away from the folds, against time integration from each point's whole state
    curves, selected = {}, {}
    for h in HB_HARMONICS:
        curve = timing[f"hb{h}"].result
        folds = curve.omega[curve.turning_point]
        problem = curve.problem
        entries = {"hb": (curve.omega, curve.x_nonlinear[:, :, 0], curve.stable)}
        if version:
            r = timing[f"ph{h}"].result
            # pyHarm computes no stability: the same determinant criterion as the project's
            # stability=False, det ∂R/∂y of this project's H-harmonic balance at pyHarm's point
            stable, residual = [], []
            for w, state in zip(r["omega"], r["harmonics"]):
                y = problem.to_real(state[:, None])
                res, jac, _ = problem.residual_and_jacobians(y, w)
                stable.append(np.linalg.det(jac) > 0)
                residual.append(np.max(np.abs(res)) * problem.x_scale / abs(state[1]))
            entries["ph"] = (r["omega"], r["harmonics"], np.array(stable))
            r["residual"] = float(np.max(residual))
        for tool, (omega, states, stable) in entries.items():
            away = np.all(np.abs(omega[:, None] - folds[None, :]) > band_margin, axis=1)
            keep = stable & away
            selected[tool, h] = (omega[keep], states[keep], keep)
        curves[h] = (curve, folds)
    keys = list(selected)
    omega_all = np.concatenate([selected[key][0] for key in keys])
    start = time.perf_counter()
    width = max(HB_HARMONICS) + 1
    states_all = np.concatenate([np.pad(selected[key][1], ((0, 0), (0, width - selected[key][1].shape[1]))) for key in keys])
    reference, converged = time_reference(system, omega_all, states_all, quick)
    t_reference = time.perf_counter() - start
    errors, offset = {}, 0
    for key in keys:
        omega, states, _ = selected[key]
        ref = reference[offset : offset + omega.size]
        ok = converged[offset : offset + omega.size]
        offset += omega.size
        same = ok & (np.abs(np.abs(ref[:, 1]) - np.abs(states[:, 1])) < BRANCH * np.abs(states[:, 1]))
        first, higher, resolved = harmonic_errors(states[same], ref[same])
        errors[key] = {
            "n": int(same.sum()),
            "left": int((~same).sum()),
            "first": first,
            "higher": higher[resolved],
            "resolved": int(resolved.sum()),
        }

    def err_cell(values: np.ndarray) -> str:
        return f"{values.max():.1e} ({np.median(values):.1e})" if values.size else "—"

    rows, goal = [], []
    for h in HB_HARMONICS:
        curve, _ = curves[h]
        n_hb = curve.omega.size
        ph = timing.get(f"ph{h}")
        n_ph = ph.result["accepted"] if ph else 0
        variants = ([("ph", f"pyHarm-os {version}, nh = {h}")] if ph else []) + [
            ("hb", f"this project, H = {h}, stability=False (determinant sign)"),
            ("hill", f"this project, H = {h}, stability=True ("
                     + ("Hill)" if h > 1 else "at H = 1 the determinant again, no Hill)") + ", same curve"),
        ]
        if h == 1:
            variants.append(("df", "this project, describing-function trace (H = 1, no X₀), same step"))
        for tool, label in variants:
            t = timing[f"{tool}{h}" if tool != "df" else "df"]
            n = n_ph if tool == "ph" else t.result.omega.size
            if ph:
                per_curve = f"{fmt_ratio(ph.cpu_median / t.cpu_median)} ({fmt_ratio(ph.median / t.median)})"
                per_point = fmt_ratio((ph.cpu_median / n_ph) / (t.cpu_median / n))
            else:
                per_curve = per_point = "—"
            e = errors.get((tool, h))
            rows.append(
                [
                    label,
                    f"{n}",
                    fmt_cpu_wall(t),
                    fmt_ms(t.cpu_median / n),
                    per_curve,
                    per_point,
                    f"{e['n']} ({e['left']})" if e else "″" if tool == "hill" else "—",
                    err_cell(e["first"]) if e else "″" if tool == "hill" else "—",
                    (f"{err_cell(e['higher'])} [{e['resolved']}]" if e else "″" if tool == "hill" else "—"),
                ]
            )
        if ph:
            goal.append((h, n_hb, n_ph, ph.cpu_median / timing[f"hb{h}"].cpu_median, ph.median / timing[f"hb{h}"].median,
                         (ph.cpu_median / n_ph) / (timing[f"hb{h}"].cpu_median / n_hb)))
    print_table(
        "Time per curve and per point, pyHarm ÷ this project, and accuracy against time integration",
        ["method", "points", "CPU / wall per curve (s)", "CPU per point (ms)", "pyHarm ÷ this, curve CPU (wall)",
         "per point CPU",
         "compared (left branch)", "X1 error max (median)", f"harmonics 2–{HB_REFERENCE_HARMONICS} error max (median) [points]"],
        rows,
    )
    steps = "256 steps per period, tolerance 1e-9" if quick else "512 steps per period, tolerance 1e-10"
    print(
        f"  Accuracy: at every curve's points that are stable by the Jacobian determinant and farther than 2 % of the band"
        f" ({band_margin:.2f} rad/s)\n  from the project's folds at that H, against the vectorised RK4 integration"
        f" (steady_state_response, {steps}) started\n  from the point's full harmonic-balance state ({omega_all.size} points,"
        f" {fmt_time(t_reference)} s, {int(converged.sum())} converged); 'left branch': the integration settled more than"
        f" {100 * BRANCH:.0f} % away\n  (not compared). X1 error: |(|X1| − |X1,ref|)| / |X1,ref|. Harmonics 2–"
        f"{HB_REFERENCE_HARMONICS}: ‖ |X_k| − |X_k,ref| ‖ / ‖X_k,ref‖ over k = 2…{HB_REFERENCE_HARMONICS}"
        f" (harmonics above H count as 0, so H = 1 is 100 %),\n  at the [points] where they carry at least"
        f" {100 * HB_RESOLVED:.1f} % of |X1| (below that the integration's own error dominates)."
    )
    shares = ", ".join(f"H = {h}: {100 * curves[h][0].harmonic_share:.2g} %" for h in HB_HARMONICS)
    folds = "; ".join(f"H = {h}: {fmt_list(np.sort(curves[h][1]))}" for h in HB_HARMONICS)
    print(f"  Share of the two highest harmonics (truncation check): {shares}.\n  Folds (rad/s): {folds}.")
    hill_notes = []
    for h in HB_HARMONICS:
        hill, plain = timing[f"hill{h}"].result, timing[f"hb{h}"].result
        note = f"H = {h}: {timing[f'hill{h}'].cpu_median / timing[f'hb{h}'].cpu_median:.2f}× the trace"
        if np.array_equal(hill.omega, plain.omega):  # the same curve: compare the two stability verdicts
            det_unstable = ~plain.stable & ~plain.turning_point
            note += f", calls {hill_contradictions(hill, plain)} of {int(det_unstable.sum())} determinant-unstable points stable"
        hill_notes.append(note)
    print(
        "  Hill stability (stability=True) costs " + "; ".join(hill_notes) + ".\n"
        "  A negative determinant of ∂R/∂y means an odd number of real Floquet multipliers above 1 (unstable), so a\n"
        "  point that Hill's method calls stable there contradicts it; pyHarm-os computes no stability (its tangent"
        " predictor\n  only flags a sign change of det J as a fold or branching bifurcation)."
    )
    if version:
        residuals = ", ".join(f"H = {h}: {timing[f'ph{h}'].result['residual']:.1e}" for h in HB_HARMONICS)
        builds = [timing[f"ph{h}"].result["build"] for h in HB_HARMONICS]
        print(
            f"  pyHarm-os points satisfy this project's H-harmonic balance to a relative residual (max |R|·x_scale/|X1|) of"
            f" {residuals};\n  pyHarm times are operate(); building Maestro(...) adds {fmt_time(min(builds))}–"
            f"{fmt_time(max(builds))} s per curve (last run)."
        )
        print(
            f"  Goal (≥ {HB_GOAL:.0f}× faster than pyHarm-os at every H, stability=False like for like; CPU medians): "
            + "; ".join(f"H = {h}: {p} vs {q} points {c:.2f}× (wall {m:.2f}×, per point {pp:.2f}×)"
                        for h, p, q, c, m, pp in goal)
            + " — " + ("met." if min(g[3] for g in goal) >= HB_GOAL else "NOT met.")
        )
        hill_ratios = [timing[f"ph{h}"].cpu_median / timing[f"hill{h}"].cpu_median for h in HB_HARMONICS]
        print(
            f"  Goal (≥ {HB_HILL_GOAL:g}× pyHarm-os with stability on — Hill, at H = 1 the determinant — against its"
            " stability-free curve; CPU medians): "
            + ", ".join(f"H = {h}: {r:.2f}×" for h, r in zip(HB_HARMONICS, hill_ratios))
            + " — " + ("met." if min(hill_ratios) >= HB_HILL_GOAL else "NOT met.")
        )
    else:
        print("  pyHarm-os is not installed here: pip install -e '.[benchmark]' in a separate venv (it pins pandas < 3).")
    multi_harmonic_grid_benchmark(quick)


def multi_harmonic_grid_benchmark(quick: bool) -> None:
    """Part 1c(b): the multi-harmonic FRF on Part 1a's fixed grid, swept up to the upper fold and
    down to the lower one (the folds of each H, from the project's trace), both tools at
    equal points: pyHarm-os' fixed-ω sweeps (previous-solution predictor, as Part 1a(a)); the
    project's trace at its default steps, ``stability=False``, then ``stepped_sine`` up and
    down (all grid points polished together by batched Newton). Accuracy: the relative
    first-harmonic difference between the tools at each grid point, and each tool's largest
    relative residual in the project's H-harmonic balance."""
    repeats = 3 if quick else 5
    system, version = duffing(), pyharm_version()
    grid = np.linspace(*BAND, N_GRID)
    tasks, grids = {}, {}
    for h in HB_HARMONICS:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", HarmonicTruncationWarning)  # Part 1c(a) prints the shares
            curve = trace_harmonic_balance(system, {0: FORCE}, *BAND, harmonics=h, samples=HB_SAMPLES, stability=False)
        folds = np.sort(curve.omega[curve.turning_point])
        grids[h] = (grid[grid < folds[-1]], grid[grid > folds[0]][::-1])

        def project(h=h):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", HarmonicTruncationWarning)
                c = trace_harmonic_balance(system, {0: FORCE}, *BAND, harmonics=h, samples=HB_SAMPLES, stability=False)
            return stepped_sine(c, grids[h][0], "up"), stepped_sine(c, grids[h][1], "down")

        tasks[f"hb{h}"] = timed(project)
        if version:
            def pyharm(h=h):
                t_up, up = pyharm_run(pyharm_grid_sweep(grids[h][0]), h, HB_SAMPLES)
                t_down, down = pyharm_run(pyharm_grid_sweep(grids[h][1]), h, HB_SAMPLES)
                return t_up + t_down, (up, down), up["cpu"] + down["cpu"]

            tasks[f"ph{h}"] = pyharm
    for task in tasks.values():
        task()  # warm-up (pyHarm's JIT)
    timing = interleaved(tasks, repeats)
    rows, ratios = [], []
    for h in HB_HARMONICS:
        up, down = timing[f"hb{h}"].result
        problem = up.problem
        # SweepResult holds ascending ω; pyHarm returns sweep order (up, then down descending)
        x_project = np.concatenate([up.x_nonlinear, down.x_nonlinear[::-1]])[:, :, 0]
        omega = np.concatenate([up.omega, down.omega[::-1]])
        n = omega.size

        def worst_residual(omega, states):
            return max(np.max(np.abs(problem.residual(problem.to_real(s[:, None]), w))) * problem.x_scale / abs(s[1])
                       for w, s in zip(omega, states))

        t = timing[f"hb{h}"]
        cells = [f"H = {h}", f"{n}", fmt_cpu_wall(t), fmt_ms(t.cpu_median / n),
                 f"{worst_residual(omega, x_project):.1e}"]
        if version:
            ph = timing[f"ph{h}"]
            ph_up, ph_down = ph.result
            ph_omega = np.concatenate([ph_up["omega"], ph_down["omega"]])
            ph_states = np.concatenate([ph_up["harmonics"], ph_down["harmonics"]])
            n_ph = ph_omega.size
            same = (n_ph == n) and np.allclose(ph_omega, omega, atol=1e-9)
            difference = (np.max(np.abs(np.abs(ph_states[:, 1]) - np.abs(x_project[:, 1])) / np.abs(x_project[:, 1]))
                          if same else float("nan"))
            ratio = (ph.cpu_median / n_ph) / (t.cpu_median / n)
            ratios.append(ratio)
            cells += [f"{n_ph}", fmt_cpu_wall(ph), fmt_ms(ph.cpu_median / n_ph),
                      f"{worst_residual(ph_omega, ph_states):.1e}", f"{difference:.1e}", fmt_ratio(ratio)]
        rows.append(cells)
    header = ["H", "points", "project CPU / wall (s)", "CPU per point (ms)", "max residual"]
    if version:
        header += ["pyHarm points", "pyHarm CPU / wall (s)", "CPU per point (ms)", "max residual", "|X1| difference",
                   "pyHarm ÷ this (CPU)"]
    print_table(f"(b) Multi-harmonic FRF on the {N_GRID}-point grid, swept up to the upper fold and down to the lower one "
                f"(medians of {repeats} interleaved; load average {load_average()})", header, rows)
    if ratios:
        print(f"  Goal (≥ {HB_GOAL:.0f}× faster than pyHarm-os at every H, stability off) on the grid: "
              + ", ".join(f"{r:.2f}×" for r in ratios) + " — " + ("met." if min(ratios) >= HB_GOAL else "NOT met."))


