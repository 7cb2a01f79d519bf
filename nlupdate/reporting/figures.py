"""Figures without pyplot: built on :class:`matplotlib.figure.Figure`, saved atomically.

Importing this module (or any plotting module of the project) never selects a backend
or touches pyplot's global state, so the numerics stay importable anywhere (servers,
Dask workers, notebooks with their own backend). A PNG is written to a temporary file
beside its target and renamed, so a reader never sees half a picture.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib import colormaps
from matplotlib.figure import Figure

from nlupdate.files import atomic_file


def save_figure(figure: Figure, path: str | os.PathLike, dpi: int = 120) -> Path:
    """Write ``figure`` as PNG to ``path`` (atomically) and return the path."""
    path = Path(path)
    with atomic_file(path) as temporary:
        figure.savefig(temporary, dpi=dpi, format="png")
    return path


def level_colours(count: int, low: float = 0.0, high: float = 0.9) -> np.ndarray:
    """``count`` colours from viridis, dark for the lowest force level (RGBA rows)."""
    return colormaps["viridis"](np.linspace(low, high, max(int(count), 1)))


def phase_deg(h: np.ndarray) -> np.ndarray:
    """Phase in degrees in [−270, 90): a receptance with positive damping lies in [−180, 0]."""
    return (np.degrees(np.angle(h)) + 270.0) % 360.0 - 270.0


def frf_curve(table: pd.DataFrame, response_dof: str, input_dof: str,
              force_level: float) -> tuple[np.ndarray, np.ndarray]:
    """The rows of one curve of a measured-FRF table, by ascending frequency: (Hz, H);
    empty arrays when the table has no such curve (the plot then shows nothing there)."""
    rows = table[(table["response_dof"].astype(str) == str(response_dof))
                 & (table["input_dof"].astype(str) == str(input_dof))
                 & np.isclose(table["force_level_n"].to_numpy(dtype=float), float(force_level), rtol=1e-9, atol=0.0)]
    rows = rows.sort_values("frequency_hz", kind="mergesort")
    return rows["frequency_hz"].to_numpy(dtype=float), rows["h_real"].to_numpy() + 1j * rows["h_imag"].to_numpy()
