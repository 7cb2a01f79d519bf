"""Stepped-sine FRFs as evidence: simulate, measure the gap, localise, set up candidate fits.

Candidate places are the measured coordinates (element to ground) and every pair of them
(element between them): the measured response amplitudes and relative displacements are
what a candidate's describing function is fitted against.
"""
from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations
from typing import Sequence

import numpy as np
from numpy.typing import NDArray

from nlupdate.discovery.candidates import FoundEffect, augment
from nlupdate.discovery.frf_data import FRFData
from nlupdate.discovery.frf_fit import FRFContext, frf_context
from nlupdate.discovery.gap import GapReport, level_gap
from nlupdate.discovery.localisation import band_shares
from nlupdate.discovery.simulation import simulate_points
from nlupdate.model.linear import LumpedModel, ModalModel
from nlupdate.model.system import NonlinearSystem
from nlupdate.response.harmonic_balance import HarmonicSettings


@dataclass(frozen=True, eq=False)
class Prediction:
    """Model amplitudes (m) at the measured points, at ``dofs`` (columns of ``x``)."""

    dofs: tuple[int, ...]
    x: NDArray[np.complex128]

    def at(self, dof: int) -> NDArray[np.complex128]:
        return self.x[:, self.dofs.index(dof)]


def natural_omega(system: NonlinearSystem) -> NDArray[np.float64]:
    """Undamped natural frequencies (rad/s) of the linear model, if it can say."""
    model = system.model
    if isinstance(model, ModalModel):
        return model.omega_r
    if isinstance(model, LumpedModel):
        return model.modes(None if not model.is_sparse else min(model.n_dof - 1, 20))[0]
    return np.array([])


@dataclass(frozen=True, eq=False)
class FRFEvidence:
    """Measured FRFs with the noise level and settings used to judge candidates;
    ``harmonic_balance``: how the model is simulated (None: describing function)."""

    data: FRFData
    noise_fraction: float
    sweep: str
    penalty: float
    harmonic_balance: HarmonicSettings | None = None

    kind = "frf"

    @property
    def n_data(self) -> int:
        return 2 * self.data.h.size

    @property
    def chi2_scale(self) -> float:
        return 2.0 / self.noise_fraction**2

    def predict(self, system: NonlinearSystem) -> Prediction:
        dofs = tuple(dict.fromkeys(self.data.response_dofs + system.nonlinear_dofs))
        x = simulate_points(system, self.data.input_dof, self.data.force, self.data.omega, dofs, self.sweep,
                            self.harmonic_balance)
        return Prediction(dofs, x)

    def h_model(self, prediction: Prediction) -> NDArray[np.complex128]:
        return np.column_stack([prediction.at(d) for d in self.data.response_dofs]) / self.data.force[:, None]

    def misfit_per_point(self, prediction: Prediction) -> NDArray[np.float64]:
        """χ² contribution of every point; a point the model cannot reach counts as a 100 % error."""
        r = (self.h_model(prediction) - self.data.h) / np.abs(self.data.h)
        r = np.where(np.isfinite(r), r, 1.0)
        return self.chi2_scale * np.sum(np.abs(r) ** 2, axis=1)

    def chi2(self, prediction: Prediction) -> float:
        return float(np.sum(self.misfit_per_point(prediction)))

    def gap(self, prediction: Prediction) -> GapReport:
        data = self.data
        h_model = self.h_model(prediction)
        reference = data.response_dofs.index(data.input_dof) if data.input_dof in data.response_dofs else 0
        levels = []
        for k, level in enumerate(data.levels):
            mask = data.level_index == k
            levels.append(level_gap(level, data.frequency_hz[mask], data.h[mask], h_model[mask], reference))
        return GapReport(tuple(levels))

    def bands(self, system: NonlinearSystem, prediction: Prediction) -> list[tuple[float, float]]:
        return band_shares(self.data.omega, self.misfit_per_point(prediction), natural_omega(system))

    def places(self) -> list[tuple[int, ...]]:
        measured = sorted(self.data.response_dofs)
        return [(d,) for d in measured] + list(combinations(measured, 2))

    def contexts(
        self, system: NonlinearSystem, found: Sequence[FoundEffect], prediction: Prediction
    ) -> list[FRFContext]:
        """One fitting context per place, best-explaining place first."""
        data = self.data
        measured = {dof: data.x[:, k] for k, dof in enumerate(data.response_dofs)}

        def reference(dof: int) -> NDArray:
            return measured[dof] if dof in measured else prediction.at(dof)

        contexts = []
        for place in self.places():
            same = set(place)
            fixed = tuple(e for e in system.elements if set(e.dofs) == same)
            others = NonlinearSystem(system.model, tuple(e for e in system.elements if set(e.dofs) != same))
            background = augment(others, [f for f in found if set(f.dofs) != same])
            companions = tuple(f for f in found if set(f.dofs) == same)
            contexts.append(frf_context(
                background, fixed, companions, place, data.input_dof, data.response_dofs, data.omega, data.force,
                data.level_index, data.x, reference, self.chi2_scale, self.penalty,
            ))
        return sorted(contexts, key=lambda c: -c.localisation.explained)
