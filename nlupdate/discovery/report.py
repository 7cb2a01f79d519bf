"""The output folder of a discovery: ``discovery.json``, ``augmented_model.toml`` and plots.

``discovery.json`` (SI units, frequencies in Hz, dofs = model coordinate indices: one for an
element to ground, two for an element between coordinates):

* ``effect``, ``dofs``, ``parameters`` — the first effect found, or ``"none"``, ``[]``, ``{}``;
* ``effects`` — ``[{"effect", "dofs", "parameters"(, "variant")}]`` in the order found;
* ``candidates`` — every candidate fitted, ``{"effect", "dofs", "score", "parameters",
  "chi2", "baseline_chi2", "explained", "iteration", "success"(, "variant")}``, best first
  within each iteration; ``score`` is the criterion change against the model of that
  iteration (negative = better);
* ``gap_before``, ``gap_after`` — mean over force levels of 1 − FRAC (measured band, all
  measured coordinates); ``gap_noise_level`` — σ², the gap of a perfect model (FRF data);
* ``levels_before`` / ``levels_after`` — per-level FRAC, gap, FRF error, resonance shift,
  peak ratio and their trends per decade of force;
* ``steps`` — per iteration: the places with how much of the misfit each explains and the
  apparent DF per level, the share of the misfit per mode, what was added and the gap;
* ``stop_reason``, ``criterion``, ``noise_fraction``, ``measurement`` ("frf" or "modal"),
  ``response_method`` (how the model was simulated against FRFs: "describing-function
  continuation" or "harmonic balance (H = …, …)"; None for a modal table).

``augmented_model.toml`` is the user's model with the effects added
(:func:`nlupdate.model.model_file.write_system`): every command reads it. Plots:
``frf_levels.png``, ``describing_function.png``, ``gap_per_level.png``.
"""
from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

from nlupdate.discovery.plots import plot_describing_function, plot_frfs, plot_gap
from nlupdate.discovery.workflow import DiscoveryResult
from nlupdate.model.model_file import write_system

JSON_NAME = "discovery.json"
MODEL_NAME = "augmented_model.toml"


def _plain(value: Any) -> Any:
    """JSON-safe copy: NaN/inf → None, numpy scalars → Python numbers, tuples → lists."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if hasattr(value, "item") and not isinstance(value, (str, bytes)):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def write_discovery(result: DiscoveryResult, directory: str | Path) -> dict[str, Path]:
    """Write the JSON, the augmented model and the plots into ``directory``; returns the paths."""
    directory = Path(directory)
    paths = {"json": directory / JSON_NAME, "model": directory / MODEL_NAME}
    paths["json"].write_text(json.dumps(_plain(result.to_dict()), indent=2, allow_nan=False) + "\n")
    write_system(result.augmented, paths["model"])
    paths["frf_plot"] = plot_frfs(result, directory / "frf_levels.png")
    paths["df_plot"] = plot_describing_function(result, directory / "describing_function.png")
    paths["gap_plot"] = plot_gap(result, directory / "gap_per_level.png")
    return paths
