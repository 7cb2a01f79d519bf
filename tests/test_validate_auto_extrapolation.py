"""``auto`` on an extrapolated level: a candidate whose prediction leaves the physical range
is refused, with a warning, and the baseline is the last fallback (issue 34).

Reference, independent of the code under test: one mode whose joint damps as a Jenkins
joint does — the equivalent damping ratio rising to its largest at the slip transition
(a = a₁) and falling as 1/a beyond it, ζ(a) = ζ₀ + g·u/(1 + u²), u = a/a₁, the natural
frequency softening as ω₀(1 − s·u/(1 + u)) — solved in closed form by single-harmonic
balance line by line (``a·|ω(a)² − Ω² + 2iζ(a)ω(a)Ω| = F``, bisection on a grid, the root
unique here, asserted). Its three lower levels reach 0.2–1.4 a₁ at resonance, across the
damping's maximum, the top one 3.3 a₁: the ``lines`` models' damping quadratics through the
three lower levels are already falling at the largest kept amplitude and fall to nothing
beyond it (peak +989 % and +1574 %), while the truth's peak rises 1.3× (its damping falls
to 1.85 ‰ from 2.9 ‰).
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest
from single_mode_reference import exact_linear_limit, stepped_sine

from nlupdate.core.measurement.frf_table import frf_table
from nlupdate.core.validation.auto_choice import PEAK_GROWTH, choose_model
from nlupdate.core.validation.held_out import validate

W0, ZETA0, A1, SOFTENING, GROWTH = 2 * np.pi * 80.0, 0.001, 1e-4, 0.003, 0.004
LEVELS = (0.03, 0.08, 0.2, 0.35)
F = np.linspace(78.5, 81.0, 51)
LIMIT = exact_linear_limit(W0, ZETA0)


def denominator(a, omega):
    u = a / A1
    w, zeta = W0 * (1 - SOFTENING * u / (1 + u)), ZETA0 + GROWTH * u / (1 + u**2)
    return w**2 - omega**2 + 2j * zeta * w * omega


@pytest.fixture(scope="module")
def data():
    return stepped_sine(denominator, LEVELS, F, np.geomspace(1e-9, 1e-1, 8000))


@pytest.fixture(scope="module")
def top(data):
    return validate(data, "top", ["lines", "lines-background", "auto"])


def test_auto_refuses_the_lines_models_whose_extrapolation_leaves_the_physical_range(data, top):
    rows = {r.requested: r for r in top.held_out}
    for name in ("lines", "lines-background"):  # the failure the choice must not make: the peak ×10 and more
        assert rows[name].compared["peak_abs"].relative_error > 5.0, name
        assert "the extrapolation leaves the physical range" in rows[name].note, name
    choice = top.choices[LEVELS[-1]]
    assert choice.name not in ("lines", "lines-background") and set(choice.refused) == {"lines", "lines-background"}
    assert "lines refused" in choice.warning and f"{choice.name} used" in choice.warning
    assert f"above {PEAK_GROWTH:g} ×" in choice.refused["lines-background"]
    # without the level a lines model ranks first (the old rank; `lines` since the lines models take the
    # modal constant of every level at once, `lines-background` before)
    assert choose_model(data.subset(list(LEVELS[:3]))).name in ("lines", "lines-background")
    auto, base = rows["auto"].compared, rows["auto"].baseline
    assert auto["peak_abs"].inside and auto["damping_ratio"].inside  # the truth in the 95 % band
    for name in ("damping_ratio", "peak_abs"):  # as good as the log-amplitude baseline, not 10x off
        assert abs(auto[name].relative_error) < 1.1 * abs(base[name].relative_error), name
    assert top.summary()["auto_choices"]["0.35"]["warning"] == choice.warning


def test_every_candidate_refused_falls_back_to_the_baseline(data):
    """With the exact linear limit kept only the ``lines`` models are candidates; both leave
    the range, so the baseline predicts the level — the baseline's own figures, with a band."""
    kept = dataclasses.replace(data, linear_limit=LIMIT)
    result = validate(kept, "top", ["auto"])
    (row,) = result.held_out
    choice = result.choices[LEVELS[-1]]
    assert row.model == "baseline" and "every candidate refused" in choice.warning
    for name, c in row.compared.items():
        assert c.predicted == pytest.approx(row.baseline[name].predicted, rel=1e-9), name
        assert c.low < c.predicted < c.high, name


def test_no_value_is_printed_as_if_fine(data, tmp_path, capsys):
    """``nlupdate validate``: a measured value outside its band, a prediction without a value
    or outside its own band each get a line saying so; auto's refusals go to stderr."""
    from nlupdate.app.cli import main

    frames = [frf_table(f, level, "0", "0", h) for level, f, h in zip(data.levels, data.frequencies, data.receptances)]
    pd.concat(frames, ignore_index=True).to_csv(tmp_path / "levels.csv", index=False)
    common = ["validate", "--measured", str(tmp_path / "levels.csv"), "--hold-out", "top", "--response-controlled",
              "off"]
    assert main([*common, "--model", "lines,auto", "--out", str(tmp_path / "out")]) == 0
    out, err = capsys.readouterr()
    assert "the extrapolation leaves the physical range" in err
    assert "warning: at 0.35 N (lines): no predicted damping ratio" in err  # lines' top curve: too sharp a peak
    # the bad news first: the first line on stderr names the level, the quantity and the model
    assert err.splitlines()[0].startswith("warning: measured OUTSIDE the prediction's 95 % band: 0.35 N damping ratio")
    assert "warning: auto at 0.35 N (an extrapolation): lines refused" in err and "; lines-background refused" in err
    # auto's reason: the scores in words, a candidate that failed named with why (three kept
    # levels, two left to fit: the Iwan backbone's three parameters need three), no "nan"
    (reason,) = [line for line in out.splitlines() if line.startswith("auto at 0.35 N: ")]
    assert "nan" not in reason and "amplitude-iwan failed to fit with one kept curve left out: the iwan backbone " \
                                   "needs at least 3 samples, got 2" in reason, reason
    depth = 0
    for char in reason:  # no parentheses inside parentheses
        depth += {"(": 1, ")": -1}.get(char, 0)
        assert depth <= 1, reason


def test_a_value_outside_a_band_gets_its_line():
    """The verdict names each quantity whose measured value lies outside its band (or that has
    no predicted value); the notes name a prediction outside its own band."""
    from types import SimpleNamespace

    from nlupdate.core.validation.held_out import Compared
    from nlupdate.core.validation.verdict import comparison_notes, said
    from nlupdate.reporting.validation_text import said_line

    def verdict_lines(validation, unit):
        return [said_line(line) for line in said(validation, unit)]

    def held(**compared):
        return SimpleNamespace(level=0.35, label="lines", compared=compared, half_power_lines=9, note="",
                               extrapolation="")

    outside = held(resonance_hz=Compared(2.0, 2.1, 1.5, 2.5), peak_abs=Compared(1.0, 2.0, 1.5, 2.5))
    fine = held(resonance_hz=Compared(2.0, 2.1, 1.5, 2.5), damping_ratio=Compared(2.0, 3.0, 1.5, 2.5))
    validation = SimpleNamespace(held_out=[outside, fine], response_controlled=(), choices={},
                                 response_controlled_notes=())
    assert verdict_lines(validation, "N") == [
        "warning: measured OUTSIDE the prediction's 95 % band: 0.35 N peak |H| (lines)",
        "warning: at 0.35 N (lines): the predicted damping ratio 3 lies OUTSIDE its own 95 % band [1.5, 2.5]"]
    assert comparison_notes(fine) == ["the predicted damping ratio 3 lies OUTSIDE its own 95 % band [1.5, 2.5]"]
    assert verdict_lines(SimpleNamespace(held_out=[fine], response_controlled=(), choices={},
                                         response_controlled_notes=()), "N")[0].startswith(
        "every held-out level's resonance, damping ratio and peak |H| lies within")


def test_the_report_summary_opens_with_any_validation_warning():
    """A study report's summary opens with the validation's first warning and counts the rest
    (it showed only a miss: an extrapolation or a note with every value in its band left the
    summary silent); nothing when nothing warns."""
    from types import SimpleNamespace

    from nlupdate.core.validation.held_out import Compared
    from nlupdate.core.validation.verdict import said
    from nlupdate.reporting.validation_text import summary_headline

    inside = {"resonance_hz": Compared(2.0, 2.1, 1.5, 2.5)}
    top = SimpleNamespace(level=1.46, label="lines", compared=inside, half_power_lines=9, note="",
                          extrapolation="1.46 N lies above the kept levels 0.19–0.97 N: an extrapolation")
    interior = SimpleNamespace(level=0.49, label="lines", compared=inside, half_power_lines=9, note="", extrapolation="")

    def validation(*held):
        return SimpleNamespace(held_out=list(held), response_controlled=(), choices={}, response_controlled_notes=())

    assert summary_headline(said(validation(interior), "N")) is None
    assert summary_headline(said(validation(interior, top), "N")) == (  # every value in band, but one is extrapolated
        "every held-out level's resonance, damping ratio and peak |H| lies within its prediction's 95 % band, but "
        "1.46 N lies outside what the fit kept, where a band does not measure the form's error (1 more warning opens "
        "the validation section)")
    outside = SimpleNamespace(level=0.97, label="lines", compared={"peak_abs": Compared(1.0, 2.0, 1.5, 2.5)},
                              half_power_lines=9, note="", extrapolation="")
    assert summary_headline(said(validation(outside, top), "N")) == (
        "measured OUTSIDE the prediction's 95 % band: 0.97 N peak |H| (lines) (1 more warning opens the validation "
        "section)")


def test_the_study_report_states_the_refusal(top):
    from nlupdate.reporting.report import _validation_section

    lines = _validation_section(top, {})
    assert f"Warning: {top.choices[LEVELS[-1]].warning}" in lines
    table = next(line for line in lines if "measured in its 95 % band (f, ζ, peak)" in line)
    # the warnings come before the table they qualify, as on the terminal (they came after it)
    assert lines.index(f"Warning: {top.choices[LEVELS[-1]].warning}") < lines.index(table)
    # each quantity says whether the measured value is in its band; lines' top damping has no value, so no band
    # (+0.035 Hz, +1459 % with the modal constant and other modes' share of every level at once, issue 34; +0.037 Hz,
    # +1097 % with the lowest level's one-mode fit's constant residual; +0.038 Hz, +989 % before) both bands hold the
    # measured value; the peak's is flagged: wider than twice the levels' spread (it reaches +3976255 %), it tests
    # nothing (nlupdate.core.validation.compared)
    row = next(line for line in table.splitlines() if line.startswith("| 0.35 | lines |")).split(" | ")
    assert row[2] == "+0.035 [-0.05, +0.16]" and row[3] == "—" and row[4].startswith("+1459 [")
    assert row[5] == "yes, —, yes (band uninformative)"
    assert any(line.startswith("Warning: at 0.35 N (lines): the extrapolation leaves the physical range")
               and lines.index(line) < lines.index(table) for line in lines)


def test_auto_says_when_the_kept_curves_do_not_tell_its_two_best_apart():
    """The published BRB levels: with 0.4886 N held out the three kept levels score ``lines``
    0.549 and ``lines-background`` 0.564 (per curve 0.908, 0.118, 0.255 and 0.946, 0.100,
    0.219) — a near tie, stated in the reason (it was not); with 0.1947 N held out
    ``lines-background`` 0.235 against ``lines`` 0.237 is told apart: lower on each of the
    three curves (0.260, 0.105, 0.295 against 0.261, 0.109, 0.299), by a margin steadier
    than it is large (measured since the lines models take the modal constant of every
    level at once, issue 34; before, ``amplitude-polynomial`` 0.455 against ``lines`` 0.501 at
    0.1947 N, a near tie, and ``lines-background`` 0.438 against ``lines`` 0.537 at 0.4886 N)."""
    from nlupdate.core.validation.auto_choice import near_tie
    from test_real_measurements import brb_levels

    data = brb_levels()
    levels = [float(v) for v in data.levels]
    interior = choose_model(data.subset([levels[0], *levels[2:]]), (), levels[1])
    assert interior.name == "lines"
    assert "lines-background is within two standard errors of lines over the 3 kept curves" in interior.reason
    low = choose_model(data.subset(levels[1:]), (), levels[0])
    assert low.name == "lines-background" and "within two standard errors" not in low.reason
    # the paired rule itself: equal errors tie, a runner-up worse on every curve by far more than its scatter does not
    assert near_tie(np.array([0.3, 0.4, 0.5]), np.array([0.31, 0.39, 0.52]))
    assert not near_tie(np.array([0.3, 0.4, 0.5]), np.array([0.6, 0.71, 0.79]))
