"""Updating runs and the candidate models they give: running one, comparing and ranking them.

A sweep is a list of :class:`UpdatingRun` — one per finite-difference formula, per
parameter set, per weighting… :func:`update` runs one: a pure function of its (picklable)
description and of the point evaluator it is given (by default it builds its own adapter
from the run's :class:`~nlupdate.fe.adapters.registry.AdapterSpec` and evaluates in order).
Running the sweep — in order with one memoised evaluator per model, so that a point two
runs need is solved once, or concurrently — is the chain's business
(:mod:`nlupdate.study.chain`).

Each result is a candidate model. :func:`compare_candidates` tabulates them mode by mode
against the targets (frequency error in %) and, when the extracted linear FRF of the
identification is given, against that FRF: the candidate's receptance by modal
superposition with the given modal damping, correlated by FRAC over a band
``f_target·(1 ± band_fraction)`` around each target mode. :func:`rank_candidates`
scores them for the modes a user weights, the runs that converged first: a run that did
not converge is never ranked above one that did, however small its errors where it stopped.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Mapping, Sequence

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from nlupdate.fe.adapters.base import FEAdapter, Parameter
from nlupdate.core.correlation.metrics import frac
from nlupdate.fe.adapters.registry import AdapterSpec, build_adapter
from nlupdate.core.updating.eigensensitivity import EigensensitivityOptions, UpdatingResult, inverse_eigensensitivity
from nlupdate.core.updating.evaluation import MemoisedEvaluator, PointEvaluator
from nlupdate.core.updating.optimisation import OptimisationOptions, optimise_frequencies
from nlupdate.core.updating.targets import UpdatingTargets

METHODS = ("eigensensitivity", "optimisation")


@dataclass(frozen=True)
class UpdatingRun:
    """One updating run.

    method: ``eigensensitivity`` (options: EigensensitivityOptions) or ``optimisation``
    (options: OptimisationOptions); fixed: values of other adapter parameters.
    """

    name: str
    adapter: AdapterSpec
    parameters: tuple[Parameter, ...]
    targets: UpdatingTargets
    method: str
    options: EigensensitivityOptions | OptimisationOptions
    fixed: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        expected = {"eigensensitivity": EigensensitivityOptions, "optimisation": OptimisationOptions}.get(self.method)
        if expected is None:
            raise ValueError(f"task {self.name!r}: method must be one of {list(METHODS)}, got {self.method!r}")
        if not isinstance(self.options, expected):
            raise ValueError(f"task {self.name!r}: method {self.method!r} needs {expected.__name__}")


def update(task: UpdatingRun, evaluate_points: PointEvaluator | None = None) -> UpdatingResult:
    """Run one updating task; the result carries the task's name.

    ``evaluate_points`` runs the FE evaluations (default: a memoised evaluator over a new
    adapter built from ``task.adapter``, in order).
    """
    evaluator = evaluate_points if evaluate_points is not None else MemoisedEvaluator(build_adapter(task.adapter))
    return run_method(task.method, evaluator, task.parameters, task.targets, task.options, task.fixed, task.name)


def run_method(
    method: str,
    model: FEAdapter | PointEvaluator,
    parameters: Sequence[Parameter],
    targets: UpdatingTargets,
    options: EigensensitivityOptions | OptimisationOptions,
    fixed: Mapping[str, float] | None = None,
    name: str = "",
) -> UpdatingResult:
    """One updating run on an adapter (or point evaluator) ``model``: ``method``
    (:data:`METHODS`) with its ``options``; the result carries ``name``."""
    if method == "eigensensitivity":
        result = inverse_eigensensitivity(model, parameters, targets, options, fixed)
    elif method == "optimisation":
        result = optimise_frequencies(model, parameters, targets, options, fixed)
    else:
        raise ValueError(f"updating method must be one of {list(METHODS)}, got {method!r}")
    return dataclasses.replace(result, name=name)


def _modal_damping(value: float | Sequence[float], result: UpdatingResult, what: str) -> float | NDArray[np.float64]:
    """Scalar, or per target mode mapped onto the paired model modes (others: the mean)."""
    values = np.atleast_1d(np.asarray(value, dtype=float))
    if values.size == 1:
        return float(values[0])
    n_targets = result.targets.n_modes
    if values.size != n_targets:
        raise ValueError(f"{what}: give one value or one per target mode ({n_targets}), got {values.size}")
    per_mode = np.full(result.final.natural_frequencies_hz.size, values.mean())
    per_mode[list(result.final_pairing.model_indices)] = values
    return per_mode


def candidate_frf(
    result: UpdatingResult,
    frequency_hz: ArrayLike,
    response_dof: str,
    input_dof: str,
    damping_ratios: float | Sequence[float] = 0.0,
    loss_factors: float | Sequence[float] = 0.0,
    which: str = "final",
) -> NDArray[np.complex128]:
    """Receptance (m/N) of the ``final`` (or ``initial``) model of a candidate by modal
    superposition of its computed modes with the given modal damping."""
    modal = result.final if which == "final" else result.initial
    coordinates = list(modal.coordinates)
    for name, dof in (("response_dof", response_dof), ("input_dof", input_dof)):
        if dof not in coordinates:
            raise ValueError(f"{name} {dof!r} is not a model coordinate; the model has {coordinates}")
    model = modal.to_modal_model(
        _modal_damping(damping_ratios, result, "damping_ratios"), _modal_damping(loss_factors, result, "loss_factors")
    )
    omega = 2 * np.pi * np.asarray(frequency_hz, dtype=float)
    return model.receptance(omega, [coordinates.index(response_dof)], [coordinates.index(input_dof)])[:, 0, 0]


def compare_candidates(
    results: Sequence[UpdatingResult],
    reference_frf: tuple[ArrayLike, ArrayLike] | None = None,
    response_dof: str | None = None,
    input_dof: str | None = None,
    damping_ratios: float | Sequence[float] = 0.0,
    loss_factors: float | Sequence[float] = 0.0,
    band_fraction: float = 0.1,
) -> pd.DataFrame:
    """Mode-by-mode comparison of the candidates (and the initial model, first rows).

    Columns: candidate, mode, target_hz, f_hz, error_pct, mac (NaN without measured
    shapes), frac (NaN without ``reference_frf`` = (frequencies Hz, complex H) or with
    fewer than 3 reference points in the band). The initial model is that of the first
    result, named ``initial``.
    """
    if not results:
        raise ValueError("no candidates to compare")
    if reference_frf is not None and (response_dof is None or input_dof is None):
        raise ValueError("comparing with a reference FRF needs response_dof and input_dof")
    if not 0 < band_fraction < 1:
        raise ValueError(f"band_fraction must be in (0, 1), got {band_fraction}")
    targets = results[0].targets
    rows = []
    entries = [("initial", results[0], "initial")] + [(r.name, r, "final") for r in results]
    for name, result, which in entries:
        modal, pairing = (result.initial, result.initial_pairing) if which == "initial" else (result.final, result.final_pairing)
        f_model = np.asarray(modal.natural_frequencies_hz)[list(pairing.model_indices)]
        fracs = np.full(targets.n_modes, np.nan)
        if reference_frf is not None:
            f_ref = np.asarray(reference_frf[0], dtype=float)
            h_ref = np.asarray(reference_frf[1], dtype=complex)
            h_model = candidate_frf(result, f_ref, response_dof, input_dof, damping_ratios, loss_factors, which)
            for i, f_target in enumerate(targets.frequencies_hz):
                band = np.abs(f_ref - f_target) <= band_fraction * f_target
                if band.sum() >= 3:
                    fracs[i] = frac(h_ref[band], h_model[band])
        for i, label in enumerate(targets.labels):
            rows.append({
                "candidate": name,
                "mode": label,
                "target_hz": float(targets.frequencies_hz[i]),
                "f_hz": float(f_model[i]),
                "error_pct": float(100 * (f_model[i] / targets.frequencies_hz[i] - 1)),
                "mac": pairing.mac[i],
                "frac": float(fracs[i]),
            })
    return pd.DataFrame(rows)


def rank_candidates(
    comparison: pd.DataFrame,
    user_weights: Mapping[str, float] | Sequence[float],
    converged: Mapping[str, bool] | None = None,
) -> pd.DataFrame:
    """Score and rank the candidates of a :func:`compare_candidates` table.

    ``user_weights``: per mode label (mapping) or per mode in table order (sequence);
    modes not listed in a mapping weigh 0. Scores: ``weighted_abs_error_pct`` =
    Σ w|error| / Σ w (lower is better) and ``weighted_frac`` = Σ w·FRAC / Σ w (higher is
    better; NaN when a weighted mode has no FRAC). ``converged``: per run name whether it
    converged (runs not named, and the initial model, count as converged). ``rank`` orders
    the converged candidates by the error score, then those that did not converge by
    theirs; ``rank_frac`` likewise by FRAC. Column ``converged`` (the initial model: NA).
    Sorted by ``rank``; the initial model is ranked like any converged candidate.
    """
    labels = list(dict.fromkeys(comparison["mode"]))
    if isinstance(user_weights, Mapping):
        unknown = set(user_weights) - set(labels)
        if unknown:
            raise ValueError(f"user weights name unknown mode(s) {sorted(unknown)}; modes are {labels}")
        weights = {label: float(user_weights.get(label, 0.0)) for label in labels}
    else:
        values = [float(w) for w in user_weights]
        if len(values) != len(labels):
            raise ValueError(f"user weights: {len(values)} values for {len(labels)} modes {labels}")
        weights = dict(zip(labels, values))
    if any(w < 0 for w in weights.values()) or not sum(weights.values()) > 0:
        raise ValueError(f"user weights must be ≥ 0 and not all zero, got {weights}")
    table = comparison.assign(weight=comparison["mode"].map(weights))
    total = sum(weights.values())
    rows = []
    for name, group in table.groupby("candidate", sort=False):
        weighted = group[group["weight"] > 0]
        rows.append({
            "candidate": name,
            "weighted_abs_error_pct": float((weighted["weight"] * weighted["error_pct"].abs()).sum() / total),
            "weighted_frac": float((weighted["weight"] * weighted["frac"]).sum() / total)
            if weighted["frac"].notna().all() else float("nan"),
            **{f"error_pct:{m}": float(e) for m, e in zip(group["mode"], group["error_pct"])},
        })
    ranking = pd.DataFrame(rows)
    converged = dict(converged or {})
    ranking["converged"] = pd.array([pd.NA if name == "initial" else bool(converged.get(name, True))
                                     for name in ranking["candidate"]], dtype="boolean")
    behind = (ranking["converged"] == False).fillna(False).to_numpy()  # noqa: E712 (NA: the initial model)
    offset = len(ranking)  # the not converged rank after every converged one
    ranking["rank"] = (ranking["weighted_abs_error_pct"].rank(method="min") + offset * behind)
    ranking["rank"] = ranking["rank"].rank(method="min").astype(int)
    frac_rank = ranking["weighted_frac"].rank(method="min", ascending=False) + offset * behind
    ranking["rank_frac"] = frac_rank.rank(method="min").astype("Int64")
    return ranking.sort_values(["rank", "candidate"], kind="mergesort").reset_index(drop=True)


def best_ranked(ranking: pd.DataFrame | None) -> str | None:
    """The study's best updated model: the candidate of a :func:`rank_candidates` table (or
    the archived ``ranking`` table) with the lowest ``rank`` other than ``initial`` (the
    initial model is the reference, never the best); None without one. The one owner of
    "best": the report, the trust warnings, ``archive list`` and ``archive compare`` ask it."""
    if ranking is None:
        return None
    updated = ranking[ranking["candidate"] != "initial"].sort_values("rank", kind="mergesort")
    return None if updated.empty else str(updated["candidate"].iloc[0])
