"""``validate`` with the mode's linear limit from another test (an impact) kept beside the
force levels (issue 34 item 2, issue 37: every test type in one model).

Reference, independent of the code under test: one mode whose joint slips as a microslip
joint does — natural frequency and damping ratio moving as (a/a₁)^1.5, saturating, not the
quadratics the ``lines`` models fit — solved in closed form by single-harmonic balance line
by line (``a·|ω(a)² − Ω² + 2iζ(a)ω(a)Ω| = F``, bisection on a grid, the root unique here,
asserted), and its response-controlled runs, which hold a and are linear there. Its exact
linear limit (ω₀, ζ₀) is the impact's.
"""
from __future__ import annotations

import dataclasses
import json

import numpy as np
import pandas as pd
import pytest
from single_mode_reference import exact_linear_limit, stepped_sine

from nlupdate.core.identification.response_controlled import HeldRun
from nlupdate.core.measurement.frf_table import frf_table
from nlupdate.core.validation.held_out import repeatability
from nlupdate.core.validation.held_response import predict_held_runs
from nlupdate.core.validation.auto_choice import choose_model
from nlupdate.core.validation.models import model_fitter
from nlupdate.core.validation.resonance import resonance

W0, ZETA0, A1, SOFTENING, GROWTH = 2 * np.pi * 80.5, 0.0015, 1e-4, 0.004, 0.003
LEVELS = (0.1, 0.2, 0.35, 0.5)
F = np.linspace(79.2, 81.2, 41)
LIMIT = exact_linear_limit(W0, ZETA0)


def denominator(a, omega):
    u = (a / A1) ** 1.5
    w, zeta = W0 * (1 - SOFTENING * u / (1 + u)), ZETA0 + GROWTH * u / (1 + 0.5 * u)
    return w**2 - omega**2 + 2j * zeta * w * omega


@pytest.fixture(scope="module")
def data():
    return stepped_sine(denominator, LEVELS, F, np.geomspace(1e-9, 1e-2, 6000))


def run(held):
    h = 1 / denominator(held, 2 * np.pi * F)
    return HeldRun(f"{held:g} m", "0", "0", F.copy(), h, held, held / np.abs(h))


@pytest.mark.parametrize("model", ["lines", "lines-background"])
def test_the_linear_limit_carries_a_run_far_below_the_levels(data, model):
    """A run held at 2 µm, 35 × below the lowest level's 69 µm at resonance: from the levels
    alone a downward extrapolation of the quadratics (damping −21 … −33 %, peak +26 … +50 %);
    with the exact linear limit kept it is predicted within 5 % and 0.01 Hz."""
    runs = [run(2e-6)]
    errors = {}
    for limit in (None, LIMIT):
        kept = dataclasses.replace(data, linear_limit=limit)
        (out,) = predict_held_runs(kept, runs, model, repeatability(kept, runs))
        errors[limit is not None] = out.compared
    without, anchored = errors[False], errors[True]
    assert abs(without["damping_ratio"].relative_error) > 0.15
    assert abs(anchored["resonance_hz"].error) < 0.01
    assert abs(anchored["damping_ratio"].relative_error) < 0.05
    assert abs(anchored["peak_abs"].relative_error) < 0.05


def test_the_fitted_linear_limit_is_the_impacts_and_other_models_refuse_it(data):
    kept = dataclasses.replace(data, linear_limit=LIMIT)
    assert kept.subset(LEVELS[:3]).linear_limit is LIMIT  # every refit keeps it
    # far below every level the anchored model is the linear mode: its curve's resonance and damping
    h = model_fitter("lines")(kept).at_response(F, 1e-9)
    linear = resonance(F, 1 / denominator(0.0, 2 * np.pi * F))
    assert resonance(F, h).resonance_hz == pytest.approx(linear.resonance_hz, abs=0.01)
    assert resonance(F, h).damping_ratio == pytest.approx(linear.damping_ratio, rel=0.03)
    with pytest.raises(ValueError, match="lines, lines-background"):
        model_fitter("amplitude-polynomial")(kept)
    assert set(choose_model(kept).scores) == {"lines", "lines-background"}


def test_validate_keeps_an_impacts_linear_limit(data, tmp_path, capsys):
    """``nlupdate validate --impact FILE`` with levels held out: the exact free decay of the
    linear mode (scipy's LTI response to a 1 ms half-sine blow) gives the linear limit the
    lines models keep; a model that cannot keep it is refused in one line."""
    import scipy.signal

    from nlupdate.app.cli import main

    frames = [frf_table(f, level, "0", "0", h) for level, f, h in zip(data.levels, data.frequencies, data.receptances)]
    pd.concat(frames, ignore_index=True).to_csv(tmp_path / "levels.csv", index=False)
    t = np.arange(0, 8.0, 1 / 2000.0)
    force = np.where((t >= 0.1) & (t < 0.101), 100 * np.sin(np.pi * (t - 0.1) / 1e-3), 0.0)
    x = scipy.signal.lsim(([1.0], [1.0, 2 * ZETA0 * W0, W0**2]), force, t)[1]
    pd.DataFrame({"time_s": t, "0": x, "force": force}).to_csv(tmp_path / "impact.csv", index=False)
    common = ["validate", "--measured", str(tmp_path / "levels.csv"), "--impact", str(tmp_path / "impact.csv"),
              "--channel", "0", "--hold-out", "top", "--response-controlled", "off"]
    assert main([*common, "--model", "lines", "--out", str(tmp_path / "out")]) == 0
    summary = json.loads((tmp_path / "out" / "validation.json").read_text())
    assert summary["linear_limit"]["frequency_hz"] == pytest.approx(W0 / (2 * np.pi), rel=1e-5)
    assert summary["linear_limit"]["damping_ratio"] == pytest.approx(ZETA0, rel=0.02)
    assert [r["level"] for r in summary["held_out"]] == [LEVELS[-1]]
    capsys.readouterr()
    assert main([*common, "--model", "amplitude-polynomial", "--out", str(tmp_path / "refused")]) == 2
    assert "cannot keep a linear limit" in capsys.readouterr().err


if __name__ == "__main__":  # python tests/test_validate_linear_limit.py: with and without the limit, every run and the top
    from nlupdate.core.validation.held_out import validate

    levels = data.__wrapped__()
    runs = [run(x) for x in (2e-6, 5e-6, 1e-5)]
    for model in ("lines", "lines-background"):
        for limit in (None, LIMIT):
            kept = dataclasses.replace(levels, linear_limit=limit)
            cells = [f"{1e6 * o.held_m:g} µm {o.compared['resonance_hz'].error:+.4f} Hz "
                     f"{100 * o.compared['damping_ratio'].relative_error:+.1f} % "
                     f"{100 * o.compared['peak_abs'].relative_error:+.1f} %"
                     for o in predict_held_runs(kept, runs, model, repeatability(kept, runs))]
            top = validate(kept, "top", [model]).held_out[0].compared
            cells.append(f"top {top['resonance_hz'].error:+.4f} Hz {100 * top['damping_ratio'].relative_error:+.1f} % "
                         f"{100 * top['peak_abs'].relative_error:+.1f} %")
            print(f"{model}, {'the exact linear limit kept' if limit else 'levels only'}: " + "; ".join(cells))
