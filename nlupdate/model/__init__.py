"""The nonlinear model: a linear structure plus local nonlinear elements (docs/methods.md §1–§2).

* :mod:`~nlupdate.model.linear` — lumped and modal linear models, receptances ``H = Z⁻¹``;
* :mod:`~nlupdate.model.elements` — local elements and their describing functions;
* :mod:`~nlupdate.model.system` — linear model + elements + forcing, condensed harmonic balance;
* :mod:`~nlupdate.model.model_file` — TOML model files.
"""
