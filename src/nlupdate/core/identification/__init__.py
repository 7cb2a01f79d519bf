"""Identification of local nonlinearities and extraction of linear FRFs (docs/methods.md §4–§5, §7).

Modules
-------
* :mod:`~nlupdate.core.identification.data` — measured curves per force level (:class:`FRFLevels`).
* :mod:`~nlupdate.core.identification.dfmodels` — describing-function models: the source's PRD
  polynomial and named physical elements (cubic, Jenkins, Coulomb, quadratic damping, gap).
* :mod:`~nlupdate.core.identification.prd` — PRD at one coordinate: the source's naive least
  squares and the improved joint output-error estimator; linear-FRF extraction.
* :mod:`~nlupdate.core.identification.ddf` — DDF method for comparison.
* :mod:`~nlupdate.core.identification.frequency` — choice of the excitation frequency.
* :mod:`~nlupdate.core.identification.uncertainty` — Monte-Carlo statistics over the noise model.
* :mod:`~nlupdate.core.identification.trust` — warnings about results not to be trusted
  (parameters on a bound or not determined by the data, a residual far above the noise).
* :mod:`~nlupdate.core.identification.scalar_balance` — scalar harmonic balance (amplitude roots).
* :mod:`~nlupdate.core.identification.regenerate` — nonlinear FRFs on extracted linear FRFs.
* :mod:`~nlupdate.core.identification.linear_frf` — the linear FRF from every level (or the low one) and its modes.
* :mod:`~nlupdate.core.identification.modal_fit` — modal model of an extracted linear FRF.
* :mod:`~nlupdate.core.identification.methods` — PRD and DDF behind one interface.
* :mod:`~nlupdate.core.identification.pipeline` — the identification step: fit, linear FRF, modes,
  Monte Carlo; :mod:`~nlupdate.core.identification.summary` — its JSON summary and tables.
* :mod:`~nlupdate.core.identification.amplitude_modal_fit` — amplitude-dependent modal models
  from a modal table or FRFs at several levels.
"""
from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.ddf import identify_ddf
from nlupdate.core.identification.dfmodels import PhysicalModel, PolynomialModel
from nlupdate.core.identification.frequency import recommend_frequency
from nlupdate.core.identification.prd import IdentificationError, identify_prd
from nlupdate.core.identification.regenerate import regenerate_frf

__all__ = [
    "FRFLevels", "IdentificationError", "PhysicalModel", "PolynomialModel",
    "identify_ddf", "identify_prd", "recommend_frequency", "regenerate_frf",
]
