"""Discovery: which effect a model is missing, where, with which parameters — and the proof.

Given a model and measurements at several force levels (stepped-sine FRFs or a modal
table), :func:`discover` measures the gap, localises it, fits every effect of an open
library there, picks one by an information criterion (or answers ``none``), adds it and
shows the gap shrink, and repeats. See :mod:`nlupdate.core.discovery.workflow`.

Modules: ``effects`` (the library), ``workflow`` (the loop and its restarts), ``search`` (one
greedy search), ``reconsider`` (joint refit and reconsideration), ``options``, ``result``, ``gap``, ``localisation``,
``frf_data`` / ``frf_evidence`` / ``frf_fit`` (stepped-sine FRFs), ``modal_data`` /
``modal_evidence`` / ``modal_fit`` (modal tables), ``candidates`` (criterion and
significance), ``fitting`` and ``starts`` (least squares from variable-projection starts),
``joint`` (every effect refitted together), ``equivalence`` (degenerate candidates give way
to simpler effects), ``linear_edits``, ``simulation`` (nearest stable solution per point),
``report`` and ``plots`` (output folder), ``errors``. The hidden-effect test cases live in
``benchmarks/discovery_cases.py``.
"""
from nlupdate.core.discovery.candidates import CandidateFit, FoundEffect
from nlupdate.core.discovery.effects import EFFECT_NAMES, LIBRARY, DFSamples, Effect, ElementEffect, LinearEffect, EffectParameter
from nlupdate.core.discovery.errors import DiscoveryError, MeasuredDataError, ModelSolveError
from nlupdate.core.discovery.workflow import DiscoveryOptions, DiscoveryResult, discover, fit_candidate

__all__ = [
    "CandidateFit", "DFSamples", "DiscoveryError", "DiscoveryOptions", "DiscoveryResult", "EFFECT_NAMES", "Effect",
    "ElementEffect", "FoundEffect", "LIBRARY", "LinearEffect", "MeasuredDataError", "ModelSolveError", "EffectParameter",
    "discover", "fit_candidate",
]
