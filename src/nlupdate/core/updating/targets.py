"""Updating targets: measured natural frequencies (and optionally mode shapes).

Targets come either as a list of frequencies or from the linear FRF extracted by the
identification (PRD/DDF) step. That FRF is a measured-FRF table
(:mod:`nlupdate.core.measurement.frf_table`: columns frequency_hz, force_level_n, response_dof,
input_dof, h_real, h_imag); its natural frequencies are read from one response/input
curve by :func:`frf_natural_frequencies`:

``peak`` (default)
    the most prominent peaks of |H|, refined by a parabola through the peak sample and
    its two neighbours (in log|H|). The |H| peak of an isolated mode lies at
    ``f_r·√(1 − 2ζ²)`` (viscous) or at f_r (structural damping); neighbouring modes bias
    it by roughly the square of the loss factor (about 1e-4 relative for η = 1 %, 4e-5
    for η = 0.2 % in the tests' 3-dof chain).
``line_fit``
    the line-fit (Dobson) estimate of
    :func:`nlupdate.core.correlation.metrics.natural_frequencies` (zero of Re(1/H)
    fitted in ω² over ±1 % around each peak), less biased for moderately damped modes,
    more for very lightly damped ones whose peak is much narrower than the fit band.
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from nlupdate.core.correlation.metrics import natural_frequencies
from nlupdate.input_files import read_input_text
from nlupdate.core.measurement.frf_files import read_frf_table

#: File name of the extracted linear FRF inside an identification result directory.
LINEAR_FRF_FILE = "linear_frf.parquet"
#: Ways of reading natural frequencies from an FRF (see the module docstring).
FRF_METHODS = ("peak", "line_fit")


@dataclass(frozen=True, eq=False)
class UpdatingTargets:
    """Measured modal data to update against.

    frequencies_hz: target natural frequencies (Hz), one per target mode.
    weights: relative weight of each target mode in the least-squares problems
        (default 1). The residual of mode i is multiplied by √w_i.
    mode_shapes: optional measured mode shapes, shape (n_coordinates, n_targets), any
        scaling; needed for MAC pairing and mode-shape residuals.
    coordinates: names of the rows of ``mode_shapes`` (must be model coordinates).
    labels: names of the target modes (default ``mode1``, ``mode2``, …).
    model_modes: for ``order`` pairing, the 1-based numbers of the model modes paired
        with the targets (default 1, 2, …, n_targets).
    """

    frequencies_hz: NDArray[np.float64]
    weights: NDArray[np.float64] | None = None
    mode_shapes: NDArray[np.float64] | None = None
    coordinates: tuple[str, ...] = ()
    labels: tuple[str, ...] = ()
    model_modes: tuple[int, ...] = field(default=())

    def __post_init__(self) -> None:
        f = np.atleast_1d(np.asarray(self.frequencies_hz, dtype=float))
        if f.ndim != 1 or f.size == 0 or not np.all(np.isfinite(f)) or np.any(f <= 0):
            raise ValueError(f"targets: frequencies_hz must be a non-empty list of positive numbers (Hz), got {f.tolist()}")
        n = f.size
        weights = np.ones(n) if self.weights is None else np.atleast_1d(np.asarray(self.weights, dtype=float))
        if weights.shape != (n,) or np.any(weights < 0) or not np.all(np.isfinite(weights)) or not weights.sum() > 0:
            raise ValueError(f"targets: weights must be {n} non-negative numbers, not all zero, got {weights.tolist()}")
        labels = tuple(self.labels) or tuple(f"mode{i + 1}" for i in range(n))
        if len(labels) != n or len(set(labels)) != n:
            raise ValueError(f"targets: labels must be {n} distinct names, got {list(labels)}")
        shapes = self.mode_shapes
        if shapes is not None:
            shapes = np.asarray(shapes, dtype=float)
            if shapes.ndim != 2 or shapes.shape[1] != n:
                raise ValueError(f"targets: mode_shapes must have shape (n_coordinates, {n}), got {shapes.shape}")
            if len(self.coordinates) != shapes.shape[0]:
                raise ValueError(
                    f"targets: {shapes.shape[0]} mode-shape rows need as many coordinate names, got {list(self.coordinates)}"
                )
        modes = tuple(int(m) for m in self.model_modes)
        if modes and (len(modes) != n or min(modes) < 1 or len(set(modes)) != n):
            raise ValueError(f"targets: model_modes must be {n} distinct mode numbers ≥ 1, got {list(modes)}")
        object.__setattr__(self, "frequencies_hz", f)
        object.__setattr__(self, "weights", weights)
        object.__setattr__(self, "mode_shapes", shapes)
        object.__setattr__(self, "coordinates", tuple(str(c) for c in self.coordinates))
        object.__setattr__(self, "labels", labels)
        object.__setattr__(self, "model_modes", modes)

    @property
    def n_modes(self) -> int:
        return self.frequencies_hz.size

    def with_weights(self, weights: ArrayLike | None) -> "UpdatingTargets":
        """Same targets with other mode weights (None keeps the current ones)."""
        if weights is None:
            return self
        return UpdatingTargets(self.frequencies_hz, weights, self.mode_shapes, self.coordinates, self.labels, self.model_modes)


def linear_frf_path(path: str | os.PathLike) -> Path:
    """Locate the extracted linear FRF table of an identification result.

    ``path`` is the table itself (``.parquet``/``.csv``/``.uff``), a result directory
    holding ``linear_frf.parquet``, or a JSON file whose ``"linear_frf"`` entry is the
    table's path (relative to the JSON file).
    """
    path = Path(path)
    if path.is_dir():
        table = path / LINEAR_FRF_FILE
        if not table.is_file():
            raise FileNotFoundError(f"{path}: identification result directory has no {LINEAR_FRF_FILE}")
        return table
    if not path.is_file():
        raise FileNotFoundError(f"identification result not found: {path}")
    if path.suffix.lower() == ".json":
        try:
            data = json.loads(read_input_text(path, "identification result"))
        except json.JSONDecodeError as error:
            raise ValueError(f"{path}: not valid JSON ({error})") from error
        entry = data.get("linear_frf") if isinstance(data, dict) else None
        if not isinstance(entry, str):
            raise ValueError(f"{path}: expected a JSON object with a string entry 'linear_frf' (path of the linear FRF table)")
        return linear_frf_path(path.parent / entry)
    return path


def read_linear_frf(
    path: str | os.PathLike,
    response_dof: str,
    input_dof: str,
    force_level_n: float | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.complex128]]:
    """One extracted linear FRF curve: (frequencies Hz ascending, receptance m/N).

    ``force_level_n`` selects the curve when the table holds several levels; when None
    the (response, input) pair must have exactly one.
    """
    table_path = linear_frf_path(path)
    table = read_frf_table(table_path)
    return select_curve(table, response_dof, input_dof, force_level_n, source=str(table_path))


def select_curve(
    table: pd.DataFrame,
    response_dof: str,
    input_dof: str,
    force_level_n: float | None = None,
    source: str = "<table>",
) -> tuple[NDArray[np.float64], NDArray[np.complex128]]:
    """(frequency Hz, complex H) of one (response, input[, force level]) curve of ``table``."""
    mask = (table["response_dof"].astype(str) == str(response_dof)) & (table["input_dof"].astype(str) == str(input_dof))
    if not mask.any():
        pairs = sorted({(str(r), str(i)) for r, i in table[["response_dof", "input_dof"]].itertuples(index=False)})
        raise ValueError(
            f"{source}: no FRF for response_dof={response_dof!r}, input_dof={input_dof!r}; available (response, input): {pairs}"
        )
    curve = table.loc[mask]
    levels = np.unique(curve["force_level_n"].to_numpy(dtype=float))
    if force_level_n is None:
        if levels.size != 1:
            raise ValueError(
                f"{source}: the ({response_dof}, {input_dof}) FRF has force levels {levels.tolist()} N; "
                f"give force_level_n to choose one"
            )
        level = levels[0]
    else:
        matches = levels[np.isclose(levels, float(force_level_n), rtol=1e-9, atol=0.0)]
        if matches.size == 0:
            raise ValueError(f"{source}: no force level {force_level_n} N for ({response_dof}, {input_dof}); available {levels.tolist()}")
        level = matches[0]
    curve = curve.loc[np.isclose(curve["force_level_n"].to_numpy(dtype=float), level, rtol=1e-9, atol=0.0)]
    curve = curve.sort_values("frequency_hz", kind="mergesort")
    frequency = curve["frequency_hz"].to_numpy(dtype=float)
    h = curve["h_real"].to_numpy(dtype=float) + 1j * curve["h_imag"].to_numpy(dtype=float)
    return frequency, h


def peak_frequencies(
    frequency_hz: ArrayLike,
    h: ArrayLike,
    n_modes: int,
    band_hz: Sequence[float] | None = None,
) -> NDArray[np.float64]:
    """The ``n_modes`` most prominent peaks of |H| (Hz, ascending), parabola-refined.

    ``band_hz = (low, high)`` restricts the search. Raises ValueError when fewer peaks
    than asked are found.
    """
    f = np.asarray(frequency_hz, dtype=float)
    magnitude = np.abs(np.asarray(h, dtype=complex))
    if band_hz is not None:
        low, high = band_hz
        keep = (f >= low) & (f <= high)
        f, magnitude = f[keep], magnitude[keep]
    if f.size < 3:
        raise ValueError(f"peak picking: the FRF has {f.size} points in the band {band_hz}, need at least 3")
    log_mag = np.log(np.maximum(magnitude, np.finfo(float).tiny))
    import scipy.signal  # here: importing it costs 0.3 s (it imports scipy.stats)

    indices, properties = scipy.signal.find_peaks(log_mag, prominence=0.0)
    if indices.size < n_modes:
        raise ValueError(
            f"peak picking: found {indices.size} peak(s) of |H| between {f[0]:g} and {f[-1]:g} Hz, "
            f"expected {n_modes}"
        )
    chosen = np.sort(indices[np.argsort(properties["prominences"])[::-1][:n_modes]])
    refined = []
    for i in chosen:
        y0, y1, y2 = log_mag[i - 1], log_mag[i], log_mag[i + 1]
        curvature = y0 - 2 * y1 + y2
        shift = 0.5 * (y0 - y2) / curvature if curvature < 0 else 0.0
        spacing = 0.5 * (f[i + 1] - f[i - 1])
        refined.append(f[i] + shift * spacing)
    return np.asarray(refined)


def frf_natural_frequencies(
    frequency_hz: ArrayLike,
    h: ArrayLike,
    n_modes: int,
    band_hz: Sequence[float] | None = None,
    method: str = "peak",
) -> NDArray[np.float64]:
    """The ``n_modes`` natural frequencies (Hz, ascending) of an FRF in ``band_hz``,
    by ``method`` (see the module docstring)."""
    if method not in FRF_METHODS:
        raise ValueError(f"unknown method {method!r} for natural frequencies from an FRF; expected one of {list(FRF_METHODS)}")
    if method == "peak":
        return peak_frequencies(frequency_hz, h, n_modes, band_hz)
    f = np.asarray(frequency_hz, dtype=float)
    hh = np.asarray(h, dtype=complex)
    if band_hz is not None:
        keep = (f >= band_hz[0]) & (f <= band_hz[1])
        f, hh = f[keep], hh[keep]
    found = natural_frequencies(f, hh, n_modes)
    if found.size < n_modes:
        raise ValueError(f"line fit: found {found.size} peak(s) of |H| between {f[0]:g} and {f[-1]:g} Hz, expected {n_modes}")
    return found
