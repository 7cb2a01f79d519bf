"""Discovery: which effect the model is missing, where, with which parameters — and proof.

Length: one module because it is the loop below and nothing else — its options, its result
and the steps that carry state from round to round (the joint refit and reconsideration,
``_Settle``; the search path, ``_Path``); every numerical piece it calls (gap, localisation,
candidate fits, joint fits, equivalence) lives in its own module.

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

from dataclasses import dataclass, field, replace
from typing import Any, Callable, Sequence

import numpy as np
import pandas as pd

from nlupdate.core.discovery.candidates import (
    CRITERIA, CandidateFit, FoundEffect, at_noise_level, augment, is_significant, penalty,
)
from nlupdate.core.discovery.effects import DFSamples, Effect, library
from nlupdate.core.discovery.equivalence import Equivalence, simpler_equivalent
from nlupdate.core.discovery.starts import joint_starts
from nlupdate.core.discovery.errors import DiscoveryError, MeasuredDataError, ModelSolveError, UnphysicalModelError
from nlupdate.core.discovery.frf_data import SWEEP_DIRECTIONS, FRFData
from nlupdate.core.discovery.frf_evidence import FRFEvidence
from nlupdate.core.discovery.gap import GapReport
from nlupdate.core.discovery.joint import JointFit
from nlupdate.core.discovery.localisation import Localisation
from nlupdate.core.discovery.places import place_name
from nlupdate.core.discovery.modal_evidence import ModalEvidence
from nlupdate.core.discovery.modal_data import ModalData
from nlupdate.core.measurement.modal_table import MODAL_COLUMNS
from nlupdate.core.model.system import NonlinearSystem
from nlupdate.core.response.harmonic_balance import HarmonicSettings
from nlupdate.core.response.method import HARMONICS_FORM, describe, samples_form, valid_harmonics, valid_samples

MapCandidates = Callable[[Callable[[Any], CandidateFit], Sequence[Any]], Any]
_TRIALS = 3  # significant candidates tried in turn when the best cannot be simulated or does not help
_SWAP_ALTERNATIVES = 3  # alternatives per effect refitted jointly when reconsidering it
_SCREENED = 5  # alternatives to an earlier effect fitted at their place after screening
_RESTART_RATIO = 1.5  # a search whose RMS residual ends above this many times the noise level is restarted
_RECONSIDER_PASSES = 3


@dataclass(frozen=True)
class DiscoveryOptions:
    """Settings of :func:`discover`.

    effects: names of library effects or :class:`~nlupdate.core.discovery.effects.Effect`
    instances (None: the whole library). criterion: ``"bic"`` or ``"aic"``.
    max_effects: most effects to add. min_evidence, min_explained: significance rule
    (:func:`~nlupdate.core.discovery.candidates.is_significant`); min_evidence is also the
    criterion margin by which a joint refit must prefer a swap or may lose an effect.
    place_share, max_places: candidates are fitted at every place that explains at least
    ``place_share`` of what the best place explains, at most ``max_places`` of them.
    noise_fraction: relative noise std of the FRFs (None: from the data — their stated
    uncertainty, repeats, or the model-free estimate), never below min_noise_fraction.
    sweep: how the test reached each frequency — "up", "down" or "unknown"; None: as the
    measured table states (its ``sweep_direction`` column), else unknown. It only decides
    which points are marked as following another branch: every point is compared with the
    model's nearest stable solution.
    frequency_uncertainty, damping_uncertainty: relative std of modal-table frequencies
    and damping ratios. harmonic_balance: None to simulate the model by the describing
    function (default), or the settings of a multi-harmonic balance (measured FRFs only;
    the candidates' fits stay describing-function fits, the simulated gap and the check of
    every added effect use the balance). equivalence_tolerance: DF deviation within which a
    candidate counts as its simpler equivalent. poor_fit_ratio: RMS residual over noise
    level above which the fit is reported poor. joint_refit: refit every effect together
    after each addition and reconsider earlier choices (switch off only to compare).
    restarts: when a search ends with an RMS residual above 1.5× the noise level, search
    again without its first choice (then without the next first choice), up to this many times, and keep the result
    with the lower criterion.
    """

    effects: tuple[str | Effect, ...] | None = None
    criterion: str = "bic"
    max_effects: int = 3
    min_evidence: float = 10.0
    min_explained: float = 0.5
    max_places: int = 10
    place_share: float = 0.5
    noise_fraction: float | None = None
    min_noise_fraction: float = 0.002
    sweep: str | None = None
    frequency_uncertainty: float = 0.002
    damping_uncertainty: float = 0.05
    harmonic_balance: HarmonicSettings | None = None
    equivalence_tolerance: float = 0.1
    poor_fit_ratio: float = 5.0
    joint_refit: bool = True
    restarts: int = 2

    def __post_init__(self) -> None:
        if self.criterion not in CRITERIA:
            raise DiscoveryError(f"options.criterion: expected one of {CRITERIA}, got {self.criterion!r}")
        if self.sweep is not None and self.sweep not in SWEEP_DIRECTIONS:
            raise DiscoveryError(f"options.sweep: expected one of {', '.join(SWEEP_DIRECTIONS)} or None (as the data "
                                 f"state), got {self.sweep!r}")
        if int(self.restarts) < 0:
            raise DiscoveryError(f"options.restarts: expected an integer ≥ 0, got {self.restarts!r}")
        for name in ("max_effects", "max_places"):
            if int(getattr(self, name)) < 1:
                raise DiscoveryError(f"options.{name}: expected a positive integer, got {getattr(self, name)!r}")
        for name in ("min_noise_fraction", "frequency_uncertainty", "damping_uncertainty", "poor_fit_ratio"):
            if not getattr(self, name) > 0:
                raise DiscoveryError(f"options.{name}: expected a positive number, got {getattr(self, name)!r}")
        for name in ("place_share", "equivalence_tolerance"):
            if not 0 <= getattr(self, name) <= 1:
                raise DiscoveryError(f"options.{name}: expected a fraction in [0, 1], got {getattr(self, name)!r}")
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
    added (None if nothing), the simulated gap before and after it, the places whose
    candidates were fitted, the candidates that gave way to a simpler equivalent, and what
    the joint refit changed (``changes``: one sentence each; ``refitted``: every effect's
    values after it)."""

    iteration: int
    localisation: tuple[Localisation, ...]
    bands: tuple[tuple[float, float], ...]
    candidates: tuple[CandidateFit, ...]
    samples: DFSamples | None
    accepted: FoundEffect | None
    gap_before: float
    gap_after: float | None
    note: str = ""
    places_fitted: tuple[tuple[int, ...], ...] = ()
    changes: tuple[str, ...] = ()
    refitted: tuple[FoundEffect, ...] = ()


@dataclass(frozen=True, eq=False)
class DiscoveryResult:
    """What :func:`discover` found: the effects in the order found, the augmented model,
    the gap before and after, every step, the predictions for plotting, how well the result
    fits (``misfit_ratio``: RMS residual over the noise level; ``fit``: "good" or "poor") and
    the warnings (points the model cannot solve, a poor fit). FRF data: ``residuals_after``
    (n, m) complex relative residuals of the model after, ``other_branch_after`` (n,) the
    points where the measurement follows another branch than the stated sweep."""

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
    misfit_ratio: float = float("nan")
    misfit_ratio_before: float = float("nan")
    warnings: tuple[str, ...] = ()
    noise_source: str = ""
    sweep: str = "unknown"
    residuals_after: Any = None
    other_branch_after: Any = None
    restarts: tuple[str, ...] = ()

    @property
    def fit(self) -> str:
        """``"poor"`` when the RMS residual exceeds ``poor_fit_ratio`` × the noise level, else ``"good"``."""
        return "poor" if self.misfit_ratio > self.options.poor_fit_ratio else "good"

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

    def place(self, dofs: Sequence[int]) -> str:
        """``dofs`` as the model names them: ``"m2–m3"``, ``"m1 (to ground)"`` (:func:`place_name`)."""
        return place_name(dofs, tuple(self.system.model.dof_names))

    @property
    def candidates(self) -> tuple[CandidateFit, ...]:
        return tuple(c for step in self.steps for c in step.candidates)

    def __repr__(self) -> str:
        """One line: the effects found where, the gap before → after and the fit (the
        default dataclass repr printed every measured point: 90 kB)."""
        found = ", ".join(f"{e.name} on {self.place(e.dofs)} ("
                          + ", ".join(f"{k} = {v:.4g}" for k, v in e.parameters.items()) + ")"
                          for e in self.effects) or "no effect"
        return (f"<DiscoveryResult: {found}; gap {self.gap_before.gap:.3g} → {self.gap_after.gap:.3g}; "
                f"{self.summary()}>")

    def summary(self) -> str:
        """One line on how well the effects found explain the data."""
        if self.fit == "poor":
            named = "the effects found do not explain" if self.effects else "no effect of the library explains"
            return (f"fit: POOR — the residual is {self.misfit_ratio:.3g}× the noise level (limit "
                    f"{self.options.poor_fit_ratio:g}×): {named} the measurement; see the residual against "
                    "amplitude for what is missing")
        return f"fit: good — the residual is {self.misfit_ratio:.3g}× the noise level"

    def to_dict(self) -> dict:
        """The ``discovery.json`` content (see :mod:`nlupdate.core.discovery.outputs`)."""
        effects = [{**e.to_dict(), "place": self.place(e.dofs)} for e in self.effects]
        first = effects[0] if effects else {"effect": "none", "dofs": [], "place": "", "parameters": {}}
        return {
            "effect": first["effect"],
            "dofs": first["dofs"],
            "place": first["place"],
            "parameters": first["parameters"],
            "effects": effects,
            "fit": self.fit,
            "misfit_to_noise": self.misfit_ratio,
            "misfit_to_noise_before": self.misfit_ratio_before,
            "poor_fit_limit": self.options.poor_fit_ratio,
            "summary": self.summary(),
            "warnings": list(self.warnings),
            "candidates": [c.to_dict() for c in self.candidates],
            "gap_before": self.gap_before.gap,
            "gap_after": self.gap_after.gap,
            "gap_noise_level": self.noise_fraction**2 if self.kind == "frf" else None,
            "noise_fraction": self.noise_fraction if self.kind == "frf" else None,
            "noise_source": self.noise_source if self.kind == "frf" else None,
            "sweep_direction": self.sweep if self.kind == "frf" else None,
            "measurement": self.kind,
            "criterion": self.options.criterion,
            "response_method": describe(self.options.harmonic_balance) if self.kind == "frf" else None,
            "stop_reason": self.stop_reason,
            "restarts": list(self.restarts),
            "levels_before": self.gap_before.to_dict(),
            "levels_after": self.gap_after.to_dict(),
            "steps": [
                {
                    "iteration": s.iteration,
                    "gap_before": s.gap_before,
                    "gap_after": s.gap_after,
                    "accepted": s.accepted.to_dict() if s.accepted else None,
                    "places": [loc.to_dict() for loc in s.localisation],
                    "places_fitted": [list(p) for p in s.places_fitted],
                    "equivalences": [c.to_dict() for c in s.candidates if c.equivalent is not None],
                    "changes": list(s.changes),
                    "effects_after_refit": [e.to_dict() for e in s.refitted],
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


def select_places(contexts: Sequence[Any], share: float, most: int) -> list[Any]:
    """The contexts (sorted, best-explaining first) whose place explains at least ``share`` of
    what the best place explains, at most ``most`` of them (at least one)."""
    if not contexts:
        return []
    best = max(c.localisation.explained for c in contexts)
    chosen = [c for c in contexts if c.localisation.explained >= share * best]
    return chosen[:most] or list(contexts[:1])


def _same_place(a: Sequence[int], b: Sequence[int]) -> bool:
    return set(a) == set(b)


@dataclass
class _Settle:
    """Joint refit and reconsideration of a trial set of effects (module docstring, step 4)."""

    evidence: Any
    system: NonlinearSystem
    prediction: Any
    joint: JointFit
    effects: tuple[Effect, ...]
    samples: dict
    options: DiscoveryOptions
    round: Sequence[CandidateFit]  # this iteration's significant-looking candidates, best first
    places: Sequence[tuple[int, ...]]
    newest: tuple = ()

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self.system.model.dof_names)

    def place(self, dofs: Sequence[int]) -> str:
        return place_name(dofs, self.names)

    def equivalence(self, found: FoundEffect) -> Equivalence | None:
        samples = next((v for k, v in self.samples.items() if _same_place(k, found.dofs)), None)
        if samples is None:
            return None
        return simpler_equivalent(found.effect, found.values, found.dofs, samples, self.effects,
                                  self.options.equivalence_tolerance)

    def alternatives(self, trial: list[FoundEffect], index: int) -> list[FoundEffect]:
        """What could stand instead of ``trial[index]``, best first (at most ``_SWAP_ALTERNATIVES``):
        for the new effect, the next candidates of this round; for an earlier one, every
        library effect at every place screened against the joint values of the others (the
        criterion at the variable-projection starts), the best ``_SCREENED`` fitted there."""
        current = trial[index]
        taken = {_key(f) for f in trial}
        if _key(current) == self.newest:
            chosen = [c.found() for c in self.round if _key(c.found()) not in taken]
            return chosen[:_SWAP_ALTERNATIVES]
        rest = trial[:index] + trial[index + 1 :]
        screened = []
        for place in self.places:
            context = self.evidence.context(place, self.system, rest, self.prediction)
            for effect in self.effects:
                if effect.applies_to(place) and (effect, frozenset(place)) not in taken:
                    screened.append((_screen(context, effect), context, effect))
        screened.sort(key=lambda item: item[0])
        fits = [context.fit(effect) for _, context, effect in screened[:_SCREENED]]
        fits = [f for f in fits if f.success and np.isfinite(f.chi2)]
        fits.sort(key=lambda f: f.chi2 + len(f.effect.parameters) * self.joint.penalty)
        alternatives = []
        for fit in fits:
            if simpler_equivalent(fit.effect, fit.values, fit.dofs, self.samples_at(fit.dofs), self.effects,
                                  self.options.equivalence_tolerance) is None:
                alternatives.append(fit.found())
        return alternatives[:_SWAP_ALTERNATIVES]

    def samples_at(self, dofs: Sequence[int]) -> DFSamples:
        return next(v for k, v in self.samples.items() if _same_place(k, dofs))

    def __call__(self, trial: list[FoundEffect]) -> tuple[list[FoundEffect], FoundEffect, float, list[str]]:
        """The trial (the last effect is the new one) refitted jointly and reconsidered:
        (effects, the new effect as it ended up, joint χ², what changed)."""
        joint, margin = self.joint, self.options.min_evidence
        newest = self.newest = _key(trial[-1])
        changes: list[str] = []
        refitted, chi2, _ = joint.refit(trial)
        trial = list(refitted)
        for _ in range(_RECONSIDER_PASSES):
            changed = False
            for k, found in enumerate(list(trial)):  # degenerate limits give way to the simpler effect
                equivalent = self.equivalence(found)
                if equivalent is None:
                    continue
                simpler = FoundEffect(equivalent.simpler, found.dofs, equivalent.simpler_values)
                refitted, chi2_new, ok = joint.refit(trial[:k] + [simpler] + trial[k + 1 :])
                if ok:
                    newest = _key(simpler) if _key(found) == newest else newest
                    trial, chi2, changed = list(refitted), chi2_new, True
                    changes.append("joint refit: " + equivalent.describe(found.dofs, self.names))
            for k in range(len(trial) - 1, -1, -1):  # earlier effects no longer needed
                if len(trial) == 1 or _key(trial[k]) == newest:
                    continue
                without = trial[:k] + trial[k + 1 :]
                refitted, chi2_new, ok = joint.refit(without)
                gain = joint.criterion(without, chi2_new) - joint.criterion(trial, chi2)
                if ok and gain < margin:
                    changes.append(f"joint refit: {trial[k].name} on {self.place(trial[k].dofs)} dropped — without it "
                                   f"the criterion changes by {gain:+.1f} (needs more than +{margin:g} to keep it)")
                    trial, chi2, changed = list(refitted), chi2_new, True
            best = None  # the one swap the joint fit prefers most: another effect, here or elsewhere
            for k in range(len(trial)):
                for alternative in self.alternatives(trial, k):
                    candidate = trial[:k] + [alternative] + trial[k + 1 :]
                    refitted, chi2_new, ok = joint.refit(candidate)
                    if not ok:
                        continue
                    gain = joint.criterion(trial, chi2) - joint.criterion(candidate, chi2_new)
                    if gain > margin and (best is None or gain > best[0]):
                        best = (gain, k, list(refitted), chi2_new)
            if best is not None:
                gain, k, refitted, chi2_new = best
                changes.append(f"joint refit: {trial[k].name} on {self.place(trial[k].dofs)} swapped for "
                               f"{refitted[k].name} on {self.place(refitted[k].dofs)} (criterion {-gain:+.1f})")
                newest = _key(refitted[k]) if _key(trial[k]) == newest else newest
                trial, chi2, changed = refitted, chi2_new, True
            if not changed:
                break
        added = next((f for f in trial if _key(f) == newest), trial[-1])
        return trial, added, chi2, changes


def _key(found: FoundEffect) -> tuple:
    return found.effect, frozenset(found.dofs)


def _screen(context: Any, effect: Effect) -> float:
    """Criterion of ``effect`` at a context's place at its best variable-projection start (with
    the effects found there at their values): a cheap ranking before fitting."""
    companions = [c.effect for c in context.companions]
    current = [np.array(c.values) for c in context.companions]
    samples = context.samples
    if companions:
        taken = sum((e.nu(v, samples.amplitude, samples.omega) for e, v in zip(companions, current)),
                    np.zeros_like(samples.nu))
        samples = DFSamples(samples.amplitude, samples.omega, samples.nu - taken, samples.std)
    best = np.inf
    with np.errstate(all="ignore"):
        for start in joint_starts([effect], samples):
            r = context.residual([effect] + companions, [start[0]] + current)
            best = min(best, float(np.sum(np.where(np.isfinite(r), r, 1e6) ** 2)))
    return best + len(effect.parameters) * context.penalty


@dataclass(frozen=True, eq=False)
class _Path:
    """One greedy search: the effects found, its steps, why it stopped, the final prediction
    and its criterion (χ² + cost of all parameters)."""

    found: tuple[FoundEffect, ...]
    steps: tuple[DiscoveryStep, ...]
    stop: str
    prediction: Any
    chi2: float
    criterion: float


def _search(evidence: Any, system: NonlinearSystem, before: Any, options: DiscoveryOptions, effects: tuple[Effect, ...],
            map_candidates: MapCandidates, excluded_first: frozenset) -> _Path:
    """The loop of the module docstring from the model alone; ``excluded_first``: effect keys
    the first iteration may not choose (a restart)."""
    found: list[FoundEffect] = []
    current, prediction = system, before
    names = tuple(system.model.dof_names)
    steps: list[DiscoveryStep] = []
    stop = f"{options.max_effects} effect(s) found (max_effects)"
    for iteration in range(1, options.max_effects + 1):
        gap_now = evidence.gap(prediction).gap
        chi2_now = evidence.chi2(prediction)
        criterion_now = chi2_now + evidence.penalty * _parameters(found)
        if at_noise_level(chi2_now, evidence.n_data):
            stop = "the misfit is at the noise level"
            steps.append(DiscoveryStep(iteration, (), (), (), None, None, gap_now, None, stop))
            break
        contexts = evidence.contexts(system, found, prediction)
        fitted = select_places(contexts, options.place_share, options.max_places)
        jobs = [(context, effect) for context in fitted for effect in effects if effect.applies_to(context.dofs)]
        samples = {c.dofs: c.samples for c in contexts}
        candidates = []
        for fit in map_candidates(fit_candidate, jobs):
            equivalent = simpler_equivalent(fit.effect, fit.values, fit.dofs, samples[fit.dofs], effects,
                                            options.equivalence_tolerance) if fit.success else None
            candidates.append(replace(fit, iteration=iteration, equivalent=equivalent))
        candidates.sort(key=lambda fit: (fit.score, fit.name, fit.dofs))
        ranked = [c for c in candidates if c.equivalent is None
                  and not (iteration == 1 and _key(c.found()) in excluded_first)]
        best = ranked[0] if ranked else None
        place = next((c for c in fitted if best is not None and c.dofs == best.dofs), fitted[0])
        common = dict(
            iteration=iteration, localisation=tuple(c.localisation for c in contexts),
            bands=tuple(evidence.bands(current, prediction)), candidates=tuple(candidates), samples=place.samples,
            gap_before=gap_now, places_fitted=tuple(c.dofs for c in fitted),
        )
        settle = _Settle(evidence, system, prediction, evidence.joint(system, prediction), effects, samples, options,
                         ranked, [c.dofs for c in contexts])
        accepted, why, changes, rejected = None, "no candidates", [], []
        for candidate in ranked[:_TRIALS]:
            significant, reason = is_significant(candidate, options.min_evidence, options.min_explained, names)
            if not significant:
                why = reason if candidate is best else why  # later ones: keep why the earlier failed
                break
            refitted = iter(candidate.companions)  # the effects found earlier at this place, in order
            trial = [next(refitted) if _same_place(f.dofs, candidate.dofs) else f for f in found] + [candidate.found()]
            changes, added = [], trial[-1]
            if options.joint_refit:
                trial, added, _, changes = settle(trial)
            try:
                trial_system = augment(system, trial)
            except UnphysicalModelError as error:  # a finding about this candidate: try the next one
                why = f"rejected {candidate.name} on {place_name(candidate.dofs, names)}: {error}"
                rejected.append(why)
                continue
            try:
                trial_prediction = evidence.predict(trial_system)
            except ModelSolveError as error:
                why = f"the model with {candidate.name} on {place_name(candidate.dofs, names)} cannot be simulated ({error})"
                continue
            gap_trial = evidence.gap(trial_prediction).gap
            criterion_trial = evidence.chi2(trial_prediction) + evidence.penalty * _parameters(trial)
            if criterion_trial > criterion_now - options.min_evidence:
                why = (f"adding {candidate.name} on {place_name(candidate.dofs, names)} did not lower the simulated misfit "
                       f"(criterion {criterion_now:.1f} → {criterion_trial:.1f}; gap {gap_now:.3g} → {gap_trial:.3g})")
                continue
            accepted = candidate
            break
        if accepted is None:
            stop = why
            steps.append(DiscoveryStep(**common, accepted=None, gap_after=None,
                                       note="; ".join(dict.fromkeys(rejected + [why]))))
            break
        found = trial
        current, prediction = trial_system, trial_prediction
        steps.append(DiscoveryStep(**common, accepted=added, gap_after=gap_trial, note="; ".join(rejected),
                                   changes=tuple(changes), refitted=tuple(found)))
    chi2 = evidence.chi2(prediction)
    return _Path(tuple(found), tuple(steps), stop, prediction, chi2, chi2 + evidence.penalty * _parameters(found))


def _parameters(found: Sequence[FoundEffect]) -> int:
    return sum(len(f.effect.parameters) for f in found)


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
    path = _search(evidence, system, before, options, effects, map_candidates, frozenset())
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
        excluded = excluded | {_key(first)}
        latest = other = _search(evidence, system, before, options, effects, map_candidates, excluded)
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
