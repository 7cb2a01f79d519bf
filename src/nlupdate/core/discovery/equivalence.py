"""Equivalences: a candidate that degenerates to a simpler effect over the measured amplitudes.

Some effects contain simpler ones as limits of their parameters: a gap whose clearance is far
below the amplitudes is a linear spring (``ν → kc``), a Jenkins joint that never slips is a
spring kf, one that always slips is Coulomb friction, a microslip joint that never slips is a
spring. Fitted to data, the larger effect can sit in such a limit and still win on the
criterion, because its spare parameter soaks up a little of something else that is missing
(a gap with a 3 µm clearance beating ``stiffness_error`` by taking part of a cubic spring
elsewhere); then the search builds on a disguise.

The test is generic, so it holds for any effect of the library: over the place's measured
samples (amplitude A_k, frequency ω_k, and the standard deviation s_k with which the data
determine the element's DF there, :class:`~nlupdate.core.discovery.effects.DFSamples`), the
candidate's DF ``ν_c`` is fitted by every library effect with **fewer parameters** (its
least-squares values, by the variable projection of :mod:`nlupdate.core.discovery.starts`), and
the weighted relative deviation

    d = √( Σ_k |ν_s(A_k, ω_k) − ν_c(A_k, ω_k)|² / s_k²  /  Σ_k |ν_c(A_k, ω_k)|² / s_k² )

is computed. When the smallest d is at most the tolerance (10 % by default:
``DiscoveryOptions.equivalence_tolerance``), the candidate *is* that simpler effect at the
data's amplitudes: it gives way to it, and the report names the equivalence.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from nlupdate.core.discovery.effects import DFSamples, Effect
from nlupdate.core.discovery.places import place_name
from nlupdate.core.discovery.starts import joint_starts


@dataclass(frozen=True, eq=False)
class Equivalence:
    """``effect`` at ``values`` behaves as ``simpler`` at ``simpler_values`` over the measured
    amplitudes, within ``deviation`` (weighted relative RMS of the DF difference)."""

    effect: Effect
    values: tuple[float, ...]
    simpler: Effect
    simpler_values: tuple[float, ...]
    deviation: float

    def describe(self, dofs: Sequence[int], names: Sequence[str] = ()) -> str:
        """One sentence; ``names``: the model's coordinate names (:func:`place_name`)."""
        own = ", ".join(f"{k} = {v:.3g}" for k, v in self.effect.parameter_dict(self.values).items())
        other = ", ".join(f"{k} = {v:.3g}" for k, v in self.simpler.parameter_dict(self.simpler_values).items())
        return (f"{self.effect.name} on {place_name(dofs, names)} ({own}) ≈ {self.simpler.name} ({other}) over the measured "
                f"amplitudes (DF within {100 * self.deviation:.1f} %): the simpler one is used")

    def to_dict(self) -> dict:
        return {"effect": self.effect.name, "parameters": self.effect.parameter_dict(self.values),
                "equivalent_to": self.simpler.name, "equivalent_parameters": self.simpler.parameter_dict(self.simpler_values),
                "deviation": self.deviation}


def simpler_equivalent(
    effect: Effect, values: Sequence[float], dofs: Sequence[int], samples: DFSamples, library: Sequence[Effect],
    tolerance: float,
) -> Equivalence | None:
    """The simplest library effect (fewest parameters, then smallest deviation) that ``effect``
    at ``values`` degenerates to at these samples, or None (see module docstring)."""
    nu = effect.nu(np.asarray(values, dtype=float), samples.amplitude, samples.omega)
    weight = np.where(np.isfinite(samples.std) & (samples.std > 0), 1.0 / samples.std**2, 0.0)
    size = float(np.sum(weight * np.abs(nu) ** 2))
    if not np.isfinite(size) or size <= 0:
        return None
    target = DFSamples(samples.amplitude, samples.omega, nu, samples.std)
    best: Equivalence | None = None
    for other in library:
        if len(other.parameters) >= len(effect.parameters) or not other.applies_to(dofs) or other == effect:
            continue
        with np.errstate(all="ignore"):
            start = joint_starts([other], target, count=1)[0][0]
            deviation = float(np.sqrt(np.sum(weight * np.abs(other.nu(start, samples.amplitude, samples.omega) - nu) ** 2)
                                      / size))
        if not np.isfinite(deviation) or deviation > tolerance:
            continue
        key = (len(other.parameters), deviation)
        if best is None or key < (len(best.simpler.parameters), best.deviation):
            best = Equivalence(effect, tuple(float(v) for v in values), other, tuple(float(v) for v in start), deviation)
    return best
