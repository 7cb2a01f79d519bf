"""Linear model updating against measured (or PRD-extracted) natural frequencies.

* :mod:`~nlupdate.updating.sensitivity` — finite-difference sensitivities (4 formulas)
* :mod:`~nlupdate.updating.targets`, :mod:`~nlupdate.updating.pairing`,
  :mod:`~nlupdate.updating.residuals` — targets, mode pairing, response vector
* :mod:`~nlupdate.updating.eigensensitivity` — inverse eigensensitivity iteration
* :mod:`~nlupdate.updating.optimisation` — bounded weighted least-squares fit
* :mod:`~nlupdate.updating.evaluation` — point evaluators: who runs the FE evaluations
* :mod:`~nlupdate.updating.runs` — one run (:func:`update`), the candidates' comparison and ranking
* :mod:`~nlupdate.updating.target_uncertainty` — parameter uncertainty from target uncertainty
* :mod:`~nlupdate.updating.stopping` — why a run stopped (converged, iteration limit, cycle, bound)
* :mod:`~nlupdate.updating.parameter_warnings` — warnings: runs that did not converge or ended on a bound, spread
  above the value
"""
from nlupdate.updating.eigensensitivity import EigensensitivityOptions, UpdatingResult, inverse_eigensensitivity
from nlupdate.updating.evaluation import MemoisedEvaluator, PointEvaluator
from nlupdate.updating.optimisation import OptimisationOptions, optimise_frequencies
from nlupdate.updating.pairing import ModePairing, pair_modes
from nlupdate.updating.runs import UpdatingRun, compare_candidates, rank_candidates, update
from nlupdate.updating.sensitivity import FORMULAS, assemble_jacobian, jacobian, stencil_points
from nlupdate.updating.targets import UpdatingTargets, frf_natural_frequencies, peak_frequencies

__all__ = [
    "UpdatingRun", "compare_candidates", "rank_candidates", "update", "EigensensitivityOptions", "UpdatingResult",
    "inverse_eigensensitivity", "OptimisationOptions", "optimise_frequencies", "ModePairing", "pair_modes", "FORMULAS",
    "assemble_jacobian", "jacobian", "stencil_points", "MemoisedEvaluator", "PointEvaluator", "UpdatingTargets",
    "peak_frequencies", "frf_natural_frequencies",
]
