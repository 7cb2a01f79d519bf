"""What ``nlupdate amplitude`` says about how far to trust its model, checked on data whose
answer is known:

* the modal amplitude of FRFs per volt is in m·√(kg·V/N), not m·√kg (the printed range and the
  figures' axis said m·√kg, the unit of a physical modal amplitude, for the transmitter
  beam's m/V curves); the same curves per newton keep m·√kg and the same numbers;
* a figure whose model carries warnings (a linear limit extrapolated, on a bound, a stiffening
  backbone) says in its title that the linear limit is not determined, instead of stating it
  as the answer the terminal contradicts;
* a ring-down or impact record read without a shape at its channel, joined with modal
  samples, is refused in one line naming the file and the ``--shape`` to give (the line named
  neither).
"""
from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from nlupdate.app.cli import main
from nlupdate.core.identification.modal_samples import ModalSamples
from nlupdate.core.measurement.frf_files import write_frf_table
from nlupdate.core.measurement.frf_table import frf_table
from nlupdate.core.model.amplitude_modal import AmplitudeModalModel
from nlupdate.reporting import backbone_plots
from single_mode_reference import amplitude

BRB = Path(__file__).parent / "data" / "brb"
LEVELS = (0.2, 0.5, 1.0, 1.5)
F = np.linspace(78.0, 82.0, 81)
A_REF = 1e-4  # m: the closed-form mode's amplitude scale (unit modal mass, shape 1)


def _denominator(a, omega):
    """ω(a)² − Ω² + 2iζ(a)ω(a)Ω of a mode softening 0.3 % and damping 0.2 → 0.4 % over a = A_REF."""
    w = 2 * np.pi * 80.0 * (1 - 0.003 * np.asarray(a) / A_REF)
    zeta = 0.002 * (1 + np.asarray(a) / A_REF)
    return w**2 - omega**2 + 2j * zeta * w * omega


def _table(unit: str) -> pd.DataFrame:
    grid = np.geomspace(1e-8, 1e-2, 4000)
    rows = [frf_table(F, level, "0", "0", np.array([1 / _denominator(amplitude(_denominator, level, 2 * np.pi * f,
                                                                                    grid), 2 * np.pi * f) for f in F]))
            for level in LEVELS]
    return pd.concat(rows, ignore_index=True).assign(reference_unit=unit)


def _amplitude(unit: str, tmp_path: Path, capsys) -> tuple[str, dict]:
    path = tmp_path / f"{unit}.parquet"
    write_frf_table(_table(unit), path)
    assert main(["amplitude", "--measured", str(path), "--backbone", "polynomial", "--bootstrap", "0",
                 "--out", str(tmp_path / unit)]) == 0
    printed = capsys.readouterr().out
    line = next(text for text in printed.splitlines() if text.startswith("mode 1: linear limit"))
    return line, json.loads((tmp_path / unit / "amplitude_model.json").read_text())


def test_a_model_of_frfs_per_volt_states_its_modal_amplitude_per_volt(tmp_path, capsys):
    per_newton, model_n = _amplitude("N", tmp_path, capsys)
    per_volt, model_v = _amplitude("V", tmp_path, capsys)
    span = r"modal amplitudes ([\d.e+-]+)–([\d.e+-]+) "
    assert re.search(span + r"m·√kg\)", per_newton), per_newton
    assert re.search(span + r"m·√\(kg·V/N\)\)", per_volt), per_volt  # it said m·√kg
    # the same numbers: the unit is what differs; and they are the closed form's (shape 1, unit mass)
    assert re.search(span, per_newton).groups() == re.search(span, per_volt).groups()
    low, high = map(float, re.search(span, per_newton).groups())
    grid = np.geomspace(1e-8, 1e-2, 4000)  # each level's largest amplitude over its lines, in closed form
    peaks = [max(amplitude(_denominator, level, 2 * np.pi * f, grid) for f in F) for level in (LEVELS[0], LEVELS[-1])]
    assert np.allclose([low, high], peaks, rtol=0.05), (low, high, peaks)
    assert model_v["reference_unit"] == "V" and model_n["reference_unit"] == "N"
    # amplitude_model.json's units alike (they said m*sqrt(kg) per volt)
    assert model_n["units"].startswith("modal amplitude a in m*sqrt(kg) (mass-normalised mode), shapes in 1/sqrt(kg)")
    assert model_v["units"].startswith("modal amplitude a in m*sqrt(kg*V/N)") and "shapes in 1/sqrt(kg*V/N)" in model_v["units"]


def _model(warnings: tuple[str, ...], unit: str = "N") -> AmplitudeModalModel:
    return AmplitudeModalModel(natural_frequency_hz=80.0, damping_ratio=0.002, shapes=(("0", 1.0),),
                               frequency_coefficients=(-0.003,), damping_coefficients=(0.002,),
                               reference_amplitude=A_REF, warnings=warnings, reference_unit=unit)


def _figures(model: AmplitudeModalModel, tmp_path: Path, monkeypatch) -> list:
    a = np.geomspace(0.3 * A_REF, A_REF, 5)
    samples = ModalSamples(a, model.frequency_hz(a), model.damping(a), np.ones(5), 1.0)
    curve = pd.DataFrame({"modal_amplitude": a, "natural_frequency_hz": model.frequency_hz(a),
                          "damping_ratio": model.damping(a)})
    for column in ("natural_frequency_hz", "damping_ratio"):
        curve[f"{column}_low"], curve[f"{column}_high"] = curve[column] * 0.99, curve[column] * 1.01
    tmp_path.mkdir(parents=True, exist_ok=True)
    drawn = []
    original = backbone_plots.save_figure
    monkeypatch.setattr(backbone_plots, "save_figure", lambda fig, path: drawn.append(fig) or original(fig, path))
    backbone_plots.plot_sources(model, [("levels.csv (stepped-sine)", samples)], curve, tmp_path)
    return drawn


def test_the_figures_say_when_the_linear_limit_is_not_determined(tmp_path, monkeypatch):
    warned = "the linear damping ratio ζ₀ = 0.002 % is the damping curve's extrapolation below every sample"
    for figure in _figures(_model((warned,)), tmp_path, monkeypatch):
        title = figure.axes[0].get_title()
        assert "linear limit 80 Hz" in title and "NOT determined" in title and "see the warnings" in title, title
    for figure in _figures(_model(()), tmp_path / "ok", monkeypatch)[-2:]:
        assert "NOT determined" not in figure.axes[0].get_title()


def test_the_figures_label_a_per_volt_modal_amplitude(tmp_path, monkeypatch):
    (frequency, damping) = _figures(_model((), "V"), tmp_path, monkeypatch)
    assert frequency.axes[0].get_xlabel() == "modal amplitude a (m·√(kg·V/N))"
    assert damping.axes[0].get_xlabel() == "modal amplitude a (m·√(kg·V/N))"
    (frequency, _) = _figures(_model((), "N"), tmp_path / "n", monkeypatch)[-2:]
    assert frequency.axes[0].get_xlabel() == "modal amplitude a (m·√kg)"


def test_an_impact_without_its_channels_shape_is_refused_naming_the_file_and_the_option(tmp_path, capsys):
    """The BRB's hammer impact (acc3, m/s²) with its response-controlled runs, the shape given
    only under the runs' coordinate acc3:y: the record's amplitudes are in m, not modal."""
    runs, impact = BRB / "ForcedFrequencyResponses.mat", BRB / "HammerImpact_1600Hz.mat"
    code = main(["amplitude", "--response-controlled", str(runs), "--coordinates", f"{runs}=acc3:-y,acc3:y",
                 "--shape", "acc3:y=0.7271", "--impact", str(impact), "--channel", "acc3", "--response-unit", "m/s^2",
                 "--backbone", "polynomial", "--out", str(tmp_path / "out")])
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert code != 0 and not (tmp_path / "out").exists()
    assert str(impact) in error and "--shape acc3=VALUE" in error and "acc3:y=0.7271" in error, error


def test_validate_prints_each_held_sample_beside_its_prediction():
    """A ring-down held out of a mode linear in a (tests/test_held_type_bands.py: f = 10 Hz ·
    (1 − 0.02 a/A), ζ = 0.5 % (1 + 2a/A), measured to 1e-5 and 0.5 %): the terminal gave only the
    largest errors; each of the 12 samples now has its row, its numbers the truth's."""
    from test_held_type_bands import held_type_lines
    from test_held_type_bands import A, held_out, truth

    summary = held_out((1e-5, 0.005))
    lines = held_type_lines(summary, "N")
    header = next(k for k, line in enumerate(lines) if line.startswith("modal amplitude (m·√kg)"))
    rows = lines[header + 1:]
    assert len(rows) == len(summary["samples"]) == 12
    for row, entry in zip(rows, summary["samples"]):
        cells = row.split()
        a = float(cells[0])
        f, zeta = truth(np.array([a]))
        assert a == pytest.approx(entry["modal_amplitude"], rel=2e-3) and 0.40 * A <= a * (1 + 2e-3)
        assert float(cells[1]) == pytest.approx(f[0], abs=2e-3)  # measured, to the printed 3 decimals
        assert float(cells[2]) == pytest.approx(f[0], abs=2e-3)  # predicted: the model of the right form
        assert row.endswith("yes, yes")


def test_an_impacts_frequency_error_is_printed_to_the_digits_it_has():
    """The BRB's impact against the linear limit of the fit of its other tests (80.5797 Hz
    measured, 80.6175 Hz predicted: +0.0378 Hz, +0.047 %): the row said "(+0.0 %)"."""
    from test_held_type_bands import held_type_lines

    measured, predicted = 80.57967619, 80.61749787
    entry = {"source": "tap.mat", "modal_amplitude": 3.6e-6, "within_fit": False, "predicted_at_modal_amplitude": 0.0,
             "extrapolation": "the impact tap.mat lies below every kept sample",
             "natural_frequency_hz": {"measured": measured, "predicted": predicted, "error": predicted - measured,
                                      "relative_error": predicted / measured - 1},
             "damping_ratio": {"measured": 0.0014165, "predicted": 0.0016135, "error": 1.97e-4,
                               "relative_error": 0.0016135 / 0.0014165 - 1}}
    summary = {"test_type": "impact", "samples": [entry], "levels": [], "model": {}}
    (row,) = [line for line in held_type_lines(summary, "N") if "natural frequency" in line and "tap.mat" in line]
    assert "+0.0378 Hz (+0.047 %)" in row, row


def test_the_summary_figure_stars_the_extrapolated_levels():
    """validate --hold-out each on four levels: the lowest and the highest held-out level lie
    outside the kept ones (the terminal warns so; on the BRB 0.1947 and 1.46 N) — the summary
    figure drew them like the interior ones while response_controlled.png starred its runs."""
    from types import SimpleNamespace

    from nlupdate.reporting.validation_plots import summary_figure
    from test_validation_figures import REPEAT, _held

    levels = (0.1947, 0.4886, 0.9699, 1.46)
    held = [_held(level) for level in levels]
    for result in held:
        kept = [v for v in levels if v != result.level]
        result.kept = tuple(kept)
        result.extrapolation = "an extrapolation" if not min(kept) < result.level < max(kept) else ""
    figure = summary_figure(SimpleNamespace(reference_unit="N", held_out=held, repeatability=REPEAT))
    for ax in figure.axes:
        assert [t.get_text() for t in ax.get_xticklabels()] == ["0.1947*", "0.4886", "0.9699", "1.46*"]
        assert ax.get_xlabel() == "held-out level (N); *: extrapolated"


def test_an_all_in_band_verdict_on_an_extrapolated_level_is_a_warning():
    """validate --hold-out top (the transmitter beam's 0.45 V, every value in its band): the
    first line read "every held-out level's … lies within its prediction's 95 % band", a pass,
    and the warning that the level is an extrapolation came after it. The first line now says so."""
    from types import SimpleNamespace

    from nlupdate.core.validation.held_out import Compared
    from nlupdate.core.validation.verdict import said
    from nlupdate.reporting.validation_text import said_line

    def verdict_lines(validation, unit):
        return [said_line(line) for line in said(validation, unit)]

    inside = {"resonance_hz": Compared(42.74, 42.755, 42.73, 42.79), "damping_ratio": Compared(7.8e-4, 7.1e-4, 4e-4, 1e-3)}
    top = SimpleNamespace(level=0.45, label="auto → amplitude-polynomial", compared=inside, half_power_lines=9, note="",
                          extrapolation="held-out level 0.45 V lies above the highest kept level (0.1–0.3 V)")
    interior = SimpleNamespace(**{**vars(top), "level": 0.2, "extrapolation": ""})
    validation = SimpleNamespace(held_out=[top], response_controlled=(), choices={}, response_controlled_notes=())
    first, second = verdict_lines(validation, "V")
    assert first.startswith("warning: every held-out level's") and "0.45 V lies outside what the fit kept" in first
    assert second == f"warning: {top.extrapolation}"
    validation.held_out = [interior]  # inside the kept levels: the pass stands
    assert verdict_lines(validation, "V") == ["every held-out level's resonance, damping ratio and peak |H| lies within "
                                              "its prediction's 95 % band"]


def test_a_held_out_level_outside_the_kept_ones_says_so_on_its_figure():
    from nlupdate.reporting.validation_plots import held_out_figure
    from test_validation_figures import _held

    top = _held(1.46)
    top.extrapolation = "held-out level 1.46 N lies above the highest kept level (0.5–1 N): an extrapolation"
    assert "EXTRAPOLATED" in held_out_figure(top, "N").axes[0].get_title()
    assert "EXTRAPOLATED" not in held_out_figure(_held(0.7), "N").axes[0].get_title()  # between the kept 0.5 and 1 N


def test_the_residual_column_is_explained():
    """The tables' last column, residual/noise (on the BRB 20–728 for the models, up to 2e3 for the
    baseline), was printed without a word of what it is."""
    from types import SimpleNamespace

    from nlupdate.core.validation.held_out import Compared
    from nlupdate.reporting.validation_text import validation_lines
    from test_validation_figures import REPEAT

    compared = {"resonance_hz": Compared(80.0, 80.1, 79.8, 80.4), "damping_ratio": Compared(2e-3, 2.2e-3, 1.5e-3, 3e-3),
                "peak_abs": Compared(1e-4, 1.1e-4, 0.8e-4, 1.4e-4)}
    held = SimpleNamespace(level=0.49, label="lines", compared=compared, baseline=compared, residual_to_noise=728.0,
                           baseline_residual_to_noise=570.0)
    lines = validation_lines(SimpleNamespace(held_out=[held], response_controlled=(), choices={},
                                             repeatability=REPEAT), "N")
    header = next(line for line in lines if line.startswith("level (N)"))
    assert header.rstrip().endswith("residual/noise")
    assert any(line.startswith("residual/noise: the RMS over the curve's lines of |H predicted − H measured| over "
                               "the measurement noise") for line in lines)


def test_a_fit_without_bands_says_so_in_the_legend(tmp_path, monkeypatch):
    """The iwan backbone's default (--bootstrap 0): backbone.csv's band columns are NaN and the
    figures drew the curve alone, as if it were certain; the legend now says there is no band."""
    model = _model(())
    a = np.geomspace(0.3 * A_REF, A_REF, 5)
    samples = ModalSamples(a, model.frequency_hz(a), model.damping(a), np.ones(5), 1.0)
    curve = pd.DataFrame({"modal_amplitude": a, "natural_frequency_hz": model.frequency_hz(a),
                          "damping_ratio": model.damping(a)})
    for column in ("natural_frequency_hz", "damping_ratio"):
        curve[f"{column}_low"] = curve[f"{column}_high"] = np.nan
    drawn = []
    original = backbone_plots.save_figure
    monkeypatch.setattr(backbone_plots, "save_figure", lambda fig, path: drawn.append(fig) or original(fig, path))
    backbone_plots.plot_sources(model, [("levels.csv (stepped-sine)", samples)], curve, tmp_path)
    for figure in drawn:
        labels = [t.get_text() for legend in figure.legends for t in legend.get_texts()]
        assert "no 95 % band (no bootstrap refits: --bootstrap N)" in labels, labels


def test_frfs_joining_the_runs_without_a_shape_are_refused_with_the_runs_value(tmp_path, capsys):
    """The BRB's levels and its response-controlled runs, no --shape: the runs take 0.7271 1/√kg
    from their lowest run's modal constant (0.65-0.8 by scipy's one-mode fit alone,
    tests/test_response_controlled.py) and print it; the refusal of the levels asked for
    --shape acc3:y=VALUE without it. It now offers the value the runs read."""
    runs = BRB / "ForcedFrequencyResponses.mat"
    code = main(["amplitude", "--measured", str(runs), "--response-controlled", str(runs), "--coordinates",
                 f"{runs}=acc3:-y,acc3:y", "--backbone", "polynomial", "--out", str(tmp_path / "out")])
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert code != 0 and not (tmp_path / "out").exists()
    offered = re.search(r"e\.g\. --shape acc3:y=([\d.]+)$", error)
    assert offered and 0.65 < float(offered[1]) < 0.8, error
