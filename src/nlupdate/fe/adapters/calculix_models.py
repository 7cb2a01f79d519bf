"""The CalculiX models a study's ``[adapter] kind = "calculix"`` names: ``model = "tbeam"`` (the
solid T-beam, :mod:`nlupdate.fe.adapters.calculix_tbeam`) or ``"brb"`` (the Brake–Reuss beam
reduced at its bolts, :mod:`nlupdate.fe.adapters.calculix_brb`)."""
from __future__ import annotations

from nlupdate.fe.adapters import calculix_brb, calculix_tbeam
from nlupdate.fe.adapters.base import FEAdapter


def from_options(model: str | None, options: dict) -> FEAdapter:
    """The adapter of ``model`` built from the study's ``[adapter.options]``."""
    if model == "brb":
        return calculix_brb.from_options(options)
    if model == "tbeam":
        return calculix_tbeam.from_options(model, options)
    raise ValueError(f"calculix adapter: model must be 'tbeam' or 'brb', got {model!r}")
