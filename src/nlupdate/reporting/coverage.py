"""Where data lie along an axis, for drawing a fitted curve honestly: solid over the
stretches the points cover, dashed across the gaps between them (a layout choice, shared
by the identification-fit plot and the caption the report writes under it)."""
from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

#: Consecutive data amplitudes more than this factor apart leave a gap: the curve between
#: them is interpolated across a stretch no measurement covers, and drawn dashed.
AMPLITUDE_GAP_RATIO = 2.0


def covered_intervals(values: ArrayLike, gap_ratio: float = AMPLITUDE_GAP_RATIO) -> list[tuple[float, float]]:
    """The stretches ``values`` (positive, e.g. response amplitudes in m) cover: sorted,
    split wherever two consecutive values are more than ``gap_ratio`` apart (a gap in
    log amplitude); ``(low, high)`` per stretch, in the unit of ``values``. Non-finite
    and non-positive values are ignored; no values give an empty list."""
    v = np.sort(np.asarray(values, dtype=float).ravel())
    v = v[np.isfinite(v) & (v > 0)]
    if not v.size:
        return []
    breaks = np.flatnonzero(v[1:] > gap_ratio * v[:-1]) + 1
    return [(float(part[0]), float(part[-1])) for part in np.split(v, breaks)]


def describe_intervals(intervals: list[tuple[float, float]], scale: float = 1e3, unit: str = "mm") -> str:
    """``intervals`` as text for a caption, e.g. ``0.0155–0.0195 mm and 0.45–3.05 mm``
    (values multiplied by ``scale``, three significant digits)."""
    parts = [f"{low * scale:.3g}–{high * scale:.3g} {unit}" for low, high in intervals]
    return parts[0] if len(parts) == 1 else ", ".join(parts[:-1]) + " and " + parts[-1]
