"""Nonlinear frequency responses of a model (METHODS §3).

* :mod:`~nlupdate.response.continuation` — Newton + pseudo-arclength continuation;
* :mod:`~nlupdate.response.stepped_sine` — a stepped-sine test read off a traced curve;
* :mod:`~nlupdate.response.fixed_point` — the source's relaxed fixed-point iteration;
* :mod:`~nlupdate.response.time_integration` — the time-domain reference;
* :mod:`~nlupdate.response.simulate` — responses at several force levels as a measured-FRF table.
"""
