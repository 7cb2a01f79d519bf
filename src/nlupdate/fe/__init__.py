"""Finite-element models: the built-in frame models (:mod:`nlupdate.fe.models`) and the
adapters that run FE codes behind one interface (:mod:`nlupdate.fe.adapters`).

Same layer as :mod:`nlupdate.core`: pure functions and external solver runs, no
orchestration.
"""
