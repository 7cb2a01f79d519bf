"""Discovery on data in which the effect is hidden: measured by time integration of a truth
the workflow never sees, with 1–2 % noise; the workflow gets the model without the effect.

Each case must name the hidden effect(s) at the right coordinate(s) and shrink the mean gap
(1 − FRAC) to at most 0.3 of what it was; the negative controls (data made by the model
itself plus noise) must answer ``none`` and leave the model unchanged. Truth parameters are
drawn per seed relative to the structure (``benchmarks/discovery_cases.py``), places
and seeds vary. The default run covers a representative subset; ``-m slow`` runs every case
of the first benchmark (``benchmarks/discovery.py --legacy``), the same set with other seeds
(so other truth parameters, noise and places) and more negative-control seeds. The hard
cases of issue 22 are in ``tests/test_discovery_hard.py`` and the benchmark.
"""
import pickle
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

from nlupdate.core.discovery import DiscoveryOptions, discover, fit_candidate
from nlupdate.core.discovery.effects import library
from nlupdate.core.discovery.workflow import measurement_evidence
from nlupdate.core.model.elements import CubicStiffness, JenkinsFriction

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from discovery_cases import hidden_case, legacy_cases, sdof, two_dof  # noqa: E402

SDOF, TWO_DOF = sdof(), two_dof()

FAST_CASES = {
    "cubic_a": hidden_case(SDOF, (("cubic_stiffness", (0,)),), seed=11),
    "cubic_b": hidden_case(SDOF, (("cubic_stiffness", (0,)),), seed=12, noise=0.02),
    "friction": hidden_case(SDOF, (("dry_friction", (0,)),), seed=13),
    "gap_between": hidden_case(TWO_DOF, (("gap", (0, 1)),), seed=14),
    "stiffness_m2": hidden_case(TWO_DOF, (("stiffness_error", (1,)),), seed=16, noise=0.015),
    "friction_and_cubic": hidden_case(SDOF, (("dry_friction", (0,)), ("cubic_stiffness", (0,))), seed=17),
}
CONTROLS = {
    "linear": hidden_case(SDOF, (), seed=18),
    "nonlinear": hidden_case(
        SDOF, (), seed=19, model_elements=(CubicStiffness((0,), 1.5e11), JenkinsFriction((0,), kf=1.5e5, slip_force=12.0))
    ),
}


@pytest.fixture(scope="module")
def measured():
    """Time-integration measurements, made once per module."""
    return {name: case.measure() for name, case in {**FAST_CASES, **CONTROLS}.items()}


@pytest.fixture(scope="module")
def discovered(measured):
    """Discovery results with default options, computed once per case."""
    cache = {}

    def result(name):
        if name not in cache:
            case = {**FAST_CASES, **CONTROLS}[name]
            cache[name] = discover(case.model, measured[name])
        return cache[name]

    return result


def assert_found(case, result):
    found = sorted((e.name, e.dofs) for e in result.effects)
    assert found == sorted(case.expected), f"{case.name}: found {found}; stop: {result.stop_reason}"
    assert result.gap_after.gap <= 0.3 * result.gap_before.gap, (
        f"{case.name}: gap {result.gap_before.gap:.3g} → {result.gap_after.gap:.3g}"
    )


@pytest.mark.parametrize("name", list(FAST_CASES))
def test_hidden_effect_is_named_at_its_place_and_the_gap_shrinks(discovered, name):
    case = FAST_CASES[name]
    result = discovered(name)
    assert_found(case, result)
    assert result.effect == case.expected[0][0] or len(case.expected) > 1
    # the augmented model is the model plus what was found: its elements are the effects'
    assert len(result.augmented.elements) == sum(e.name not in ("stiffness_error", "mass_error", "damping_error")
                                                 for e in result.effects)


@pytest.mark.parametrize("name,tolerance", [("cubic_a", 0.03), ("friction", 0.05), ("gap_between", 0.1)])
def test_fitted_parameters_are_close_to_the_hidden_truth(discovered, name, tolerance):
    case = FAST_CASES[name]
    result = discovered(name)
    element = case.truth.elements[0]
    truth = {"cubic_stiffness": {"k3": getattr(element, "k3", None)},
             "dry_friction": {"kf": getattr(element, "kf", None), "slip_force": getattr(element, "slip_force", None)},
             "gap": {"gap": getattr(element, "gap", None), "kc": getattr(element, "kc", None)}}[result.effect]
    for key, value in truth.items():
        assert result.parameters[key] == pytest.approx(value, rel=tolerance), key


@pytest.mark.parametrize("name", list(CONTROLS))
def test_model_that_made_the_data_gets_none_and_no_change(discovered, name):
    case = CONTROLS[name]
    result = discovered(name)
    assert result.effect == "none" and result.effects == () and result.dofs == () and result.parameters == {}
    assert result.augmented.elements == case.model.elements
    w = 2 * np.pi * SDOF.frequency_hz
    np.testing.assert_array_equal(result.augmented.model.receptance(w, [0], [0]), case.model.model.receptance(w, [0], [0]))
    assert result.gap_after.gap == result.gap_before.gap


def test_json_has_the_documented_keys(discovered):
    data = discovered("friction_and_cubic").to_dict()
    assert {"effect", "dofs", "parameters", "effects", "candidates", "gap_before", "gap_after"} <= set(data)
    assert [e["effect"] for e in data["effects"]] in (["dry_friction", "cubic_stiffness"], ["cubic_stiffness", "dry_friction"])
    assert data["effect"] == data["effects"][0]["effect"]
    assert all({"effect", "dofs", "score", "parameters"} <= set(c) for c in data["candidates"])
    per_level = data["levels_before"]["levels"]
    assert len(per_level) == 4 and {"frac", "frf_error", "resonance_shift_percent", "peak_ratio"} <= set(per_level[0])


def test_a_missing_nonlinearity_changes_with_force_and_a_linear_error_does_not(discovered):
    """The gap report's trend: the resonance shift of the missing friction moves with the
    force level; that of a stiffness error does not."""
    friction = discovered("friction").gap_before
    linear = discovered("stiffness_m2").gap_before
    shift = lambda report: [level.resonance_shift_percent for level in report.levels]  # noqa: E731
    assert np.ptp(shift(friction)) > 3.0
    assert np.ptp(shift(linear)) < 0.5


def test_candidate_fits_run_through_an_injected_map_with_the_same_result(measured, discovered):
    case = FAST_CASES["gap_between"]
    sequential = discovered("gap_between")
    with ThreadPoolExecutor(2) as pool:
        parallel = discover(case.model, measured["gap_between"], map_candidates=pool.map)
    in_reverse = discover(case.model, measured["gap_between"],
                          map_candidates=lambda f, jobs: [f(j) for j in reversed(jobs)][::-1])
    for other in (parallel, in_reverse):
        assert [c.to_dict() for c in other.candidates] == [c.to_dict() for c in sequential.candidates]
        assert other.to_dict() == sequential.to_dict()


def test_candidate_jobs_survive_pickling(measured):
    """A flow may ship jobs to other processes."""
    case = FAST_CASES["cubic_a"]
    evidence = measurement_evidence(case.model, measured["cubic_a"], DiscoveryOptions(), "measured")
    context = evidence.contexts(case.model, [], evidence.predict(case.model))[0]
    job = (context, library(["cubic_stiffness"])[0])
    assert fit_candidate(pickle.loads(pickle.dumps(job))).to_dict() == fit_candidate(job).to_dict()


@pytest.mark.slow
@pytest.mark.parametrize("case", legacy_cases(0) + legacy_cases(1000), ids=lambda case: case.name)
def test_every_first_benchmark_case(case):
    """The first benchmark's 22 SDOF / 2-DOF cases and 22 more with other seeds, parameters
    and places (the hard cases of issue 22: ``benchmarks/discovery.py``)."""
    result = discover(case.model, case.measure())
    if case.expected:
        assert_found(case, result)
    else:
        assert result.effect == "none" and result.augmented.elements == case.model.elements


@pytest.mark.slow
@pytest.mark.parametrize("seed", [501, 502, 503, 504])
def test_negative_controls_over_seeds(seed):
    structure = SDOF if seed % 2 else TWO_DOF
    case = hidden_case(structure, (), seed=seed, noise=0.01 + 0.005 * (seed % 3))
    assert discover(case.model, case.measure()).effect == "none"


def test_the_describing_function_plot_shows_the_final_model_against_the_truth(discovered, tmp_path):
    """describing_function.png draws, besides the first round's candidates, the final model at
    the place — every effect found there, refitted together — and that curve is the hidden
    truth's describing function (Jenkins + cubic) over the measured amplitudes."""
    from matplotlib.figure import Figure

    from nlupdate.core.discovery import plots

    result = discovered("friction_and_cubic")
    drawn: list[Figure] = []
    original = Figure.savefig
    try:
        Figure.savefig = lambda self, *a, **k: (drawn.append(self), original(self, *a, **k))
        plots.plot_describing_function(result, tmp_path / "df.png")
    finally:
        Figure.savefig = original
    left, right = drawn[0].axes[:2]
    final = [line for line in left.get_lines() if line.get_label().startswith("final model")]
    assert len(final) == 1 and "dry_friction" in final[0].get_label() and "cubic_stiffness" in final[0].get_label()
    assert any(line.get_label().startswith("round 1:") for line in left.get_lines())
    amplitude = np.asarray(final[0].get_xdata())
    omega = np.full(amplitude.size, 2 * np.pi * 700.0)  # rate-independent elements: ω does not matter
    truth = sum(element.describing_function(amplitude, omega) for element in FAST_CASES["friction_and_cubic"].truth.elements)
    drawn_nu = np.asarray(final[0].get_ydata()) + 1j * np.asarray(
        next(line for line in right.get_lines() if line.get_label().startswith("final model")).get_ydata())
    assert np.max(np.abs(drawn_nu - truth)) < 0.05 * np.max(np.abs(truth))
    assert "negative is better" in " ".join(text.get_text() for text in drawn[0].texts)
