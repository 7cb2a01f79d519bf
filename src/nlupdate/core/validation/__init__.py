"""Judging a model where it was not fitted: held-out force levels (docs/methods.md §10).

:mod:`~nlupdate.core.validation.resonance` measures a curve (resonance, damping, peak),
:mod:`~nlupdate.core.validation.baseline` is the log-amplitude interpolation every physics model
must beat, :mod:`~nlupdate.core.validation.models` the models that can be held to it and
:mod:`~nlupdate.core.validation.held_out` fits on the kept levels and predicts the others.
"""
