"""Finite-difference sensitivities against analytical derivatives."""
from __future__ import annotations

import numpy as np
import pytest

from nlupdate.fe.adapters.base import Parameter
from nlupdate.fe.adapters.lumped import LumpedAdapter
from nlupdate.core.updating.evaluation import MemoisedEvaluator
from nlupdate.core.updating.sensitivity import FORMULAS, assemble_jacobian, jacobian, step_size, stencil, stencil_points


def response(values):
    a, b = values["a"], values["b"]
    return np.array([a**3 * b, np.sin(a) + np.exp(b), a / b])


def exact(a, b):
    return np.array([[3 * a**2 * b, a**3], [np.cos(a), np.exp(b)], [1 / b, -a / b**2]])


@pytest.mark.parametrize("formula", list(FORMULAS))
def test_error_order_matches_formula(formula):
    """Halving the step divides the truncation error by 2^order."""
    a, b = 1.3, 0.7
    errors = []
    for relative_step in (4e-2, 2e-2):
        parameters = [Parameter("a", "-", a, 0, 10, relative_step), Parameter("b", "-", b, 0, 10, relative_step)]
        s = jacobian(response, {"a": a, "b": b}, parameters, formula)
        errors.append(np.abs(s - exact(a, b)).max())
    order = np.log2(errors[0] / errors[1])
    assert order == pytest.approx(stencil(formula).order, abs=0.25)
    assert errors[1] < 0.05 * np.abs(exact(a, b)).max()  # 2 % steps


def test_step_relative_to_current_value_and_to_bound_width_at_zero():
    p = Parameter("k", "N/m", 2.0, -5.0, 15.0, 1e-3)
    assert step_size(2.0, p) == pytest.approx(2e-3)
    assert step_size(-4.0, p) == pytest.approx(4e-3)
    assert step_size(0.0, p) == pytest.approx(1e-3 * 20.0)


def test_unknown_formula_is_rejected():
    with pytest.raises(ValueError, match="central4"):
        stencil("central6")


@pytest.mark.parametrize("formula", list(FORMULAS))
def test_single_dof_frequency_sensitivity_and_counts(formula):
    """f = √(k/m)/2π: ∂f/∂k = f/(2k), ∂f/∂m = −f/(2m); the base point is not solved again."""
    k, m = 4e5, 0.25
    evaluator = MemoisedEvaluator(LumpedAdapter([m], [k]))
    parameters = [Parameter("k1", "N/m", k, 1e5, 1e6, 1e-4), Parameter("m1", "kg", m, 0.1, 1.0, 1e-4)]
    evaluator([{"k1": k, "m1": m}])  # the base point, as the updating loop does first
    points = stencil_points({"k1": k, "m1": m}, parameters, formula)
    responses = [result.natural_frequencies_hz for result in evaluator(points)]
    s = assemble_jacobian(responses, {"k1": k, "m1": m}, parameters, formula)
    f = np.sqrt(k / m) / (2 * np.pi)
    np.testing.assert_allclose(s[0], [f / (2 * k), -f / (2 * m)], rtol=2e-4)
    new_per_parameter = {"forward": 1, "backward": 1, "central2": 2, "central4": 4}[formula]
    one_sided = formula in ("forward", "backward")
    assert evaluator.counts() == {"new": 1 + 2 * new_per_parameter, "cached": 2 if one_sided else 0}


def test_assembly_rejects_a_stencil_of_the_wrong_length():
    parameters = [Parameter("a", "-", 1.3, 0, 10, 1e-3)]
    with pytest.raises(ValueError, match="needs 4 stencil responses, got 2"):
        assemble_jacobian([np.zeros(3)] * 2, {"a": 1.3}, parameters, "central4")
