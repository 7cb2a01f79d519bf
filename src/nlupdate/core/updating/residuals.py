"""The response vector that updating drives towards its targets.

For paired modes i = 1…n (see :mod:`nlupdate.core.updating.pairing`) the response is

* ``f_i^model / f_i^target`` (target value 1), and, with ``use_mode_shapes``,
* ``MSF_i φ_i^model / ‖φ_i^meas‖`` at the measured coordinates, with the modal scale
  factor ``MSF_i = φ_i^measᵀ φ_i^model / φ_i^modelᵀ φ_i^model`` (target
  ``φ_i^meas / ‖φ_i^meas‖``); this is invariant to the sign and scaling of either shape.

Residual components are weighted by ``√w_i`` (target mode weights), mode-shape
components additionally by ``mode_shape_weight``. Frequencies are dimensionless
(relative), so modes of different frequency weigh alike.

Every model evaluation goes through a point evaluator
(:mod:`nlupdate.core.updating.evaluation`; ``fixed`` values are merged into every point), which
computes each distinct point once and decides where the FE runs happen.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from nlupdate.fe.adapters.base import ModalResult, Parameter
from nlupdate.core.correlation.metrics import mac_matrix
from nlupdate.core.updating.pairing import PAIRING_METHODS, ModePairing, model_shapes_at, pair_modes
from nlupdate.core.updating.evaluation import PointEvaluator
from nlupdate.core.updating.sensitivity import assemble_jacobian, stencil, stencil_points
from nlupdate.core.updating.targets import UpdatingTargets
from nlupdate.settings import setting


@dataclass(frozen=True)
class ResponseOptions:
    """Settings shared by every updating method: how the response and its Jacobian are formed.

    formula: finite-difference formula of the sensitivities (see
    :mod:`nlupdate.core.updating.sensitivity`); pairing, min_mac: see
    :mod:`nlupdate.core.updating.pairing`; use_mode_shapes, mode_shape_weight: see this module.
    The declared fields are the study's ``[updating]`` table (:mod:`nlupdate.settings`).
    """

    formula: str = "forward"
    pairing: str = setting(
        "order", kind="choice", choices=PAIRING_METHODS,
        meaning="target i ↔ model mode i (or `model_modes`); one-to-one by least relative frequency distance; "
                "one-to-one by largest MAC (needs `mode_shapes` at ≥ 2 coordinates)")
    min_mac: float = setting(0.0, kind="number", minimum=0, meaning='with `"mac"`: a pair below it is an error')
    use_mode_shapes: bool = setting(False, kind="boolean",
                                    meaning="add scaled mode-shape residuals to the frequency residuals")
    mode_shape_weight: float = setting(1.0, kind="number", minimum=0, meaning="weight of the mode-shape residuals")

    def __post_init__(self) -> None:
        stencil(self.formula)
        if self.pairing not in PAIRING_METHODS:
            raise ValueError(f"pairing must be one of {list(PAIRING_METHODS)}, got {self.pairing!r}")


class ModalResponse:
    """Parameter values → paired modal response, for one model (behind a point
    evaluator) and one target set."""

    def __init__(
        self,
        evaluate_points: PointEvaluator,
        parameters: Sequence[Parameter],
        targets: UpdatingTargets,
        fixed: Mapping[str, float] | None = None,
        options: ResponseOptions = ResponseOptions(),
    ) -> None:
        self.evaluate_points = evaluate_points
        self.parameters = tuple(parameters)
        self.targets = targets
        self.fixed = {k: float(v) for k, v in (fixed or {}).items()}
        overlap = set(self.fixed) & {p.name for p in self.parameters}
        if overlap:
            raise ValueError(f"parameter(s) {sorted(overlap)} are both updated and fixed")
        self.pairing_method = options.pairing
        self.min_mac = options.min_mac
        if options.use_mode_shapes and targets.mode_shapes is None:
            raise ValueError("use_mode_shapes needs measured mode shapes in the targets")
        self.use_mode_shapes = options.use_mode_shapes
        self.mode_shape_weight = float(options.mode_shape_weight)
        if self.use_mode_shapes:
            norms = np.linalg.norm(targets.mode_shapes, axis=0)
            if np.any(norms == 0):
                raise ValueError("targets: a measured mode shape is all zeros")
            self._shape_norms = norms

    # ----------------------------------------------------------------- evaluation
    def full_point(self, values: Mapping[str, float]) -> dict[str, float]:
        """The model point for updating-parameter ``values``: fixed values merged in."""
        return {**self.fixed, **{k: float(v) for k, v in values.items()}}

    def evaluate(self, values: Mapping[str, float]) -> ModalResult:
        """Model result at the updating-parameter ``values``."""
        return self.evaluate_points([self.full_point(values)])[0]

    def pair(self, result: ModalResult) -> ModePairing:
        return pair_modes(result, self.targets, self.pairing_method, self.min_mac)

    def frequencies(self, result: ModalResult, pairing: ModePairing) -> NDArray[np.float64]:
        """Paired model natural frequencies (Hz), one per target."""
        return np.asarray(result.natural_frequencies_hz, dtype=float)[list(pairing.model_indices)]

    def errors_pct(self, result: ModalResult, pairing: ModePairing) -> NDArray[np.float64]:
        """Frequency errors ``100 (f_model − f_target) / f_target`` per target mode (%)."""
        return 100.0 * (self.frequencies(result, pairing) / self.targets.frequencies_hz - 1.0)

    # ----------------------------------------------------------------- vectors
    def vector(self, result: ModalResult, pairing: ModePairing) -> NDArray[np.float64]:
        """Response vector (see the module docstring)."""
        parts = [self.frequencies(result, pairing) / self.targets.frequencies_hz]
        if self.use_mode_shapes:
            model = model_shapes_at(result, self.targets.coordinates)[:, list(pairing.model_indices)]
            measured = self.targets.mode_shapes
            msf = np.einsum("ir,ir->r", measured, model) / np.einsum("ir,ir->r", model, model)
            parts.append((model * msf / self._shape_norms).T.ravel())
        return np.concatenate(parts)

    def target_vector(self) -> NDArray[np.float64]:
        parts = [np.ones(self.targets.n_modes)]
        if self.use_mode_shapes:
            parts.append((self.targets.mode_shapes / self._shape_norms).T.ravel())
        return np.concatenate(parts)

    def weights(self) -> NDArray[np.float64]:
        """Residual weights √w (and √w·mode_shape_weight for shape components)."""
        root = np.sqrt(self.targets.weights)
        parts = [root]
        if self.use_mode_shapes:
            n_coords = len(self.targets.coordinates)
            parts.append(np.repeat(root * self.mode_shape_weight, n_coords))
        return np.concatenate(parts)

    def jacobian(self, values: Mapping[str, float], base: ModalResult, pairing: ModePairing, formula: str) -> NDArray[np.float64]:
        """``∂(response vector)/∂p`` at ``values`` (whose result is ``base``, paired by
        ``pairing``): every stencil point is handed to the evaluator in one request.

        The base pairing is kept; with ``mac`` pairing each paired base mode is followed
        to the perturbed mode of highest MAC (over all model coordinates), so a mode
        swap inside the stencil cannot corrupt the derivative.
        """
        points = stencil_points(values, self.parameters, formula)
        results = self.evaluate_points([self.full_point(point) for point in points])
        base_shapes = base.mode_shapes[:, list(pairing.model_indices)]
        responses = []
        for result in results:
            followed = pairing
            if self.pairing_method == "mac":
                mac = mac_matrix(base_shapes, result.mode_shapes)
                followed = ModePairing(tuple(int(k) for k in mac.argmax(axis=1)), pairing.mac, pairing.method)
            responses.append(self.vector(result, followed))
        return assemble_jacobian(responses, values, self.parameters, formula)
