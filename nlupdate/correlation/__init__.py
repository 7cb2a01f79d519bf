"""How well a model matches measurements (METHODS §7).

* :mod:`~nlupdate.correlation.metrics` — FRAC, MAC, natural-frequency and peak errors.
"""
