"""Candidates as plain data, and the information criterion that ranks them.

Misfit. Under the docs/methods.md §8 noise model (relative std σ of every measured value) the
misfit of a model is ``χ² = Σ |r|²`` over the ``n`` real residuals ``r`` scaled by their
noise std (FRF data: real and imaginary parts of ``(X_model − X̃)/|X̃|`` divided by
``σ/√2``; modal data: relative frequency and damping errors over their uncertainties).
A model that is right up to noise has ``χ² ≈ n``.

Criterion. Adding a candidate with k parameters changes the criterion by
``score = χ²_candidate − χ²_model + k·c`` with ``c = ln n`` (BIC) or 2 (AIC); negative is
better. :func:`is_significant` then asks that the best candidate

1. lowers the criterion by more than ``min_evidence`` (10 = "very strong" on the
   Kass–Raftery scale), and
2. removes at least ``min_explained`` of the misfit in excess of the noise, ``χ²_model − n``:
   an effect worth adding explains the disagreement, not a sliver of it,

and the workflow stops before that when the model's misfit is already at the noise level
(:func:`at_noise_level`: ``χ² − n`` within three standard deviations ``3·√(2n)`` of the
χ² distribution).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from nlupdate.core.discovery.effects import Effect
from nlupdate.core.discovery.places import place_name
from nlupdate.core.model.system import NonlinearSystem

CRITERIA = ("bic", "aic")


def penalty(criterion: str, n_data: int) -> float:
    """Criterion cost of one parameter: ``ln n`` (BIC) or 2 (AIC)."""
    if criterion == "bic":
        return float(np.log(n_data))
    if criterion == "aic":
        return 2.0
    raise ValueError(f"criterion must be one of {CRITERIA}, got {criterion!r}")


def at_noise_level(chi2: float, n_data: int) -> bool:
    """The misfit is explained by the measurement noise (within 3 std of a χ²_n draw)."""
    return chi2 - n_data <= 3.0 * np.sqrt(2.0 * n_data)


class _EffectAtValues:
    """What an effect at SI values reads as (:class:`FoundEffect`, :class:`CandidateFit`): its
    name, its parameters by name, and its variant in a JSON record."""

    effect: Effect
    values: tuple[float, ...]

    @property
    def name(self) -> str:
        return self.effect.name

    @property
    def parameters(self) -> dict[str, float]:
        return self.effect.parameter_dict(self.values)

    def _with_variant(self, out: dict) -> dict:
        """``out`` with the effect's ``variant``, when it has one."""
        if self.effect.variant:
            out["variant"] = self.effect.variant
        return out


@dataclass(frozen=True, eq=False)
class FoundEffect(_EffectAtValues):
    """An effect placed in the model: effect, model coordinate indices and SI values."""

    effect: Effect
    dofs: tuple[int, ...]
    values: tuple[float, ...]

    def to_dict(self) -> dict:
        return self._with_variant({"effect": self.name, "dofs": list(self.dofs), "parameters": self.parameters})


def augment(system: NonlinearSystem, effects: Sequence[FoundEffect]) -> NonlinearSystem:
    """The system with the effects added in order."""
    for found in effects:
        system = found.effect.apply(system, found.dofs, found.values)
    return system


@dataclass(frozen=True, eq=False)
class CandidateFit(_EffectAtValues):
    """One candidate fitted at one place.

    chi2 / baseline_chi2: misfit with and without the candidate (see module docstring);
    score: criterion change (negative = better); companions: effects found earlier at the
    same place, refitted jointly with the candidate; success: the fit converged to finite
    values; equivalent: set when the candidate degenerates to a simpler effect over the
    measured amplitudes (:mod:`nlupdate.core.discovery.equivalence`) — it then gives way to it.
    """

    effect: Effect
    dofs: tuple[int, ...]
    values: tuple[float, ...]
    chi2: float
    baseline_chi2: float
    n_data: int
    score: float
    success: bool
    companions: tuple[FoundEffect, ...] = ()
    iteration: int = field(default=0)
    equivalent: Any = None

    @property
    def explained(self) -> float:
        """Fraction of the misfit in excess of the noise that the candidate removes."""
        excess = self.baseline_chi2 - self.n_data
        return float((self.baseline_chi2 - self.chi2) / excess) if excess > 0 else 0.0

    def found(self) -> FoundEffect:
        return FoundEffect(self.effect, self.dofs, self.values)

    def to_dict(self) -> dict:
        out = self._with_variant({
            "effect": self.name, "dofs": list(self.dofs), "score": self.score, "parameters": self.parameters,
            "chi2": self.chi2, "baseline_chi2": self.baseline_chi2, "explained": self.explained,
            "iteration": self.iteration, "success": self.success,
        })
        if self.equivalent is not None:
            out["equivalent_to"] = self.equivalent.simpler.name
            out["equivalent_parameters"] = self.equivalent.simpler.parameter_dict(self.equivalent.simpler_values)
            out["equivalence_deviation"] = self.equivalent.deviation
        return out


def is_significant(best: CandidateFit, min_evidence: float, min_explained: float,
                   names: Sequence[str] = ()) -> tuple[bool, str]:
    """Whether the best candidate is worth adding, and why not if it is not (its place named
    by the model's coordinate ``names``)."""
    if not best.success:
        return False, f"the best candidate ({best.name}) did not converge"
    if best.score > -min_evidence:
        return False, (
            f"no candidate lowers the criterion by more than {min_evidence:g} "
            f"(best: {best.name} on {place_name(best.dofs, names)}, {best.score:+.1f})"
        )
    if best.explained < min_explained:
        return False, (
            f"the best candidate ({best.name} on {place_name(best.dofs, names)}) explains only "
            f"{100 * best.explained:.0f} % of the misfit above the noise (needs {100 * min_explained:.0f} %)"
        )
    return True, ""
