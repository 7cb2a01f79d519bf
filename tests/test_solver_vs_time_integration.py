"""Describing-function solvers against direct time integration of the same systems.

* Stable points: the continuation's stable branches (stepped-sine emulation up and down on a
  frequency grid, all dofs) are used as initial conditions of the time integration. A stable
  DF point that is a true attractor stays put, and the first-harmonic amplitudes must agree
  within 2 %. "Away from folds" means farther than 2 % of the frequency band from every
  turning point the continuation reports; near a fold the single-harmonic and the
  multi-harmonic folds differ slightly, and a single-harmonic start can fall outside the
  branch's thin basin of attraction. The 3:1 superharmonic resonances (3ω at a natural
  frequency of the nonlinear system: ω ≈ 0.33–0.58 rad/s for the SDOF cases, ≈ 105–280 Hz
  for the 2-DOF) lie below the chosen bands, so no region is excluded for them; the measured
  harmonic ratio (RMS of harmonics ≥ 2 over the first) is asserted small where 2 % is claimed.
* Jumps: stepped_sine jumps at the continuation folds; time_sweep, a stepped sine in the time
  domain with the state carried over, jumps at the same grid points.
* The fixed-point iteration agrees with the continuation where it converges on a
  single-valued stretch (outside the fold band, where the DF equation has one solution).
"""
import numpy as np
import pytest

from nlupdate.core.response.continuation import trace_frequency_response
from nlupdate.core.model.elements import CubicStiffness, JenkinsFriction, SymmetricGap
from nlupdate.core.response.fixed_point import fixed_point_response
from nlupdate.core.model.linear import LumpedModel
from nlupdate.core.response.stepped_sine import stepped_sine
from nlupdate.core.model.system import NonlinearSystem
from nlupdate.core.response.time_integration import steady_state_response, time_sweep

TWO_PI = 2 * np.pi

# (a) hardening Duffing oscillator: m = 1 kg, c = 0.05 N·s/m, k = 1 N/m, k3 = 1 N/m³, F = 0.1 N.
DUFFING = NonlinearSystem(LumpedModel([[1.0]], [[1.0]], [[0.05]]), (CubicStiffness((0,), 1.0),))
DUFFING_FORCE, DUFFING_BAND = 0.1, (0.5, 2.5)

# (b) docs/methods.md §8 2-DOF: ground–k1–m1–k2–m2–k3–ground, γ = 0.005 on K, cubic + Jenkins at m1.
TWO_DOF = NonlinearSystem(
    LumpedModel.with_loss_factor(np.diag([0.1, 0.5]), 1e6 * np.array([[2.0, -1.0], [-1.0, 2.0]]), 0.005),
    (CubicStiffness((0,), 1e10), JenkinsFriction((0,), kf=8e4, slip_force=1.0)),
)
TWO_DOF_BAND = (TWO_PI * 600, TWO_PI * 850)

# (c) symmetric gap: m = 1, c = 0.05, k = 1, contact kc = 2 N/m beyond ±0.2 m, F = 0.1 N.
GAP = NonlinearSystem(LumpedModel([[1.0]], [[1.0]], [[0.05]]), (SymmetricGap((0,), gap=0.2, kc=2.0),))
GAP_FORCE, GAP_BAND = 0.1, (0.6, 2.5)


def stable_points(system, force, band, grid):
    """Stable DF points (all branches met by sweeps up and down) at grid frequencies away from folds."""
    curve = trace_frequency_response(system, {0: force}, *band)
    folds = curve.omega[curve.turning_point]
    omega, x = [], []
    dofs = range(system.model.n_dof)
    for direction in ("up", "down"):
        sweep = stepped_sine(curve, grid, direction)
        omega.append(sweep.omega)
        x.append(sweep.response(dofs))
    # keep a down-sweep point only where it lies on another branch than the up-sweep one
    other = np.abs(x[1] - x[0]).max(axis=1) > 1e-6 * np.abs(x[0]).max(axis=1)
    omega, x = np.concatenate([omega[0], omega[1][other]]), np.concatenate([x[0], x[1][other]])
    away = np.all(np.abs(omega[:, None] - folds[None, :]) > 0.02 * (band[1] - band[0]), axis=1)
    keep = away & np.all(np.isfinite(x), axis=1)
    return omega[keep], x[keep], folds


def assert_attractor_within(result, x_df, dofs, rtol):
    assert result.converged.all(), f"not converged at {result.omega[~result.converged]} rad/s"
    for dof in dofs:
        error = np.abs(np.abs(result.x[:, dof]) - np.abs(x_df[:, dof])) / np.abs(result.x[:, dof])
        worst = np.argmax(error)
        assert error[worst] < rtol, (
            f"dof {dof}: DF {abs(x_df[worst, dof]):.6g} m vs TI {abs(result.x[worst, dof]):.6g} m "
            f"at {result.omega[worst]:.6g} rad/s (harmonic ratio {result.harmonic_ratio[worst, dof]:.3g})"
        )


def assert_single_jump_across(grid, jumps, fold, direction):
    """One jump, at the first grid point past ``fold`` in the sweep direction (same units)."""
    assert len(jumps) == 1, f"expected one jump, got {jumps}"
    grid = np.sort(np.asarray(grid, float))
    i = int(np.argmin(np.abs(grid - jumps[0])))
    assert np.isclose(grid[i], jumps[0])
    low, high = (grid[i - 1], grid[i]) if direction == "up" else (grid[i], grid[i + 1])
    assert low < fold < high, f"{direction} jump at {jumps[0]:.6g}, fold at {fold:.6g}"


def test_duffing_stable_branches_are_time_domain_attractors_within_2_percent():
    omega, x_df, folds = stable_points(DUFFING, DUFFING_FORCE, DUFFING_BAND, np.linspace(*DUFFING_BAND, 21))
    assert folds.size == 2 and omega.size >= 20  # bistable: the nonlinearity matters
    result = steady_state_response(DUFFING, {0: DUFFING_FORCE}, omega, initial=x_df)
    assert_attractor_within(result, x_df, [0], 0.02)
    assert result.harmonic_ratio.max() < 0.03


def test_gap_stable_branches_are_time_domain_attractors_within_2_percent():
    omega, x_df, folds = stable_points(GAP, GAP_FORCE, GAP_BAND, np.linspace(*GAP_BAND, 21))
    assert folds.size == 2
    result = steady_state_response(GAP, {0: GAP_FORCE}, omega, initial=x_df)
    assert_attractor_within(result, x_df, [0], 0.02)
    assert result.harmonic_ratio.max() < 0.04


def two_dof_cases(frequencies_hz):
    """Stable DF points of the 2-DOF at 0.01 N (stuck friction), 1 N (slipping near the m1
    resonance) and 100 N (cubic hardening, two folds), stacked for one vectorised run."""
    omegas, forces, xs = [], [], []
    for force, hz in frequencies_hz.items():
        omega, x, _ = stable_points(TWO_DOF, force, TWO_DOF_BAND, TWO_PI * np.asarray(hz, float))
        omegas.append(omega)
        forces.append(np.full(omega.size, force))
        xs.append(x)
    return np.concatenate(omegas), np.concatenate(forces), np.concatenate(xs)


def test_two_dof_friction_and_cubic_match_time_integration_within_2_percent():
    omega, force, x_df = two_dof_cases(
        {0.01: [650, 745, 760], 1.0: [700, 738, 745, 800], 100.0: [650, 700, 800, 850]}
    )
    # the nonlinearity matters: at the stuck m1 resonance (745 Hz) the receptance |X|/F at
    # m1 drops by more than half from 0.01 N to 1 N (the slider slips: softer, more damped)
    at_745 = {f: np.isclose(omega, TWO_PI * 745) & (force == f) for f in (0.01, 1.0)}
    assert all(mask.sum() == 1 for mask in at_745.values()), "745 Hz must be a single-valued point"
    receptance = {f: abs(x_df[mask, 0][0]) / f for f, mask in at_745.items()}
    assert receptance[1.0] < 0.5 * receptance[0.01]
    assert (force == 100.0).sum() == 5  # 800 Hz is bistable at 100 N: both branches checked
    # tolerance 1e-4 on the period-to-period change; 32 steps per period (RK4 error ≈ 0.1 %
    # at the lightly damped resonance); the broad grid with 1e-6 and 64 steps is a slow test.
    result = steady_state_response(
        TWO_DOF, {0: force}, omega, initial=x_df, tolerance=1e-4, steps_per_period=32, max_periods=3000
    )
    assert_attractor_within(result, x_df, [0, 1], 0.02)
    assert result.harmonic_ratio[:, 0].max() < 0.02


def test_duffing_sweeps_jump_at_the_continuation_folds_and_in_the_time_domain():
    curve = trace_frequency_response(DUFFING, {0: DUFFING_FORCE}, *DUFFING_BAND)
    upper_fold, lower_fold = sorted(curve.omega[curve.turning_point], reverse=True)
    # short sweeps across each fold, starting on the branch that ends there; folds inside a cell
    up_grid = np.array([1.43, 1.47, 1.50, 1.54, 1.58])
    down_grid = np.array([1.11, 1.15, 1.19, 1.22, 1.26])
    up = stepped_sine(curve, up_grid, "up")
    down = stepped_sine(curve, down_grid, "down")
    assert_single_jump_across(up_grid, TWO_PI * np.array(up.jumps_hz), upper_fold, "up")
    assert_single_jump_across(down_grid, TWO_PI * np.array(down.jumps_hz), lower_fold, "down")
    # time domain, state carried from frequency to frequency
    t_up = time_sweep(DUFFING, {0: DUFFING_FORCE}, up_grid, "up", initial=up.x_nonlinear[0], steps_per_period=32)
    t_down = time_sweep(
        DUFFING, {0: DUFFING_FORCE}, down_grid, "down", initial=down.x_nonlinear[-1], steps_per_period=32
    )
    assert t_up.converged.all() and t_down.converged.all()
    assert t_up.jumps_hz == pytest.approx(up.jumps_hz)
    assert t_down.jumps_hz == pytest.approx(down.jumps_hz)
    # away from the fold cell the time-domain sweep follows the same branches
    for sweep, td in ((up, t_up), (down, t_down)):
        np.testing.assert_allclose(np.abs(td.x[:, 0]), np.abs(sweep.x_nonlinear[:, 0]), rtol=0.02)


@pytest.mark.parametrize(
    "system, force, band",
    [
        (DUFFING, DUFFING_FORCE, DUFFING_BAND),
        (GAP, GAP_FORCE, GAP_BAND),
        (TWO_DOF, 1.0, TWO_DOF_BAND),
        (TWO_DOF, 100.0, TWO_DOF_BAND),
    ],
    ids=["duffing", "gap", "two_dof_1N", "two_dof_100N"],
)
def test_fixed_point_agrees_with_continuation_on_single_valued_stretches(system, force, band):
    curve = trace_frequency_response(system, {0: force}, *band)
    folds = curve.omega[curve.turning_point]
    grid = np.linspace(*band, 60)
    if folds.size:  # single-valued outside the fold band, with a 2 %-of-band margin
        margin = 0.02 * (band[1] - band[0])
        grid = grid[(grid < folds.min() - margin) | (grid > folds.max() + margin)]
    fixed = fixed_point_response(system, {0: force}, grid, tolerance=1e-10, max_iterations=5000)
    newton = stepped_sine(curve, grid, "up")
    ok = fixed.converged
    assert ok.sum() >= 0.5 * grid.size, f"fixed point converged at only {ok.sum()} of {grid.size} points"
    error = np.abs(fixed.x_nonlinear[ok] - newton.x_nonlinear[ok]) / np.abs(newton.x_nonlinear[ok])
    assert error.max() < 1e-6


@pytest.mark.slow
def test_two_dof_broad_grid_with_tight_time_integration_tolerance():
    frequencies = np.linspace(600, 850, 26)
    omega, force, x_df = two_dof_cases({0.01: frequencies, 1.0: frequencies, 100.0: frequencies})
    result = steady_state_response(TWO_DOF, {0: force}, omega, initial=x_df, tolerance=1e-6, max_periods=8000)
    assert_attractor_within(result, x_df, [0, 1], 0.02)


@pytest.mark.slow
def test_duffing_full_band_time_sweeps_jump_within_one_grid_step_of_the_folds():
    curve = trace_frequency_response(DUFFING, {0: DUFFING_FORCE}, *DUFFING_BAND)
    upper_fold, lower_fold = sorted(curve.omega[curve.turning_point], reverse=True)
    # 0.03 rad/s steps, offset so that no grid point is within 0.5 % of a fold of either
    # model (time-domain folds measured at ≈ 1.168–1.170 and 1.520–1.525 rad/s)
    grid = np.arange(0.815, 1.9, 0.03)
    for direction, fold in (("up", upper_fold), ("down", lower_fold)):
        emulated = stepped_sine(curve, grid, direction)
        swept = time_sweep(DUFFING, {0: DUFFING_FORCE}, grid, direction, steps_per_period=32)
        assert swept.converged.all()
        assert swept.jumps_hz == pytest.approx(emulated.jumps_hz)
        assert_single_jump_across(grid, TWO_PI * np.array(swept.jumps_hz), fold, direction)


@pytest.mark.slow
def test_two_dof_100N_time_sweeps_jump_across_the_continuation_folds():
    curve = trace_frequency_response(TWO_DOF, {0: 100.0}, *TWO_DOF_BAND)
    upper_fold, lower_fold = sorted(curve.frequency_hz[curve.turning_point], reverse=True)
    # Up: 2 Hz steps on the resonant branch (half-power bandwidth γf ≈ 4 Hz); coarser steps
    # throw the response out of that branch's basin before the fold, as in a real test.
    # Time-domain folds measured near 823–825 Hz (DF 826.6) and ≤ 744.8 Hz (DF 744.8).
    cases = (
        ("up", np.array([814.0, 816.0, 818.0, 820.0, 828.0, 832.0]), upper_fold),
        ("down", np.array([728.0, 736.0, 753.0, 762.0]), lower_fold),
    )
    for direction, grid_hz, fold in cases:
        grid = TWO_PI * grid_hz
        emulated = stepped_sine(curve, grid, direction)
        start = emulated.response([0, 1])[0 if direction == "up" else -1]
        swept = time_sweep(
            TWO_DOF, {0: 100.0}, grid, direction, initial=start, tolerance=1e-4, steps_per_period=32, max_periods=6000
        )
        assert swept.converged.all()
        assert swept.jumps_hz == pytest.approx(emulated.jumps_hz)
        assert_single_jump_across(grid_hz, swept.jumps_hz, fold, direction)
