"""Pairing model modes with target modes.

Methods (``pairing`` option of the updating functions):

``order``
    Target i ↔ model mode i (or the model mode numbers listed in
    ``UpdatingTargets.model_modes``). The default when only frequencies are known; the
    adapter is expected to return the modes that were measured (e.g. the T-beam
    surrogate filters out the local modes of the thin beams).
``nearest``
    One-to-one assignment minimising the sum of relative frequency distances
    ``|f_model − f_target| / f_target`` (Hungarian algorithm). Useful when only
    frequencies are known but the model may reorder or add modes.
``mac``
    One-to-one assignment maximising the sum of MAC values between measured and model
    mode shapes at the measured coordinates (Hungarian algorithm); needs measured mode
    shapes at two or more coordinates. Pairs with MAC below ``min_mac`` are an error.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.optimize
from numpy.typing import NDArray

from nlupdate.fe.adapters.base import ModalResult
from nlupdate.core.correlation.metrics import mac_matrix
from nlupdate.core.updating.targets import UpdatingTargets

PAIRING_METHODS = ("order", "nearest", "mac")


@dataclass(frozen=True)
class ModePairing:
    """model_indices[i] is the 0-based model mode paired with target i; mac[i] its MAC
    (NaN when the targets have no mode shapes)."""

    model_indices: tuple[int, ...]
    mac: tuple[float, ...]
    method: str


def model_shapes_at(result: ModalResult, coordinates: tuple[str, ...]) -> NDArray[np.float64]:
    """Rows of the model mode shapes at the named coordinates (n_coordinates × n_modes)."""
    index = {name: i for i, name in enumerate(result.coordinates)}
    missing = [c for c in coordinates if c not in index]
    if missing:
        raise ValueError(
            f"measured coordinates {missing} are not model coordinates; the model has {list(result.coordinates)}"
        )
    return result.mode_shapes[[index[c] for c in coordinates]]


def target_mac(result: ModalResult, targets: UpdatingTargets) -> NDArray[np.float64] | None:
    """MAC matrix (n_targets × n_model_modes), or None without measured mode shapes."""
    if targets.mode_shapes is None:
        return None
    return mac_matrix(targets.mode_shapes, model_shapes_at(result, targets.coordinates))


def pair_modes(result: ModalResult, targets: UpdatingTargets, method: str = "order", min_mac: float = 0.0) -> ModePairing:
    """Pair the model modes of ``result`` with ``targets``; see the module docstring."""
    if method not in PAIRING_METHODS:
        raise ValueError(f"unknown pairing method {method!r}; expected one of {list(PAIRING_METHODS)}")
    f_model = np.asarray(result.natural_frequencies_hz, dtype=float)
    n_targets = targets.n_modes
    if f_model.size < n_targets:
        raise ValueError(f"the model returned {f_model.size} mode(s), fewer than the {n_targets} target modes")
    mac = target_mac(result, targets)
    if method == "order":
        indices = [m - 1 for m in targets.model_modes] if targets.model_modes else list(range(n_targets))
        if max(indices) >= f_model.size:
            raise ValueError(f"model mode {max(indices) + 1} requested for pairing, the model returned {f_model.size}")
    elif method == "nearest":
        cost = np.abs(f_model[None, :] - targets.frequencies_hz[:, None]) / targets.frequencies_hz[:, None]
        rows, cols = scipy.optimize.linear_sum_assignment(cost)
        indices = list(cols[np.argsort(rows)])
    else:
        if mac is None or len(targets.coordinates) < 2:
            raise ValueError("MAC pairing needs measured mode shapes at two or more coordinates (targets.mode_shapes)")
        rows, cols = scipy.optimize.linear_sum_assignment(-mac)
        indices = list(cols[np.argsort(rows)])
    mac_values = tuple(float(mac[i, j]) for i, j in enumerate(indices)) if mac is not None else (float("nan"),) * n_targets
    if method == "mac":
        low = [(targets.labels[i], v) for i, v in enumerate(mac_values) if v < min_mac]
        if low:
            raise ValueError(f"MAC pairing: target mode(s) {low} have MAC below min_mac = {min_mac}")
    return ModePairing(tuple(int(i) for i in indices), mac_values, method)
