"""Discovery: which effect the model is missing, where, with which parameters — and proof.

Here: the run from a measured table to a result, with its restarts; one search (steps 1–3
and 5) in :mod:`nlupdate.core.discovery.search`, the joint refit and reconsideration (step 4) in
:mod:`nlupdate.core.discovery.reconsider`, the settings in :mod:`nlupdate.core.discovery.options`,
the result in :mod:`nlupdate.core.discovery.result`; every numerical piece they call (gap,
localisation, candidate fits, joint fits, equivalence) lives in its own module.

:func:`discover` runs the loop:

1. **gap** — simulate the current model at every measured force level and frequency and
   compare each measured point with the model's nearest stable solution there
   (:mod:`nlupdate.core.discovery.gap`, :mod:`nlupdate.core.discovery.simulation`); points the model
   cannot solve count as misfit and are reported per level;
2. **localise** — for every candidate place, how much of the *current* misfit one element
   there can remove — what it explains beyond what the model already explains — and its
   apparent describing function (:mod:`nlupdate.core.discovery.localisation`);
3. **name** — fit every effect of the library at every place with a substantial share: the
   places that explain at least ``place_share`` (½) of what the best place explains, at most
   ``max_places`` (10) of them, best first. The cost per iteration is at most
   ``max_places × library size`` candidate fits (each a few hundredths of a second to a
   tenth on a 3–4-coordinate test) plus the joint refits of step 4. Candidates are ranked
   by an information criterion; a candidate that degenerates to a simpler effect over the
   measured amplitudes gives way to it (:mod:`nlupdate.core.discovery.equivalence`); stop with
   ``none`` when the best is not significant against the measurement noise
   (:mod:`nlupdate.core.discovery.candidates`);
4. **refit together and reconsider** — the best candidate is added to the effects found so
   far and *every parameter of every effect* is refitted jointly, each point solved exactly
   for all of them (:mod:`nlupdate.core.discovery.joint`). Then each effect is reconsidered
   against that joint fit: an earlier effect that no longer improves the criterion by
   ``min_evidence`` is dropped, an effect is swapped for another (at the same place or
   elsewhere) when the joint fit prefers it by ``min_evidence``, and one that now sits in a
   degenerate limit gives way to its simpler equivalent. The alternatives to the new effect
   are the next candidates of its round; those to an earlier effect are every library
   effect at every place, screened by the criterion at their variable-projection starts
   against the others' joint values, the five best fitted there; in both cases the three
   best are refitted jointly, and the one swap the joint fit prefers most is made (at most
   ``3 × effects`` joint refits per pass, three passes);
5. **add and look again** — re-simulate; accept the new set only if the model can be
   simulated and its simulated misfit (the criterion: χ² of the traced model plus the cost
   of its parameters) drops by more than ``min_evidence`` (else try the next significant
   candidate, up to three); repeat until the misfit is at the noise level, nothing more is significant,
   or ``max_effects`` are found;
6. **restart** — a greedy search can take a first step that no later step repairs (a mass
   error standing in for a stuck joint). When it ends with an RMS residual more than 1.5
   times the noise level, the search is run again without its first choice (then without the next one; ``restarts`` = 2) and
   the result with the lower criterion is kept (by more than ``min_evidence``); each
   restart is a sentence in the result.

At the end the misfit is compared with the noise: when the root-mean-square residual is more
than ``poor_fit_ratio`` (5) times the noise level, the result says ``fit: poor`` with that
ratio instead of presenting the effects as the explanation.

Candidate fits are independent jobs run through ``map_candidates(fit_candidate, jobs)``
(default: the built-in, sequential ``map``), so an orchestrator can run them in parallel;
the result does not depend on the order the jobs finish in.
"""
from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
import pandas as pd

from nlupdate.core.discovery.candidates import augment, penalty
from nlupdate.core.discovery.effects import library
from nlupdate.core.discovery.errors import DiscoveryError, MeasuredDataError
from nlupdate.core.discovery.frf_data import FRFData
from nlupdate.core.discovery.frf_evidence import FRFEvidence
from nlupdate.core.discovery.gap import GapReport
from nlupdate.core.discovery.modal_data import ModalData
from nlupdate.core.discovery.modal_evidence import ModalEvidence
from nlupdate.core.discovery.options import DiscoveryOptions
from nlupdate.core.discovery.places import place_name
from nlupdate.core.discovery.reconsider import effect_key
from nlupdate.core.discovery.result import DiscoveryResult, DiscoveryStep
from nlupdate.core.discovery.search import MapCandidates, fit_candidate, search, select_places
from nlupdate.core.measurement.modal_table import MODAL_COLUMNS
from nlupdate.core.model.system import NonlinearSystem

_RESTART_RATIO = 1.5  # a search whose RMS residual ends above this many times the noise level is restarted


def measurement_evidence(system: NonlinearSystem, measured: pd.DataFrame, options: DiscoveryOptions, source: str):
    """The measured table as evidence against ``system`` (FRF or modal, by its columns),
    with the noise level and criterion of ``options``."""
    if not isinstance(measured, pd.DataFrame):
        raise MeasuredDataError(f"{source}: expected a measured-FRF or modal table (pandas DataFrame), got {type(measured).__name__}")
    if set(MODAL_COLUMNS) <= set(measured.columns):
        if options.harmonic_balance is not None:
            raise DiscoveryError(f"{source}: harmonic balance applies to measured FRFs; a modal table is compared "
                                 "with the single-mode phase-resonance solution (use the default method)")
        data = ModalData.from_table(measured, system.model, source)
        return ModalEvidence(
            data, options.frequency_uncertainty, options.damping_uncertainty, penalty(options.criterion, 2 * data.n_points)
        )
    data = FRFData.from_table(measured, system.model, source)
    floor = options.min_noise_fraction
    if options.noise_fraction is not None:
        noise, value_noise = max(options.noise_fraction, floor), None
    else:
        noise = max(data.noise_fraction(), floor)
        value_noise = None if data.point_noise is None else np.maximum(
            np.where(np.isfinite(data.point_noise), data.point_noise, 1e6), floor)
    sweep = options.sweep if options.sweep is not None else data.sweep
    return FRFEvidence(data, noise, sweep, penalty(options.criterion, 2 * data.h.size), options.harmonic_balance,
                       value_noise)


def discover(
    system: NonlinearSystem,
    measured: pd.DataFrame,
    options: DiscoveryOptions = DiscoveryOptions(),
    *,
    map_candidates: MapCandidates = map,
    source: str = "measured",
) -> DiscoveryResult:
    """Find the effects ``system`` is missing against ``measured`` (see module docstring).

    ``measured`` is a measured-FRF table (:mod:`nlupdate.core.measurement.frf_table`; several
    force levels, one input coordinate, coordinate names of the model) or a modal table
    (:mod:`nlupdate.core.measurement.modal_table`). ``source`` names the table in errors.
    Raises :class:`~nlupdate.core.discovery.errors.MeasuredDataError` for unusable data and
    :class:`~nlupdate.core.discovery.errors.ModelSolveError` when the model cannot be solved.
    """
    evidence = measurement_evidence(system, measured, options, source)
    effects = library(options.effects)
    before = evidence.predict(system)
    path = search(evidence, system, before, options, effects, map_candidates, frozenset())
    excluded: frozenset = frozenset()
    restarts: list[str] = []
    latest = path  # the last search: its first choice is the next one left out
    names = tuple(system.model.dof_names)
    for _ in range(options.restarts):
        if path.chi2 < _RESTART_RATIO**2 * evidence.n_data or not path.found or path.steps[0].accepted is None:
            break
        first = next((s.accepted for s in latest.steps[:1] if s.accepted is not None), None)
        if first is None:
            break
        excluded = excluded | {effect_key(first)}
        latest = other = search(evidence, system, before, options, effects, map_candidates, excluded)
        places = ", ".join(f"{f.name} on {place_name(f.dofs, names)}" for f in other.found) or "none"
        kept = other.criterion < path.criterion - options.min_evidence
        restarts.append(f"restart without {first.name} on {place_name(first.dofs, names)} first (the search ended at "
                        f"{np.sqrt(path.chi2 / evidence.n_data):.2g}× the noise level): found {places}, criterion {other.criterion:.1f} against {path.criterion:.1f} — "
                        f"{'kept' if kept else 'not kept'}")
        if kept:
            path = other
        if not other.steps or other.steps[0].accepted is None:
            break
    prediction, found = path.prediction, path.found
    chi2_before = evidence.chi2(before)
    gap_after = evidence.gap(prediction)
    result = DiscoveryResult(
        kind=evidence.kind, data=evidence.data, system=system, augmented=augment(system, found), effects=tuple(found),
        steps=path.steps, gap_before=evidence.gap(before), gap_after=gap_after,
        prediction_before=before, prediction_after=prediction, noise_fraction=getattr(evidence, "noise_fraction", 0.0),
        stop_reason=path.stop, options=options, misfit_ratio=float(np.sqrt(path.chi2 / evidence.n_data)),
        misfit_ratio_before=float(np.sqrt(chi2_before / evidence.n_data)),
        noise_source=_noise_source(evidence, options), sweep=getattr(evidence, "sweep", "unknown"),
        residuals_after=evidence.residuals(prediction) if evidence.kind == "frf" else None,
        other_branch_after=evidence.other_branch(prediction) if evidence.kind == "frf" else None,
        restarts=tuple(restarts),
    )
    return replace(result, warnings=_warnings(result, gap_after))


def _noise_source(evidence: Any, options: DiscoveryOptions) -> str:
    """Where the noise level came from (FRF data only), for the result."""
    if evidence.kind != "frf":
        return ""
    if options.noise_fraction is not None:
        return "given (options.noise_fraction)"
    noise = evidence.data.noise
    detail = noise.detail if noise is not None else "unknown"
    if evidence.noise_fraction == options.min_noise_fraction:
        detail += f"; raised to the floor min_noise_fraction = {options.min_noise_fraction:g}"
    return detail


def _warnings(result: DiscoveryResult, gap_after: GapReport) -> tuple[str, ...]:
    """The result's warnings: levels with points the model cannot solve, and a poor fit."""
    out = []
    for level in gap_after.levels:
        if level.unsolved_points:
            low, high = level.unsolved_hz
            out.append(f"at {level.force_n:g} N the {'augmented ' if result.effects else ''}model has no stable "
                       f"solution at {level.unsolved_points} of {level.points} measured points ({low:g}–{high:g} Hz); "
                       "they count as misfit (100 % error) in the gap and the criterion")
    if result.fit == "poor":
        out.append(result.summary())
    return tuple(out)


__all__ = [
    "DiscoveryOptions", "DiscoveryResult", "DiscoveryStep", "MapCandidates", "discover", "fit_candidate",
    "measurement_evidence", "select_places",
]
