"""The numerics: the science of the project, as pure functions and frozen dataclasses.

``model`` (linear models and nonlinear elements), ``response`` (describing functions,
multi-harmonic balance, continuation, time integration), ``measurement`` (reading test data
into FRF tables), ``identification`` (PRD/DDF, modal and amplitude-dependent models),
``updating`` (inverse eigensensitivity, bounded optimisation), ``prediction``,
``correlation``, ``validation`` (held-out levels) and ``discovery``.

Nothing here imports Prefect, the orchestration, the app layer or ``matplotlib.pyplot``
(tests/test_layering.py checks it); the FE adapters (:mod:`nlupdate.fe`) sit beside it.
"""
