"""Discovery: which effect the model is missing, where, with which parameters — and proof.

:func:`discover` runs the loop of the issue on plain inputs:

1. **gap** — simulate the current model at every measured force level and frequency and
   compare (:mod:`nlupdate.discovery.gap`);
2. **localise** — for every candidate place, how much of the misfit one element there can
   remove and its apparent describing function (:mod:`nlupdate.discovery.localisation`);
3. **name** — fit every effect of the library at the best places
   (:mod:`nlupdate.discovery.frf_fit`, :mod:`nlupdate.discovery.modal_fit`) and rank them by
   an information criterion; stop with ``none`` when the best is not significant against
   the measurement noise (:mod:`nlupdate.discovery.candidates`);
4. **add and look again** — add the effect, re-simulate; accept it only if the model can
   be simulated and the simulated gap shrinks (else try the next significant candidate, up
   to three); repeat until the misfit is at the noise level, nothing more is significant,
   or ``max_effects`` are found.

Candidate fits are independent jobs run through ``map_candidates(fit_candidate, jobs)``
(default: the built-in, sequential ``map``), so an orchestrator can run them in parallel;
the result does not depend on the order the jobs finish in.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any, Callable, Sequence

import pandas as pd

from nlupdate.discovery.candidates import (
    CRITERIA, CandidateFit, FoundEffect, at_noise_level, augment, is_significant, penalty,
)
from nlupdate.discovery.effects import DFSamples, Effect, library
from nlupdate.discovery.errors import DiscoveryError, MeasuredDataError, ModelSolveError
from nlupdate.discovery.frf_data import FRFData
from nlupdate.discovery.frf_evidence import FRFEvidence
from nlupdate.discovery.gap import GapReport
from nlupdate.discovery.localisation import Localisation
from nlupdate.discovery.modal_evidence import ModalEvidence
from nlupdate.discovery.modal_data import ModalData
from nlupdate.measurement.modal_table import MODAL_COLUMNS
from nlupdate.model.system import NonlinearSystem
from nlupdate.response.harmonic_balance import HarmonicSettings
from nlupdate.response_method import HARMONICS_FORM, describe, samples_form, valid_harmonics, valid_samples

MapCandidates = Callable[[Callable[[Any], CandidateFit], Sequence[Any]], Any]
_TRIALS = 3  # significant candidates tried in turn when the best cannot be simulated or does not help


@dataclass(frozen=True)
class DiscoveryOptions:
    """Settings of :func:`discover`.

    effects: names of library effects or :class:`~nlupdate.discovery.effects.Effect`
    instances (None: the whole library). criterion: ``"bic"`` or ``"aic"``.
    max_effects: most effects to add. min_evidence, min_explained: significance rule
    (:func:`~nlupdate.discovery.candidates.is_significant`). max_places: places whose
    candidates are fitted per iteration (the best-explaining ones).
    noise_fraction: relative noise std of the FRFs (None: estimated from the data),
    never below min_noise_fraction. sweep: stepped-sine direction of the test.
    frequency_uncertainty, damping_uncertainty: relative std of modal-table frequencies
    and damping ratios. harmonic_balance: None to simulate the model by the describing
    function (default), or the settings of a multi-harmonic balance (measured FRFs only;
    the candidates' fits stay describing-function fits, the simulated gap and the check of
    every added effect use the balance).
    """

    effects: tuple[str | Effect, ...] | None = None
    criterion: str = "bic"
    max_effects: int = 3
    min_evidence: float = 10.0
    min_explained: float = 0.5
    max_places: int = 3
    noise_fraction: float | None = None
    min_noise_fraction: float = 0.002
    sweep: str = "up"
    frequency_uncertainty: float = 0.002
    damping_uncertainty: float = 0.05
    harmonic_balance: HarmonicSettings | None = None

    def __post_init__(self) -> None:
        if self.criterion not in CRITERIA:
            raise DiscoveryError(f"options.criterion: expected one of {CRITERIA}, got {self.criterion!r}")
        if self.sweep not in ("up", "down"):
            raise DiscoveryError(f"options.sweep: expected 'up' or 'down', got {self.sweep!r}")
        for name in ("max_effects", "max_places"):
            if int(getattr(self, name)) < 1:
                raise DiscoveryError(f"options.{name}: expected a positive integer, got {getattr(self, name)!r}")
        for name in ("min_noise_fraction", "frequency_uncertainty", "damping_uncertainty"):
            if not getattr(self, name) > 0:
                raise DiscoveryError(f"options.{name}: expected a positive fraction, got {getattr(self, name)!r}")
        if self.noise_fraction is not None and not self.noise_fraction > 0:
            raise DiscoveryError(f"options.noise_fraction: expected a positive fraction (e.g. 0.01), got {self.noise_fraction!r}")
        settings = self.harmonic_balance
        if settings is not None:
            if not isinstance(settings, HarmonicSettings):
                raise DiscoveryError(f"options.harmonic_balance: expected None or HarmonicSettings, got {settings!r}")
            if not valid_harmonics(settings.harmonics):
                raise DiscoveryError(f"options.harmonic_balance.harmonics: expected {HARMONICS_FORM}, "
                                     f"got {settings.harmonics!r}")
            if not valid_samples(settings.samples, settings.harmonics):
                raise DiscoveryError(f"options.harmonic_balance.samples: expected {samples_form(settings.harmonics)}, "
                                     f"got {settings.samples!r}")
        library(self.effects)


@dataclass(frozen=True, eq=False)
class DiscoveryStep:
    """One iteration: where the misfit sits, every candidate fitted (best first), what was
    added (None if nothing) and the simulated gap before and after it."""

    iteration: int
    localisation: tuple[Localisation, ...]
    bands: tuple[tuple[float, float], ...]
    candidates: tuple[CandidateFit, ...]
    samples: DFSamples | None
    accepted: FoundEffect | None
    gap_before: float
    gap_after: float | None
    note: str = ""


@dataclass(frozen=True, eq=False)
class DiscoveryResult:
    """What :func:`discover` found: the effects in the order found, the augmented model,
    the gap before and after, every step, and the predictions for plotting."""

    kind: str
    data: Any
    system: NonlinearSystem
    augmented: NonlinearSystem
    effects: tuple[FoundEffect, ...]
    steps: tuple[DiscoveryStep, ...]
    gap_before: GapReport
    gap_after: GapReport
    prediction_before: Any
    prediction_after: Any
    noise_fraction: float
    stop_reason: str
    options: DiscoveryOptions = field(repr=False, default=DiscoveryOptions())

    @property
    def effect(self) -> str:
        """Name of the first effect found, or ``"none"``."""
        return self.effects[0].name if self.effects else "none"

    @property
    def dofs(self) -> tuple[int, ...]:
        return self.effects[0].dofs if self.effects else ()

    @property
    def parameters(self) -> dict[str, float]:
        return self.effects[0].parameters if self.effects else {}

    @property
    def candidates(self) -> tuple[CandidateFit, ...]:
        return tuple(c for step in self.steps for c in step.candidates)

    def to_dict(self) -> dict:
        """The ``discovery.json`` content (see :mod:`nlupdate.discovery.report`)."""
        first = self.effects[0].to_dict() if self.effects else {"effect": "none", "dofs": [], "parameters": {}}
        return {
            "effect": first["effect"],
            "dofs": first["dofs"],
            "parameters": first["parameters"],
            "effects": [e.to_dict() for e in self.effects],
            "candidates": [c.to_dict() for c in self.candidates],
            "gap_before": self.gap_before.gap,
            "gap_after": self.gap_after.gap,
            "gap_noise_level": self.noise_fraction**2 if self.kind == "frf" else None,
            "noise_fraction": self.noise_fraction if self.kind == "frf" else None,
            "measurement": self.kind,
            "criterion": self.options.criterion,
            "response_method": describe(self.options.harmonic_balance) if self.kind == "frf" else None,
            "stop_reason": self.stop_reason,
            "levels_before": self.gap_before.to_dict(),
            "levels_after": self.gap_after.to_dict(),
            "steps": [
                {
                    "iteration": s.iteration,
                    "gap_before": s.gap_before,
                    "gap_after": s.gap_after,
                    "accepted": s.accepted.to_dict() if s.accepted else None,
                    "places": [loc.to_dict() for loc in s.localisation],
                    "mode_bands": [{"mode_hz": f, "share": share} for f, share in s.bands],
                    "note": s.note,
                }
                for s in self.steps
            ],
        }


def fit_candidate(job: tuple[Any, Effect]) -> CandidateFit:
    """Fit one (context, effect) job — the unit of work given to ``map_candidates``."""
    context, effect = job
    return context.fit(effect)


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
    noise = options.noise_fraction if options.noise_fraction is not None else data.noise_fraction()
    noise = max(noise, options.min_noise_fraction)
    return FRFEvidence(data, noise, options.sweep, penalty(options.criterion, 2 * data.h.size), options.harmonic_balance)


def discover(
    system: NonlinearSystem,
    measured: pd.DataFrame,
    options: DiscoveryOptions = DiscoveryOptions(),
    *,
    map_candidates: MapCandidates = map,
    source: str = "measured",
) -> DiscoveryResult:
    """Find the effects ``system`` is missing against ``measured`` (see module docstring).

    ``measured`` is a measured-FRF table (:mod:`nlupdate.measurement.frf_table`; several
    force levels, one input coordinate, coordinate names of the model) or a modal table
    (:mod:`nlupdate.measurement.modal_table`). ``source`` names the table in errors.
    Raises :class:`~nlupdate.discovery.errors.MeasuredDataError` for unusable data and
    :class:`~nlupdate.discovery.errors.ModelSolveError` when the model cannot be solved.
    """
    evidence = measurement_evidence(system, measured, options, source)
    effects = library(options.effects)
    before = evidence.predict(system)
    found: list[FoundEffect] = []
    current, prediction = system, before
    steps: list[DiscoveryStep] = []
    stop = f"{options.max_effects} effect(s) found (max_effects)"
    for iteration in range(1, options.max_effects + 1):
        gap_now = evidence.gap(prediction).gap
        if at_noise_level(evidence.chi2(prediction), evidence.n_data):
            stop = "the misfit is at the noise level"
            steps.append(DiscoveryStep(iteration, (), (), (), None, None, gap_now, None, stop))
            break
        contexts = evidence.contexts(system, found, prediction)
        fitted = contexts[: options.max_places]
        jobs = [(context, effect) for context in fitted for effect in effects if effect.applies_to(context.dofs)]
        candidates = sorted(
            (replace(fit, iteration=iteration) for fit in map_candidates(fit_candidate, jobs)),
            key=lambda fit: (fit.score, fit.name, fit.dofs),
        )
        best = candidates[0] if candidates else None
        place = next((c for c in fitted if best is not None and c.dofs == best.dofs), fitted[0])
        common = dict(
            iteration=iteration, localisation=tuple(c.localisation for c in contexts),
            bands=tuple(evidence.bands(current, prediction)), candidates=tuple(candidates), samples=place.samples,
            gap_before=gap_now,
        )
        accepted, why = None, "no candidates"
        for candidate in candidates[:_TRIALS]:
            significant, reason = is_significant(candidate, options.min_evidence, options.min_explained)
            if not significant:
                why = reason if candidate is best else why  # later ones: keep why the earlier failed
                break
            refitted = iter(candidate.companions)  # the effects found earlier at this place, in order
            trial = [next(refitted) if set(f.dofs) == set(candidate.dofs) else f for f in found] + [candidate.found()]
            trial_system = augment(system, trial)
            try:
                trial_prediction = evidence.predict(trial_system)
            except ModelSolveError as error:
                why = f"the model with {candidate.name} on dofs {list(candidate.dofs)} cannot be simulated ({error})"
                continue
            gap_trial = evidence.gap(trial_prediction).gap
            if gap_trial >= gap_now:
                why = (f"adding {candidate.name} on dofs {list(candidate.dofs)} did not shrink the simulated gap "
                       f"({gap_now:.3g} → {gap_trial:.3g})")
                continue
            accepted = candidate
            break
        if accepted is None:
            stop = why
            steps.append(DiscoveryStep(**common, accepted=None, gap_after=None, note=why))
            break
        found = trial
        current, prediction = trial_system, trial_prediction
        steps.append(DiscoveryStep(**common, accepted=accepted.found(), gap_after=gap_trial))
    return DiscoveryResult(
        kind=evidence.kind, data=evidence.data, system=system, augmented=augment(system, found), effects=tuple(found),
        steps=tuple(steps), gap_before=evidence.gap(before), gap_after=evidence.gap(prediction),
        prediction_before=before, prediction_after=prediction, noise_fraction=getattr(evidence, "noise_fraction", 0.0),
        stop_reason=stop, options=options,
    )
