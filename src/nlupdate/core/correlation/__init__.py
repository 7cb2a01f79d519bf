"""How well a model matches measurements (docs/methods.md §7).

* :mod:`~nlupdate.core.correlation.metrics` — FRAC, MAC, natural-frequency and peak errors.
"""
