"""An identification method is written once: its class in
src/nlupdate/core/identification/methods.py, registered in
:data:`~nlupdate.core.identification.methods.METHODS` (issue 36).

Outside that module no source compares a string with a method's name (``method == "prd"``):
the pipeline asks the method (its protocol) and the report and the fit figure read their
method-specific wording from it.
"""
from __future__ import annotations

import ast
from pathlib import Path
from types import SimpleNamespace

import numpy as np

import nlupdate
from nlupdate.core.identification.methods import METHODS

PACKAGE = Path(nlupdate.__file__).parent
REGISTRY = PACKAGE / "core" / "identification" / "methods.py"


def test_no_branch_on_a_method_name_outside_the_registry():
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        if path == REGISTRY:
            continue
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Compare):
                strings = {n.value for n in ast.walk(node) if isinstance(n, ast.Constant) and isinstance(n.value, str)}
                if strings & set(METHODS):
                    found.append(f"{path.relative_to(PACKAGE)}:{node.lineno} {sorted(strings & set(METHODS))}")
    assert found == []


def test_each_method_words_its_own_fit():
    """The registry's wording names each method's own setup: PRD its excitation frequency,
    low force and high levels; DDF its force pair and band (stand-in results carrying the
    setup fields the fits record)."""
    prd = SimpleNamespace(method="prd", estimator="improved", extras={"half_window": 0.02}, amplitude=np.ones(12),
                          setup=SimpleNamespace(frequency_hz=712.5, low_force=0.01, high_forces=(0.3, 1.0, 0.5)))
    ddf = SimpleNamespace(method="ddf", estimator="naive", extras={}, amplitude=np.ones(40),
                          setup=SimpleNamespace(force_pair=(0.01, 1.5), band_hz=(600.0, 850.0)))
    assert METHODS["prd"].describe_fit(prd) == ("PRD at **712.5 Hz** from the 0.01 N (low) and 3 high levels "
                                                "(0.3–1 N), improved estimator.")
    assert METHODS["prd"].describe_points(prd, "V") == ("12 points: 3 force levels (0.3–1 V) against 0.01 V, "
                                                        "within ±2 % of 712.5 Hz")
    one = SimpleNamespace(method="prd", estimator="naive", extras={}, amplitude=np.ones(3),
                          setup=SimpleNamespace(frequency_hz=700.0, low_force=0.05, high_forces=(2.0,)))
    assert METHODS["prd"].describe_fit(one) == "PRD at **700 Hz** from the 0.05 N (low) and 1 high level (2 N), " \
                                               "naive estimator."
    assert METHODS["prd"].describe_points(one, "N") == "3 points: 1 force level (2 N) against 0.05 N, at 700 Hz"
    assert METHODS["ddf"].describe_fit(ddf) == "DDF between 0.01 and 1.5 N over 600–850 Hz, naive estimator."
    assert METHODS["ddf"].describe_points(ddf, "N") == "40 points: 1.5 N against 0.01 N, 600–850 Hz"
    assert {name: method.fitted_quantity for name, method in METHODS.items()} == {
        "prd": "y = 1/H_i − 1/H_1", "ddf": "Δ(x₂) implied by 1/H₂ − 1/H₁ + Δ(x₁)"}
