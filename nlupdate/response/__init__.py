"""Nonlinear frequency responses of a model (docs/methods.md §3).

* :mod:`~nlupdate.response.balance` — what the solvers need from a balance problem (the protocol);
* :mod:`~nlupdate.response.continuation` — Newton + pseudo-arclength continuation, its options,
  with :mod:`~nlupdate.response.arclength` (corrections and tangents of many points at once),
  :mod:`~nlupdate.response.curve_fill` (the points between long continuation steps, all at
  once) and :mod:`~nlupdate.response.folds` (turning points located all at once);
* :mod:`~nlupdate.response.sweep` — a stepped-sine test on a grid by the fastest exact route;
* :mod:`~nlupdate.response.closed_form` — every root at once where the elements allow (cubic springs);
* :mod:`~nlupdate.response.stepped_sine` — a stepped-sine test read off a traced curve;
* :mod:`~nlupdate.response.harmonic_balance` — the multi-harmonic balance, with
  :mod:`~nlupdate.response.aft` (element forces over a period) and
  :mod:`~nlupdate.response.hill` (Floquet multipliers);
* :mod:`~nlupdate.response.fixed_point` — the source's relaxed fixed-point iteration;
* :mod:`~nlupdate.response.time_integration` — the time-domain reference;
* :mod:`~nlupdate.response.simulate` — responses at several force levels as a measured-FRF table.
"""
