"""Stepped-sine FRFs as evidence: simulate, measure the gap, localise, set up candidate fits.

Candidate places are the measured coordinates (element to ground) and every pair of them
(element between them): the measured response amplitudes and relative displacements are
what a candidate's describing function is fitted against.

Misfit. Every measured value k has a relative noise std σ_k (the table's stated
uncertainty, else the one noise fraction of the evidence); its residual is
``(H_model − H̃)/|H̃|`` scaled by ``√2/σ_k`` (real and imaginary parts each carry σ_k/√2),
so ``χ² = Σ 2|r_k|²/σ_k²`` and a model right up to noise has ``χ² ≈ n`` (n real values).
A point the model cannot solve counts as a 100 % error of every value there.
"""
from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations
from typing import Sequence

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.discovery.candidates import FoundEffect, augment
from nlupdate.core.discovery.frf_data import FRFData
from nlupdate.core.discovery.frf_fit import FRFContext, frf_context
from nlupdate.core.discovery.gap import GapReport, level_gap
from nlupdate.core.discovery.joint import FRFJoint
from nlupdate.core.discovery.localisation import band_shares
from nlupdate.core.discovery.simulation import simulate_nearest
from nlupdate.core.model.linear import LumpedModel, ModalModel
from nlupdate.core.model.system import NonlinearSystem
from nlupdate.core.response.harmonic_balance import HarmonicSettings

_OTHER_BRANCH = 1e-3  # relative difference between two solutions that makes them different branches


@dataclass(frozen=True, eq=False)
class Prediction:
    """Model amplitudes (m) at the measured points, at ``dofs`` (columns of ``x``): the
    solution nearest the measurement (``x``) and the stated sweep's reading (``x_sweep``, None
    when the direction is unknown)."""

    dofs: tuple[int, ...]
    x: NDArray[np.complex128]
    x_sweep: NDArray[np.complex128] | None = None

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
    """Measured FRFs with the noise level and settings used to judge candidates.

    noise_fraction: the one relative noise std reported (σ, gap noise level σ²);
    value_noise: relative noise std per measured value (n, m) — σ everywhere unless the
    data state their own; sweep: the stated sweep direction ("up", "down", "unknown");
    ``harmonic_balance``: how the model is simulated (None: describing function).
    """

    data: FRFData
    noise_fraction: float
    sweep: str
    penalty: float
    harmonic_balance: HarmonicSettings | None = None
    value_noise: NDArray[np.float64] | None = None

    kind = "frf"

    @property
    def n_data(self) -> int:
        return 2 * self.data.h.size

    @property
    def chi2_scale(self) -> NDArray[np.float64]:
        """``2/σ_k²`` per measured value (n, m)."""
        sigma = self.value_noise if self.value_noise is not None else np.full(self.data.h.shape, self.noise_fraction)
        return 2.0 / sigma**2

    def predict(self, system: NonlinearSystem) -> Prediction:
        data = self.data
        dofs = tuple(dict.fromkeys(data.response_dofs + system.nonlinear_dofs))
        simulated = simulate_nearest(
            system, data.input_dof, data.force, data.omega, dofs, data.x, list(range(len(data.response_dofs))),
            np.sqrt(self.chi2_scale) / np.abs(data.x), self.sweep, self.harmonic_balance,
        )
        return Prediction(dofs, simulated.x, simulated.x_sweep)

    def h_model(self, prediction: Prediction) -> NDArray[np.complex128]:
        return np.column_stack([prediction.at(d) for d in self.data.response_dofs]) / self.data.force[:, None]

    def other_branch(self, prediction: Prediction) -> NDArray[np.bool_]:
        """Points where the solution nearest the measurement is not the stated sweep's."""
        if prediction.x_sweep is None:
            return np.zeros(self.data.force.size, bool)
        columns = [prediction.dofs.index(d) for d in self.data.response_dofs]
        nearest, swept = prediction.x[:, columns], prediction.x_sweep[:, columns]
        with np.errstate(invalid="ignore"):
            differ = np.linalg.norm(nearest - swept, axis=1) > _OTHER_BRANCH * np.linalg.norm(nearest, axis=1)
        return differ & np.all(np.isfinite(nearest), axis=1) & np.all(np.isfinite(swept), axis=1)

    def residuals(self, prediction: Prediction) -> NDArray[np.complex128]:
        """Complex relative residuals ``(H_model − H̃)/|H̃|`` (n, m); 1 where unsolved."""
        r = (self.h_model(prediction) - self.data.h) / np.abs(self.data.h)
        return np.where(np.isfinite(r), r, 1.0)

    def misfit_per_point(self, prediction: Prediction) -> NDArray[np.float64]:
        """χ² contribution of every point; a point the model cannot reach counts as a 100 % error."""
        return np.sum(self.chi2_scale * np.abs(self.residuals(prediction)) ** 2, axis=1)

    def chi2(self, prediction: Prediction) -> float:
        return float(np.sum(self.misfit_per_point(prediction)))

    def gap(self, prediction: Prediction) -> GapReport:
        data = self.data
        h_model = self.h_model(prediction)
        other = self.other_branch(prediction)
        reference = data.response_dofs.index(data.input_dof) if data.input_dof in data.response_dofs else 0
        levels = []
        for k, level in enumerate(data.levels):
            mask = data.level_index == k
            levels.append(level_gap(level, data.frequency_hz[mask], data.h[mask], h_model[mask], reference, other[mask]))
        return GapReport(tuple(levels))

    def bands(self, system: NonlinearSystem, prediction: Prediction) -> list[tuple[float, float]]:
        return band_shares(self.data.omega, self.misfit_per_point(prediction), natural_omega(system))

    def places(self) -> list[tuple[int, ...]]:
        measured = sorted(self.data.response_dofs)
        return [(d,) for d in measured] + list(combinations(measured, 2))

    def context(
        self, place: tuple[int, ...], system: NonlinearSystem, found: Sequence[FoundEffect], prediction: Prediction,
        current_misfit: float | None = None,
    ) -> FRFContext:
        """The fitting context of one place: the user's elements there are fixed, the effects
        found there are the companions, everything else is the frozen background."""
        data = self.data
        measured = {dof: data.x[:, k] for k, dof in enumerate(data.response_dofs)}

        def reference(dof: int) -> NDArray:
            return measured[dof] if dof in measured else prediction.at(dof)

        same = set(place)
        fixed = tuple(e for e in system.elements if set(e.dofs) == same)
        others = NonlinearSystem(system.model, tuple(e for e in system.elements if set(e.dofs) != same))
        background = augment(others, [f for f in found if set(f.dofs) != same])
        companions = tuple(f for f in found if set(f.dofs) == same)
        return frf_context(
            background, fixed, companions, place, data.input_dof, data.response_dofs, data.omega, data.force,
            data.level_index, data.x, reference, self.chi2_scale, self.penalty, current_misfit,
        )

    def contexts(
        self, system: NonlinearSystem, found: Sequence[FoundEffect], prediction: Prediction
    ) -> list[FRFContext]:
        """One fitting context per place, the place that explains most of the current misfit first."""
        current = self.chi2(prediction)
        contexts = [self.context(place, system, found, prediction, current) for place in self.places()]
        return sorted(contexts, key=lambda c: -c.localisation.explained)

    def joint(self, system: NonlinearSystem, prediction: Prediction) -> FRFJoint:
        """The joint problem of every effect at once (see :mod:`nlupdate.core.discovery.joint`)."""
        data = self.data
        return FRFJoint.build(
            system, data.input_dof, data.response_dofs, data.omega, data.force, data.x,
            {dof: prediction.at(dof) for dof in prediction.dofs}, self.chi2_scale, self.penalty,
        )
