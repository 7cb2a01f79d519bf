"""Mesh refinement study: natural frequencies against element count.

For nested meshes (each element count a multiple of the previous one) the consistent
mass frame elements give Rayleigh–Ritz upper bounds, so every frequency decreases
monotonically towards its converged value.
"""
from __future__ import annotations

from typing import Any, Callable, Sequence

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from nlupdate.fe.models.frame import FrameModel

Builder = Callable[[Any, int], FrameModel]
FrequencyFunction = Callable[[FrameModel, int], NDArray[np.float64]]


def _all_modes(model: FrameModel, n_modes: int) -> NDArray[np.float64]:
    return model.modal(n_modes).frequencies_hz


def mesh_refinement_study(
    builder: Builder,
    params: Any,
    element_counts: Sequence[int],
    n_modes: int,
    frequencies: FrequencyFunction | None = None,
) -> pd.DataFrame:
    """Frequencies of the lowest ``n_modes`` modes for each mesh.

    ``builder(params, count)`` returns a :class:`FrameModel` (e.g.
    :func:`~nlupdate.fe.models.tbeam.tbeam_model`, :func:`~nlupdate.fe.models.gunbarrel.gunbarrel_model`);
    ``frequencies(model, n_modes)`` selects the modes (default: all modes; use
    :func:`~nlupdate.fe.models.tbeam.global_frequencies` for the T-beam's global modes).

    Returns one row per (mesh, mode) with columns ``mesh_parameter`` (the count passed
    to the builder), ``elements`` (elements in the model), ``dofs`` (free dofs),
    ``mode`` (1-based), ``frequency_hz`` and ``change_percent``: the difference from the
    same mode on the finest mesh (largest count), in percent.
    """
    counts = [int(c) for c in element_counts]
    if not counts or any(c < 1 for c in counts) or len(set(counts)) != len(counts):
        raise ValueError(
            f"mesh_refinement_study: element_counts must be distinct positive integers, got {list(element_counts)}"
        )
    if int(n_modes) != n_modes or n_modes < 1:
        raise ValueError(f"mesh_refinement_study: n_modes must be a positive integer, got {n_modes!r}")
    select = frequencies or _all_modes
    rows = []
    for count in sorted(counts):
        model = builder(params, count)
        freqs = np.asarray(select(model, int(n_modes)), dtype=float)
        dofs = len(model.transformation()[1])
        for mode, f in enumerate(freqs, start=1):
            rows.append(
                {"mesh_parameter": count, "elements": model.n_elements, "dofs": dofs, "mode": mode, "frequency_hz": f}
            )
    table = pd.DataFrame(rows)
    finest = table[table["mesh_parameter"] == max(counts)].set_index("mode")["frequency_hz"]
    table["change_percent"] = 100.0 * (table["frequency_hz"] / table["mode"].map(finest) - 1.0)
    return table


__all__ = ["mesh_refinement_study"]
