"""The nonlinear model: a linear structure plus local nonlinear elements (docs/methods.md §1–§2).

* :mod:`~nlupdate.core.model.linear` — lumped and modal linear models, receptances ``H = Z⁻¹``;
* :mod:`~nlupdate.core.model.elements` — local elements and their describing functions;
* :mod:`~nlupdate.core.model.system` — linear model + elements + forcing, condensed harmonic balance;
* :mod:`~nlupdate.core.model.amplitude_modal` — one nonlinear mode's backbone and damping against amplitude;
* :mod:`~nlupdate.core.model.single_mode` — that mode's dynamic stiffness and receptance (the damping convention);
* :mod:`~nlupdate.core.model.model_file` — TOML model files.
"""
