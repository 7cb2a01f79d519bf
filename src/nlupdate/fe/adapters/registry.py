"""The adapter registry: which FE code a study's ``[adapter]`` names, built anywhere.

An :class:`AdapterSpec` — kind, model name, constructor options — is a plain, picklable
description, so updating runs can be shipped to worker processes; :func:`build_adapter`
turns it into a fresh :class:`~nlupdate.fe.adapters.base.FEAdapter` in whichever process
runs the work, through the ``from_options(model, options)`` function of the kind's module
(:data:`ADAPTERS`). A new FE code is one module with a ``from_options`` and one entry here.

Kinds and their options:

``lumped``
    :class:`nlupdate.fe.adapters.lumped.LumpedAdapter`; options ``masses`` (kg) and
    ``stiffnesses`` (N/m), lists.
``surrogate``
    :class:`nlupdate.fe.adapters.surrogate.SurrogateAdapter` with ``model`` ``tbeam`` or
    ``gunbarrel``; options are its keyword arguments (``n_modes``, ``mesh_options``,
    ``global_modes_only``, ``coordinates``, ``parameter_names``) and
    ``base_parameters``, a table of fields of the model's parameter dataclass.
``calculix``
    :class:`nlupdate.fe.adapters.calculix.CalculixAdapter` with ``model = "tbeam"`` (the
    solid T-beam deck of :mod:`nlupdate.fe.adapters.calculix_tbeam`); options ``mesh``
    (a table of :class:`~nlupdate.fe.adapters.calculix_tbeam.TBeamMesh` counts),
    ``element_type`` and the adapter's keyword arguments (``n_modes``, ``executable``,
    ``threads``, ``timeout_s``, ``work_root``). CalculiX returns all modes, including
    the local modes of the thin beams: pair with ``nearest`` or list ``model_modes``.
    ``model = "brb"``: the Brake–Reuss beam reduced exactly at its bolts
    (:mod:`nlupdate.fe.adapters.calculix_brb`; options ``mesh``, ``n_modes``,
    ``fixed_interface_modes`` and the run options).
``mapdl``
    :class:`nlupdate.fe.adapters.mapdl.MapdlAdapter`; options ``deck`` (path of the
    parametric APDL deck), ``parameter_names`` (list), ``coordinates``
    (``{name = [node, "ux"|"uy"|"uz"]}``; node: a node number, an APDL expression in
    the deck's units, or ``[x, y, z]`` in metres) and the adapter's keyword arguments
    (``n_modes``, ``executable``, ``n_processors``, ``timeout_s``, ``apdl_names``,
    ``units`` = ``"SI"`` | ``"mm-t-s"`` | ``"mm-kg-s"`` (the deck's units; results come
    back in SI), ``location_tolerance_m``, ``min_frequency_hz``, ``keep_files``, …).
"""
from __future__ import annotations

import importlib
from dataclasses import dataclass, field
from typing import Any, Mapping

from nlupdate.fe.adapters.base import FEAdapter
from nlupdate.fingerprints import fingerprint

#: Kind → module whose ``from_options(model, options)`` builds its adapter.
ADAPTERS: dict[str, str] = {
    "lumped": "nlupdate.fe.adapters.lumped",
    "surrogate": "nlupdate.fe.adapters.surrogate",
    "calculix": "nlupdate.fe.adapters.calculix_models",
    "mapdl": "nlupdate.fe.adapters.mapdl",
}
ADAPTER_KINDS = tuple(ADAPTERS)


@dataclass(frozen=True)
class AdapterSpec:
    """kind: one of :data:`ADAPTER_KINDS`; model: model name where the kind needs one;
    options: constructor options."""

    kind: str
    model: str | None = None
    options: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.kind not in ADAPTERS:
            raise ValueError(f"unknown adapter kind {self.kind!r}; expected one of {list(ADAPTER_KINDS)}")

    def identity(self) -> str:
        """Fingerprint of the description: equal specs, equal identity (option order
        ignored). The model itself (a deck file's content, a mesh) is fingerprinted by the
        built adapter's ``model_fingerprint()``."""
        return fingerprint(self.kind, self.model, self.options)


def build_adapter(spec: AdapterSpec) -> FEAdapter:
    """A new adapter for ``spec`` (built in whichever process calls this); ``ValueError``
    naming the kind for options its adapter does not take."""
    try:
        module = importlib.import_module(ADAPTERS[spec.kind])
    except ModuleNotFoundError as error:
        raise ValueError(f"adapter kind {spec.kind!r} is not available: {error}") from error
    return module.from_options(spec.model, dict(spec.options))
