"""One greedy discovery search: rounds of candidates, each added only if the simulated misfit drops.

Each iteration (steps 1–3 and 5 of :mod:`nlupdate.core.discovery.workflow`) measures the gap,
localises it, fits every library effect at the places with a substantial share
(:func:`select_places`), ranks the candidates, and tries the significant ones in turn (at most
three): each is refitted jointly with the effects found (:mod:`~nlupdate.core.discovery.reconsider`),
the model re-simulated, and the set accepted only when its criterion drops by more than
``min_evidence``. The search stops at the noise level, when nothing more is significant, or
at ``max_effects``.

Candidate fits are independent jobs run through ``map_candidates(fit_candidate, jobs)``, so an
orchestrator can run them in parallel; the result does not depend on the order they finish in.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, Callable, Sequence

from nlupdate.core.discovery.candidates import CandidateFit, FoundEffect, at_noise_level, augment, is_significant
from nlupdate.core.discovery.effects import Effect
from nlupdate.core.discovery.equivalence import simpler_equivalent
from nlupdate.core.discovery.errors import ModelSolveError, UnphysicalModelError
from nlupdate.core.discovery.options import DiscoveryOptions
from nlupdate.core.discovery.places import place_name
from nlupdate.core.discovery.reconsider import Settle, effect_key, same_place
from nlupdate.core.discovery.result import DiscoveryStep
from nlupdate.core.model.system import NonlinearSystem

MapCandidates = Callable[[Callable[[Any], CandidateFit], Sequence[Any]], Any]
_TRIALS = 3  # significant candidates tried in turn when the best cannot be simulated or does not help


def fit_candidate(job: tuple[Any, Effect]) -> CandidateFit:
    """Fit one (context, effect) job — the unit of work given to ``map_candidates``."""
    context, effect = job
    return context.fit(effect)


def select_places(contexts: Sequence[Any], share: float, most: int) -> list[Any]:
    """The contexts (sorted, best-explaining first) whose place explains at least ``share`` of
    what the best place explains, at most ``most`` of them (at least one)."""
    if not contexts:
        return []
    best = max(c.localisation.explained for c in contexts)
    chosen = [c for c in contexts if c.localisation.explained >= share * best]
    return chosen[:most] or list(contexts[:1])


@dataclass(frozen=True, eq=False)
class SearchPath:
    """One greedy search: the effects found, its steps, why it stopped, the final prediction
    and its criterion (χ² + cost of all parameters)."""

    found: tuple[FoundEffect, ...]
    steps: tuple[DiscoveryStep, ...]
    stop: str
    prediction: Any
    chi2: float
    criterion: float


def search(evidence: Any, system: NonlinearSystem, before: Any, options: DiscoveryOptions, effects: tuple[Effect, ...],
            map_candidates: MapCandidates, excluded_first: frozenset) -> SearchPath:
    """The search of the module docstring from the model alone; ``excluded_first``: effect keys
    (:func:`~nlupdate.core.discovery.reconsider.effect_key`) the first iteration may not choose (a restart)."""
    found: list[FoundEffect] = []
    current, prediction = system, before
    names = tuple(system.model.dof_names)
    steps: list[DiscoveryStep] = []
    stop = f"{options.max_effects} effect(s) found (max_effects)"
    for iteration in range(1, options.max_effects + 1):
        gap_now = evidence.gap(prediction).gap
        chi2_now = evidence.chi2(prediction)
        criterion_now = chi2_now + evidence.penalty * parameter_count(found)
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
                  and not (iteration == 1 and effect_key(c.found()) in excluded_first)]
        best = ranked[0] if ranked else None
        place = next((c for c in fitted if best is not None and c.dofs == best.dofs), fitted[0])
        common = dict(
            iteration=iteration, localisation=tuple(c.localisation for c in contexts),
            bands=tuple(evidence.bands(current, prediction)), candidates=tuple(candidates), samples=place.samples,
            gap_before=gap_now, places_fitted=tuple(c.dofs for c in fitted),
        )
        settle = Settle(evidence, system, prediction, evidence.joint(system, prediction), effects, samples, options,
                         ranked, [c.dofs for c in contexts])
        accepted, why, changes, rejected = None, "no candidates", [], []
        for candidate in ranked[:_TRIALS]:
            significant, reason = is_significant(candidate, options.min_evidence, options.min_explained, names)
            if not significant:
                why = reason if candidate is best else why  # later ones: keep why the earlier failed
                break
            refitted = iter(candidate.companions)  # the effects found earlier at this place, in order
            trial = [next(refitted) if same_place(f.dofs, candidate.dofs) else f for f in found] + [candidate.found()]
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
            criterion_trial = evidence.chi2(trial_prediction) + evidence.penalty * parameter_count(trial)
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
    return SearchPath(tuple(found), tuple(steps), stop, prediction, chi2, chi2 + evidence.penalty * parameter_count(found))


def parameter_count(found: Sequence[FoundEffect]) -> int:
    """The number of parameters of the effects ``found``."""
    return sum(len(f.effect.parameters) for f in found)

