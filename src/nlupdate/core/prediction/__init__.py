"""The updated nonlinear model and what it predicts at every force level (docs/methods.md §6).

* :mod:`~nlupdate.core.prediction.predict` — updated linear model + identified elements,
  its damping from the low-force test, and the predicted FRFs.
"""
