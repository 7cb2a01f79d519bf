"""What the figures and printed lines of ``nlupdate validate`` and ``nlupdate amplitude`` show
(the artists and the text, not the pixels):

* a held-out level's figure carries the measured points, the prediction, its 95 % band and
  the baseline, names everything the fit kept (runs, a linear limit) and keeps its legend off
  the axes;
* the summary figure's grey repeatability is the one printed: ±1σ in Hz, and the relative
  scatter of the damping ratio and of the peak (it was the damping's points over the mean
  damping, 3 × the stated 6 % on the Brake–Reuss beam, and no peak band), those two panels
  on a log axis of predicted/measured labelled in % error; the response-controlled figure
  uses the pooled repeatability its bands use and its title names a kept linear limit;
* the backbone and damping figures mark every source, name the disagreeing ones, show the
  held-out ones (they were left off), draw the band and grey out the amplitudes without
  samples;
* the printed amplitude fit opens with its bad news.
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from matplotlib.collections import PolyCollection
from matplotlib.patches import Rectangle

from nlupdate.core.identification.modal_samples import ModalSamples
from nlupdate.core.model.amplitude_modal import AmplitudeModalModel
from nlupdate.core.validation.held_out import Compared, Repeatability
from nlupdate.reporting.backbone_plots import plot_sources
from nlupdate.reporting.validation_plots import held_out_figure, response_controlled_figure, summary_figure
from nlupdate.reporting.validation_text import repeatability_line

F = np.linspace(79.0, 81.0, 41)


def _curve(f0: float = 80.0, zeta: float = 0.002) -> np.ndarray:
    w, w0 = 2 * np.pi * F, 2 * np.pi * f0
    return 1.0 / (w0**2 - w**2 + 2j * zeta * w0 * w)


def _held(level: float, requested: str = "auto") -> SimpleNamespace:
    compared = {"resonance_hz": Compared(80.0, 80.1, 79.8, 80.4), "damping_ratio": Compared(0.002, 0.0022, 0.0015, 0.003),
                "peak_abs": Compared(1e-4, 1.1e-4, 0.8e-4, 1.4e-4)}
    baseline = {name: Compared(c.measured, c.measured * 1.05) for name, c in compared.items()}
    predicted = _curve(80.1)
    return SimpleNamespace(level=level, kept=(0.5, 1.0), label="auto → lines", requested=requested, compared=compared,
                           baseline=baseline, frequency_hz=F, measured=_curve(), predicted=predicted,
                           abs_low=np.abs(predicted) * 1e-3, abs_high=np.abs(predicted) * 1.5,
                           baseline_frf=_curve(79.9), held_m=1e-4 * level, extrapolation="")


REPEAT = Repeatability(resonance_hz=0.15, damping_ratio=5e-4, levels=4, damping_relative=0.06, peak_relative=0.04)
POOLED = Repeatability(resonance_hz=0.085, damping_ratio=3e-4, levels=12, damping_relative=0.15, peak_relative=0.03,
                       degree=2)


def _labels(figure) -> list[str]:
    return [text.get_text() for legend in figure.legends for text in legend.get_texts()]


def test_a_held_out_figure_shows_measured_prediction_band_and_baseline():
    figure = held_out_figure(_held(0.2), "N", "8 response-controlled runs + the impact's linear limit")
    (ax,) = figure.axes
    assert ax.get_legend() is None and len(figure.legends) == 1  # the legend sits below the axes, off the data
    labels = " ".join(_labels(figure))
    assert "measured (held out)" in labels and "log-amplitude baseline" in labels
    assert "95 % band of the prediction (cut at the axis)" in labels  # its low edge is 1e-3 of the curve
    assert "0.5, 1 N + 8 response-controlled runs + the impact's linear limit" in labels.replace("\n", " ")
    assert any(isinstance(c, PolyCollection) for c in ax.collections)
    low, high = ax.get_ylim()  # the axis spans the curves, not the band's far edge
    assert low > 1e-3 * np.abs(_curve(80.1)).min()


def _span(ax) -> tuple[float, float]:
    """The lower and upper edge of the grey repeatability span of one panel."""
    (patch,) = [p for p in ax.patches if isinstance(p, Rectangle) and p.get_facecolor()[:3] == pytest.approx((0.85,) * 3)]
    return tuple(patch.get_path().transformed(patch.get_patch_transform()).get_extents().intervaly)


def test_the_summary_draws_the_repeatability_it_states():
    validation = SimpleNamespace(reference_unit="N", held_out=[_held(0.2), _held(1.0)], repeatability=REPEAT)
    figure = summary_figure(validation)
    resonance, damping, peak = figure.axes
    assert _span(resonance) == pytest.approx((-0.15, 0.15))
    # the relative panels: predicted/measured on a log axis, the span exp(±σ) of the log scatter printed
    assert damping.get_yscale() == "log" and _span(damping) == pytest.approx((np.exp(-0.06), np.exp(0.06)))
    assert _span(peak) == pytest.approx((np.exp(-0.04), np.exp(0.04)))
    # its ticks read as % errors: the 95 % band of +50 % (high 0.003 against 0.002) is labelled so
    assert damping.yaxis.get_major_formatter()(1.5, 0) == "+50" and damping.yaxis.get_major_formatter()(1.0, 0) == "0"
    assert all(ax.get_legend() is None for ax in figure.axes)
    assert "auto → lines, 95 % band" in _labels(figure)
    line = repeatability_line(REPEAT, "held-out levels")
    assert "about a line" in line and "damping ratio 6 % of itself" in line and "peak |H| 4 % of itself" in line


def test_the_response_controlled_figure_uses_the_pooled_repeatability():
    validation = SimpleNamespace(reference_unit="N", response_controlled=[_held(0.2), _held(1.0)],
                                 repeatability=REPEAT, runs_repeatability=POOLED)
    figure = response_controlled_figure(validation)
    resonance, damping, _ = figure.axes
    assert _span(resonance) == pytest.approx((-0.085, 0.085))
    assert _span(damping) == pytest.approx((np.exp(-0.15), np.exp(0.15)))
    assert "about a parabola" in repeatability_line(POOLED, "response-controlled runs")
    assert "impact" not in figure.get_suptitle()
    validation.linear_limit = SimpleNamespace(frequency_hz=80.58, damping_ratio=0.0014)  # --impact kept
    assert "from the force-controlled levels and the impact's linear limit" in response_controlled_figure(
        validation).get_suptitle()


def _backbone_model() -> AmplitudeModalModel:
    """A softening, more damped polynomial backbone near the BRB's mode (80.6 Hz, 0.14 %)."""
    return AmplitudeModalModel(natural_frequency_hz=80.6, damping_ratio=0.0014, shapes=(("acc3", 0.7),),
                               frequency_coefficients=(-0.004,), damping_coefficients=(0.004,),
                               reference_amplitude=4e-4)


def _banded_curve(model: AmplitudeModalModel, a: np.ndarray) -> pd.DataFrame:
    """backbone.csv's columns for ``model`` at ``a``, with a ±1 % band."""
    curve = pd.DataFrame({"modal_amplitude": a, "natural_frequency_hz": model.frequency_hz(a),
                          "damping_ratio": model.damping(a)})
    for column in ("natural_frequency_hz", "damping_ratio"):
        curve[f"{column}_low"], curve[f"{column}_high"] = curve[column] * 0.99, curve[column] * 1.01
    return curve


def _drawn_figures(monkeypatch) -> list:
    """The figures backbone_plots saves from now on, in order (each still saved)."""
    from nlupdate.reporting import backbone_plots

    drawn: list = []
    original = backbone_plots.save_figure
    monkeypatch.setattr(backbone_plots, "save_figure", lambda fig, path: drawn.append(fig) or original(fig, path))
    return drawn


def test_the_backbone_figures_mark_every_source_and_the_disagreeing_one(tmp_path, monkeypatch):
    model = _backbone_model()
    a = np.geomspace(3e-5, 4e-4, 6)
    parts = [(f"{name} ({kind})", ModalSamples(a * k, model.frequency_hz(a * k), model.damping(a * k), np.ones(6), 0.7))
             for k, (name, kind) in zip((1.0, 0.9), (("rd.csv", "ring-down"), ("rc.mat", "response-controlled")))]
    curve, drawn = _banded_curve(model, a), _drawn_figures(monkeypatch)
    held = [("tap.csv (impact)", ModalSamples(a[:1] / 10, model.frequency_hz(a[:1] / 10), model.damping(a[:1] / 10),
                                               np.ones(1), 0.7))]
    paths = plot_sources(model, parts, curve, tmp_path, frozenset({"rd.csv (ring-down)"}), held)
    assert all(p.is_file() for p in paths) and len(drawn) == 2
    for figure in drawn:
        labels = _labels(figure)
        assert "rd.csv (ring-down): 6 sample(s) — DISAGREES with the fit" in labels
        assert "rc.mat (response-controlled): 6 sample(s)" in labels
        assert "tap.csv (impact): 1 sample(s), held out (not fitted)" in labels
        assert "polynomial fit, the sources not held out" in labels and "no samples (extrapolated or held)" in labels
        assert any(label.startswith("95 % band of the fit (bootstrap)") for label in labels)
        assert figure.axes[0].get_xlim()[0] < a[0] / 10  # the held-out sample is on the axis
        assert figure.axes[0].get_legend() is None


def test_a_source_keeps_its_marker_and_colour_whichever_other_source_is_held_out(tmp_path, monkeypatch):
    """The BRB's impact was an orange square beside the ring-down and a blue circle with the
    ring-down held out: its look came from its place among the fitted sources."""
    model = _backbone_model()
    a = np.geomspace(3e-5, 4e-4, 6)

    def samples(k: float) -> ModalSamples:
        return ModalSamples(a * k, model.frequency_hz(a * k), model.damping(a * k), np.ones(6), 0.7)

    ring_down, impact, runs = ("rd.csv (ring-down)", samples(1.0)), ("tap.csv (impact)", samples(0.1)), \
        ("rc.mat (response-controlled)", samples(0.9))
    curve, drawn = _banded_curve(model, a), _drawn_figures(monkeypatch)

    def looks() -> dict[str, tuple]:
        lines = drawn[-1].axes[0].get_lines()
        return {line.get_label().split(":")[0]: (line.get_marker(), line.get_markeredgecolor(), line.get_markerfacecolor())
                for line in lines if ".csv" in line.get_label() or ".mat" in line.get_label()}

    (tmp_path / "all").mkdir(), (tmp_path / "held").mkdir()
    plot_sources(model, [ring_down, impact, runs], curve, tmp_path / "all")
    every = looks()
    plot_sources(model, [impact, runs], curve, tmp_path / "held", held=[ring_down])
    held = looks()
    for source in ("tap.csv (impact)", "rc.mat (response-controlled)"):
        assert held[source] == every[source]
    assert held["rd.csv (ring-down)"][0] == every["rd.csv (ring-down)"][0]  # the same marker, filled grey
    assert len({look[:2] for look in every.values()}) == 3


def test_the_printed_amplitude_fit_opens_with_its_bad_news():
    from nlupdate.reporting.amplitude_report import amplitude_lines

    model = _backbone_model()
    a = np.geomspace(3e-5, 4e-4, 6)
    agreement = pd.DataFrame({"source": ["rd.csv", "rc.mat"], "test_type": ["ring-down", "response-controlled"],
                              "samples": [6, 6], "compared_with": ["agreeing sources"] * 2,
                              "frequency_offset": [1e-4, -3e-4], "frequency_score": [3.6, -1.0],
                              "damping_offset": [0.234, 0.0014], "damping_score": [66.0, 0.17],
                              "consistent": [False, True]})
    fit = SimpleNamespace(model=model, samples=ModalSamples(a, model.frequency_hz(a), model.damping(a), np.ones(6), 0.7),
                          agreement=agreement, resamples=200, held_errors=None, held_worst=lambda: [], unit="N",
                          options=SimpleNamespace(backbone="polynomial"),
                          disagreeing=lambda: ["rd.csv"], poor=lambda: True, misfit=lambda: (0.0013, 0.101))
    lines = amplitude_lines(fit)
    assert lines[0].startswith("warning: rd.csv disagrees with the joint fit")
    assert lines[1].startswith("warning: the model misses its samples by 0.13 % in frequency and 10.1 % in damping")
    assert lines[2].startswith("mode 1: linear limit 80.6 Hz")
    assert "rd.csv (ring-down): 6 sample(s), mean misfit +0.01 % in frequency (+3.6 standard errors), +23 % in " \
           "damping (+66) — DISAGREES" in lines[-2]


def test_a_held_out_type_opens_with_the_values_outside_their_bands():
    """``validate --hold-out-type``: the first line names each level (or the samples) whose
    measured value lies outside the prediction's band; the table gives the bands."""
    from test_held_type_bands import held_type_lines

    def compared(measured, predicted, low=None, high=None):
        out = {"measured": measured, "predicted": predicted, "error": predicted - measured,
               "relative_error": predicted / measured - 1}
        return out if low is None else {**out, "low": low, "high": high, "inside": low <= measured <= high}

    level = {"level": 0.1947, "within_fit": True, "resonance_hz": compared(80.262, 80.383, 80.08, 80.68),
             "damping_ratio": compared(0.00119, 0.00249, 0.00136, 0.00361), "peak_abs": compared(5.6e-4, 4.2e-4)}
    lines = held_type_lines({"test_type": "stepped-sine", "levels": [level], "samples": [], "model": {}}, "N")
    assert lines[0] == ("warning: stepped-sine held out: measured OUTSIDE the prediction's 95 % band: "
                        "0.1947 N damping ratio")
    assert lines[2].split() == ["0.1947", "80.262", "80.383", "[80.08,", "80.68]", "0.119", "0.249", "[0.136,",
                                "0.361]", "-25.0", "yes,", "NO,", "—"]
    sample = {"within_fit": True, "modal_amplitude": 1e-4, "natural_frequency_hz": compared(80.4, 80.41, 80.3, 80.5),
              "damping_ratio": compared(0.002, 0.0016, 0.0017, 0.0019)}
    lines = held_type_lines({"test_type": "ring-down", "levels": [], "samples": [sample, sample], "model": {}}, "N")
    assert lines[0] == ("warning: ring-down held out: measured OUTSIDE the prediction's 95 % band: damping ratio of 2 "
                        "of the 2 held-out samples within the fitted amplitudes")
    assert len(lines) == 4 and lines[3].split()[-2:] == ["yes,", "NO"]  # then one row per sample
    outside = {**sample, "within_fit": False, "source": "tap.csv", "modal_amplitude": 2e-3,
               "predicted_at_modal_amplitude": 2e-3}  # an impact above the fitted amplitudes
    assert held_type_lines({"test_type": "impact", "levels": [], "samples": [outside], "model": {}}, "N")[0] == (
        "warning: impact held out: no held-out sample lies within the fitted amplitudes: each prediction is an "
        "extrapolation, without a band")


def test_a_held_sample_figure_is_grey_to_the_axis_edges_beyond_the_fitted_amplitudes():
    """The grey spans stopped short of the axes' automatic margins, leaving a white strip at
    each end that read as fitted amplitudes (the BRB's runs held out from levels and ring-down)."""
    from matplotlib.patches import Rectangle

    from nlupdate.reporting.held_type_plots import held_type_figure

    model = _backbone_model()
    a = np.geomspace(2.7e-5, 4.4e-4, 8)
    samples = pd.DataFrame({"modal_amplitude": a, "natural_frequency_hz": model.frequency_hz(a),
                            "predicted_frequency_hz": model.frequency_hz(a), "damping_ratio": model.damping(a),
                            "predicted_damping_ratio": model.damping(a)})
    result = SimpleNamespace(test_type="response-controlled", levels=pd.DataFrame(), samples=samples,
                             fitted_range=(3.1e-5, 3.7e-4), model=model,
                             fitted_on=[("levels.mat", "stepped-sine", 4), ("tap.mat", "ring-down", 8)])
    for ax in held_type_figure(result).axes:
        spans = sorted((p.get_x(), p.get_x() + p.get_width()) for p in ax.patches if isinstance(p, Rectangle))
        assert ax.get_xlim()[0] == pytest.approx(spans[0][0]) and ax.get_xlim()[1] == pytest.approx(spans[-1][1])
