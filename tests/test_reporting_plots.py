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
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import to_rgba
from matplotlib.figure import Figure
from matplotlib.text import Text
from studies import TWO_DOF_STUDY, study_text, two_dof_study

from nlupdate.core.identification.uncertainty import CurveBand
from nlupdate.reporting.archive import archive_figures, write_archive
from nlupdate.reporting.figures import FIT_COLOUR, png_bytes, unwrapped_phase_deg
from nlupdate.reporting.identification_plots import fit_figure, zoom_window
from nlupdate.reporting.styles import run_styles
from nlupdate.reporting.updating_plots import convergence_figure
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
        solid = _solid_fit_x(ax)
        assert solid.min() >= points.min() - 1e-12 and solid.max() <= points.max() + 1e-12
        dotted = np.asarray(lines["fit, extrapolated"].get_xdata())[np.isfinite(lines["fit, extrapolated"].get_ydata())]
        assert dotted.min() < points.min() and dotted.max() > points.max()
        spans = [p for p in ax.patches if p.get_label() == "no data"]
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
    amplitude = result.identification.result.amplitude * 1e3  # one stretch, no gap (checked above)
    assert (f"solid where the data lie ({amplitude.min():.3g}–{amplitude.max():.3g} mm) and dotted beyond them"
            in report)
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
    from nlupdate.core.identification.uncertainty import Uncertainty
    from nlupdate.reporting.identification_report import monte_carlo_note

    edge = "ValueError: modal fit near 43.37 Hz ran to the edge of its band ({} Hz): no clear resonance there"
    note = monte_carlo_note(Uncertainty({}, 0.05, 40, 6, 1, {edge.format(47.7): 4, edge.format(39.1): 2}))
    assert "40 Monte-Carlo samples — the measured curves perturbed 40 times with fresh noise" in note
    assert "spread of the 34 results" in note and "6 samples failed and are left out" in note
    assert "(6 × modal fit near 43.37 Hz ran to the edge of its band: no clear resonance there)" in note
    assert "may be understated" in note


# ----------------------------------------------------------------------------- what each plot claims


def _drawn(figure: Figure) -> Figure:
    """``figure`` laid out and drawn as the archive writes it (PNG at 120 dpi)."""
    png_bytes(figure)
    return figure


def _text_boxes(figure: Figure) -> list[tuple[str, object]]:
    """(what, window extent) of every visible, non-empty text a reader sees: the figure's
    title and legends, and per axes its titles, axis labels, tick labels, texts and legend."""
    renderer = figure.canvas.get_renderer()
    items = []

    def add(artist, what):
        if artist is None or not artist.get_visible():
            return
        if isinstance(artist, Text) and not artist.get_text().strip():
            return
        items.append((what, artist.get_window_extent(renderer)))

    add(figure._suptitle, "suptitle")
    for legend in figure.legends:
        add(legend, "figure legend")
    for k, ax in enumerate(figure.axes):
        if not ax.get_visible() or not ax.axison:
            continue
        for title in (ax.title, ax._left_title, ax._right_title):
            add(title, f"axes {k} title {title.get_text()!r}")
        for axis in (ax.xaxis, ax.yaxis):
            add(axis.label, f"axes {k} label {axis.label.get_text()!r}")
            for tick in axis.get_major_ticks() + axis.get_minor_ticks():
                lo, hi = sorted(axis.get_view_interval())
                if lo - 1e-9 * abs(hi - lo) <= tick.get_loc() <= hi + 1e-9 * abs(hi - lo):
                    for label in (tick.label1, tick.label2):
                        add(label, f"axes {k} tick {label.get_text()!r}")
        for text in ax.texts:
            add(text, f"axes {k} text {text.get_text()!r}")
        add(ax.get_legend(), f"axes {k} legend")
    return items


def overlapping_texts(figure: Figure) -> list[str]:
    """Pairs of texts of ``figure`` whose boxes (from the renderer) overlap by more than
    half a pixel each way."""
    items = _text_boxes(_drawn(figure))
    out = []
    for i, (a, box_a) in enumerate(items):
        for b, box_b in items[i + 1:]:
            width = min(box_a.x1, box_b.x1) - max(box_a.x0, box_b.x0)
            height = min(box_a.y1, box_b.y1) - max(box_a.y0, box_b.y0)
            if width > 0.5 and height > 0.5:
                out.append(f"{a} / {b}")
    return out


def test_the_overlap_check_catches_two_labels_on_one_spot():
    figure = Figure()
    ax = figure.subplots()
    ax.text(0.5, 0.5, "σ of target mode1: 0.1 %")
    ax.text(0.52, 0.51, "σ of target mode2: 0.11 %")
    assert overlapping_texts(figure) == [
        "axes 0 text 'σ of target mode1: 0.1 %' / axes 0 text 'σ of target mode2: 0.11 %'"]


def test_no_text_of_any_plot_overlaps_another(figures):
    for name, figure in figures.items():
        assert overlapping_texts(figure) == [], name


def _fit_stub(amplitude_mm: np.ndarray, band_width: float):
    """An identification with a cubic-spring PRD curve y = ¾ k3 A² (1 + 0.05 i) (k3 = 1e10
    N/m³, a loss factor 0.05), points exactly on it at ``amplitude_mm`` and a Monte-Carlo
    band ±``band_width`` (N/m) around it over 0.01–5 mm: what :func:`fit_figure` reads,
    nothing else."""
    k3 = 1e10

    def fitted_y(a):
        return 0.75 * k3 * np.asarray(a, float) ** 2 * (1 + 0.05j)

    amplitude = np.asarray(amplitude_mm, float) * 1e-3
    grid = np.geomspace(1e-5, 5e-3, 300)
    y = fitted_y(grid)
    band = CurveBand(grid, (y.real - band_width, y.real + band_width), (y.imag - band_width, y.imag + band_width),
                     (np.abs(y), np.abs(y)), (np.zeros_like(grid), np.zeros_like(grid)), 20)
    result = SimpleNamespace(method="ddf", amplitude=amplitude, y=fitted_y(amplitude), fitted_y=fitted_y,
                             amplitude_range=(amplitude.min(), amplitude.max()), point_force_n=None,
                             estimator="basic", extras={},
                             setup=SimpleNamespace(force_pair=(1.0, 10.0), band_hz=(40.0, 50.0)))
    return SimpleNamespace(result=result, reference_unit="N", fit_band=band,
                           misfit_in_noise_units=lambda: np.ones(amplitude.size))


def _solid_fit_x(ax) -> np.ndarray:
    """x (mm) of every finite point of the solid lines in the fit's colour."""
    xs = [np.asarray(line.get_xdata(), float)[np.isfinite(np.asarray(line.get_ydata(), float))]
          for line in ax.get_lines()
          if to_rgba(line.get_color()) == to_rgba(FIT_COLOUR) and line.get_linestyle() == "-"]
    return np.concatenate(xs)


def test_the_fit_is_solid_only_where_the_data_lie_and_the_caption_says_so():
    """Points at 0.1–0.3 mm and at 2–3 mm, none in between (a factor 6.7 apart): solid
    over those two stretches only, drawn across them, the gap dashed and shaded, the
    title naming both stretches."""
    amplitude = np.concatenate([np.linspace(0.1, 0.3, 20), np.linspace(2.0, 3.0, 20)])
    figure = fit_figure(_fit_stub(amplitude, 1.0), "stub")
    for ax in figure.axes[:2]:
        solid = _solid_fit_x(ax)
        inside = ((solid >= 0.1 - 1e-9) & (solid <= 0.3 + 1e-9)) | ((solid >= 2.0 - 1e-9) & (solid <= 3.0 + 1e-9))
        assert inside.all(), solid[~inside]
        assert solid.min() == pytest.approx(0.1) and solid.max() == pytest.approx(3.0)
        assert np.any(np.isclose(solid, 0.3)) and np.any(np.isclose(solid, 2.0))  # both stretches drawn to their ends
        dashed = [line for line in ax.get_lines() if line.get_linestyle() == "--"
                  and to_rgba(line.get_color()) == to_rgba(FIT_COLOUR)]
        assert len(dashed) == 1
        x = np.asarray(dashed[0].get_xdata(), float)[np.isfinite(np.asarray(dashed[0].get_ydata(), float))]
        assert x.min() == pytest.approx(0.3) and x.max() == pytest.approx(2.0)
        shaded = [p.get_x() for p in ax.patches if p.get_x() > 0.2 and p.get_x() < 1.0]
        assert shaded == [pytest.approx(0.3)]  # the gap is greyed like the extrapolation
    title = figure._suptitle.get_text()
    assert "0.1–0.3 mm and 2–3 mm" in title and "dashed across the gap" in title


def test_the_fit_of_the_whole_chain_is_solid_over_its_data(figures, result):
    """The 2-DOF study's points leave no gap (no two consecutive amplitudes 2× apart): one
    solid stretch from the smallest to the largest amplitude, and the report's caption says so."""
    amplitude = np.sort(result.identification.result.amplitude) * 1e3
    assert np.max(amplitude[1:] / amplitude[:-1]) < 2
    for ax in figures["identification_fit.png"].axes[:2]:
        solid = _solid_fit_x(ax)
        assert solid.min() == pytest.approx(amplitude[0]) and solid.max() == pytest.approx(amplitude[-1])


def _pixels(figure: Figure) -> np.ndarray:
    """The RGB pixels of ``figure`` as drawn now (floats 0–255, row 0 at the top)."""
    canvas = FigureCanvasAgg(figure)
    canvas.draw()
    return np.asarray(canvas.buffer_rgba(), dtype=float)[..., :3]


def band_pixels(figure: Figure, bands: list, x_ranges: list) -> list[np.ndarray]:
    """Per band (each in its own axes; ``x_ranges``: data-unit limits per band, or None),
    the display coordinates (n×2, pixel centres) of the pixels of its axes that change
    visibly (by more than 10 % of full scale in some channel) when the bands are drawn:
    what of each band shows beside the curves over it."""
    _drawn(figure)
    with_bands = _pixels(figure)
    for band in bands:
        band.set_visible(False)
    without = _pixels(figure)
    for band in bands:
        band.set_visible(True)
    height = with_bands.shape[0]
    changed = np.abs(with_bands - without).max(axis=-1) > 25
    rows, columns = np.nonzero(changed)
    xy = np.column_stack([columns + 0.5, height - rows - 0.5])
    out = []
    for band, x_range in zip(bands, x_ranges):
        box = band.axes.get_window_extent()
        inside = (xy[:, 0] > box.x0 + 2) & (xy[:, 0] < box.x1 - 2) & (xy[:, 1] > box.y0 + 2) & (xy[:, 1] < box.y1 - 2)
        if x_range is not None:
            ends = band.axes.transData.transform(np.column_stack([x_range, [1.0, 1.0]]))[:, 0]
            inside &= (xy[:, 0] >= ends.min()) & (xy[:, 0] <= ends.max())
        out.append(xy[inside])
    return out


def distance_to_lines(points: np.ndarray, lines: list) -> np.ndarray:
    """Distance (pixels) of each display point to the nearest of ``lines`` (matplotlib
    Line2D, their drawn paths, broken at NaN)."""
    best = np.full(len(points), np.inf)
    for line in lines:
        xy = line.get_transform().transform(np.asarray(line.get_xydata(), float))
        finite = np.all(np.isfinite(xy), axis=1)
        for run in np.split(np.arange(len(xy)), np.flatnonzero(np.diff(finite.astype(int))) + 1):
            if not finite[run[0]] or run.size < 2:
                continue
            a, b = xy[run[:-1]], xy[run[1:]]
            for k in range(0, len(points), 256):
                p = points[k:k + 256, None, :]
                t = np.clip(np.sum((p - a) * (b - a), -1) / np.maximum(np.sum((b - a) ** 2, -1), 1e-12), 0, 1)
                d = np.sqrt(np.min(np.sum((p - a - t[..., None] * (b - a)) ** 2, -1), axis=1))
                best[k:k + 256] = np.minimum(best[k:k + 256], d)
    return best


#: How far (points) a band must reach beyond the edge of its curve to count as shown.
MARGIN_PT = 2.0


def check_band_claims(figure: Figure, curve, over_the_data: bool = False) -> int:
    """Every Monte-Carlo band of ``figure`` against its legend entry, measured on the
    rendered pixels: one called narrower than the line changes no pixel further than
    MARGIN_PT (+1.5 px of antialiasing) beyond the edge of its curve (the lines
    ``curve(line)`` picks; over the data's x range when ``over_the_data``); any other
    changes 30 pixels or more beyond that edge. Returns how many bands it checked."""
    bands = [band for ax in figure.axes for band in _band(ax)]
    ranges = []
    for band in bands:
        data = [c.get_offsets()[:, 0] for c in band.axes.collections if c.get_label().startswith("data")]
        ranges.append((data[0].min(), data[0].max()) if over_the_data and "narrower" in band.get_label() else None)
    px = figure.dpi / 72
    for band, shown in zip(bands, band_pixels(figure, bands, ranges)):
        lines = [line for line in band.axes.get_lines() if curve(line)]
        assert lines, band.get_label()
        width = max(line.get_linewidth() if line.get_linestyle() not in ("None", "none", "") else line.get_markersize()
                    for line in lines) * px
        beyond = distance_to_lines(shown, lines) - width / 2
        where = re.search(r"narrower than the line.* in (\w+) y$", band.get_label())  # "… in Re y": that panel only
        if "narrower than the line" in band.get_label() and (where is None
                                                             or band.axes.get_ylabel().startswith(where.group(1))):
            assert beyond.max(initial=0) <= MARGIN_PT * px + 1.5, (band.get_label(), beyond.max(initial=0))
        else:
            assert np.count_nonzero(beyond > 1.5) >= 30, (band.get_label(), np.count_nonzero(beyond > 1.5))
    return len(bands)


def _fit_line(line) -> bool:
    return to_rgba(line.get_color()) == to_rgba(FIT_COLOUR)


def _extracted_line(line) -> bool:
    return line.get_label() == "extracted linear FRF"


def test_a_legend_claims_a_band_only_where_it_shows(figures):
    """Every Monte-Carlo band of the archive's plots, against what its legend entry says."""
    checked = check_band_claims(figures["identification_fit.png"], _fit_line, over_the_data=True)
    assert "over the data" in _band(figures["identification_fit.png"].axes[0])[0].get_label()
    checked += check_band_claims(figures["linear_frf.png"], _extracted_line)
    checked += check_band_claims(figures["candidate_frfs.png"], _extracted_line)
    assert checked == 7


def test_a_wide_band_is_drawn_and_claimed_and_a_thin_one_is_called_narrower_than_the_line():
    """The stub's band is ±w around Re y (up to 6.75e4 N/m over the data) and Im y (up to
    3.4e3 N/m): w = 5e3 shows in both, w = 1 in neither, w = 300 only in Im y."""
    amplitude = np.linspace(0.5, 3.0, 30)
    for width, note in ((5e3, None), (1.0, "narrower than the line over the data"),
                        (300.0, "narrower than the line over the data in Re y")):
        figure = fit_figure(_fit_stub(amplitude, width), "stub")
        assert check_band_claims(figure, _fit_line, over_the_data=True) == 2
        legend = [t.get_text() for t in figure.legends[0].get_texts() if "Monte-Carlo" in t.get_text()]
        assert legend == ["95 % Monte-Carlo band (20 fits)" + (f": {note}" if note else "")]


def test_each_mode_zoom_covers_the_mode_within_the_data(figures, result):
    """Around each mode: inside the frequencies the extracted FRF covers, the resonance ± one
    half-power bandwidth (η·f) shown, and no more than ten bandwidths either side."""
    ident = result.identification
    f = np.asarray(ident.linear_frequency_hz)
    axes = figures["linear_frf.png"].axes
    for k, mode in enumerate(ident.modes):
        natural, eta = float(mode.natural_frequencies_hz[0]), float(mode.loss_factors[0])
        low, high = axes[2 * (k + 1)].get_xlim()
        assert f.min() - 1e-9 <= low and high <= f.max() + 1e-9, (low, high, f.min(), f.max())
        assert low <= natural - eta * natural and high >= natural + eta * natural
        assert high - low <= 2 * 10 * eta * natural


def test_a_zoom_stays_where_the_data_are():
    """Data at 79.2–81.2 Hz around an 80.2 Hz mode with η = 0.05 (bandwidth 4 Hz): the
    zoom is the data's span, not ±10 % (72–88 Hz)."""
    f = np.linspace(79.2, 81.2, 41)
    assert zoom_window(f, 80.2, 0.05, 0.1) == (pytest.approx(79.2), pytest.approx(81.2))
    wide = np.linspace(50, 110, 601)  # η = 0.002: 4 bandwidths either side, 0.64 Hz
    assert zoom_window(wide, 80.0, 0.002, 0.1) == (pytest.approx(79.36), pytest.approx(80.64))


def _convergence():
    """Five runs of two parameters: four that coincide (one parameter set, four difference
    formulas) and an optimisation; both parameters converge onto their hidden truth, and the
    two targets have nearly equal σ (0.1 and 0.11 %)."""
    names = [f"eigensensitivity {f} {{E, h}}" for f in ("forward", "backward", "central", "central4")]
    rows = []
    for name in names:
        for it, (e, h, err) in enumerate(((210e9, 1.5e-3, 5.0), (196e9, 1.46e-3, 0.5), (195e9, 1.45e-3, 0.05))):
            rows.append({"run": name, "iteration": it, "p:E": e, "p:h": h, "max_abs_error_pct": err})
    for it, (e, h, err) in enumerate(((210e9, 1.5e-3, 5.0), (190e9, 1.47e-3, 1.0), (194e9, 1.452e-3, 0.2),
                                      (195e9, 1.45e-3, 0.01))):
        rows.append({"run": "optimisation", "iteration": it, "p:E": e, "p:h": h, "max_abs_error_pct": err})
    runs = [SimpleNamespace(name=n, method="eigensensitivity", parameters=("E", "h")) for n in names]
    runs.append(SimpleNamespace(name="optimisation", method="optimisation", parameters=("E", "h")))
    parameters = [SimpleNamespace(name="E", unit="Pa"), SimpleNamespace(name="h", unit="m")]
    return convergence_figure(pd.DataFrame(rows), run_styles(runs), parameters, {"E": 195e9, "h": 1.45e-3},
                              {"mode1": 0.1, "mode2": 0.11}), names


def test_convergence_keeps_coinciding_runs_apart_and_puts_no_text_on_its_lines():
    figure, coinciding = _convergence()
    _drawn(figure)
    assert overlapping_texts(figure) == []
    for ax in figure.axes:
        lines = {line.get_label(): line for line in ax.get_lines() if not line.get_label().startswith("_")}
        runs = [lines[n] for n in coinciding if n in lines]
        assert len(runs) == 4
        for i, a in enumerate(runs):  # every marker of a run clear of the others' at some iteration
            for b in runs[i + 1:]:
                pa, pb = (line.get_transform().transform(line.get_xydata()) for line in (a, b))
                size = max(a.get_markersize(), b.get_markersize()) * figure.dpi / 72
                assert np.max(np.hypot(*(pa - pb).T)) >= size, (a.get_label(), b.get_label())
        renderer = figure.canvas.get_renderer()
        for text in ax.texts:
            box = text.get_window_extent(renderer)
            for line in lines.values():
                path = line.get_transform().transform_path(line.get_path())
                assert not path.intersects_bbox(box, filled=False), (text.get_text(), line.get_label())
    legend = [t.get_text() for t in figure.legends[0].get_texts()]
    assert {"σ of target mode1: 0.1 %", "σ of target mode2: 0.11 %"} <= set(legend)
    assert [ax.get_title() for ax in figure.axes[:2]] == ["parameter E (hidden truth 195)",
                                                          "parameter h (hidden truth 1.45)"]
