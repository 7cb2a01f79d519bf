"""Adapter for the built-in frame-element surrogate (:mod:`nlupdate.fe.models`).

The surrogate runs in-process in milliseconds, so it is the default FE code for tests,
sensitivity studies and for trying an updating set-up before an external FE run.

Models: ``"tbeam"`` (:func:`~nlupdate.fe.models.tbeam.tbeam_model`, parameters
:class:`~nlupdate.fe.models.tbeam.TBeamParameters`) and ``"gunbarrel"``
(:func:`~nlupdate.fe.models.gunbarrel.gunbarrel_model`, :class:`~nlupdate.fe.models.gunbarrel.GunBarrelParameters`).
Updating parameters are named like the fields of the parameter dataclass (``E``,
``h1``, ``h2``, ``w1``, ``motor_stiffness``, …) in its SI units; a solve replaces those
fields of the base parameters and keeps the others.

Mode shapes are mass-normalised (1/√kg) at the measurement coordinates; each mode's
sign is fixed so that its entry at the first coordinate (the drive point) is positive,
or, if that entry is negligible (< 1e-6 of the mode's largest entry), its largest entry.
"""
from __future__ import annotations

import inspect
import time
from dataclasses import dataclass, fields, replace
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from nlupdate.fingerprints import fingerprint
from nlupdate.fe.adapters.base import FEAdapter, ModalResult
from nlupdate.fe.models.frame import FrameModel, ModalSolution
from nlupdate.fe.models.gunbarrel import GUNBARREL_COORDINATES, GunBarrelParameters, gunbarrel_model
from nlupdate.fe.models.tbeam import TBEAM_COORDINATES, TBeamParameters, global_modes, tbeam_model

#: Bump when the surrogate's element formulation or models change (invalidates caches).
SURROGATE_VERSION = "1"


@dataclass(frozen=True)
class SurrogateModel:
    """A built-in model: parameter class, builder ``(params, **mesh_options)`` and
    default measurement coordinates."""

    parameter_class: type
    builder: Callable[..., FrameModel]
    coordinates: tuple[str, ...]
    has_local_modes: bool


MODELS: dict[str, SurrogateModel] = {
    "tbeam": SurrogateModel(TBeamParameters, tbeam_model, TBEAM_COORDINATES, True),
    "gunbarrel": SurrogateModel(GunBarrelParameters, gunbarrel_model, GUNBARREL_COORDINATES, False),
}


def _sign_normalise(shapes: np.ndarray) -> np.ndarray:
    shapes = shapes.copy()
    for r in range(shapes.shape[1]):
        column = shapes[:, r]
        peak = np.max(np.abs(column))
        reference = column[0] if abs(column[0]) > 1e-6 * peak else column[np.argmax(np.abs(column))]
        if reference < 0:
            shapes[:, r] = -column
    return shapes


class SurrogateAdapter(FEAdapter):
    """FE adapter backed by the built-in frame surrogate.

    Parameters
    ----------
    model:
        ``"tbeam"`` or ``"gunbarrel"``.
    base_parameters:
        Parameter dataclass instance of that model (default: its defaults).
    coordinates:
        Measurement coordinates ``"<node label>:<dof>"`` (default: the model's list,
        drive point first).
    n_modes:
        Number of modes returned.
    mesh_options:
        Keyword arguments of the builder, e.g. ``{"elements_per_beam": 24,
        "theory": "timoshenko", "joint": "patch"}`` for the T-beam or
        ``{"elements": 48}`` for the gun barrel.
    global_modes_only:
        T-beam only: return the lowest ``n_modes`` global modes (beam 1 bending),
        skipping local modes of the thin beams.
    parameter_names:
        Updating parameters accepted by :meth:`evaluate` (default: every field of the
        parameter dataclass).
    """

    name = "surrogate"

    def __init__(
        self,
        model: str,
        base_parameters: Any | None = None,
        coordinates: Sequence[str] | None = None,
        n_modes: int = 3,
        mesh_options: Mapping[str, Any] | None = None,
        global_modes_only: bool = False,
        parameter_names: Sequence[str] | None = None,
    ) -> None:
        if model not in MODELS:
            raise ValueError(f"SurrogateAdapter: model must be one of {sorted(MODELS)}, got {model!r}")
        spec = MODELS[model]
        base = spec.parameter_class() if base_parameters is None else base_parameters
        if not isinstance(base, spec.parameter_class):
            raise ValueError(
                f"SurrogateAdapter: base_parameters for {model!r} must be a {spec.parameter_class.__name__}, "
                f"got {type(base).__name__}"
            )
        field_names = tuple(f.name for f in fields(base))
        names = field_names if parameter_names is None else tuple(parameter_names)
        unknown = [n for n in names if n not in field_names]
        if unknown:
            raise ValueError(
                f"SurrogateAdapter: parameter_names {unknown} are not fields of {type(base).__name__} {list(field_names)}"
            )
        if int(n_modes) != n_modes or n_modes < 1:
            raise ValueError(f"SurrogateAdapter: n_modes must be a positive integer, got {n_modes!r}")
        if global_modes_only and not spec.has_local_modes:
            raise ValueError(f"SurrogateAdapter: global_modes_only applies to the T-beam only, not to {model!r}")
        super().__init__(names)
        self.model_name = model
        self.spec = spec
        self.base_parameters = base
        self.coordinates = tuple(spec.coordinates if coordinates is None else coordinates)
        self.n_modes = int(n_modes)
        self.mesh_options = dict(mesh_options or {})
        self.global_modes_only = bool(global_modes_only)
        try:
            inspect.signature(spec.builder).bind(base, **self.mesh_options)
        except TypeError as error:
            raise ValueError(
                f"SurrogateAdapter: bad mesh_options {self.mesh_options} for {model!r} "
                f"({spec.builder.__name__}{inspect.signature(spec.builder)}): {error}"
            ) from error
        # Build once: checks the mesh options and the coordinate names early.
        probe = self._build(base)
        for coordinate in self.coordinates:
            probe.coordinate_index(coordinate)

    def _build(self, params: Any) -> FrameModel:
        return self.spec.builder(params, **self.mesh_options)

    def model_fingerprint(self) -> str:
        return fingerprint({
            "version": SURROGATE_VERSION, "model": self.model_name, "base": self.base_parameters,
            "coordinates": self.coordinates, "n_modes": self.n_modes, "mesh_options": self.mesh_options,
            "global_modes_only": self.global_modes_only,
        }, length=16)

    def solver_version(self) -> str:
        return f"nlupdate frame surrogate {SURROGATE_VERSION}"

    def parameters_for(self, parameters: Mapping[str, float]) -> Any:
        """The base parameter dataclass with the named fields replaced."""
        return replace(self.base_parameters, **{k: float(v) for k, v in parameters.items()})

    def check_values(self, parameters: Mapping[str, float]) -> None:
        self.parameters_for(self._check(parameters))  # the parameter class checks its ranges

    def _solve(self, parameters: Mapping[str, float]) -> ModalResult:
        start = time.perf_counter()
        model = self._build(self.parameters_for(parameters))
        solution: ModalSolution
        if self.global_modes_only:
            solution, _ = global_modes(model, self.n_modes)
        else:
            solution = model.modal(self.n_modes)
        shapes = _sign_normalise(model.shapes_at(solution.shapes, self.coordinates))
        return ModalResult(
            natural_frequencies_hz=np.asarray(solution.frequencies_hz, dtype=float),
            mode_shapes=shapes,
            coordinates=self.coordinates,
            metadata={
                "solver": "surrogate",
                "model": self.model_name,
                "mesh_size": model.n_elements,
                "dofs": len(model.transformation()[1]),
                "wall_time_s": time.perf_counter() - start,
                "log_path": None,
                "global_modes_only": self.global_modes_only,
            },
        )


def from_options(model: str | None, options: dict) -> SurrogateAdapter:
    """The adapter of a study's ``[adapter] kind = "surrogate"`` (:mod:`nlupdate.fe.adapters.registry`)."""
    if model not in MODELS:
        raise ValueError(f"surrogate adapter: model must be one of {sorted(MODELS)}, got {model!r}")
    base = options.pop("base_parameters", None)
    try:
        if base is not None:
            base = MODELS[model].parameter_class(**base)
        return SurrogateAdapter(model, base, **options)
    except TypeError as error:
        raise ValueError(f"surrogate adapter: {error}") from None


__all__ = ["MODELS", "SURROGATE_VERSION", "SurrogateAdapter", "SurrogateModel", "from_options"]
