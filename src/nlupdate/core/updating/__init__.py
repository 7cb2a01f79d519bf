"""Linear model updating against measured (or PRD-extracted) natural frequencies.

* :mod:`~nlupdate.core.updating.sensitivity` — finite-difference sensitivities (4 formulas)
* :mod:`~nlupdate.core.updating.targets`, :mod:`~nlupdate.core.updating.pairing`,
  :mod:`~nlupdate.core.updating.residuals` — targets, mode pairing, response vector
* :mod:`~nlupdate.core.updating.eigensensitivity` — inverse eigensensitivity iteration
* :mod:`~nlupdate.core.updating.optimisation` — bounded weighted least-squares fit
* :mod:`~nlupdate.core.updating.evaluation` — point evaluators: who runs the FE evaluations
* :mod:`~nlupdate.core.updating.runs` — one run (:func:`update`), the candidates' comparison and ranking
* :mod:`~nlupdate.core.updating.target_uncertainty` — parameter uncertainty from target uncertainty
* :mod:`~nlupdate.core.updating.stopping` — why a run stopped (converged, iteration limit, cycle, bound)
* :mod:`~nlupdate.core.updating.parameter_warnings` — warnings: runs that did not converge or ended on a bound, spread
  above the value
"""
from nlupdate.core.updating.eigensensitivity import EigensensitivityOptions, UpdatingResult, inverse_eigensensitivity
from nlupdate.core.updating.evaluation import MemoisedEvaluator, PointEvaluator
from nlupdate.core.updating.optimisation import OptimisationOptions, optimise_frequencies
from nlupdate.core.updating.pairing import ModePairing, pair_modes
from nlupdate.core.updating.runs import UpdatingRun, compare_candidates, rank_candidates, update
from nlupdate.core.updating.sensitivity import FORMULAS, assemble_jacobian, jacobian, stencil_points
from nlupdate.core.updating.targets import UpdatingTargets, frf_natural_frequencies, peak_frequencies

__all__ = [
    "UpdatingRun", "compare_candidates", "rank_candidates", "update", "EigensensitivityOptions", "UpdatingResult",
    "inverse_eigensensitivity", "OptimisationOptions", "optimise_frequencies", "ModePairing", "pair_modes", "FORMULAS",
    "assemble_jacobian", "jacobian", "stencil_points", "MemoisedEvaluator", "PointEvaluator", "UpdatingTargets",
    "peak_frequencies", "frf_natural_frequencies",
]
