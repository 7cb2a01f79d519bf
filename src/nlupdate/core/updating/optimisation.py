"""Optimisation-based updating: bounded minimisation of weighted frequency errors.

Minimises ``½ Σ_i w_i (f_i(p)/f_i^target − 1)²`` (plus weighted mode-shape terms with
``use_mode_shapes``, see :mod:`nlupdate.core.updating.residuals`) over the chosen parameters
within their bounds, with ``scipy.optimize.least_squares`` (``dogbox`` or the
trust-region reflective ``trf``) in normalised parameters ``x = p / s`` (as in
:mod:`nlupdate.core.updating.eigensensitivity`). The Jacobian comes from the same
finite-difference formulas as the eigensensitivity method; each Jacobian's stencil goes
to the point evaluator in one request, and no point is computed twice. Each call of the objective is one history row
(``iteration`` = call number).

Unlike the eigensensitivity iteration this does not stop when a frequency error is
small: it minimises the weighted sum, which is what makes different weightings and
parameter sets give different *candidate* models when the targets cannot all be met.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np
import pandas as pd
import scipy.optimize

from nlupdate.fe.adapters.base import FEAdapter, Parameter
from nlupdate.core.updating.eigensensitivity import (
    UpdatingResult, history_columns, history_row, normalisation, parameter_bounds, parameter_values,
)
from nlupdate.core.updating.residuals import ModalResponse, ResponseOptions
from nlupdate.core.updating.evaluation import PointEvaluator, as_evaluator
from nlupdate.core.updating.stopping import bound_reason
from nlupdate.core.updating.sensitivity import FORMULAS
from nlupdate.core.updating.targets import UpdatingTargets
from nlupdate.settings import setting

OPTIMISATION_METHODS = ("trf", "dogbox")


@dataclass(frozen=True)
class OptimisationOptions(ResponseOptions):
    """Settings of :func:`optimise_frequencies`, in addition to the shared
    :class:`~nlupdate.core.updating.residuals.ResponseOptions`.

    method: ``least_squares`` method, ``dogbox`` (default: handles parameters that end
        on a bound in fewer evaluations) or ``trf``.
    max_evaluations: limit on objective calls (``max_nfev``).
    ftol, xtol, gtol: ``least_squares`` tolerances (x in normalised parameters).

    The fields declared here are keys of the study's ``[optimisation]`` table.
    """

    method: str = setting("dogbox", kind="choice", choices=OPTIMISATION_METHODS, meaning="least-squares method")
    formula: str = setting("forward", kind="choice", choices=tuple(FORMULAS), meaning="finite-difference Jacobian")
    max_evaluations: int = setting(100, kind="integer", minimum=1,
                                   meaning="limit on objective calls (`max_nfev`)")
    ftol: float = setting(1e-10, kind="number", minimum=0, above_minimum=True,
                          meaning="`least_squares` tolerance on the cost (x normalised)")
    xtol: float = setting(1e-10, kind="number", minimum=0, above_minimum=True,
                          meaning="`least_squares` tolerance on the step (x normalised)")
    gtol: float = setting(1e-10, kind="number", minimum=0, above_minimum=True,
                          meaning="`least_squares` tolerance on the gradient (x normalised)")

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.method not in OPTIMISATION_METHODS:
            raise ValueError(f"optimisation method must be one of {list(OPTIMISATION_METHODS)}, got {self.method!r}")
        if self.max_evaluations < 1:
            raise ValueError(f"max_evaluations must be ≥ 1, got {self.max_evaluations}")


def optimise_frequencies(
    model: FEAdapter | PointEvaluator,
    parameters: Sequence[Parameter],
    targets: UpdatingTargets,
    options: OptimisationOptions = OptimisationOptions(),
    fixed: Mapping[str, float] | None = None,
) -> UpdatingResult:
    """Bounded weighted least-squares fit of the paired natural frequencies to ``targets``.

    Returns an :class:`~nlupdate.core.updating.eigensensitivity.UpdatingResult` with
    ``method="optimisation"``; ``iterations`` is the number of objective calls and
    ``reason`` the optimiser's message. It converged when the optimiser's own tests were
    met with every parameter inside its bounds (``stop``: ``"converged"``); one that met
    them on a bound stopped there (``"parameter at bound"``); ``max_evaluations`` is its
    ``"iteration limit"``. ``model``: an adapter or a point evaluator, as
    for :func:`~nlupdate.core.updating.eigensensitivity.inverse_eigensensitivity`.
    """
    parameters = tuple(parameters)
    if not parameters:
        raise ValueError("optimisation needs at least one updating parameter")
    evaluate_points = as_evaluator(model)
    response = ModalResponse(evaluate_points, parameters, targets, fixed, options)
    names = [p.name for p in parameters]
    scale = normalisation(parameters)
    lower_p = np.array([p.lower for p in parameters])
    upper_p = np.array([p.upper for p in parameters])
    weights = response.weights()
    target = response.target_vector()
    start_time = time.perf_counter()
    counts_before = evaluate_points.counts()
    last_counts = dict(counts_before)
    rows: list[dict[str, object]] = []
    previous_x: list[np.ndarray] = []
    last_jacobian: dict[str, object] = {"sensitivity": None, "point": None}

    def values_of(x: np.ndarray) -> dict[str, float]:
        return parameter_values(x, scale, parameters)

    def residual(x: np.ndarray) -> np.ndarray:
        values = values_of(x)
        result = response.evaluate(values)
        pairing = response.pair(result)
        now = evaluate_points.counts()
        step = float(np.max(np.abs(x - previous_x[-1]))) if previous_x else float("nan")
        previous_x.append(np.array(x))
        rows.append(history_row(
            response, result, pairing, values,
            method="optimisation", formula=options.formula, iteration=len(rows), step_norm=step, rejected_steps=0,
            new_evaluations=now["new"] - last_counts["new"], cached_evaluations=now["cached"] - last_counts["cached"],
            wall_time_s=time.perf_counter() - start_time,
        ))
        last_counts.update(now)
        return weights * (response.vector(result, pairing) - target)

    def residual_jacobian(x: np.ndarray) -> np.ndarray:
        values = values_of(x)
        result = response.evaluate(values)
        pairing = response.pair(result)
        s_p = response.jacobian(values, result, pairing, options.formula)
        last_jacobian.update(sensitivity=s_p, point=dict(values))
        return weights[:, None] * s_p * scale[None, :]

    x0 = np.array([p.start for p in parameters]) / scale
    initial_values = values_of(x0)
    initial = response.evaluate(initial_values)
    initial_pairing = response.pair(initial)
    solution = scipy.optimize.least_squares(
        residual, x0, jac=residual_jacobian, bounds=(lower_p / scale, upper_p / scale), method=options.method,
        x_scale=1.0, ftol=options.ftol, xtol=options.xtol, gtol=options.gtol, max_nfev=options.max_evaluations,
    )
    values = values_of(solution.x)
    final = response.evaluate(values)
    counts_after = evaluate_points.counts()
    reason = str(solution.message)
    if solution.status == 0:
        stop = "iteration limit"
    elif solution.status < 0:
        stop = "no decrease"
    else:
        on_bound = bound_reason(values, parameter_bounds(parameters))
        stop, reason = ("converged", reason) if on_bound is None else ("parameter at bound", f"{on_bound}; {reason}")
    return UpdatingResult(
        method="optimisation",
        parameters=values,
        converged=stop == "converged",
        reason=reason,
        iterations=int(solution.nfev),
        history=pd.DataFrame(rows, columns=history_columns(names, targets.labels)),
        initial=initial,
        final=final,
        initial_pairing=initial_pairing,
        final_pairing=response.pair(final),
        counts={k: counts_after[k] - counts_before[k] for k in ("new", "cached")},
        wall_time_s=time.perf_counter() - start_time,
        targets=targets,
        sensitivity=last_jacobian["sensitivity"],
        sensitivity_point=last_jacobian["point"],
        bounds=parameter_bounds(parameters),
        stop=stop,
    )
