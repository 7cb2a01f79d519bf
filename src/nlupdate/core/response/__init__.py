"""Nonlinear frequency responses of a model (docs/methods.md §3).

* :mod:`~nlupdate.core.response.balance` — what the solvers need from a balance problem (the protocol);
* :mod:`~nlupdate.core.response.continuation` — Newton + pseudo-arclength continuation, with its
  options (:mod:`~nlupdate.core.response.continuation_options`), its predictor–corrector steps
  (:mod:`~nlupdate.core.response.continuation_steps`),
  :mod:`~nlupdate.core.response.arclength` (corrections and tangents of many points at once),
  :mod:`~nlupdate.core.response.curve_fill` (the points between long continuation steps, all at
  once) and :mod:`~nlupdate.core.response.folds` (turning points located all at once);
* :mod:`~nlupdate.core.response.sweep` — a stepped-sine test on a grid by the fastest exact route;
* :mod:`~nlupdate.core.response.closed_form` — every root at once where the elements allow (cubic springs);
* :mod:`~nlupdate.core.response.stepped_sine` — a stepped-sine test read off a traced curve;
* :mod:`~nlupdate.core.response.harmonic_balance` — the multi-harmonic balance, with
  :mod:`~nlupdate.core.response.aft` (element forces over a period) and
  :mod:`~nlupdate.core.response.hill` (Floquet multipliers);
* :mod:`~nlupdate.core.response.fixed_point` — the source's relaxed fixed-point iteration;
* :mod:`~nlupdate.core.response.time_integration` — the time-domain reference (its operators and
  step bound in :mod:`~nlupdate.core.response.time_operators`, its stepping loop in
  :mod:`~nlupdate.core.response.time_stepping`);
* :mod:`~nlupdate.core.response.simulate` — responses at several force levels as a measured-FRF table.
* :mod:`~nlupdate.core.response.steady_state` — the canonical entry point: one force vector's
  steady-state response read as a stepped sine or as the stable solution nearest to measurements.
"""
