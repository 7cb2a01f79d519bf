"""Figures without pyplot: built on :class:`matplotlib.figure.Figure`, saved atomically.

Importing this module (or any plotting module of the project) never selects a backend
or touches pyplot's global state, so the numerics stay importable anywhere (servers,
Dask workers, notebooks with their own backend). A PNG is written to a temporary file
beside its target and renamed, so a reader never sees half a picture.

Conventions of every plot: measured data are black (or viridis by force level) points,
the initial model is grey and dashed, each updating run has its own colour and line
style (:mod:`nlupdate.reporting.styles`), a shaded band is a 95 % Monte-Carlo band
(its legend entry says when it is narrower than the line over it: :func:`label_thin_bands`),
a grey region marks where a curve has no data (extrapolated beyond them, or across a gap
between them), and no text is placed on a curve.
"""
from __future__ import annotations

import io
import os
from pathlib import Path
from typing import Sequence

import numpy as np
import pandas as pd
from matplotlib import colormaps
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.axes import Axes
from matplotlib.collections import PolyCollection
from matplotlib.figure import Figure
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from nlupdate.files import atomic_file

#: How the plots style the initial model and the measured data.
INITIAL_STYLE = {"color": "0.4", "ls": "--", "lw": 1.1}
MEASURED_STYLE = {"color": "k", "ls": "none", "marker": ".", "ms": 2}
#: Colour of an extracted linear FRF and of a fitted describing function.
EXTRACTED_COLOUR = "crimson"
FIT_COLOUR = "C1"
#: Fill of a region where a curve is extrapolated (no data there).
EXTRAPOLATION_FILL = {"color": "0.5", "alpha": 0.13, "lw": 0}
BAND_LABEL = "95 % Monte-Carlo band"
#: What a band's legend entry adds where the band does not show beside its curve (:func:`band_shows`).
THIN_BAND_NOTE = "narrower than the line"
#: Line width (points) of a fitted curve.
FIT_WIDTH = 1.6


def band_fill(ax: Axes, x: ArrayLike, low: ArrayLike, high: ArrayLike, label: str, curve: ArrayLike | None = None,
              covered_by: float = FIT_WIDTH, judged_over: Sequence[tuple[float, float]] | None = None,
              **style) -> PolyCollection:
    """A 95 % band between ``low`` and ``high`` over ``x`` (a ``fill_between``, no edge),
    remembering what it spans, the ``curve`` drawn over it (values on ``x``; None: the
    band's middle), that curve's width in points (``covered_by``) and the x intervals
    where the band matters (``judged_over``, e.g. where the data lie; None: everywhere),
    so :func:`label_thin_bands` can tell whether it shows beside the curve."""
    x, low, high = (np.asarray(v, float) for v in (x, low, high))
    fill = ax.fill_between(x, low, high, lw=0, label=label, **style)
    fill.nlupdate_band = (x, low, high, (low + high) / 2 if curve is None else np.asarray(curve, float),
                          float(covered_by), None if judged_over is None else [tuple(map(float, i)) for i in judged_over])
    return fill


def _distance_to_polyline(points: np.ndarray, line: np.ndarray) -> np.ndarray:
    """Distance of each of ``points`` (n×2) to the polyline through ``line`` (m×2, m ≥ 2).

    Exact, without comparing every point with every segment: a point's distance to the
    nearest vertex bounds its distance to the polyline, so a block of points (neighbours
    along x) is compared only with the segments whose bounding boxes come that close."""
    a, b = line[:-1], line[1:]
    d = b - a
    length2 = np.maximum(np.einsum("ij,ij->i", d, d), 1e-12)
    low, high = np.minimum(a, b), np.maximum(a, b)
    bound = cKDTree(line).query(points)[0]
    order = np.argsort(points[:, 0], kind="stable")
    out = np.empty(len(points))
    for start in range(0, len(points), 256):
        block = order[start:start + 256]
        p = points[block]
        reach = float(bound[block].max())
        near = np.all((high >= p.min(axis=0) - reach) & (low <= p.max(axis=0) + reach), axis=1)
        a_n, d_n = a[near], d[near]
        t = np.clip(np.einsum("ijk,jk->ij", p[:, None, :] - a_n[None], d_n) / length2[near][None], 0.0, 1.0)
        nearest = a_n[None] + t[..., None] * d_n[None]
        out[block] = np.sqrt(np.min(np.sum((p[:, None, :] - nearest) ** 2, axis=-1), axis=1))
    return out


def band_reach_pt(fill: PolyCollection) -> float:
    """How far (points, on the page) a :func:`band_fill` band reaches from its curve: the
    largest distance of its edges from the curve held over about 3 pixels along x (a
    one-sample spike shows as no more than a sliver), within the axes' current limits and
    the band's ``judged_over`` intervals; 0 when none of it is there."""
    x, low, high, curve, _, intervals = fill.nlupdate_band
    ax = fill.axes
    lo, hi = sorted(ax.get_xlim())
    keep = (x >= lo) & (x <= hi) & np.isfinite(low) & np.isfinite(high) & np.isfinite(curve)
    if intervals is not None:
        keep &= np.any([(x >= a) & (x <= b) for a, b in intervals], axis=0) if intervals else False
    if ax.get_yscale() == "log":
        keep &= (low > 0) & (high > 0) & (curve > 0)
    finite = np.isfinite(curve) & ((curve > 0) if ax.get_yscale() == "log" else True) & (x >= lo) & (x <= hi)
    if not np.any(keep) or np.count_nonzero(finite) < 2:
        return 0.0
    line = ax.transData.transform(np.column_stack([x[finite], curve[finite]]))
    reach = 0.0
    for edge in (low, high):
        points = ax.transData.transform(np.column_stack([x[keep], edge[keep]]))
        distance = _distance_to_polyline(points, line)
        # a spike at one sample is a sliver of a pixel: count a reach held over ~3 pixels of x
        step = float(np.median(np.abs(np.diff(points[:, 0])))) if len(points) > 1 else 3.0
        span = int(min(len(distance), max(1, np.ceil(3.0 / max(step, 1e-9)) + 1)))
        held = np.lib.stride_tricks.sliding_window_view(distance, span).min(axis=1)
        reach = max(reach, float(held.max()))
    return reach * 72 / fill.figure.dpi


#: How far (points) a band must reach beyond the edge of its curve to show.
BAND_MARGIN_PT = 2.0


def band_shows(fill: PolyCollection) -> bool:
    """Whether a :func:`band_fill` band reaches :data:`BAND_MARGIN_PT` beyond the edge of
    the curve over it somewhere it is judged, at the figure's current layout."""
    return band_reach_pt(fill) > fill.nlupdate_band[4] / 2 + BAND_MARGIN_PT


def label_thin_bands(figure: Figure) -> None:
    """Lay ``figure`` out and add :data:`THIN_BAND_NOTE` (with "over the data" when the
    band is judged there only) to the label of every :func:`band_fill` band that does not
    show beside its curve (:func:`band_shows`), so no legend claims a band a reader cannot
    see. Call it once the axes limits are final and before the legends are made."""
    FigureCanvasAgg(figure)
    engine = figure.get_layout_engine()
    if engine is not None:
        engine.execute(figure)
    for ax in figure.axes:
        for fill in ax.collections:
            spec = getattr(fill, "nlupdate_band", None)
            if spec is None or fill.get_label().startswith("_") or THIN_BAND_NOTE in fill.get_label():
                continue
            if not band_shows(fill):
                where = " over the data" if spec[5] is not None else ""
                fill.set_label(f"{fill.get_label()}: {THIN_BAND_NOTE}{where}")


def grid_in_inches(figure: Figure, rows: int, columns: int, left: float, right: float, top: float,
                   bottom: float, wspace: float = 0.0, hspace: float = 0.0) -> dict[str, float]:
    """GridSpec keywords (``left``, ``right``, ``top``, ``bottom``, ``wspace``, ``hspace``)
    placing a ``rows``×``columns`` grid on ``figure`` with margins and gaps given in inches.

    A fixed layout costs no drawing: constrained layout measures every tick label of every
    axes twice before the figure is drawn, most of the CPU of a many-panel figure. Use it
    where the text around the panels has a known size (fixed font sizes, a known number of
    title lines)."""
    width, height = figure.get_size_inches()
    cell_width = (width - left - right - (columns - 1) * wspace) / columns
    cell_height = (height - top - bottom - (rows - 1) * hspace) / rows
    return {"left": left / width, "right": 1 - right / width, "top": 1 - top / height, "bottom": bottom / height,
            "wspace": wspace / cell_width, "hspace": hspace / cell_height}


def save_figure(figure: Figure, path: str | os.PathLike, dpi: int = 120) -> Path:
    """Write ``figure`` as PNG to ``path`` (atomically) and return the path."""
    path = Path(path)
    png = png_bytes(figure, dpi)
    with atomic_file(path) as temporary:
        Path(temporary).write_bytes(png)
    return path


def png_bytes(figure: Figure, dpi: int = 120) -> bytes:
    """``figure`` as PNG.

    A figure with a layout engine (constrained layout) is laid out once at ``dpi`` and
    then frozen: ``savefig`` would otherwise draw it twice (a hidden draw to lay it out,
    then the real one). Layout and drawing share one Agg renderer, so every text is
    measured once, not once per renderer. The pixels are the same; ``figure`` is left
    without its engine and at ``dpi`` (the axis labels' offsets from their tick labels
    are in pixels of the last draw, so a reader measuring them needs the same dpi)."""
    FigureCanvasAgg(figure)
    figure.set_dpi(dpi)
    engine = figure.get_layout_engine()
    if engine is not None:
        engine.execute(figure)
        figure.set_layout_engine(None)
    buffer = io.BytesIO()
    figure.savefig(buffer, dpi=dpi, format="png")
    return buffer.getvalue()


def level_colours(count: int, low: float = 0.0, high: float = 0.9) -> np.ndarray:
    """``count`` colours from viridis, dark for the lowest force level (RGBA rows)."""
    return colormaps["viridis"](np.linspace(low, high, max(int(count), 1)))


def unwrapped_phase_deg(h: ArrayLike, window: int = 9) -> NDArray[np.float64]:
    """Phase of ``h`` in degrees, continuous along the curve and robust to noise.

    The phase is followed along a moving average of the unit phasors ``h/|h|`` (over
    ``window`` points), and each point keeps its own deviation from it (within ±180°), so
    a noisy point never adds a permanent 360° step. The curve is shifted by a multiple
    of 360° so that its first points lie in [−270°, 90°) (a receptance with positive
    damping starts near 0° and falls by 180° per mode). NaN points stay NaN; each
    stretch between them is unwrapped on its own."""
    h = np.asarray(h, dtype=complex)
    out = np.full(h.shape, np.nan)
    finite = np.isfinite(h) & (h != 0)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], finite.astype(int), [0]])))
    for start, stop in zip(edges[::2], edges[1::2]):
        z = h[start:stop]
        unit = z / np.abs(z)
        k = min(int(window), z.size)
        smooth = np.convolve(unit, np.ones(k) / k, mode="same")
        smooth = np.where(np.abs(smooth) > 0, smooth, unit)
        reference = np.unwrap(np.angle(smooth))
        phase = reference + np.angle(z * np.exp(-1j * reference))
        first = float(np.median(phase[: max(1, z.size // 20)]))
        phase -= 2 * np.pi * np.floor((first + 1.5 * np.pi) / (2 * np.pi))
        out[start:stop] = np.degrees(phase)
    return out


def frf_curve(table: pd.DataFrame, response_dof: str, input_dof: str,
              force_level: float) -> tuple[np.ndarray, np.ndarray]:
    """The rows of one curve of a measured-FRF table, by ascending frequency: (Hz, H);
    empty arrays when the table has no such curve (the plot then shows nothing there)."""
    rows = table[(table["response_dof"].astype(str) == str(response_dof))
                 & (table["input_dof"].astype(str) == str(input_dof))
                 & np.isclose(table["force_level_n"].to_numpy(dtype=float), float(force_level), rtol=1e-9, atol=0.0)]
    rows = rows.sort_values("frequency_hz", kind="mergesort")
    return rows["frequency_hz"].to_numpy(dtype=float), rows["h_real"].to_numpy() + 1j * rows["h_imag"].to_numpy()


_PREFIXES = ((1e9, "G"), (1e6, "M"), (1e3, "k"), (1.0, ""), (1e-3, "m"), (1e-6, "µ"), (1e-9, "n"))
#: Units a plot may write with an SI prefix (others are written as given).
PREFIXABLE_UNITS = frozenset({"Pa", "m", "N", "N/m", "N/m²", "N/m³", "N/m^2", "N/m^3", "Hz", "s", "N s/m", "N·s/m"})


def prefixed_unit(values: ArrayLike, unit: str) -> tuple[float, str]:
    """(scale, unit with prefix) to write ``values`` in ``unit`` readably: E in Pa → GPa,
    a thickness in m → mm; divide the values by the scale. Units outside
    :data:`PREFIXABLE_UNITS` keep scale 1."""
    values = np.abs(np.asarray(values, dtype=float))
    values = values[np.isfinite(values) & (values > 0)]
    if unit not in PREFIXABLE_UNITS or not values.size:
        return 1.0, unit
    largest = float(values.max())
    for scale, prefix in _PREFIXES:
        if largest >= scale:
            return scale, prefix + unit
    return _PREFIXES[-1][0], _PREFIXES[-1][1] + unit
