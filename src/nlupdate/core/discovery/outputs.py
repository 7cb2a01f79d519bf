"""The output folder of a discovery: ``discovery.json``, ``augmented_model.toml`` and plots.

``discovery.json`` (SI units, frequencies in Hz, dofs = model coordinate indices: one for an
element to ground, two for an element between coordinates):

* ``effect``, ``dofs``, ``place``, ``parameters`` — the first effect found, or ``"none"``,
  ``[]``, ``""``, ``{}``; ``place`` names the dofs as the model does (``"m2–m3"``,
  ``"m1 (to ground)"``; ``"dofs [1, 2]"`` for a model without ``dof_names``);
* ``effects`` — ``[{"effect", "dofs", "place", "parameters"(, "variant")}]`` in the order found
  (after the joint refits: every parameter fitted together);
* ``fit`` — ``"good"``, or ``"poor"`` when the RMS residual left is more than
  ``poor_fit_limit`` (5) times the noise level: then the effects named do not explain the
  measurement; ``misfit_to_noise`` (and ``misfit_to_noise_before``) is that ratio
  (``√(χ²/n)``, 1 for a model right up to noise); ``summary`` says it in one line;
* ``warnings`` — results not to be taken as they stand: points the model cannot solve (per
  level, with their count and frequencies; they count as misfit) and a poor fit;
* ``candidates`` — every candidate fitted, ``{"effect", "dofs", "score", "parameters",
  "chi2", "baseline_chi2", "explained", "iteration", "success"(, "variant")}``, best first
  within each iteration; ``score`` is the criterion change against the model of that
  iteration (negative = better); a candidate that degenerates to a simpler effect over the
  measured amplitudes carries ``equivalent_to``, ``equivalent_parameters`` and
  ``equivalence_deviation`` and gave way to it;
* ``gap_before``, ``gap_after`` — mean over force levels of 1 − FRAC (measured band, all
  measured coordinates); ``gap_noise_level`` — σ², the gap of a perfect model (FRF data);
* ``levels_before`` / ``levels_after`` — per-level FRAC, gap, FRF error, resonance shift,
  peak ratio, ``points``, ``unsolved_points`` and ``unsolved_hz`` (where the model has no
  stable solution), ``other_branch_points`` (where the measurement follows another branch
  than a sweep in the stated direction) and the trends per decade of force;
* ``steps`` — per iteration: the places with how much of the current misfit each explains
  and the apparent DF per level, ``places_fitted``, ``equivalences``, ``changes`` (what the
  joint refit reconsidered: swaps, drops, simpler equivalents), ``effects_after_refit``, the
  share of the misfit per mode, what was added and the gap;
* ``restarts`` — the searches run again without their first choice because the first one
  ended above 1.5× the noise level, each with what it found and whether it was kept;
* ``stop_reason``, ``criterion``, ``noise_fraction`` and ``noise_source`` (how it was
  obtained), ``sweep_direction`` (as stated by the data or the options),
  ``measurement`` ("frf" or "modal"),
  ``response_method`` (how the model was simulated against FRFs: "describing-function
  continuation" or "harmonic balance (H = …, …)"; None for a modal table).

``augmented_model.toml`` is the user's model with the effects added
(:func:`nlupdate.core.model.model_file.write_system`): every command reads it. Plots:
``frf_levels.png``, ``describing_function.png``, ``gap_per_level.png``,
``residual_amplitude.png``.
"""
from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

from nlupdate.core.discovery.plots import plot_describing_function, plot_frfs, plot_gap, plot_residuals
from nlupdate.core.discovery.workflow import DiscoveryResult
from nlupdate.core.model.model_file import write_system

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
    paths["residual_plot"] = plot_residuals(result, directory / "residual_amplitude.png")
    return paths
