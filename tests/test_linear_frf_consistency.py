"""The placement check: the linear FRF each force level gives must be the same at every level.

A 3-DOF chain ground–m1–m2–m3 (1 kg masses, 1.6e5 N/m springs, loss factor 0.02), driven
and measured at the tip m3 (coordinate 2), five levels 0.1–4 N, lines ±8 % around each
linear mode. The measurements are the first harmonic of a *time integration* of the
system to the steady state (:mod:`nlupdate.core.response.time_integration`, independent of the
describing functions the identification uses), with 1 % noise, seeds 1–5. Cases:

* a cubic spring from the tip to ground — the nonlinearity at the measured coordinate:
  the check passes and the linear modes land within 0.5 % of the chain's eigenvalues
  (scipy's generalised eigenproblem, the independent reference);
* a cubic spring between m1 and m2, two unmeasured coordinates: flagged, the cause named
  and ``nlupdate discover`` suggested;
* the tip data fitted with a Jenkins element where the truth is a cubic spring — the wrong
  element set: flagged.

The slow test adds the issue's case (a cubic spring between the two outer masses, the
measured one and m1) and the Monte-Carlo intervals of the modes.
"""
from __future__ import annotations

import json
import warnings

import numpy as np
import pytest
import scipy.linalg

from nlupdate.core.identification.consistency import SPREAD_LIMIT
from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.pipeline import IdentificationSettings, identify
from nlupdate.core.measurement.frf_table import frf_table
from nlupdate.core.model.elements import CubicStiffness
from nlupdate.core.model.linear import LumpedModel
from nlupdate.core.model.system import NonlinearSystem
from nlupdate.reporting.identification_report import identification_section
from nlupdate.core.response.sweep import frequency_sweep
from nlupdate.core.response.time_integration import steady_state_response

from cli_runs import run_cli

STIFFNESS = 1.6e5
MASS = np.eye(3)
K = STIFFNESS * np.array([[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])
LINEAR = LumpedModel.with_loss_factor(MASS, K, 0.02)
TRUTH_HZ = np.sqrt(scipy.linalg.eigh(K, MASS, eigvals_only=True)) / (2 * np.pi)
LINES = np.concatenate([np.linspace(0.92 * f, 1.08 * f, 13) for f in TRUTH_HZ])
LEVELS = np.array([0.1, 0.3, 1.0, 2.0, 4.0])
TIP = 2
NOISE = 0.01
SEEDS = range(1, 6)
#: Where to fit the modes (the lines are three separate bands; the resonance search and the
#: excited-band choice on a gapped grid are not what is tested here: the band is all lines).
MODES_NEAR_HZ = (28.0, 80.0, 115.0)


def time_integration_levels(dofs: tuple[int, ...], k3: float) -> FRFLevels:
    """The tip receptance at every level and line by time integration, started from the
    describing-function response (the steady state it settles on is its own)."""
    system = NonlinearSystem(LINEAR, (CubicStiffness(dofs, k3),))
    omega = 2 * np.pi * LINES
    start = np.concatenate([frequency_sweep(system, {TIP: f}, omega).response([0, 1, 2]) for f in LEVELS])
    result = steady_state_response(system, {TIP: np.repeat(LEVELS, LINES.size)}, np.tile(omega, LEVELS.size),
                                   initial=start)
    assert result.converged.all()
    x = result.x[:, TIP].reshape(LEVELS.size, LINES.size)
    return FRFLevels(str(TIP), str(TIP), LEVELS, tuple(LINES for _ in LEVELS), tuple(x / LEVELS[:, None]))


@pytest.fixture(scope="module")
def at_tip() -> FRFLevels:
    return time_integration_levels((TIP,), 1e10)


@pytest.fixture(scope="module")
def between_unmeasured() -> FRFLevels:
    return time_integration_levels((0, 1), 3e11)


def identified(clean: FRFLevels, elements: tuple[str, ...], seed: int, samples: int = 2):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return identify(clean.with_noise(NOISE, np.random.default_rng(seed)),
                        IdentificationSettings(str(TIP), str(TIP), elements=elements, samples=samples, seed=seed,
                                               linear_modes_hz=MODES_NEAR_HZ, band_hz=(LINES[0], LINES[-1])))


def test_nonlinearity_at_the_measured_coordinate_passes_and_gives_the_linear_modes(at_tip):
    for seed in SEEDS:
        ident = identified(at_tip, ("cubic",), seed)
        assert ident.level_consistency.spread_ratio < SPREAD_LIMIT, seed
        assert ident.trustworthy and not [w for w in ident.warnings if w.kind == "levels_disagree"]
        summary = ident.summary()
        assert summary["trustworthy"] is True and summary["linear_frf_consistency"]["passed"] is True
        assert ident.natural_frequencies_hz == pytest.approx(TRUTH_HZ, rel=0.005)
        assert "NOT TRUSTWORTHY" not in "\n".join(identification_section(ident, {}, {}))


def _assert_flagged(ident, seed: int) -> None:
    assert ident.level_consistency.spread_ratio > SPREAD_LIMIT, seed
    assert not ident.trustworthy
    placement = [w for w in ident.warnings if w.kind == "levels_disagree"]
    assert len(placement) == 1 and ident.warnings[0] == placement[0]  # first in the list
    message = placement[0].message
    assert message.startswith("NOT TRUSTWORTHY") and "not at the measured coordinate" in message
    assert "element set is wrong" in message and "nlupdate discover" in message
    summary = ident.summary()
    assert list(summary)[:2] == ["trustworthy", "not_trustworthy_because"]
    assert summary["trustworthy"] is False and summary["not_trustworthy_because"] == [message]
    assert summary["fit"] == "poor" and summary["linear_frf_consistency"]["passed"] is False
    section = identification_section(ident, {}, {})  # a study's report.md
    assert section[:3] == ["## Identification", "", f"**{message}**"]


def test_nonlinearity_between_two_unmeasured_coordinates_is_flagged(between_unmeasured):
    for seed in SEEDS:
        _assert_flagged(identified(between_unmeasured, ("cubic",), seed), seed)


def test_identify_prints_the_failed_check_before_the_numbers(between_unmeasured, tmp_path, capsys):
    noisy = between_unmeasured.with_noise(NOISE, np.random.default_rng(1))
    table = frf_table(np.concatenate(noisy.frequencies), np.repeat(LEVELS, LINES.size), str(TIP), str(TIP),
                      np.concatenate(noisy.receptances))
    table.to_parquet(tmp_path / "measured.parquet")
    code, out, _ = run_cli(capsys, "identify", "--measured", tmp_path / "measured.parquet", "--elements", "cubic",
                           "--band", f"{LINES[0]}:{LINES[-1]}", "--samples", 2, "--out", tmp_path / "ident")
    assert code == 0
    lines = [line for line in out.splitlines() if not line.startswith(("measured:", "default "))]
    assert lines[0].startswith("warning: identification: NOT TRUSTWORTHY") and "nlupdate discover" in lines[0]
    first = next(k for k, line in enumerate(lines) if line.startswith("k3 = "))  # every warning before the numbers
    assert all(line.startswith(("warning:", "fit: ")) for line in lines[:first]), lines
    assert not any(line.startswith(("warning:", "fit: ")) for line in lines[first:]), lines
    assert json.loads((tmp_path / "ident" / "identification.json").read_text())["trustworthy"] is False


def test_wrong_element_set_is_flagged(at_tip):
    for seed in SEEDS:
        _assert_flagged(identified(at_tip, ("jenkins",), seed), seed)


@pytest.mark.slow
def test_the_issue_case_and_the_mode_intervals(at_tip):
    """The issue's case (a cubic spring between the outer masses m1 and m3, m3 measured)
    is flagged, with every reported interval holding its estimate; correctly placed, the
    true natural frequencies fall inside their 95 % Monte-Carlo intervals (binomial: at
    95 % coverage fewer than 12 of the 15 happens with probability 0.5 %)."""
    outer = time_integration_levels((0, 2), 1e10)
    inside = []
    for seed in SEEDS:
        ident = identified(outer, ("cubic",), seed, samples=20)
        _assert_flagged(ident, seed)
        for stats in ident.uncertainty.parameters.values():
            assert stats.ci95[0] <= stats.value <= stats.ci95[1]
        ident = identified(at_tip, ("cubic",), seed, samples=40)
        for i, truth in enumerate(TRUTH_HZ):
            low, high = ident.uncertainty.parameters[f"linear_f{i + 1}_hz"].ci95
            inside.append(low <= truth <= high)
    assert sum(inside) >= 12, inside


def test_elements_that_leave_no_linear_frf_fail_the_check():
    """A degenerate fit (a wrong element set driven to kf = 1e-305) gives no finite term at
    any line: that is no evidence the levels agree, and the check says so."""
    from nlupdate.core.identification.consistency import level_consistency
    from nlupdate.core.identification.linear_frf import LevelTerms
    from nlupdate.core.identification.trust import consistency_warnings

    f = np.linspace(20.0, 40.0, 21)
    nothing = np.full((3, f.size), np.nan)
    terms = LevelTerms((0.1, 1.0, 10.0), f, nothing + 0j, nothing, False, np.ones(f.size, complex),
                       np.ones((3, f.size), bool))
    check = level_consistency(terms, 0.01)
    assert not check.passed and check.spread_ratio == float("inf")
    (warning,) = consistency_warnings(check, "2")
    assert "cannot be formed: the fitted elements leave no finite value" in warning.message
    unmeasured = LevelTerms((0.1, 1.0, 10.0), f, nothing + 0j, nothing, False, np.ones(f.size, complex),
                            np.eye(3, f.size, dtype=bool))
    assert level_consistency(unmeasured, 0.01) is None  # no line two levels share: nothing to compare
