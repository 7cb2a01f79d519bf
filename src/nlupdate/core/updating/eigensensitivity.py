"""Inverse eigensensitivity updating (docs/methods.md §6).

Linearising the paired response r (relative natural frequencies, optionally scaled
mode shapes; :mod:`nlupdate.core.updating.residuals`) about the current parameters,
``r_target − r(p) ≈ S Δp``, each iteration solves the weighted, Tikhonov-regularised,
bounded least-squares problem

    min ‖W (S_x Δx − Δr)‖² + λ² ‖Δx‖²   subject to   lower ≤ p + Δp ≤ upper,
                                                        |Δx_j| ≤ Δ

in normalised parameters ``x_j = p_j / s_j`` (``s_j = |start_j|``, or the bound width
when the start is 0), so ``S_x = S · diag(s)`` is well scaled whatever the units. The
sensitivity S comes from one of the finite-difference formulas of
:mod:`nlupdate.core.updating.sensitivity`; the step is solved with
``scipy.optimize.lsq_linear`` on the stacked system ``[W S_x; λ I] Δx = [W Δr; 0]``.

Step control (``step_control``). Undamped (``"none"``, the classic iteration), Δ is
``max_step`` and every step is taken. Far from the solution, or when the targets cannot
all be met (a residual that stays large, whose curvature Gauss–Newton neglects), such
steps overshoot and come back: the iterates jump between two points for ever (a 2-cycle;
on the 3-DOF chain of ``tests/test_updating_stops.py`` every full step is longer than
``max_step``, and the clipped steps take k2 from 1.08e5 to 1.33e5 N/m and back). With
``"trust_region"`` (the default) Δ is a trust radius (Levenberg–Marquardt in the
∞-norm): a step is taken only when the weighted residual ``½‖W(r_target − r)‖²`` falls
by at least 1e-4 of what the linearisation predicts (ratio ρ); otherwise Δ becomes a
quarter of the rejected step and the step is solved again with the same sensitivity (one
new evaluation per rejected step, no new Jacobian). Δ also becomes a quarter of a taken
step with ρ < 0.25, and doubles (up to ``max_step``) after one with ρ > 0.75 that reached
it. While every step is good (ρ > 0.25) the two controls take the same steps.

Iteration k (k = 1, 2, …) computes S at p_k−1, the step, and evaluates the model at the
new point p_k. It stops (``UpdatingResult.stop``, :mod:`nlupdate.core.updating.stopping`)
when the largest relative frequency error of the paired modes is within
``frequency_tolerance`` (converged: ``"frequency"``); when the largest normalised
parameter change of the last step is within ``parameter_tolerance`` — converged:
``"parameter change"``, the usual end when the targets cannot all be met, unless a
parameter then lies on a bound (``"parameter at bound"``, not converged); when the trust
radius shrank below ``parameter_tolerance`` without finding a better point (converged,
``"parameter change"``, when the full step would remove less than 1 % of the residual — a
minimum that the finite-difference sensitivity's own error points slightly past — else
``"no decrease"``); when
the iterates return to a point visited 2–4 iterations before (``"cycle detected"``); or
after ``max_iterations`` steps (``"iteration limit"``).

Evaluation counts: the initial point costs one new evaluation; each iteration costs
``n_parameters × new_points(formula)`` new evaluations for the stencil (forward and
backward 1, central O(h²) 2, central O(h⁴) 4 per parameter) plus one for the new point,
plus one per rejected step. The one-sided formulas also request the base point once per
parameter; the point evaluator (:mod:`nlupdate.core.updating.evaluation`) returns it from
memory (counted as cached), never recomputed. All stencil points of an iteration go to
the evaluator in one request, so it may run them concurrently.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Mapping, Sequence

import numpy as np
import pandas as pd
import scipy.optimize

from nlupdate.fe.adapters.base import FEAdapter, ModalResult, Parameter
from nlupdate.core.updating.pairing import ModePairing
from nlupdate.core.updating.residuals import ModalResponse, ResponseOptions
from nlupdate.core.updating.evaluation import PointEvaluator, as_evaluator
from nlupdate.core.updating.stopping import bound_reason, cycle_period
from nlupdate.core.updating.targets import UpdatingTargets
from nlupdate.settings import setting

#: ``step_control`` settings (module docstring).
STEP_CONTROLS = ("trust_region", "none")
#: A step is taken when the residual falls by this fraction of the predicted fall.
ACCEPT_RATIO = 1e-4


@dataclass(frozen=True)
class EigensensitivityOptions(ResponseOptions):
    """Settings of :func:`inverse_eigensensitivity` (see the module docstring), in addition
    to the shared :class:`~nlupdate.core.updating.residuals.ResponseOptions`.

    frequency_tolerance: relative (0.0001 = 0.01 %) on the largest paired frequency error.
    parameter_tolerance: on the largest normalised parameter change of a step.
    regularisation: Tikhonov weight λ on the normalised step (0 = none).
    max_step: largest normalised change of any parameter per iteration.
    step_control: ``"trust_region"`` (steps that do not lower the residual are shortened)
        or ``"none"`` (every Gauss–Newton step is taken).

    The fields declared here are keys of the study's ``[eigensensitivity]`` table.
    """

    max_iterations: int = setting(20, kind="integer", minimum=1, meaning="iteration limit")
    frequency_tolerance: float = setting(
        1e-4, kind="number", minimum=0, above_minimum=True, unit="relative",
        meaning="converged when the largest paired relative frequency error is below it")
    parameter_tolerance: float = setting(
        1e-6, kind="number", minimum=0, above_minimum=True, unit="normalised",
        meaning="converged when the largest normalised parameter change of a step is below it (inside the bounds: a "
                'run at rest on a bound stops as "parameter at bound", not converged)')
    regularisation: float = setting(0.0, kind="number", minimum=0, meaning="Tikhonov weight λ on the normalised step")
    max_step: float = setting(
        0.5, kind="number", minimum=0, above_minimum=True, unit="normalised",
        meaning="largest change of any parameter per iteration, as a fraction of its scale (|start|)")
    step_control: str = setting(
        "trust_region", kind="choice", choices=STEP_CONTROLS,
        meaning="`trust_region`: a step that does not lower the weighted residual is shortened (Levenberg–Marquardt "
                "trust radius, at most `max_step`), so the iteration cannot jump back and forth; `none`: every "
                'Gauss–Newton step is taken (the classic iteration; a run whose iterates return to an earlier point '
                'stops with "cycle detected")')

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.max_iterations < 1:
            raise ValueError(f"max_iterations must be ≥ 1, got {self.max_iterations}")
        for name in ("frequency_tolerance", "parameter_tolerance", "max_step"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if self.regularisation < 0:
            raise ValueError(f"regularisation must be ≥ 0, got {self.regularisation}")
        if self.step_control not in STEP_CONTROLS:
            raise ValueError(f"step_control must be one of {list(STEP_CONTROLS)}, got {self.step_control!r}")


@dataclass(frozen=True, eq=False)
class UpdatingResult:
    """Outcome of one updating run.

    name: label of the run (task or candidate name); parameters: updated values (parameter units); converged: whether
    they are a result (``stop == "converged"``); stop: why the run stopped, one of
    :data:`~nlupdate.core.updating.stopping.STOPS`; reason: the detail in words; history: one row per iteration
    (see :func:`history_columns`); initial/final: model results at the start and the
    updated point; counts: point evaluations (``new``, ``cached``) of the run;
    sensitivity: the last Jacobian of the response vector (paired ``f/f_target``, then
    mode-shape terms) per parameter unit, at ``sensitivity_point`` (None if no iteration
    was needed); bounds: (lower, upper) of each updated parameter, to tell a result that
    ended on a bound (:func:`nlupdate.core.updating.parameter_warnings.updating_warnings`).
    """

    method: str
    parameters: dict[str, float]
    converged: bool
    reason: str
    iterations: int
    history: pd.DataFrame
    initial: ModalResult
    final: ModalResult
    initial_pairing: ModePairing
    final_pairing: ModePairing
    counts: dict[str, int]
    wall_time_s: float
    targets: UpdatingTargets = field(repr=False)
    name: str = ""
    sensitivity: np.ndarray | None = field(default=None, repr=False)
    sensitivity_point: dict[str, float] | None = None
    bounds: dict[str, tuple[float, float]] | None = None
    stop: str = "converged"

    def frequencies_hz(self, which: str = "final") -> np.ndarray:
        """Paired model frequencies (Hz) of the ``initial`` or ``final`` model."""
        result, pairing = (self.initial, self.initial_pairing) if which == "initial" else (self.final, self.final_pairing)
        return np.asarray(result.natural_frequencies_hz)[list(pairing.model_indices)]

    def _values(self) -> str:
        return ", ".join(f"{name} = {value:.6g}" for name, value in self.parameters.items())

    def __repr__(self) -> str:
        """One line: name, updated values, how it stopped (``summary()``: a few lines more)."""
        return (f"<UpdatingResult {self.name or self.method!r}: {self._values()}; {self.stop} after "
                f"{self.iterations} iteration(s)>")

    def summary(self) -> str:
        """A few lines: the updated values, how the run stopped, FE runs, and each paired
        mode's frequency (Hz) before and after against its target."""
        lines = [f"{self.name or self.method}: {self._values()}",
                 f"{self.stop} ({self.reason}) after {self.iterations} iteration(s)",
                 f"FE runs: {self.counts.get('new', 0)} new, {self.counts.get('cached', 0)} cached; "
                 f"{self.wall_time_s:.3g} s"]
        for label, target, before, after in zip(self.targets.labels, self.targets.frequencies_hz,
                                                self.frequencies_hz("initial"), self.frequencies_hz("final")):
            lines.append(f"{label}: {before:.4f} → {after:.4f} Hz (target {target:.4f} Hz)")
        return "\n".join(lines)


def normalisation(parameters: Sequence[Parameter]) -> np.ndarray:
    """Scale s_j of each parameter: |start|, or the bound width when the start is 0."""
    scales = []
    for p in parameters:
        scale = abs(p.start) if p.start != 0 else p.upper - p.lower
        if not p.lower < p.upper:
            raise ValueError(f"parameter {p.name!r}: updating needs lower < upper, got [{p.lower}, {p.upper}]")
        if not scale > 0:
            raise ValueError(f"parameter {p.name!r}: cannot normalise (start 0 and zero bound width)")
        scales.append(scale)
    return np.asarray(scales)


def parameter_values(x: np.ndarray, scale: np.ndarray, parameters: Sequence[Parameter]) -> dict[str, float]:
    """The parameters' values at the normalised vector ``x`` (``x_j = value_j / s_j``,
    :func:`normalisation`), clipped to their bounds, by name: the point a method evaluates."""
    values = np.clip(x * scale, [p.lower for p in parameters], [p.upper for p in parameters])
    return dict(zip((p.name for p in parameters), (float(v) for v in values)))


def parameter_bounds(parameters: Sequence[Parameter]) -> dict[str, tuple[float, float]]:
    """Each parameter's (lower, upper) bound by name, as :class:`UpdatingResult` states them and
    :func:`~nlupdate.core.updating.stopping.bound_reason` reads them."""
    return {p.name: (float(p.lower), float(p.upper)) for p in parameters}


def history_row(
    response: ModalResponse,
    result: ModalResult,
    pairing: ModePairing,
    values: Mapping[str, float],
    **extra: object,
) -> dict[str, object]:
    """One history record: parameter values, paired frequencies, errors (%) and MAC."""
    row: dict[str, object] = dict(extra)
    for name, value in values.items():
        row[f"p:{name}"] = float(value)
    frequencies = response.frequencies(result, pairing)
    errors = response.errors_pct(result, pairing)
    for i, label in enumerate(response.targets.labels):
        row[f"f_hz:{label}"] = float(frequencies[i])
        row[f"error_pct:{label}"] = float(errors[i])
        row[f"mac:{label}"] = pairing.mac[i]
    row["model_modes"] = ",".join(str(i + 1) for i in pairing.model_indices)
    row["max_abs_error_pct"] = float(np.max(np.abs(errors)))
    return row


def history_columns(parameter_names: Sequence[str], labels: Sequence[str]) -> list[str]:
    """Column order of the history table."""
    columns = ["method", "formula", "iteration"]
    columns += [f"p:{n}" for n in parameter_names]
    for label in labels:
        columns += [f"f_hz:{label}", f"error_pct:{label}", f"mac:{label}"]
    return columns + ["model_modes", "max_abs_error_pct", "step_norm", "rejected_steps", "new_evaluations",
                      "cached_evaluations", "wall_time_s"]


def inverse_eigensensitivity(
    model: FEAdapter | PointEvaluator,
    parameters: Sequence[Parameter],
    targets: UpdatingTargets,
    options: EigensensitivityOptions = EigensensitivityOptions(),
    fixed: Mapping[str, float] | None = None,
) -> UpdatingResult:
    """Update ``parameters`` (starting from their ``start``) so the model meets ``targets``.

    ``model`` is an adapter (evaluated in order, each point once) or a point evaluator
    (:mod:`nlupdate.core.updating.evaluation`) that decides where the FE runs happen.
    ``fixed`` holds values of other model parameters used in every evaluation.
    Returns an :class:`UpdatingResult`; see the module docstring for the algorithm,
    stopping rules and evaluation counts.
    """
    parameters = tuple(parameters)
    if not parameters:
        raise ValueError("inverse eigensensitivity needs at least one updating parameter")
    evaluate_points = as_evaluator(model)
    response = ModalResponse(evaluate_points, parameters, targets, fixed, options)
    names = [p.name for p in parameters]
    scale = normalisation(parameters)
    lower = np.array([p.lower for p in parameters]) / scale
    upper = np.array([p.upper for p in parameters]) / scale
    weights = response.weights()
    target = response.target_vector()

    start_time = time.perf_counter()
    counts_before = evaluate_points.counts()
    last_counts = dict(counts_before)
    x = np.array([p.start for p in parameters]) / scale

    def values_of(x_vector: np.ndarray) -> dict[str, float]:
        return parameter_values(x_vector, scale, parameters)

    def counts_since() -> tuple[int, int]:
        now = evaluate_points.counts()
        delta = (now["new"] - last_counts["new"], now["cached"] - last_counts["cached"])
        last_counts.update(now)
        return delta

    def cost_of(result: ModalResult, pairing: ModePairing) -> float:
        return _cost(weights, target - response.vector(result, pairing))

    values = values_of(x)
    result = response.evaluate(values)
    pairing = response.pair(result)
    initial, initial_pairing = result, pairing
    cost = cost_of(result, pairing)
    rows = []
    visited = [x.copy()]
    sensitivity, sensitivity_point = None, None
    step_norm, limited, rejected = float("nan"), False, 0
    radius = options.max_step
    damped = options.step_control == "trust_region"
    tolerance = options.parameter_tolerance
    stop, reason, iteration = "iteration limit", "maximum iterations reached", 0
    while True:
        new, cached = counts_since()
        row = history_row(
            response, result, pairing, values,
            method="eigensensitivity", formula=options.formula, iteration=iteration,
            step_norm=step_norm, rejected_steps=rejected, new_evaluations=new, cached_evaluations=cached,
            wall_time_s=time.perf_counter() - start_time,
        )
        rows.append(row)
        if row["max_abs_error_pct"] <= 100.0 * options.frequency_tolerance:
            stop, reason = "converged", "frequency"
            break
        if iteration > 0 and step_norm <= tolerance and not limited:
            stop, reason = "converged", "parameter change"
            break
        period = cycle_period(visited, tolerance)
        if period is not None:
            stop, reason = "cycle detected", (f"cycle detected: iteration {iteration} returned to the point of iteration "
                                              f"{iteration - period} (period {period})")
            break
        if iteration == options.max_iterations:
            break
        iteration += 1
        s_p = response.jacobian(values, result, pairing, options.formula)
        sensitivity, sensitivity_point = s_p, dict(values)
        s_x = s_p * scale[None, :]
        residual = target - response.vector(result, pairing)
        rejected = 0
        while True:
            step = _bounded_step(s_x, residual, weights, options.regularisation,
                                 np.maximum(lower - x, -radius), np.minimum(upper - x, radius))
            step_norm = float(np.max(np.abs(step)))
            limited = damped and step_norm >= radius * (1 - 1e-9)
            trial_x = np.clip(x + step, lower, upper)
            trial_values = values_of(trial_x)
            trial = response.evaluate(trial_values)
            trial_pairing = response.pair(trial)
            trial_cost = cost_of(trial, trial_pairing)
            predicted = cost - _cost(weights, residual - s_x @ step)
            ratio = (cost - trial_cost) / predicted if predicted > 0 else -np.inf
            if not damped or (step_norm <= tolerance and not limited) or ratio > ACCEPT_RATIO:
                break
            rejected += 1
            radius = 0.25 * step_norm
            if radius < tolerance:
                break
        if damped and radius < tolerance:  # no step longer than the tolerance lowers the residual
            stop, reason = _at_rest(s_x, residual, weights, options.regularisation, lower - x, upper - x, cost)
            break
        if damped and ratio < 0.25:
            radius = max(0.25 * step_norm, tolerance)
        elif damped and ratio > 0.75 and limited:
            radius = min(2 * radius, options.max_step)
        x, values, result, pairing, cost = trial_x, trial_values, trial, trial_pairing, trial_cost
        visited.append(x.copy())
    if stop == "converged" and reason != "frequency":
        on_bound = bound_reason(values, parameter_bounds(parameters))
        if on_bound is not None:
            stop, reason = "parameter at bound", on_bound

    counts_after = evaluate_points.counts()
    history = pd.DataFrame(rows, columns=history_columns(names, targets.labels))
    return UpdatingResult(
        method="eigensensitivity",
        parameters=values,
        converged=stop == "converged",
        reason=reason,
        iterations=iteration,
        history=history,
        initial=initial,
        final=result,
        initial_pairing=initial_pairing,
        final_pairing=pairing,
        counts={k: counts_after[k] - counts_before[k] for k in ("new", "cached")},
        wall_time_s=time.perf_counter() - start_time,
        targets=targets,
        sensitivity=sensitivity,
        sensitivity_point=sensitivity_point,
        bounds=parameter_bounds(parameters),
        stop=stop,
    )


#: At rest when the full step would remove less than this fraction of the residual.
STATIONARY_FRACTION = 1e-2


def _cost(weights: np.ndarray, residual: np.ndarray) -> float:
    """The cost the steps lower, ``½‖W Δr‖²``, of a residual (targets minus model) — the model's
    own, or the one the sensitivities predict after a step, ``Δr − SΔx``."""
    return 0.5 * float(np.sum((weights * residual) ** 2))


def _at_rest(
    sensitivity: np.ndarray,
    residual: np.ndarray,
    weights: np.ndarray,
    regularisation: float,
    lower: np.ndarray,
    upper: np.ndarray,
    cost: float,
) -> tuple[str, str]:
    """Stop and reason when the trust radius fell below ``parameter_tolerance``: converged
    (``"parameter change"``) when the undamped step within the bounds would remove less than
    :data:`STATIONARY_FRACTION` of the residual ``cost`` — a minimum, where the
    finite-difference sensitivity's own error points the last steps the wrong way — else
    ``"no decrease"``: the sensitivities promise a fall the model does not give."""
    step = _bounded_step(sensitivity, residual, weights, regularisation, lower, upper)
    predicted = cost - _cost(weights, residual - sensitivity @ step)
    if predicted <= STATIONARY_FRACTION * cost:
        return "converged", "parameter change"
    return "no decrease", (f"no decrease: no step longer than the parameter tolerance lowers the residual, though the "
                           f"sensitivities predict a {100 * predicted / cost:.3g} % fall")


def _bounded_step(
    sensitivity: np.ndarray,
    residual: np.ndarray,
    weights: np.ndarray,
    regularisation: float,
    lower: np.ndarray,
    upper: np.ndarray,
) -> np.ndarray:
    """Solve ``min ‖W(SΔx − Δr)‖² + λ²‖Δx‖²`` with ``lower ≤ Δx ≤ upper``."""
    n = sensitivity.shape[1]
    a = weights[:, None] * sensitivity
    b = weights * residual
    if regularisation > 0:
        a = np.vstack([a, regularisation * np.eye(n)])
        b = np.concatenate([b, np.zeros(n)])
    return scipy.optimize.lsq_linear(a, b, bounds=(lower, upper), method="trf", lsq_solver="exact", tol=1e-12).x
