"""What a person sees in a run archive: every multi-series plot tells its series apart,
bands are drawn where the data carry uncertainty, extrapolation is marked, no line
crosses a gap between force levels, and the report explains its numbers and columns.

The figures are those the archive writes (:func:`nlupdate.reporting.archive.archive_figures`),
inspected as matplotlib objects, for the two-DOF whole-chain study with a second
optimisation candidate: 10 runs + the initial model = 11 candidate series, one more than
matplotlib's colour cycle.
"""
from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest
from matplotlib.colors import to_rgba
from matplotlib.figure import Figure
from studies import TWO_DOF_STUDY, study_text, two_dof_study

from nlupdate.reporting.archive import archive_figures, write_archive
from nlupdate.reporting.figures import unwrapped_phase_deg
from nlupdate.study import run_study, study_from_text

RUN = {"started_utc": "2026-11-23T10:00:00+00:00", "wall_time_s": 1.0,
       "orchestration": "Prefect flow `study` on 2 threads, a Prefect server started for the run"}


@pytest.fixture(scope="module")
def result():
    study = two_dof_study()
    study["optimisation"]["candidates"].append({"name": "optimisation {k2}", "parameters": ["k2"]})
    return run_study(study_from_text(study_text(study), TWO_DOF_STUDY))


@pytest.fixture(scope="module")
def figures(result) -> dict[str, Figure]:
    return {name: draw() for _, name, draw in archive_figures(result)}


def _marker(line) -> str:
    marker = line.get_marker()
    return "None" if marker in (None, "", " ", "None", "none") else str(marker)


def series(ax) -> list[tuple[str, tuple]]:
    """(label, look) of every labelled series of ``ax``: lines (colour, line style,
    marker), filled bands and spans (face colour, hatch), bars (face colour, hatch),
    colour-mapped scatters (the colour map). An unlabelled line with more than two points
    (a data curve that escaped its label) fails here."""
    out = []
    for line in ax.get_lines():
        if line.get_label().startswith("_"):
            assert len(line.get_xdata()) <= 2, f"{ax.get_title()!r}: an unlabelled data line"
            continue
        out.append((line.get_label(), ("line", to_rgba(line.get_color()), str(line.get_linestyle()), _marker(line))))
    for collection in ax.collections:
        if collection.get_label().startswith("_"):
            continue
        if collection.get_array() is not None:
            look = ("mapped", collection.get_cmap().name)
        else:
            look = ("fill", tuple(np.round(collection.get_facecolor()[0], 3)), collection.get_hatch())
        out.append((collection.get_label(), look))
    for patch in ax.patches:
        if not patch.get_label().startswith("_"):
            out.append((patch.get_label(), ("span", tuple(np.round(patch.get_facecolor(), 3)), patch.get_hatch())))
    for container in ax.containers:
        if not container.get_label().startswith("_"):
            patch = container.patches[0]
            out.append((container.get_label(), ("bar", to_rgba(patch.get_facecolor()), patch.get_hatch())))
    return out


def look_alikes(figure: Figure) -> list[str]:
    """Series of one axes of ``figure`` that share their look with another."""
    problems = []
    for ax in figure.axes:
        found = series(ax)
        looks: dict[tuple, list[str]] = {}
        for label, look in found:
            looks.setdefault(look, []).append(label)
        problems += [f"{ax.get_title() or ax.get_ylabel()!r}: {labels}" for labels in looks.values() if len(labels) > 1]
    return problems


def test_the_check_catches_eleven_series_on_the_ten_colour_cycle():
    figure = Figure()
    ax = figure.subplots()
    for k in range(11):
        ax.plot([0, 1, 2], [k, k, k], label=f"run {k}")
    assert look_alikes(figure) == ["'': ['run 0', 'run 10']"]


def test_every_multi_series_plot_tells_its_series_apart(figures):
    assert set(figures) == {"measured_frfs.png", "identification_fit.png", "linear_frf.png", "convergence.png",
                            "frequency_errors.png", "candidate_frfs.png", "prediction_vs_measurement.png",
                            "correlation_per_level.png"}
    for name, figure in figures.items():
        assert look_alikes(figure) == [], name
    candidates = [label for label, look in series(figures["candidate_frfs.png"].axes[0]) if look[0] == "line"]
    assert len(candidates) == 12  # the extracted FRF, the initial model and 10 runs
    bars = [label for label, look in series(figures["frequency_errors.png"].axes[0]) if look[0] == "bar"]
    assert len(bars) == 11


def _band(ax):
    return [c for c in ax.collections if "Monte-Carlo band" in c.get_label()]


def test_bands_are_drawn_where_the_data_carry_uncertainty(figures):
    fit = figures["identification_fit.png"]
    for ax in fit.axes[:2]:  # Re y and Im y
        (band,) = _band(ax)
        assert np.ptp(band.get_paths()[0].vertices[:, 1]) > 0
    linear = figures["linear_frf.png"]
    assert all(_band(ax) for ax in linear.axes)  # |H| and phase, whole band and around the mode
    assert _band(figures["candidate_frfs.png"].axes[0])  # the reference of the candidates
    spans = [p.get_label() for p in figures["frequency_errors.png"].axes[0].patches]
    assert {"target ±1σ", "target ±2σ"} <= set(spans)  # the targets' uncertainty


def test_the_fit_is_solid_over_the_data_and_its_extrapolation_is_marked(figures, result):
    amplitude = result.identification.result.amplitude * 1e3
    for ax in figures["identification_fit.png"].axes[:2]:
        lines = {line.get_label(): line for line in ax.get_lines()}
        data = ax.collections[[c.get_label() for c in ax.collections].index("data (colour: force level)")]
        points = data.get_offsets()[:, 0]
        assert points.min() == pytest.approx(amplitude.min()) and points.max() == pytest.approx(amplitude.max())
        solid = np.asarray(lines["fit over the data"].get_xdata())
        assert solid.min() >= points.min() - 1e-12 and solid.max() <= points.max() + 1e-12
        dotted = np.asarray(lines["fit, extrapolated"].get_xdata())[np.isfinite(lines["fit, extrapolated"].get_ydata())]
        assert dotted.min() < points.min() and dotted.max() > points.max()
        spans = [p for p in ax.patches if p.get_label() == "extrapolation: no data"]
        assert spans and ax.get_xlim()[0] < points.min()
    assert "force levels" in figures["identification_fit.png"]._suptitle.get_text()


def test_no_line_crosses_the_gap_between_force_levels(figures):
    ax = figures["correlation_per_level.png"].axes[0]
    levels = dict(zip(ax.get_xticks(), (float(t.get_text()) for t in ax.get_xticklabels())))
    assert min(levels.values()) == 0.01 and sorted(levels.values())[1] == 20
    for line in ax.get_lines():
        if line.get_label().startswith("_"):
            continue
        x, y = np.asarray(line.get_xdata(), dtype=float), np.asarray(line.get_ydata(), dtype=float)
        joined = np.isfinite(y[:-1]) & np.isfinite(y[1:])
        for a, b in zip(x[:-1][joined], x[1:][joined]):
            assert levels[b] / levels[a] <= 3, (line.get_label(), levels[a], levels[b])


def test_predictions_show_phase_and_name_the_models_in_each_frac(figures, result):
    figure = figures["prediction_vs_measurement.png"]
    levels = len(result.predictions[0].correlation)
    assert len(figure.axes) == 2 * levels  # |H| and phase per level
    assert sum(ax.get_ylabel() == "phase (deg)" for ax in figure.axes) == 2  # 6 levels: two rows of three
    titles = [ax.get_title() for ax in figure.axes if "FRAC" in ax.get_title()]
    assert len(titles) == levels and all(re.search(r"initial \d\.\d\d, updated \d\.\d\d", t) for t in titles)


def test_candidate_frfs_say_modal_truncation_and_convergence_keeps_its_legend_off_the_curves(figures):
    texts = [t.get_text() for ax in figures["candidate_frfs.png"].axes for t in ax.texts]
    assert any("modal truncation" in t for t in texts)
    convergence = figures["convergence.png"]
    assert convergence.legends and all(ax.get_legend() is None for ax in convergence.axes)
    assert {ax.get_ylabel() for ax in convergence.axes} >= {"k1 (kN/m)", "k2 (MN/m)"}


def test_phase_is_unwrapped_through_noise():
    """A transfer FRF whose phase falls below −180° (two modes of opposite sign), with 5 %
    noise: continuous within the noise of the noise-free curve's unwrapped phase."""
    f = np.linspace(50.0, 250.0, 2001)
    w = 2 * np.pi * f
    h = sum(a / ((2 * np.pi * fr) ** 2 - w**2 + 0.02j * (2 * np.pi * fr) ** 2) for a, fr in ((1.0, 100.0), (-1.5, 180.0)))
    exact = np.degrees(np.unwrap(np.angle(h)))
    assert exact.min() < -300  # really beyond the −180° a wrapped phase shows
    rng = np.random.default_rng(4)
    noisy = h * (1 + 0.05 * (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size)) / np.sqrt(2))
    phase = unwrapped_phase_deg(noisy)
    assert np.max(np.abs(phase - exact)) < 20
    assert np.max(np.abs(np.diff(phase))) < 45


def test_report_explains_its_numbers_and_shows_readable_columns(result, tmp_path):
    folder = write_archive(result, tmp_path / "run", RUN)
    report = (folder / "report.md").read_text()
    assert "http" not in report.split("## Summary")[0]
    assert "Monte-Carlo samples — the measured curves perturbed 8 times with fresh noise" in report
    for raw in ("weighted_abs_error_pct", "weighted_frac", "force_level_n", "normalised_error", "peak_amplitude_ratio"):
        assert raw not in report
    assert "| weighted mean abs. frequency error (%) | weighted FRAC |" in report
    assert "| FRAC mode1 |" in report.split("FRAC (0–1, 1 = same shape)")[0]  # the column the text explains
    reachable = f"{result.targets.reference_fit_frac[0]:.3g} (mode1)"
    assert f"own one-mode fits — curves fitted to these very data — reach {reachable}" in report
    tables = re.findall(r"(?:^\|.*\n)+", report, flags=re.MULTILINE)
    assert len(tables) >= 6
    for table in tables:  # every line opening with "|" is a table row, and no "|" in a cell splits a column
        rows = table.splitlines()
        assert len(rows) >= 3 and re.fullmatch(r"\|(---\|)+", rows[1]), table
        assert len({row.count("|") for row in rows}) == 1, table


def test_report_mentions_no_frac_when_the_comparison_has_none(result, tmp_path):
    without = dataclasses.replace(result, comparison=result.comparison.assign(frac=np.nan))
    report = (write_archive(without, tmp_path / "run", RUN) / "report.md").read_text()
    updating = report.split("## Updating")[1].split("## Prediction")[0]
    assert "FRAC" not in updating


def test_report_says_what_the_monte_carlo_samples_are_and_why_some_failed():
    from nlupdate.identification.uncertainty import Uncertainty
    from nlupdate.reporting.report import monte_carlo_note

    edge = "ValueError: modal fit near 43.37 Hz ran to the edge of its band ({} Hz): no clear resonance there"
    note = monte_carlo_note(Uncertainty({}, 0.05, 40, 6, 1, {edge.format(47.7): 4, edge.format(39.1): 2}))
    assert "40 Monte-Carlo samples — the measured curves perturbed 40 times with fresh noise" in note
    assert "spread of the 34 results" in note and "6 samples failed and are left out" in note
    assert "(6 × modal fit near 43.37 Hz ran to the edge of its band: no clear resonance there)" in note
    assert "may be understated" in note
