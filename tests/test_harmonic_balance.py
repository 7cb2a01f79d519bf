"""Multi-harmonic balance against independent references.

References: the describing functions (closed forms, H = 1), finite differences (Jacobians),
the project's RK4 time integration and scipy's DOP853 (periodic steady states with all their
harmonics), and the geometry of the curve (folds) for stability.
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from nlupdate.core.model.elements import (
    CoulombFriction,
    CubicStiffness,
    JenkinsFriction,
    PolynomialDF,
    QuadraticDamping,
    SymmetricGap,
)
from nlupdate.core.model.linear import LumpedModel
from nlupdate.core.model.system import NonlinearSystem
from nlupdate.core.response.aft import Fourier, period_forces
from nlupdate.core.response.continuation import trace_frequency_response
from nlupdate.core.response.harmonic_balance import HarmonicTruncationWarning, trace_harmonic_balance
from nlupdate.core.response.stepped_sine import stepped_sine
from nlupdate.core.response.time_integration import steady_state_response

SDOF = LumpedModel([[1.0]], [[1.0]], [[0.05]])
DUFFING = NonlinearSystem(SDOF, (CubicStiffness((0,), 1.0),))
JENKINS = NonlinearSystem(SDOF, (JenkinsFriction((0,), kf=2.0, slip_force=0.1),))
GAP = NonlinearSystem(SDOF, (SymmetricGap((0,), gap=0.2, kc=2.0),))
TWO_DOF = NonlinearSystem(
    LumpedModel.with_loss_factor(np.diag([0.1, 0.5]), 1e6 * np.array([[2.0, -1.0], [-1.0, 2.0]]), 0.005),
    (CubicStiffness((0,), 1e10), JenkinsFriction((0,), kf=8e4, slip_force=1.0)),
)
ELEMENTS = [
    CubicStiffness((0,), 2.0),
    JenkinsFriction((0,), 3.0, 0.5),
    CoulombFriction((0,), 0.4),
    QuadraticDamping((0,), 0.3),
    SymmetricGap((0,), 0.2, 5.0),
    PolynomialDF((0,), (1.0, 0.5, 2.0), (0.3, 0.1)),
]


def _quiet_trace(*args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HarmonicTruncationWarning)
        return trace_harmonic_balance(*args, **kwargs)


def _harmonics_of(samples: np.ndarray, count: int) -> np.ndarray:
    """X₀ … X_count of one period of samples (x = X₀ + Σ Re X_k e^{ikθ})."""
    spectrum = np.fft.rfft(samples) / samples.size
    return np.concatenate([[spectrum[0].real], 2 * spectrum[1 : count + 1]])


# -- the AFT element forces ------------------------------------------------------------------
@pytest.mark.parametrize("element", ELEMENTS, ids=lambda e: type(e).__name__)
def test_one_harmonic_aft_force_is_the_describing_function(element):
    amplitude, omega = 0.7, 1.3
    g = period_forces(element, np.array([0.0, amplitude, 0.0]), omega, Fourier(1, 4096)).g
    expected = complex(element.describing_function(amplitude, omega)) * amplitude
    assert g[0] == pytest.approx(0.0, abs=1e-12)
    assert complex(g[1], g[2]) == pytest.approx(expected, rel=2e-6)


@pytest.mark.parametrize("element", ELEMENTS, ids=lambda e: type(e).__name__)
def test_aft_jacobians_match_central_differences(element):
    fourier = Fourier(5, 64)
    rng = np.random.default_rng(3)
    c = rng.standard_normal(11) * np.array([0.1] + [1 / (k + 1) ** 2 for k in range(10)])
    period = period_forces(element, c, 1.3, fourier)
    h = 1e-7
    columns = []
    for i in range(c.size):
        d = np.zeros(c.size)
        d[i] = h
        columns.append((period_forces(element, c + d, 1.3, fourier).g - period_forces(element, c - d, 1.3, fourier).g) / (2 * h))
    numeric = np.array(columns).T
    d_omega = (period_forces(element, c, 1.3 + h, fourier).g - period_forces(element, c, 1.3 - h, fourier).g) / (2 * h)
    assert np.abs(numeric - period.dg_dc).max() <= 1e-6 * np.abs(numeric).max()
    assert np.abs(d_omega - period.dg_domega).max() <= 1e-6 * max(1.0, np.abs(d_omega).max())


# -- H = 1 is the describing-function solver -------------------------------------------------
@pytest.mark.parametrize(
    "system, force, band, samples, rtol",
    [
        (DUFFING, 0.5, (0.5, 3.5), None, 1e-9),  # the cubic law is sampled exactly
        (TWO_DOF, 100.0, (2 * np.pi * 600, 2 * np.pi * 900), 8192, 2e-5),  # Jenkins: slip onset on the samples
    ],
    ids=["duffing", "two-dof-cubic-jenkins"],
)
def test_one_harmonic_reproduces_the_describing_function_curve(system, force, band, samples, rtol):
    df = trace_frequency_response(system, {0: force}, *band)
    # fill=1: every point by the continuation, as the describing-function trace does, so the
    # two curves have the same points
    hb = trace_harmonic_balance(system, {0: force}, *band, harmonics=1, samples=samples, fill=1)
    assert hb.omega.shape == df.omega.shape
    np.testing.assert_allclose(hb.omega, df.omega, rtol=rtol)
    dofs = list(range(system.model.n_dof))
    np.testing.assert_allclose(hb.response(dofs), df.response(dofs), rtol=10 * rtol, atol=1e-12)
    assert np.array_equal(hb.stable, df.stable) and np.array_equal(hb.turning_point, df.turning_point)
    assert np.abs(hb.x_nonlinear[:, 0]).max() < 1e-9 * np.abs(hb.x_nonlinear[:, 1]).max()  # no constant term


# -- against time integration ----------------------------------------------------------------
def _stable_points_away_from_folds(curve, grid, margin):
    folds = curve.omega[curve.turning_point]
    sweep = stepped_sine(curve, grid, "up")
    keep = np.isfinite(sweep.x_nonlinear.reshape(grid.size, -1)).all(axis=1)
    keep &= np.all(np.abs(grid[:, None] - folds[None, :]) > margin, axis=1) if folds.size else True
    return grid[keep], sweep.harmonics([0])[keep, :, 0]


def _sdof_dop853(law, force: float, omega: float, x0: float, v0: float, periods: int = 60, samples: int = 256) -> np.ndarray:
    """One period of samples of the steady state of ``ẍ + 0.05ẋ + x + law(x) = F cos ωt`` by
    scipy's DOP853 started at (x0, v0)."""
    period = 2 * np.pi / omega

    def rhs(t, y):
        return [y[1], force * np.cos(omega * t) - 0.05 * y[1] - y[0] - law(y[0])]

    t_eval = (periods - 1) * period + period * np.arange(samples) / samples
    solution = solve_ivp(rhs, (0.0, periods * period), [x0, v0], method="DOP853", rtol=1e-11, atol=1e-13, t_eval=t_eval)
    return solution.y[0]


def _state_at_zero(harmonics: np.ndarray, omega: float) -> tuple[float, float]:
    """x(0), ẋ(0) of ``X₀ + Σ Re(X_k e^{ikωt})``."""
    k = np.arange(1, harmonics.size)
    return float(harmonics[0].real + np.sum(harmonics[1:].real)), float(-omega * np.sum(k * harmonics[1:].imag))


def test_duffing_at_half_a_newton_within_0p2_percent_of_two_time_integrations():
    curve = _quiet_trace(DUFFING, {0: 0.5}, 0.5, 3.5, harmonics="auto")
    assert curve.problem.harmonics == 7 and curve.harmonic_share < 1e-3
    omega, hb = _stable_points_away_from_folds(curve, np.linspace(0.6, 3.4, 12), 0.06)
    assert omega.size >= 10
    df = stepped_sine(trace_frequency_response(DUFFING, {0: 0.5}, 0.5, 3.5), omega, "up").response([0])[:, 0]
    own = steady_state_response(
        DUFFING, {0: 0.5}, omega, initial=hb[:, 1][:, None], tolerance=1e-10, steps_per_period=256,
        keep_history=True, max_periods=4000,
    )
    assert own.converged.all()
    df_errors = []
    for i, w in enumerate(omega):
        x0, v0 = _state_at_zero(hb[i], w)
        for samples in (own.history[i][0, 0], _sdof_dop853(lambda x: x**3, 0.5, w, x0, v0)):
            reference = _harmonics_of(samples, 5)
            assert abs(abs(hb[i, 1]) - abs(reference[1])) < 2e-3 * abs(reference[1])
            for k in (3, 5):  # higher harmonics, relative to the first
                assert abs(hb[i, k] - reference[k]) < 2e-3 * abs(reference[1])
        df_errors.append(abs(abs(df[i]) - abs(reference[1])) / abs(reference[1]))
    assert max(df_errors) > 0.01  # the single-harmonic result is percent-level off here


@pytest.mark.parametrize("system, force", [(JENKINS, 0.3), (GAP, 0.1)], ids=["jenkins", "gap"])
def test_friction_and_gap_within_0p2_percent_of_time_integration_with_the_checked_harmonics(system, force):
    curve = _quiet_trace(system, {0: force}, 0.5, 2.5, harmonics="auto")
    assert curve.harmonic_share <= 1e-3
    omega, hb = _stable_points_away_from_folds(curve, np.linspace(0.6, 2.4, 9), 0.03)
    df = stepped_sine(trace_frequency_response(system, {0: force}, 0.5, 2.5), omega, "up").response([0])[:, 0]
    # RK4 from each point's whole harmonic-balance state, 512 steps per period (the first
    # harmonics move by < 1.2e-6 with 2048 steps; settled to 1e-8 per period)
    state = np.array([_state_at_zero(hb[i], w) for i, w in enumerate(omega)])
    reference = steady_state_response(
        system, {0: force}, omega, initial=(state[:, 0] - 1j * state[:, 1] / omega)[:, None], tolerance=1e-8,
        steps_per_period=512, keep_history=True, max_periods=4000,
    )
    assert reference.converged.all()
    first = np.array([_harmonics_of(h[0, 0], 3) for h in reference.history])
    hb_error = np.abs(np.abs(hb[:, 1]) - np.abs(first[:, 1])) / np.abs(first[:, 1])
    df_error = np.abs(np.abs(df) - np.abs(first[:, 1])) / np.abs(first[:, 1])
    assert hb_error.max() < 2e-3
    assert df_error.max() > 5 * hb_error.max()
    assert np.abs(hb[:, 3] - first[:, 3]).max() < 2e-3 * np.abs(first[:, 1]).max()
    if system is GAP:  # scipy too (a Jenkins slider is history that scipy's integrators do not carry)
        def law(x):
            return 2.0 * (x - 0.2 * np.sign(x)) if abs(x) > 0.2 else 0.0
        for i, w in enumerate(omega):
            scipy_first = _harmonics_of(_sdof_dop853(law, force, w, *_state_at_zero(hb[i], w)), 3)
            assert abs(abs(hb[i, 1]) - abs(scipy_first[1])) < 2e-3 * abs(scipy_first[1])


def test_duffing_superharmonic_resonance_three_to_one():
    """Near ω ≈ ω₀/3 the third harmonic resonates: a peak of |X₃| the single harmonic cannot show."""
    curve = _quiet_trace(DUFFING, {0: 0.5}, 0.2, 0.9, harmonics="auto")
    assert curve.problem.harmonics > 7 and curve.harmonic_share < 1e-3  # H = 7 leaves 1.7 % here
    x3 = np.abs(curve.x_nonlinear[:, 3, 0])
    peak = int(np.argmax(x3))
    assert 0 < peak < x3.size - 1 and x3[peak] > 5 * max(x3[0], x3[-1])
    omega = curve.omega[peak]
    assert 0.3 < omega < 0.5  # 3ω near the stiffened natural frequency
    df = trace_frequency_response(DUFFING, {0: 0.5}, 0.2, 0.9).response([0])[:, 0]
    assert np.all(np.diff(np.abs(df)) > 0)  # one harmonic: no resonance in this band
    result = steady_state_response(
        DUFFING, {0: 0.5}, [omega], initial=[[curve.x_nonlinear[peak, 1, 0]]], tolerance=1e-10,
        steps_per_period=256, keep_history=True, max_periods=4000,
    )
    reference = _harmonics_of(result.history[0][0, 0], 3)
    assert abs(curve.x_nonlinear[peak, 3, 0] - reference[3]) < 1e-3 * abs(reference[3])


# -- stability -------------------------------------------------------------------------------
def test_hill_flags_exactly_the_branch_between_the_folds_and_time_integration_leaves_it():
    curve = _quiet_trace(DUFFING, {0: 0.5}, 0.5, 3.5, harmonics=5)
    folds = np.flatnonzero(curve.turning_point)
    assert folds.size == 2 and not curve.bifurcations
    inside = np.zeros(curve.omega.size, bool)
    inside[folds[0] : folds[1] + 1] = True
    assert np.array_equal(~curve.stable, inside)
    mu = np.abs(curve.floquet_multipliers).max(axis=1)
    assert np.all(np.abs(mu[folds] - 1.0) < 2e-3)  # a multiplier leaves through +1 at each fold
    middle = (folds[0] + folds[1]) // 2
    result = steady_state_response(
        DUFFING, {0: 0.5}, [curve.omega[middle]], initial=[[curve.x_nonlinear[middle, 1, 0]]], tolerance=1e-8,
        max_periods=4000,
    )
    assert abs(abs(result.x[0, 0]) - abs(curve.x_nonlinear[middle, 1, 0])) > 0.2 * abs(curve.x_nonlinear[middle, 1, 0])


def _nes() -> NonlinearSystem:
    """Primary oscillator with a light nonlinear energy sink (cubic coupling): Neimark–Sacker."""
    mass = np.diag([1.0, 0.05])
    linear = 0.002
    stiffness = np.array([[1.0 + linear, -linear], [-linear, linear]])
    damping = np.array([[0.007, -0.005], [-0.005, 0.005]])
    return NonlinearSystem(LumpedModel(mass, stiffness, damping), (CubicStiffness((0, 1), 1.0),))


def test_neimark_sacker_of_an_energy_sink_is_where_time_integration_stops_settling_on_the_orbit():
    system = _nes()
    curve = _quiet_trace(system, {0: 0.01}, 0.8, 1.2, harmonics=5)
    ns = [b for b in curve.bifurcations if b.kind == "Neimark–Sacker"]
    assert len(ns) == 1
    index = ns[0].index
    multiplier = ns[0].multiplier
    assert abs(multiplier) > 1 and 0.15 < abs(np.angle(multiplier)) < np.pi - 0.15
    before, after = [index - 4, index - 2], [index + 1, index + 3]
    assert curve.stable[before].all() and not curve.stable[after].any()
    assert curve.omega[before].max() < ns[0].omega < curve.omega[after].min()
    picks = before + after
    x = curve.harmonics([0, 1])[picks]
    result = steady_state_response(system, {0: 0.01}, curve.omega[picks], initial=x[:, 1], tolerance=1e-7, max_periods=1500)
    distance = np.linalg.norm(result.x - x[:, 1], axis=1) / np.linalg.norm(x[:, 1], axis=1)
    assert result.converged[:2].all() and distance[:2].max() < 1e-3  # stable: settles on the orbit
    assert np.all(~result.converged[2:] | (distance[2:] > 0.5))  # unstable: leaves it


# -- the truncation check --------------------------------------------------------------------
def test_truncation_warning_names_the_share_and_auto_raises_the_harmonics():
    with pytest.warns(HarmonicTruncationWarning, match=r"H = 3: the highest harmonics carry 7\.8 %"):
        trace_harmonic_balance(DUFFING, {0: 0.5}, 0.5, 3.5, harmonics=3, stability=False)
    with warnings.catch_warnings():
        warnings.simplefilter("error", HarmonicTruncationWarning)
        curve = trace_harmonic_balance(DUFFING, {0: 0.5}, 0.5, 3.5, harmonics=7, stability=False)
    shares = np.abs(curve.x_nonlinear[:, 1:, 0])
    shares = shares / np.linalg.norm(shares, axis=1, keepdims=True)
    assert curve.harmonic_share == pytest.approx(shares[:, -2:].max(), rel=1e-12)
    with pytest.warns(HarmonicTruncationWarning, match="N = 16 samples per period"):
        trace_harmonic_balance(GAP, {0: 0.1}, 0.5, 2.5, harmonics=7, samples=16, stability=False)


def test_bad_settings_are_named():
    with pytest.raises(ValueError, match="harmonics: expected an integer ≥ 1 or 'auto'"):
        trace_harmonic_balance(DUFFING, {0: 0.5}, 0.5, 3.5, harmonics=0)
    with pytest.raises(ValueError, match="samples per period: 8 cannot carry 5 harmonics"):
        trace_harmonic_balance(DUFFING, {0: 0.5}, 0.5, 3.5, harmonics=5, samples=8)
    free = NonlinearSystem(LumpedModel(np.eye(2), [[1.0, -1.0], [-1.0, 1.0]]), (CubicStiffness((0, 1), 1.0),))
    with pytest.raises(ValueError, match="grounded model"):
        trace_harmonic_balance(free, {0: 0.5}, 0.5, 3.5, harmonics=3)


def test_stepped_sine_on_the_multi_harmonic_curve_jumps_past_its_own_fold():
    """Up-sweep past the upper fold: the jump is at the first grid point past the multi-harmonic
    fold (3.0389 rad/s), one grid step after the single-harmonic one (3.0290)."""
    grid = np.arange(3.000, 3.0601, 0.005)
    for curve in (_quiet_trace(DUFFING, {0: 0.5}, 0.5, 3.5, harmonics=7), trace_frequency_response(DUFFING, {0: 0.5}, 0.5, 3.5)):
        upper_fold = curve.omega[curve.turning_point].max()
        expected = grid[grid > upper_fold][0] / (2 * np.pi)
        assert stepped_sine(curve, grid, "up").jumps_hz == pytest.approx((expected,), rel=1e-12)


def test_hill_with_friction_is_unstable_exactly_between_the_folds():
    """Jenkins forces depend on the last slip: the Hill matrix must use the balance's own
    Jacobian, or spurious branch points appear (a local stick/slip tangent gave 16 at 60 N)."""
    curve = _quiet_trace(TWO_DOF, {0: 60.0}, 2 * np.pi * 600, 2 * np.pi * 900, harmonics=3)
    folds = np.flatnonzero(curve.turning_point)
    assert folds.size == 2 and not curve.bifurcations
    inside = np.zeros(curve.omega.size, bool)
    inside[folds[0] : folds[1] + 1] = True
    assert np.array_equal(~curve.stable, inside)
    assert np.allclose(np.abs(curve.floquet_multipliers[folds]).max(axis=1), 1.0, atol=1e-5)
