"""PRD/DDF identification of an Iwan joint from time-integration data (no describing-function
assumption; the joint's sliders in time), with docs/methods.md §8 noise over several seeds.

Truth: the docs/methods.md §8 SDOF (m = 0.1 kg, k = 2e6 N/m, loss factor 0.01) with an Iwan joint to
ground, F_S = 1 N, K_T = 3e5 N/m, χ = −0.5, β = 0.5 (φ_max = 6 µm); the high levels drive it
from microslip (0.13 φ_max) into macroslip (20 φ_max).
"""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.dfmodels import PhysicalModel
from nlupdate.core.identification.ddf import identify_ddf
from nlupdate.core.identification.pipeline import IdentificationSettings, identify
from nlupdate.core.identification.prd import identify_prd
from nlupdate.core.measurement.frf_table import frf_table
from nlupdate.core.measurement.noise import add_table_noise
from nlupdate.core.model.elements import IwanJoint, JenkinsFriction
from nlupdate.core.model.linear import LumpedModel
from nlupdate.core.model.system import NonlinearSystem
from nlupdate.core.response.simulate import simulate_frf_table
from nlupdate.core.response.time_integration import steady_state_response

TRUTH = IwanJoint((0,), slip_force=1.0, kt=3e5, chi=-0.5, beta=0.5)
LINEAR = LumpedModel.with_loss_factor([[0.1]], [[2e6]], 0.01)
WINDOW_HZ = np.linspace(706.0, 714.0, 9)
SEEDS = (1, 2, 3, 4, 5)


def time_integration_table(system: NonlinearSystem, levels, frequency_hz) -> pd.DataFrame:
    """Steady-state first harmonics by time integration (started from the describing-function
    solution, which only shortens the transient) at every level and frequency."""
    start, _ = simulate_frf_table(system, 0, frequency_hz, levels)
    force = start["force_level_n"].to_numpy()
    frequency = start["frequency_hz"].to_numpy()
    guess = (start["h_real"].to_numpy() + 1j * start["h_imag"].to_numpy()) * force
    result = steady_state_response(system, {0: force}, 2 * np.pi * frequency, initial=guess[:, None], tolerance=1e-7)
    assert result.converged.all()
    names = np.array(system.model.dof_names, dtype=object)[None, :]
    return frf_table(frequency[:, None], force[:, None], names, system.model.dof_names[0], result.x / force[:, None])


@pytest.fixture(scope="module")
def iwan_table():
    return time_integration_table(NonlinearSystem(LINEAR, (TRUTH,)), [0.01] + list(np.geomspace(0.2, 4.0, 9)), WINDOW_HZ)


def test_prd_recovers_the_iwan_joint_from_time_integration_with_2_percent_noise_over_five_seeds(iwan_table):
    errors = []
    for seed in SEEDS:
        data = FRFLevels.from_table(add_table_noise(iwan_table, 0.02, seed), "0", "0")
        result = identify_prd(data, 710.0, PhysicalModel(("iwan",)), estimator="improved", half_window=0.006)
        p = result.parameters()
        errors.append((p["slip_force"] / 1.0 - 1, p["kt"] / 3e5 - 1, p["chi"] + 0.5, p["beta"]))
    errors = np.array(errors)
    assert np.abs(errors[:, 0]).max() < 0.05 and np.abs(errors[:, 1]).max() < 0.05, errors
    assert np.abs(errors[:, 2]).max() < 0.05, errors


def test_ddf_with_an_iwan_joint_over_five_seeds():
    """DDF (the source's comparison method), a microslip and a macroslip level over 640–780 Hz,
    rows weighted by their noise (the naive fit is worse here: F_S −6…+2.5 %, χ −0.08…+0.23)."""
    table = time_integration_table(NonlinearSystem(LINEAR, (TRUTH,)), [0.3, 3.0], np.linspace(640.0, 780.0, 29))
    errors = []
    for seed in SEEDS:
        data = FRFLevels.from_table(add_table_noise(table, 0.02, seed), "0", "0")
        p = identify_ddf(data, (0.3, 3.0), None, 2, physical=PhysicalModel(("iwan",)), estimator="weighted").parameters()
        errors.append((p["slip_force"] - 1.0, p["kt"] / 3e5 - 1, p["chi"] + 0.5))
    errors = np.abs(np.array(errors)).max(axis=0)
    assert errors[0] < 0.05 and errors[1] < 0.05 and errors[2] < 0.05, errors  # measured 0.017, 0.031, 0.047


def test_microslip_only_data_fix_what_they_cannot_show_and_say_why():
    """Every level below φ_max: χ and the softening/damping over the measured amplitudes are
    determined; K_T, F_S and β are not, and the identification says so and fixes them."""
    coarse = IwanJoint((0,), slip_force=1.0, kt=3e5, chi=-0.5, beta=0.5, sliders=100)  # DF within 1e-2 of TRUTH's
    table = time_integration_table(NonlinearSystem(LINEAR, (coarse,)), [0.01] + list(np.geomspace(0.1, 0.8, 5)),
                                   np.linspace(703.0, 717.0, 15))
    data = FRFLevels.from_table(add_table_noise(table, 0.02, 3), "0", "0")
    identification = identify(data, IdentificationSettings("0", "0", elements=("iwan",), frequency_hz=710.0,
                                                            half_window=0.01, samples=2, noise_fraction=0.02))
    p = identification.parameters()
    assert p["beta"] == 0.0 and p["chi"] == pytest.approx(-0.5, abs=0.05)
    element = identification.elements((0,))[0]
    assert element.phi_max == pytest.approx(float(np.max(identification.result.amplitude)), rel=1e-9)
    assert p["kt"] < 3e5 and p["slip_force"] < 1.0  # lower bounds
    kinds = {w.kind: w for w in identification.warnings}
    assert "not_identifiable" in kinds and "R'" in kinds["not_identifiable"].message
    stats = identification.uncertainty.parameters  # one-sided 95 % bands, each named
    assert stats["beta"].ci95 == (0.0, np.inf) and stats["kt"].ci95 == (p["kt"], np.inf)
    assert stats["slip_force"].ci95 == (p["slip_force"], np.inf) and stats["slip_force"].bound.side == "lower"
    assert {"beta", "kt", "slip_force"} <= {w.subject for w in identification.warnings if w.kind == "at_bound"}
    amplitude = np.geomspace(identification.result.amplitude.min(), identification.result.amplitude.max(), 20)
    low = identification.result.amplitude_low
    fitted = element.describing_function(amplitude) - element.describing_function(low)
    true = TRUTH.describing_function(amplitude) - TRUTH.describing_function(low)
    assert np.max(np.abs(fitted - true) / np.abs(true)) < 0.05  # what the data determine: y(A)
    assert "fixed: beta = 0" in identification.summary()["model"]


def test_jenkins_data_fitted_with_an_iwan_joint_land_on_its_jenkins_limit():
    jenkins = JenkinsFriction((0,), kf=3e5, slip_force=1.0)
    table = time_integration_table(NonlinearSystem(LINEAR, (jenkins,)), [0.01] + list(np.geomspace(0.5, 4.0, 7)),
                                   WINDOW_HZ)
    for seed in (1, 2):
        data = FRFLevels.from_table(add_table_noise(table, 0.02, seed), "0", "0")
        as_iwan = identify_prd(data, 710.0, PhysicalModel(("iwan",)), half_window=0.006)
        as_jenkins_result = identify_prd(data, 710.0, PhysicalModel(("jenkins",)), half_window=0.006)
        as_jenkins = as_jenkins_result.parameters()
        iwan = as_iwan.elements()[0]
        # one of its two Jenkins limits (IwanJoint's docstring): χ → −1, a Jenkins element
        # with kf = βK_T/(1+β), or β → ∞, one with kf = K_T (seed 2 lands there: β ≈ 6000)
        assert iwan.chi < -0.95 or iwan.beta > 100, iwan
        amplitude = np.geomspace(*as_iwan.amplitude_range, 50)
        jenkins_df = as_jenkins_result.elements()[0].describing_function(amplitude, 0.0)
        np.testing.assert_allclose(iwan.describing_function(amplitude, 0.0), jenkins_df, rtol=1e-3)
        assert iwan.concentrated_stiffness == pytest.approx(as_jenkins["kf"], rel=5e-3)
        assert iwan.slip_force == pytest.approx(as_jenkins["slip_force"], rel=5e-3)
        assert iwan.slip_force == pytest.approx(1.0, rel=0.05) and iwan.concentrated_stiffness == pytest.approx(3e5, rel=0.05)


@pytest.mark.slow
def test_identify_chain_on_a_wide_band_time_integration_test():
    """The whole identification step (recommended frequency, linear FRF, modes, Monte Carlo)."""
    system = NonlinearSystem(LINEAR, (TRUTH,))
    table = time_integration_table(system, [0.01] + list(np.geomspace(0.2, 4.0, 11)), np.linspace(650.0, 770.0, 121))
    truth_hz = np.sqrt(2e6 / 0.1) / (2 * np.pi)
    for seed in SEEDS:
        data = FRFLevels.from_table(add_table_noise(table, 0.02, seed), "0", "0")
        identification = identify(data, IdentificationSettings("0", "0", elements=("iwan",), samples=20, seed=seed))
        p = identification.parameters()
        assert p["slip_force"] == pytest.approx(1.0, rel=0.05) and p["kt"] == pytest.approx(3e5, rel=0.05)
        assert p["chi"] == pytest.approx(-0.5, abs=0.05)
        assert identification.natural_frequencies_hz[0] == pytest.approx(truth_hz, rel=3e-3)
        assert not [w for w in identification.warnings if w.kind in ("not_identifiable", "residual_above_noise")]


def test_a_model_that_cannot_describe_the_data_is_called_a_poor_fit(iwan_table, tmp_path):
    """Iwan data (0.5 % noise) fitted with a single Jenkins slider: ``"fit": "poor"`` with the ratio, in the
    summary, on stdout and in identification.json; the Iwan joint fits the same data."""
    import json

    noisy = add_table_noise(iwan_table, 0.005, 11)
    data = FRFLevels.from_table(noisy, "0", "0")
    verdicts = {}
    for element in ("jenkins", "iwan"):
        identification = identify(data, IdentificationSettings("0", "0", elements=(element,), frequency_hz=710.0,
                                                                half_window=0.006, samples=2))
        summary = identification.summary()
        verdicts[element] = (summary["fit"], summary["fit_ratio_to_noise"])
    assert verdicts["jenkins"][0] == "poor" and verdicts["jenkins"][1] > 10, verdicts  # measured 18–27 (seeds 11–13)
    assert verdicts["iwan"][0] == "consistent" and verdicts["iwan"][1] < 2, verdicts

    measured = tmp_path / "measured.parquet"
    noisy.to_parquet(measured)
    import contextlib
    import io

    from nlupdate.app.cli import main

    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        assert main(["identify", "--measured", str(measured), "--input-dof", "0", "--response-dof", "0",
                     "--frequency", "710", "--elements", "jenkins", "--half-window", "0.006", "--samples", "2",
                     "--seed", "0", "--out", str(tmp_path / "ident")]) == 0
    assert "fit: poor" in printed.getvalue()
    written = json.loads((tmp_path / "ident" / "identification.json").read_text())
    assert written["fit"] == "poor" and written["fit_ratio_to_noise"] > 5
    assert (tmp_path / "ident" / "fit.png").stat().st_size > 0


def test_frequency_recommendation_with_an_iwan_joint_at_extreme_parameters_finds_the_linear_resonance():
    """K_T = 1e30 N/m and F_S = 1e-300 N (log-parameters at the ends of their range) make
    φ_max underflow to 0: the joint is a Coulomb slider of 1e-300 N, so the data (a linear
    SDOF, 1 % noise) and the extracted linear FRF are those of m = 0.1 kg, k = 2e6 N/m, and the
    recommendation is the measured frequency nearest √(k/m)/2π = 711.76 Hz. It used to die
    with a ZeroDivisionError in IwanJoint.r_prime."""
    from nlupdate.core.identification.frequency import recommend_frequency

    system = NonlinearSystem(LumpedModel.with_loss_factor([[0.1]], [[2e6]], 0.01), ())
    table, _ = simulate_frf_table(system, 0, np.arange(690.0, 731.0, 1.0), [0.01, 0.5, 1.0, 2.0])
    data = FRFLevels.from_table(add_table_noise(table, 0.01, 1), "0", "0")
    model = PhysicalModel(("iwan",), fixed=(("kt", 1e30), ("slip_force", 1e-300)))
    choice = recommend_frequency(data, model)
    assert choice.frequency_hz == 712.0, choice
    assert choice.linear_natural_frequency_hz == pytest.approx(np.sqrt(2e7) / (2 * np.pi), abs=0.5)


def test_a_monte_carlo_sample_given_the_point_estimates_refit_model_gets_the_free_fits_result():
    """Microslip-only data (describing-function simulation, 2 % noise): the point estimate is
    refitted with β = 0 and φ_max fixed. A Monte-Carlo sample fits that model at once (φ_max
    moved to its own largest amplitude) instead of the free fit it would throw away: on
    three noise draws the parameters equal those of the full estimator (free fit, then the
    refit) to 1e-9."""
    from nlupdate.core.identification.pipeline import _fit

    system = NonlinearSystem(LINEAR, (TRUTH,))
    table, _ = simulate_frf_table(system, 0, np.linspace(703.0, 717.0, 15), [0.01] + list(np.geomspace(0.1, 0.8, 5)))
    data = FRFLevels.from_table(add_table_noise(table, 0.02, 3), "0", "0")
    settings = IdentificationSettings("0", "0", elements=("iwan",), frequency_hz=710.0, half_window=0.01,
                                      estimator="improved", order=2)
    point = _fit(data, settings, 710.0)
    model = point.model
    assert dict(model.fixed)["beta"] == 0.0 and "phi_max" in dict(model.fixed)
    for seed in (1, 2, 3):
        sample = data.with_noise(0.02, np.random.default_rng(seed))
        full, direct = _fit(sample, settings, 710.0), _fit(sample, settings, 710.0, model)
        assert dict(direct.model.fixed)["phi_max"] == float(np.max(direct.amplitude)) != dict(model.fixed)["phi_max"]
        for name, value in full.parameters().items():
            assert direct.parameters()[name] == pytest.approx(value, rel=1e-9, abs=1e-12), name
