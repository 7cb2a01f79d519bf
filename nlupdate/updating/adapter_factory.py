"""Picklable adapter descriptions, so updating runs can be shipped to worker processes.

An :class:`AdapterSpec` names the adapter kind, the model and its constructor options;
:func:`build_adapter` turns it into a fresh :class:`~nlupdate.adapters.base.FEAdapter`
inside whichever process runs the task. Kinds:

``lumped``
    :class:`nlupdate.adapters.lumped.LumpedAdapter`; options ``masses`` (kg) and
    ``stiffnesses`` (N/m), lists.
``surrogate``
    :class:`nlupdate.adapters.surrogate.SurrogateAdapter` with ``model`` ``tbeam`` or
    ``gunbarrel``; options are its keyword arguments (``n_modes``, ``mesh_options``,
    ``global_modes_only``, ``coordinates``, ``parameter_names``) and
    ``base_parameters``, a table of fields of the model's parameter dataclass.
``calculix``
    :class:`nlupdate.adapters.calculix.CalculixAdapter` with ``model = "tbeam"`` (the
    solid T-beam deck of :mod:`nlupdate.adapters.calculix_tbeam`); options ``mesh``
    (a table of :class:`~nlupdate.adapters.calculix_tbeam.TBeamMesh` counts),
    ``element_type`` and the adapter's keyword arguments (``n_modes``, ``executable``,
    ``threads``, ``timeout_s``, ``work_root``). CalculiX returns all modes, including
    the local modes of the thin beams: pair with ``nearest`` or list ``model_modes``.
``mapdl``
    :class:`nlupdate.adapters.mapdl.MapdlAdapter`; options ``deck`` (path of the
    parametric APDL deck), ``parameter_names`` (list), ``coordinates``
    (``{name = [node, "ux"|"uy"|"uz"]}``; node: a node number, an APDL expression in
    the deck's units, or ``[x, y, z]`` in metres) and the adapter's keyword arguments
    (``n_modes``, ``executable``, ``n_processors``, ``timeout_s``, ``apdl_names``,
    ``units`` = ``"SI"`` | ``"mm-t-s"`` | ``"mm-kg-s"`` (the deck's units; results come
    back in SI), ``location_tolerance_m``, ``min_frequency_hz``, ``keep_files``, …).
"""
from __future__ import annotations

import importlib
import json
from dataclasses import dataclass, field
from typing import Any, Mapping

from nlupdate.adapters.base import FEAdapter
from nlupdate.input_files import read_input_text

ADAPTER_KINDS = ("lumped", "surrogate", "calculix", "mapdl")


@dataclass(frozen=True)
class AdapterSpec:
    """kind: one of :data:`ADAPTER_KINDS`; model: model name where the kind needs one;
    options: constructor options."""

    kind: str
    model: str | None = None
    options: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.kind not in ADAPTER_KINDS:
            raise ValueError(f"unknown adapter kind {self.kind!r}; expected one of {list(ADAPTER_KINDS)}")

    def identity(self) -> str:
        """Canonical JSON text of the spec: equal specs give equal text (dict order ignored).

        It names the *description*; the model itself (a deck file's content, a mesh) is
        fingerprinted by the built adapter's ``model_fingerprint()``."""
        return json.dumps({"kind": self.kind, "model": self.model, "options": self.options}, sort_keys=True, default=repr)


def _module(name: str, kind: str):
    try:
        return importlib.import_module(name)
    except ModuleNotFoundError as error:
        raise ValueError(f"adapter kind {kind!r} is not available: {error}") from error


def build_adapter(spec: AdapterSpec) -> FEAdapter:
    """A new adapter for ``spec`` (built in whichever process calls this)."""
    options = dict(spec.options)
    if spec.kind == "lumped":
        from nlupdate.adapters.lumped import LumpedAdapter

        try:
            return LumpedAdapter(options.pop("masses"), options.pop("stiffnesses"), **options)
        except KeyError as error:
            raise ValueError(f"lumped adapter: missing option {error.args[0]!r} (list of masses in kg / stiffnesses in N/m)") from None
        except TypeError as error:
            raise ValueError(f"lumped adapter: {error}") from None
    if spec.kind == "surrogate":
        module = _module("nlupdate.adapters.surrogate", spec.kind)
        if spec.model not in module.MODELS:
            raise ValueError(f"surrogate adapter: model must be one of {sorted(module.MODELS)}, got {spec.model!r}")
        base = options.pop("base_parameters", None)
        try:
            if base is not None:
                base = module.MODELS[spec.model].parameter_class(**base)
            return module.SurrogateAdapter(spec.model, base, **options)
        except TypeError as error:
            raise ValueError(f"surrogate adapter: {error}") from None
    if spec.kind == "mapdl":
        module = _module("nlupdate.adapters.mapdl", spec.kind)
        try:
            deck = read_input_text(options.pop("deck"), "MAPDL deck")
            names = options.pop("parameter_names")
            coordinates = {name: tuple(value) for name, value in options.pop("coordinates").items()}
        except KeyError as error:
            raise ValueError(f"mapdl adapter: missing option {error.args[0]!r} (deck, parameter_names, coordinates)") from None
        try:
            return module.MapdlAdapter(deck, names, coordinates, **options)
        except TypeError as error:
            raise ValueError(f"mapdl adapter: {error}") from None
    if spec.model != "tbeam":
        raise ValueError(f"calculix adapter: model must be 'tbeam', got {spec.model!r}")
    calculix = _module("nlupdate.adapters.calculix", spec.kind)
    tbeam = _module("nlupdate.adapters.calculix_tbeam", spec.kind)
    mesh = tbeam.TBeamMesh(**options.pop("mesh", {}))
    deck_options = {k: options.pop(k) for k in ("element_type", "stations") if k in options}
    deck = tbeam.TBeamDeck(mesh, **deck_options)
    try:
        return calculix.CalculixAdapter(deck, tbeam.TBEAM_PARAMETER_NAMES, **options)
    except TypeError as error:
        raise ValueError(f"calculix adapter: {error}") from None
