"""Smoke tests of benchmarks/frf_speed.py: its exact reference and its equal-work set-ups.

The benchmark compares this project with pyHarm-os on equal point counts; these tests check
that the configured step controls still give those counts (pyHarm only when installed, as the
optional ``benchmark`` extra), that the fixed-grid sweeps solve every grid point, and that the
exact single-harmonic reference agrees with the solver.
"""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

PATH = Path(__file__).resolve().parents[1] / "benchmarks" / "frf_speed.py"


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location("frf_speed_benchmark", PATH)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look the module up while the class is built
    spec.loader.exec_module(module)
    yield module
    sys.modules.pop(spec.name, None)


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


def test_project_point_counts(bench):
    system, forcing = bench.duffing(), {0: bench.FORCE}
    assert bench.trace_frequency_response(system, forcing, *bench.BAND).omega.size == 81
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
    _, coarse = bench.pyharm_run(bench.pyharm_constant_step(bench.PYHARM_STEP_81))
    assert abs(coarse["accepted"] - 81) <= 2
    _, former = bench.pyharm_run(bench.pyharm_continuation(**bench.PYHARM_STEP_FORMER))
    assert abs(former["accepted"] - 283) <= 6
    for sweep in grids:
        _, result = bench.pyharm_run(bench.pyharm_grid_sweep(sweep))
        assert result["accepted"] == result["solutions"] == sweep.size
        np.testing.assert_allclose(result["omega"], sweep, atol=1e-12)
        assert bench.exact_accuracy(result["omega"], result["x"])[1] < 1e-8
