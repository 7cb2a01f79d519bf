"""Identification of local nonlinearities and extraction of linear FRFs (docs/methods.md §4–§5, §7).

Modules
-------
* :mod:`~nlupdate.identification.data` — measured curves per force level (:class:`FRFLevels`).
* :mod:`~nlupdate.identification.dfmodels` — describing-function models: the source's PRD
  polynomial and named physical elements (cubic, Jenkins, Coulomb, quadratic damping, gap).
* :mod:`~nlupdate.identification.prd` — PRD at one coordinate: the source's naive least
  squares and the improved joint output-error estimator; linear-FRF extraction.
* :mod:`~nlupdate.identification.ddf` — DDF method for comparison.
* :mod:`~nlupdate.identification.frequency` — choice of the excitation frequency.
* :mod:`~nlupdate.identification.uncertainty` — Monte-Carlo statistics over the noise model.
* :mod:`~nlupdate.identification.trust` — warnings about results not to be trusted
  (parameters on a bound or not determined by the data, a residual far above the noise).
* :mod:`~nlupdate.identification.scalar_balance` — scalar harmonic balance (amplitude roots).
* :mod:`~nlupdate.identification.regenerate` — nonlinear FRFs on extracted linear FRFs.
* :mod:`~nlupdate.identification.linear_frf` — the linear FRF from every level (or the low one) and its modes.
* :mod:`~nlupdate.identification.modal_fit` — modal model of an extracted linear FRF.
* :mod:`~nlupdate.identification.methods` — PRD and DDF behind one interface.
* :mod:`~nlupdate.identification.pipeline` — the identification step: fit, linear FRF, modes,
  Monte Carlo; :mod:`~nlupdate.identification.summary` — its JSON summary and tables.
* :mod:`~nlupdate.identification.amplitude_modal_fit` — amplitude-dependent modal models
  from a modal table or FRFs at several levels.
"""
from nlupdate.identification.data import FRFLevels
from nlupdate.identification.ddf import identify_ddf
from nlupdate.identification.dfmodels import PhysicalModel, PolynomialModel
from nlupdate.identification.frequency import recommend_frequency
from nlupdate.identification.prd import IdentificationError, identify_prd
from nlupdate.identification.regenerate import regenerate_frf

__all__ = [
    "FRFLevels", "IdentificationError", "PhysicalModel", "PolynomialModel",
    "identify_ddf", "identify_prd", "recommend_frequency", "regenerate_frf",
]
