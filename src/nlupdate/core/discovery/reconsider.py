"""The joint refit and reconsideration of a trial set of effects (step 4 of :mod:`nlupdate.core.discovery.workflow`).

The best candidate is added to the effects found so far and every parameter of every effect
is refitted jointly (:mod:`nlupdate.core.discovery.joint`). Then, for at most three passes:
an effect in a degenerate limit gives way to its simpler equivalent; an earlier effect that
no longer improves the criterion by ``min_evidence`` is dropped; and the one swap the joint
fit prefers most by ``min_evidence`` is made. The alternatives to the new effect are the next
candidates of its round; those to an earlier effect are every library effect at every place,
screened by the criterion at their variable-projection starts against the others' joint
values, the five best fitted there; in both cases the three best are refitted jointly.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from nlupdate.core.discovery.candidates import CandidateFit, FoundEffect
from nlupdate.core.discovery.effects import DFSamples, Effect
from nlupdate.core.discovery.equivalence import Equivalence, simpler_equivalent
from nlupdate.core.discovery.joint import JointFit
from nlupdate.core.discovery.options import DiscoveryOptions
from nlupdate.core.discovery.places import place_name
from nlupdate.core.discovery.starts import joint_starts
from nlupdate.core.model.system import NonlinearSystem

_SWAP_ALTERNATIVES = 3  # alternatives per effect refitted jointly when reconsidering it
_SCREENED = 5  # alternatives to an earlier effect fitted at their place after screening
_RECONSIDER_PASSES = 3


def same_place(a: Sequence[int], b: Sequence[int]) -> bool:
    """Whether two places join the same coordinates (in any order)."""
    return set(a) == set(b)


def effect_key(found: FoundEffect) -> tuple:
    """What identifies a found effect across refits: its effect and its place."""
    return found.effect, frozenset(found.dofs)


@dataclass
class Settle:
    """Joint refit and reconsideration of a trial set of effects (module docstring): called with
    a trial set whose last effect is the new one."""

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
        samples = next((v for k, v in self.samples.items() if same_place(k, found.dofs)), None)
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
        taken = {effect_key(f) for f in trial}
        if effect_key(current) == self.newest:
            chosen = [c.found() for c in self.round if effect_key(c.found()) not in taken]
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
        return next(v for k, v in self.samples.items() if same_place(k, dofs))

    def __call__(self, trial: list[FoundEffect]) -> tuple[list[FoundEffect], FoundEffect, float, list[str]]:
        """The trial (the last effect is the new one) refitted jointly and reconsidered:
        (effects, the new effect as it ended up, joint χ², what changed)."""
        joint, margin = self.joint, self.options.min_evidence
        newest = self.newest = effect_key(trial[-1])
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
                    newest = effect_key(simpler) if effect_key(found) == newest else newest
                    trial, chi2, changed = list(refitted), chi2_new, True
                    changes.append("joint refit: " + equivalent.describe(found.dofs, self.names))
            for k in range(len(trial) - 1, -1, -1):  # earlier effects no longer needed
                if len(trial) == 1 or effect_key(trial[k]) == newest:
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
                newest = effect_key(refitted[k]) if effect_key(trial[k]) == newest else newest
                trial, chi2, changed = refitted, chi2_new, True
            if not changed:
                break
        added = next((f for f in trial if effect_key(f) == newest), trial[-1])
        return trial, added, chi2, changes


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

