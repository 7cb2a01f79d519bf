"""Updating studies described in TOML files, and their execution.

A study names the model (adapter), the updating parameters, the targets and the
methods; :func:`run_study` runs every method/formula/candidate as an
:class:`~nlupdate.updating.candidates.UpdatingTask` and writes, into one output
directory (built in a temporary sibling directory and renamed when complete):

==========================  ===============================================================
history.parquet             one row per iteration of every run (column ``run``)
candidates.parquet          one row per run: parameters, convergence, evaluations, time
comparison.parquet          candidate × mode: target, frequency, error %, MAC, FRAC
ranking.parquet             candidates scored for the user's mode weights
summary.json                study, targets and per-run summary
convergence.png             parameters and max |error| per iteration
frequency_errors.png        error % per mode and candidate
frf_comparison.png          extracted linear FRF vs initial and candidate models (if known)
study.toml                  copy of the study file
==========================  ===============================================================

The file format is described in :mod:`nlupdate.updating.study_file`.
"""
from __future__ import annotations

import dataclasses
import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from nlupdate.reporting.atomic import atomic_directory
from nlupdate.updating.candidates import (
    UpdatingTask,
    candidate_frf,
    candidate_table,
    compare_candidates,
    rank_candidates,
    run_tasks,
)
from nlupdate.updating.eigensensitivity import EigensensitivityOptions, UpdatingResult
from nlupdate.updating.optimisation import OptimisationOptions
from nlupdate.updating.plots import plot_convergence, plot_frequency_errors, plot_frf_comparison
from nlupdate.updating.sensitivity import FORMULA_LABELS
from nlupdate.updating.study_file import CandidateEntry, Study, StudyError, load_study
from nlupdate.updating.targets import UpdatingTargets, frf_natural_frequencies, read_linear_frf

__all__ = ["CandidateEntry", "Study", "StudyError", "StudyOutcome", "load_study", "resolve_targets", "run_study", "study_tasks"]


@dataclass(frozen=True, eq=False)
class StudyOutcome:
    """What :func:`run_study` produced (also written to ``out_dir``)."""

    out_dir: Path
    targets: UpdatingTargets
    results: list[UpdatingResult]
    history: pd.DataFrame
    candidates: pd.DataFrame
    comparison: pd.DataFrame
    ranking: pd.DataFrame


def resolve_targets(study: Study) -> tuple[UpdatingTargets, tuple[np.ndarray, np.ndarray] | None]:
    """Targets of the study and the reference (extracted linear) FRF, if any."""
    t = study.targets
    reference = None
    if "identification" in t:
        frequency, h = read_linear_frf(study.resolve(t["identification"]), t["response_dof"], t["input_dof"], t.get("force_level_n"))
        reference = (frequency, h)
        try:
            frequencies = frf_natural_frequencies(frequency, h, t["n_modes"], t.get("band_hz"), t.get("frf_method", "peak"))
        except ValueError as error:
            raise StudyError(f"{study.path}: [targets] identification {t['identification']!r}: {error}") from None
    else:
        frequencies = np.asarray(t["frequencies_hz"], dtype=float)
    frf_path = study.comparison["frf"]
    if frf_path is not None:
        if "response_dof" not in t or "input_dof" not in t:
            raise StudyError(f"{study.path}: [comparison] frf needs [targets] response_dof and input_dof")
        reference = read_linear_frf(study.resolve(frf_path), t["response_dof"], t["input_dof"], t.get("force_level_n"))
    shapes = np.asarray(t["mode_shapes"], dtype=float).T if "mode_shapes" in t else None
    try:
        targets = UpdatingTargets(
            frequencies, t.get("weights"), shapes, tuple(t.get("coordinates", ())), tuple(t.get("labels", ())),
            tuple(t.get("model_modes", ())),
        )
    except ValueError as error:
        raise StudyError(f"{study.path}: [targets]: {error}") from None
    return targets, reference


def study_tasks(study: Study, targets: UpdatingTargets) -> list[UpdatingTask]:
    """One task per eigensensitivity formula and per optimisation candidate."""
    by_name = {p.name: p for p in study.parameters}
    tasks = []
    if study.eigensensitivity is not None:
        parameters = tuple(by_name[n] for n in study.eigensensitivity["parameters"])
        for formula in study.eigensensitivity["formulas"]:
            options = EigensensitivityOptions(formula=formula, **study.eigensensitivity["options"], **study.updating)
            tasks.append(UpdatingTask(f"eigensensitivity {FORMULA_LABELS[formula]}", study.adapter, parameters, targets,
                                      "eigensensitivity", options, study.fixed))
    if study.optimisation is not None:
        options = OptimisationOptions(**study.optimisation, **study.updating)
        for entry in study.candidates:
            parameters = tuple(
                dataclasses.replace(by_name[n], start=entry.start[n]) if n in entry.start else by_name[n] for n in entry.parameters
            )
            try:
                weighted = targets.with_weights(entry.weights)
            except ValueError as error:
                raise StudyError(f"{study.path}: [[optimisation.candidates]] {entry.name!r}: {error}") from None
            tasks.append(UpdatingTask(entry.name, study.adapter, parameters, weighted, "optimisation", options, study.fixed))
    return tasks


def run_study(study: Study, out_dir: str | os.PathLike, overwrite: bool = False) -> StudyOutcome:
    """Run all tasks of ``study`` and write the outputs to ``out_dir`` atomically.

    ``out_dir`` must not exist unless ``overwrite``; it appears only once complete.
    """
    out_dir = Path(out_dir)
    if out_dir.exists() and not overwrite:
        raise FileExistsError(f"output directory {out_dir} exists; choose another or allow overwriting")
    targets, reference = resolve_targets(study)
    tasks = study_tasks(study, targets)
    results = run_tasks(tasks)

    history = pd.concat([r.history.assign(run=r.name) for r in results], ignore_index=True)
    history = history[["run"] + [c for c in history.columns if c != "run"]]
    candidates = candidate_table(results)
    t = study.targets
    model_response = t.get("model_response_dof", t.get("response_dof"))
    model_input = t.get("model_input_dof", t.get("input_dof"))
    comparison = compare_candidates(
        results, reference, model_response, model_input,
        study.comparison["damping_ratios"], study.comparison["loss_factors"], study.comparison["band_fraction"],
    )
    user_weights = study.comparison["user_weights"]
    ranking = rank_candidates(comparison, user_weights if user_weights is not None else list(targets.weights))

    with atomic_directory(out_dir, on_exists="replace") as archive:
        work = archive.path
        history.to_parquet(work / "history.parquet", index=False)
        candidates.to_parquet(work / "candidates.parquet", index=False)
        comparison.to_parquet(work / "comparison.parquet", index=False)
        ranking.to_parquet(work / "ranking.parquet", index=False)
        (work / "study.toml").write_text(study.text)
        (work / "summary.json").write_text(json.dumps(_summary(study, targets, results, ranking), indent=2, default=_json_default))
        plot_convergence(history[history["method"] == "eigensensitivity"] if study.eigensensitivity else history,
                         work / "convergence.png")
        plot_frequency_errors(comparison, work / "frequency_errors.png")
        if reference is not None:
            frequency, h = reference
            curves = {"initial": candidate_frf(results[0], frequency, model_response, model_input,
                                               study.comparison["damping_ratios"], study.comparison["loss_factors"], "initial")}
            for r in results:
                curves[r.name] = candidate_frf(r, frequency, model_response, model_input,
                                               study.comparison["damping_ratios"], study.comparison["loss_factors"])
            plot_frf_comparison(frequency, h, curves, work / "frf_comparison.png",
                                title=f"{study.name}: H({t['response_dof']}, {t['input_dof']})")
    return StudyOutcome(out_dir, targets, results, history, candidates, comparison, ranking)


def _json_default(value: object) -> object:
    if value is pd.NA:
        return None
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return str(value)


def _summary(study: Study, targets: UpdatingTargets, results: list[UpdatingResult], ranking: pd.DataFrame) -> dict[str, Any]:
    return {
        "study": study.name,
        "description": study.description,
        "study_file": str(study.path),
        "adapter": {"kind": study.adapter.kind, "model": study.adapter.model, "options": dict(study.adapter.options),
                    "fixed": study.fixed},
        "targets": {"labels": list(targets.labels), "frequencies_hz": targets.frequencies_hz.tolist(),
                    "weights": targets.weights.tolist()},
        "runs": [
            {
                "name": r.name, "method": r.method, "parameters": r.parameters, "converged": r.converged,
                "reason": r.reason, "iterations": r.iterations, "evaluations": r.counts, "wall_time_s": r.wall_time_s,
                "initial_frequencies_hz": r.frequencies_hz("initial").tolist(),
                "final_frequencies_hz": r.frequencies_hz("final").tolist(),
            }
            for r in results
        ],
        "ranking": ranking[["candidate", "weighted_abs_error_pct", "weighted_frac", "rank", "rank_frac"]].to_dict("records"),
    }
