"""The discovery fits' Jacobians against finite differences of the whole residual.

Fits at a place (:class:`nlupdate.core.discovery.frf_fit.PlaceSolution`) and the joint refit
(:class:`nlupdate.core.discovery.joint.JointSolution`) give least squares ∂r/∂θ from one solve
(implicit function theorem) instead of one solve per parameter. Every fit of a discovery
on the SDOF example (time-integration data, friction and a cubic spring hidden) is checked
at its start against central differences that re-solve the amplitudes. Where the residual
is not differentiable (a point on a fold or at the slip onset, where differences with two
steps disagree) nothing is asserted.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from scipy.optimize._numdiff import approx_derivative  # scipy 1.11 has no public name for it

import nlupdate.core.discovery.fitting as fitting
import nlupdate.core.discovery.joint as joint
from nlupdate.core.discovery import DiscoveryOptions, discover
from nlupdate.core.measurement.frf_files import read_frf_table
from nlupdate.core.model.model_file import load_system

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "discovery"


def _relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / max(np.linalg.norm(b), 1e-300))


def test_implicit_jacobians_equal_central_differences_that_solve_again(monkeypatch):
    original = fitting.fit_effects
    checked = []

    def checking(residual, effects, starts, max_nfev=40, refine=2, linearise=None):
        if linearise is not None:
            unknowns = fitting._Unknowns(effects, starts[0])
            x0 = unknowns.encode(starts[0])
            with np.errstate(all="ignore"):
                again = lambda u: residual(unknowns.decode(u))  # noqa: E731
                coarse, fine = (approx_derivative(again, x0, method="3-point", rel_step=step)
                                for step in (1e-5, 1e-7))
                steps = 1e-7 * np.maximum(1.0, np.abs(x0))
                perturbed = [unknowns.decode(x0 + step * unit) for step, unit in zip(steps, np.eye(x0.size))]
                implicit = linearise(unknowns.decode(x0)).jacobian(perturbed, steps)
            caller = sys._getframe(1).f_code.co_name
            checked.append((caller, [e.name for e in effects], _relative(coarse, fine), _relative(implicit, fine)))
        return original(residual, effects, starts, max_nfev, refine, linearise)

    monkeypatch.setattr(fitting, "fit_effects", checking)
    monkeypatch.setattr(joint, "fit_effects", checking)
    result = discover(load_system(EXAMPLES / "sdof_linear.toml"), read_frf_table(EXAMPLES / "sdof_friction_cubic.csv"),
                      DiscoveryOptions())
    assert [e.name for e in result.effects] == ["dry_friction", "cubic_stiffness"]

    smooth = [c for c in checked if c[2] < 1e-4]  # differences with two steps agree: differentiable there
    assert len(smooth) >= 0.8 * len(checked) and len(smooth) >= 20, checked
    assert any(c[0] == "refit" for c in smooth) and any(len(c[1]) >= 2 for c in smooth), checked
    worst = max(smooth, key=lambda c: c[3])
    assert worst[3] < 1e-4, worst
