"""Smoke tests of benchmarks/frf (``python benchmarks/frf_speed.py``): its exact reference and
its equal-work set-ups.

The benchmark compares this project with pyHarm-os on equal point counts; these tests check
that the configured step controls still give those counts (pyHarm only when installed, as the
optional ``benchmark`` extra), that the fixed-grid sweeps solve every grid point, and that the
exact single-harmonic reference agrees with the solver. For the multi-harmonic part: the
constant-step point counts, the harmonic error measures, that the time-integration reference
starts from the whole harmonic-balance state (not the first harmonic alone), and that pyHarm's
harmonics are read in the project's convention.
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from benchmarks.frf import common, multi_harmonic, pyharm
from nlupdate.core.response.continuation import trace_frequency_response


@pytest.fixture(scope="module")
def bench():
    """The benchmark's parts under one name, as the tests below read them."""
    names = {**vars(common), **vars(pyharm), **vars(multi_harmonic), "trace_frequency_response": trace_frequency_response}
    return SimpleNamespace(**{k: v for k, v in names.items() if not k.startswith("__")})


@pytest.fixture(scope="module")
def grids(bench):
    grid = np.linspace(*bench.BAND, bench.N_GRID)
    folds = bench.exact_folds()
    return grid[grid < folds.max()], grid[grid > folds.min()][::-1]


def test_exact_folds(bench):
    np.testing.assert_allclose(bench.exact_folds(), [1.4416, 3.0290], atol=1e-4)


def test_exact_reference_agrees_with_the_trace(bench):
    curve = bench.trace_frequency_response(bench.duffing(), {0: bench.FORCE}, *bench.BAND)
    amplitude_error, distance = bench.exact_accuracy(curve.omega, curve.x_nonlinear[:, 0])
    assert amplitude_error < 1e-7 and distance < 1e-9
    # and it sees an error: 1e-4 more amplitude is 1e-4 off the curve away from the folds
    away = ~curve.turning_point
    shifted = bench.exact_accuracy(curve.omega[away], 1.0001 * np.abs(curve.x_nonlinear[away, 0]))
    assert shifted[0] == pytest.approx(1e-4, rel=0.01)


def test_traced_route_on_a_grid_is_exact_to_1e_8_away_from_folds(bench):
    """Issue 24: the traced describing-function route (continuation, then every grid point
    polished at once) within 1e-8 of the exact curve; its polish once stopped at Newton's
    residual tolerance, 1.4e-8 off."""
    from nlupdate.core.response.sweep import frequency_sweep

    grid = np.linspace(*bench.BAND, 2000)
    folds = bench.exact_folds()
    away = np.all(np.abs(grid[:, None] - folds[None, :]) > 0.01, axis=1)
    for direction in ("up", "down"):
        sweep = frequency_sweep(bench.duffing(), {0: bench.FORCE}, grid, direction, closed_form_roots=False,
                                fold_free=False)
        assert sweep.route == "traced"
        amplitude_error, _ = bench.exact_accuracy(grid[away], sweep.x_nonlinear[away, 0])
        assert amplitude_error < 1e-8, (direction, amplitude_error)


def test_project_point_counts(bench):
    system, forcing = bench.duffing(), {0: bench.FORCE}
    assert bench.trace_frequency_response(system, forcing, *bench.BAND).omega.size == 78
    fine = bench.trace_frequency_response(system, forcing, *bench.BAND, max_step=bench.PROJECT_MAX_STEP_283)
    assert abs(fine.omega.size - 283) <= 6


def test_newton_sweep_solves_the_common_grid(bench, grids):
    grid_up, grid_down = grids
    assert (grid_up.size, grid_down.size) == (168, 137)
    for sweep in grids:
        x, converged = bench.newton_sweep(bench.duffing(), {0: bench.FORCE}, sweep, tolerance=1e-12)
        assert converged.all()
        assert bench.exact_accuracy(sweep, x)[1] < 1e-10


def test_pyharm_set_ups_give_equal_point_counts(bench, grids):
    pytest.importorskip("pyHarm")
    _, coarse = bench.pyharm_run(bench.pyharm_constant_step(bench.PYHARM_STEP_78))
    assert abs(coarse["accepted"] - 78) <= 2
    _, former = bench.pyharm_run(bench.pyharm_continuation(**bench.PYHARM_STEP_FORMER))
    assert abs(former["accepted"] - 283) <= 6
    for sweep in grids:
        _, result = bench.pyharm_run(bench.pyharm_grid_sweep(sweep))
        assert result["accepted"] == result["solutions"] == sweep.size
        np.testing.assert_allclose(result["omega"], sweep, atol=1e-12)
        assert bench.exact_accuracy(result["omega"], result["x"])[1] < 1e-8


# ---- Part 1c: multi-harmonic balance against pyHarm-os and time integration ----------------
@pytest.fixture(scope="module")
def hb_curves(bench):
    return {h: bench.hb_trace(bench.duffing(), h, stability=False) for h in bench.HB_HARMONICS}


def test_hb_constant_step_point_counts(bench, hb_curves):
    # the step is chosen for 79–81 points at every H, as pyHarm's constant step gives 80–81
    for h, curve in hb_curves.items():
        assert 79 <= curve.omega.size <= 81, (h, curve.omega.size)
        assert curve.x_nonlinear.shape == (curve.omega.size, h + 1, 1)


def test_harmonic_errors(bench):
    reference = np.zeros((2, bench.HB_REFERENCE_HARMONICS + 1), complex)
    reference[:, 1], reference[:, 3], reference[:, 5] = 2.0, 0.1j, 1e-5
    exact = reference[:, :6].copy()
    first, higher, resolved = bench.harmonic_errors(exact, reference)
    np.testing.assert_allclose([first, higher], 0.0, atol=1e-15)
    assert resolved.all()
    perturbed = exact.copy()
    perturbed[:, 1] *= 1.001
    perturbed[:, 3] *= 1.02
    first, higher, _ = bench.harmonic_errors(perturbed, reference)
    np.testing.assert_allclose(first, 1e-3, rtol=1e-9)
    np.testing.assert_allclose(higher, 0.02 * 0.1 / np.hypot(0.1, 1e-5), rtol=1e-9)
    # one harmonic: everything above it is missing (100 %); small higher harmonics are not resolved
    first, higher, _ = bench.harmonic_errors(exact[:, :2], reference)
    np.testing.assert_allclose(higher, 1.0)
    reference[:, 3] = 1e-4
    assert not bench.harmonic_errors(exact, reference)[2].any()


def test_time_reference_starts_from_the_full_state(bench, hb_curves):
    # Upper-branch points of H = 3 near the fold at 3.039 rad/s: started from the whole
    # harmonic-balance state the integration stays on the branch (and agrees to the H = 3
    # truncation error); started from the first harmonic alone it falls to the lower branch.
    curve = hb_curves[3]
    upper = curve.stable & (np.abs(curve.x_nonlinear[:, 1, 0]) > 2.5)
    pick = [int(np.flatnonzero(upper)[np.argmin(np.abs(curve.omega[upper] - w))]) for w in (2.98, 3.02)]
    omega, states = curve.omega[pick], curve.x_nonlinear[pick, :, 0]
    first_only = np.zeros_like(states)  # the start steady_state_response takes by default
    first_only[:, 1] = states[:, 1]
    # both starts integrated as one batch (the cases are independent)
    both, converged = bench.time_reference(bench.duffing(), np.tile(omega, 2), np.vstack([states, first_only]), quick=True)
    reference, fallen = both[: omega.size], both[omega.size :]
    assert converged[: omega.size].all()
    first, higher, resolved = bench.harmonic_errors(states, reference)
    assert first.max() < 1e-3 and resolved.all() and higher.max() < 0.1
    assert np.all(np.abs(fallen[:, 1]) < 0.1 * np.abs(states[:, 1]))


def test_pyharm_multi_harmonic_points(bench, hb_curves):
    pytest.importorskip("pyHarm")
    for h in (3, 7):
        _, result = bench.pyharm_run(bench.pyharm_constant_step(bench.PYHARM_HB_STEP), h, bench.HB_SAMPLES)
        assert abs(result["accepted"] - 80) <= 1
        assert result["harmonics"].shape == (result["accepted"], h + 1)
        np.testing.assert_array_equal(result["x"], result["harmonics"][:, 1])
        # pyHarm's points solve this project's H-harmonic balance (checks X_k = c_k − i s_k)
        problem = hb_curves[h].problem
        for w, state in zip(result["omega"][::8], result["harmonics"][::8]):
            residual = problem.residual(problem.to_real(state[:, None]), w)
            assert np.max(np.abs(residual)) * problem.x_scale < 1e-8 * abs(state[1])


# ---- Part 3a: the closed form against the cubic's limits, counted on the same work ----------
def test_limits_are_the_roots_of_the_cubic(bench):
    from benchmarks.frf import grid as part3
    from benchmarks.frf.cubic_reference import companion_roots, trigonometric_roots

    omega = np.linspace(*bench.BAND, 301)
    problem = bench.CondensedProblem(bench.duffing(), {0: bench.FORCE})
    coefficients = part3.cubic_coefficients(problem, omega)
    trig, companion = trigonometric_roots(*coefficients), companion_roots(*coefficients)
    assert trig.shape == companion.shape == (omega.size, 3)
    three = 0
    for i, w in enumerate(omega):
        # independent: numpy's roots of the cubic from m, c, k (benchmarks/frf/common.py)
        roots = np.roots(bench._cubic(w))
        real = np.sort(roots.real[np.abs(roots.imag) <= 1e-9 * np.abs(roots)])
        three += real.size == 3
        np.testing.assert_allclose(np.sort(trig[i][np.isfinite(trig[i])]), real, rtol=1e-7)
        np.testing.assert_allclose(np.sort_complex(companion[i]), np.sort_complex(roots), rtol=1e-9, atol=1e-12)
    assert three > 50


def test_part3a_counts_both_directions_at_every_frequency(bench):
    """The rows of Part 3a's table do the same work per frequency: the closed form read both ways
    gives the sweeps frequency_sweep gives (up and down at every frequency) and the limits one
    root set per frequency of the same grid (quick size: 2000 frequencies)."""
    from benchmarks.frf import grid as part3
    from benchmarks.frf.cubic_reference import trigonometric_roots
    from nlupdate.core.response.sweep import frequency_sweep

    omega = np.linspace(*bench.BAND, 2000)
    system, forcing = bench.duffing(), {0: bench.FORCE}
    up, down = part3.closed_form_both(bench.CondensedProblem(system, forcing), omega)
    sweeps = [frequency_sweep(system, forcing, omega, direction) for direction in ("up", "down")]
    assert up.shape == down.shape == omega.shape
    for mine, sweep in zip((up, down), sweeps):
        assert sweep.route == "closed form" and sweep.x_nonlinear.shape == (omega.size, 1)
        np.testing.assert_array_equal(mine, sweep.x_nonlinear[:, 0])
    assert not np.allclose(np.abs(up), np.abs(down))  # the two directions differ between the folds
    assert trigonometric_roots(*part3.cubic_coefficients(bench.CondensedProblem(system, forcing), omega)).shape[0] == omega.size


def test_interleaved_times_cpu_beside_wall(bench):
    import subprocess
    import sys
    import time

    def child():
        # a child process that uses CPU and reports how much: counted in the parent's CPU time
        out = subprocess.run([sys.executable, "-c", "import time\nt = time.process_time()\nwhile time.process_time() - t < 0.05: pass\n"
                              "print(time.process_time())"], capture_output=True, text=True, check=True)
        return 0.0, float(out.stdout)

    timing = bench.interleaved({"sleep": bench.timed(lambda: time.sleep(0.05)), "own": lambda: (1.0, "r", 0.123),
                                "child": child}, 3)
    sleep = timing["sleep"]
    assert sleep.times.size == sleep.cpu.size == 3
    assert sleep.median >= 0.05 and sleep.cpu_median < 0.5 * sleep.median  # waiting is not CPU time
    assert timing["own"].cpu_median == 0.123 and timing["own"].result == "r"  # a task's own CPU figure is kept
    # the children's CPU is counted: each child spins 0.05 s of CPU (the parent's own share of a
    # spawn is a few ms), and the last call's figure covers what its child reported of itself
    assert timing["child"].cpu_best >= 0.05
    assert timing["child"].cpu[-1] >= timing["child"].result
