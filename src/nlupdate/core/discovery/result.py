"""What discovery found: each iteration's step and the result with its summary and ``discovery.json`` content."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Sequence

from nlupdate.core.discovery.candidates import CandidateFit, FoundEffect
from nlupdate.core.discovery.effects import DFSamples
from nlupdate.core.discovery.gap import GapReport
from nlupdate.core.discovery.localisation import Localisation
from nlupdate.core.discovery.options import DiscoveryOptions
from nlupdate.core.discovery.places import place_name
from nlupdate.core.model.system import NonlinearSystem
from nlupdate.core.response.method import describe


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

