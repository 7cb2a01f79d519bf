"""A modal table as evidence: predict, measure the gap, set up candidate fits.

The "simulation" of a model against a modal table is the single-mode phase-resonance
solution of :mod:`nlupdate.core.discovery.backbone_fit` at every (force level, mode). The gap uses
the same FRAC as for FRFs, on the single-mode receptances
``1/(ω_x² − ω² + 2iζ_x ω_x ω)`` that the measured and the modelled (f, ζ) describe, over
``f̃·(1 ± max(10ζ̃, 0.02))`` (201 points) per mode. Candidate places are the model's
coordinates (to ground), tried in the order of how much the tested modes move there.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.discovery.candidates import FoundEffect, augment
from nlupdate.core.discovery.gap import GapReport, level_gap
from nlupdate.core.discovery.joint import ModalJoint
from nlupdate.core.discovery.modal_data import ModalData, as_modal
from nlupdate.core.discovery.backbone_fit import ModalContext, element_terms, modal_context, phase_resonance
from nlupdate.core.model.system import NonlinearSystem

_BAND_POINTS = 201


@dataclass(frozen=True, eq=False)
class ModalPrediction:
    """Natural frequency (Hz) and damping ratio of the model at every (level, mode) point."""

    frequency_hz: NDArray[np.float64]
    damping_ratio: NDArray[np.float64]


def single_mode_frf(frequency_hz: NDArray, natural_hz: float, zeta: float) -> NDArray[np.complex128]:
    """``1/(ω_x² − ω² + 2iζω_xω)`` (unit modal mass) at ``frequency_hz``."""
    w, wx = 2 * np.pi * frequency_hz, 2 * np.pi * natural_hz
    return 1.0 / (wx**2 - w**2 + 2j * zeta * wx * w)


@dataclass(frozen=True, eq=False)
class ModalEvidence:
    """Modal table with the uncertainties and criterion used to judge candidates."""

    data: ModalData
    frequency_uncertainty: float
    damping_uncertainty: float
    penalty: float

    kind = "modal"

    @property
    def n_data(self) -> int:
        return 2 * self.data.n_points

    def predict(self, system: NonlinearSystem) -> ModalPrediction:
        data = self.data
        modal = as_modal(system.model)
        terms = element_terms(modal, data.mode, system.elements)
        w, zeta, _ = phase_resonance(modal, data.mode, data.input_dof, data.force, terms)
        return ModalPrediction(w / (2 * np.pi), zeta)

    def misfit_per_point(self, prediction: ModalPrediction) -> NDArray[np.float64]:
        data = self.data
        r_f = (prediction.frequency_hz - data.frequency_hz) / (self.frequency_uncertainty * data.frequency_hz)
        r_z = (prediction.damping_ratio - data.damping_ratio) / (self.damping_uncertainty * data.damping_ratio)
        return np.nan_to_num(r_f**2 + r_z**2, nan=1e12)

    def chi2(self, prediction: ModalPrediction) -> float:
        return float(np.sum(self.misfit_per_point(prediction)))

    def gap(self, prediction: ModalPrediction) -> GapReport:
        data = self.data
        levels = []
        for k, level in enumerate(data.levels):
            points = np.flatnonzero(data.level_index == k)
            f, measured, model = [], [], []
            for p in points:
                half = max(10 * data.damping_ratio[p], 0.02)
                band = data.frequency_hz[p] * np.linspace(1 - half, 1 + half, _BAND_POINTS)
                f.append(band)
                measured.append(single_mode_frf(band, data.frequency_hz[p], data.damping_ratio[p]))
                model.append(single_mode_frf(band, prediction.frequency_hz[p], prediction.damping_ratio[p]))
            f_all = np.concatenate(f)
            order = np.argsort(f_all, kind="stable")
            levels.append(level_gap(
                level, f_all[order], np.concatenate(measured)[order, None], np.concatenate(model)[order, None], 0,
            ))
        return GapReport(tuple(levels))

    def bands(self, system: NonlinearSystem, prediction: ModalPrediction) -> list[tuple[float, float]]:
        misfit = self.misfit_per_point(prediction)
        modal = as_modal(system.model)
        total = float(misfit.sum()) or 1.0
        return [
            (float(modal.natural_frequencies_hz[m]), float(misfit[self.data.mode == m].sum() / total))
            for m in np.unique(self.data.mode)
        ]

    def context(
        self, place: tuple[int, ...], system: NonlinearSystem, found: Sequence[FoundEffect], prediction: ModalPrediction,
        current_misfit: float | None = None,
    ) -> ModalContext:
        """The fitting context of one place (user's elements there fixed, effects found there
        the companions, everything else the background)."""
        data = self.data
        same = set(place)
        fixed = tuple(e for e in system.elements if set(e.dofs) == same)
        others = NonlinearSystem(system.model, tuple(e for e in system.elements if set(e.dofs) != same))
        background = augment(others, [f for f in found if set(f.dofs) != same])
        return modal_context(
            as_modal(background.model), background.elements, fixed,
            tuple(f for f in found if set(f.dofs) == same), place, data.input_dof, data.force, data.mode,
            data.frequency_hz, data.damping_ratio, data.level_index, self.frequency_uncertainty,
            self.damping_uncertainty, self.penalty,
        )

    def contexts(
        self, system: NonlinearSystem, found: Sequence[FoundEffect], prediction: ModalPrediction
    ) -> list[ModalContext]:
        """One context per model coordinate where the tested modes move, most motion first."""
        shapes = as_modal(system.model).mode_shapes[:, np.unique(self.data.mode)]
        motion = np.max(np.abs(shapes), axis=1)
        places = [(int(d),) for d in np.argsort(-motion, kind="stable") if motion[d] > 1e-12 * motion.max()]
        return [self.context(place, system, found, prediction) for place in places]

    def joint(self, system: NonlinearSystem, prediction: ModalPrediction) -> ModalJoint:
        """Every effect at once in the single-mode model (see :mod:`nlupdate.core.discovery.joint`)."""
        data = self.data
        return ModalJoint(as_modal(system.model), data.mode, data.input_dof, data.force, data.frequency_hz,
                          data.damping_ratio, tuple(system.elements), self.frequency_uncertainty,
                          self.damping_uncertainty, self.penalty)
