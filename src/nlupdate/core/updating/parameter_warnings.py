"""Warnings about updated parameters that should not be trusted as they stand.

:func:`updating_warnings` looks at one updating run (an eigensensitivity run or an
optimisation candidate, :class:`~nlupdate.core.updating.eigensensitivity.UpdatingResult`):

* ``not_converged`` — the run did not converge: it reached its iteration limit, its
  iterates cycled, it came to rest on a bound or found no step that lowers the residual
  (:mod:`nlupdate.core.updating.stopping`). Its values are where it stopped, not a result.
* ``at_bound`` — a parameter that ended within ``BOUND_TOLERANCE`` (1e-3) of the bound
  width of its lower or upper bound. Both methods come to rest there — the
  eigensensitivity iteration because its step is clipped to zero, the optimiser because
  the projected gradient vanishes — and report it as their stop (``"parameter at
  bound"``), not as convergence: the targets are probably not reachable within the
  bounds (a wrong parameter set, wrong bounds, or a target the model cannot meet). 0.1 %
  of the width: both methods land on the bound to round-off or to their step tolerance
  (≤ 1e-6 here), while a free optimum that close to a bound by chance is improbable.
* ``uncertainty_exceeds_value`` — the standard deviation propagated from the targets'
  uncertainty (:mod:`nlupdate.core.updating.target_uncertainty`) exceeds the value's magnitude.
* ``targets_missed`` — a converged run whose model misses a weighted target frequency by
  more than ``MISS_LIMIT_SIGMA`` (3) of that target's standard deviation, and would still
  miss a weighted target (that one or another) after the step that minimises the misses
  in σ (:func:`misses_left_by_a_step` weighted by 1/σ²): the parameter set cannot
  meet its targets — a model error the ± propagated from the targets leaves out. When that
  step meets them but the run's own weights (not ∝ 1/σ²) leave one beyond its noise, it
  says so: the weights trade a target known finely against noisier ones. A model
  that can meet its targets leaves, at weights 1/σ², residuals of the order of their noise,
  smaller still with as many parameters as targets, so 3σ is exceeded by chance less than
  0.3 % of the time per target; the demo's one-parameter {E} runs miss by 323σ.
* ``stopped_short`` — the same miss, but one more step would meet every weighted target: the run stopped
  within its own tolerance, which is coarser than the targets' noise (the public
  Brake–Reuss beam's resonance is known to 1.6e-6; the default frequency tolerance is 1e-4).
  Also a run that met its tolerance at its start: it computed no sensitivity, so whether
  its parameters can meet the targets is not known, only that its tolerance is too coarse.
* ``unfitted_target_missed`` — a target of weight 0 missed beyond 3σ: the updated model
  does not hold where it was not fitted.

The warning type is :class:`~nlupdate.core.identification.trust.TrustWarning`.
"""
from __future__ import annotations

from typing import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nlupdate.core.identification.trust import TrustWarning, uncertainty_warnings
from nlupdate.core.updating.eigensensitivity import UpdatingResult
from nlupdate.core.updating.stopping import BOUND_TOLERANCE, at_bound
from nlupdate.core.updating.target_uncertainty import ParameterUncertainty

MISS_LIMIT_SIGMA = 3.0
"""A target missed by more than this many of its standard deviations is named (``targets_missed``)."""


def updating_warnings(
    result: UpdatingResult,
    bounds: Mapping[str, tuple[float, float]] | None = None,
    uncertainty: ParameterUncertainty | Mapping[str, float] | None = None,
    tolerance: float = BOUND_TOLERANCE,
    target_std_hz: ArrayLike | None = None,
) -> tuple[TrustWarning, ...]:
    """Warnings about one updating run (module docstring); the source is the run's name.

    ``bounds``: (lower, upper) per parameter (default: the run's own ``bounds``);
    ``uncertainty``: the run's propagated standard deviations, if any; ``target_std_hz``:
    the standard deviation of each target frequency (Hz, target order), if known.
    """
    bounds = result.bounds if bounds is None else bounds
    source = result.name or result.method
    state = f"converged ({result.reason})" if result.converged else f"not converged: {result.reason}"
    out = []
    if not result.converged and result.stop != "parameter at bound":  # that one: the at_bound warning below
        steps = "iterations" if result.method == "eigensensitivity" else "objective calls"
        out.append(TrustWarning(
            "run", "not_converged",
            f"did not converge ({result.reason}, after {result.iterations} {steps}): its values are where it stopped, "
            f"not updated parameters", source))
    for name, value in result.parameters.items():
        if not bounds or name not in bounds:
            continue
        lower, upper = bounds[name]
        side = at_bound(value, lower, upper, tolerance)
        if side is not None:
            bound = lower if side == "lower" else upper
            out.append(TrustWarning(
                name, "at_bound",
                f"{name} = {value:.6g} ended on its {side} bound {bound:.6g} ({state}): the targets may not be "
                f"reachable within the bounds [{lower:.6g}, {upper:.6g}]", source))
    std = uncertainty.std if isinstance(uncertainty, ParameterUncertainty) else uncertainty
    if std:
        flagged = {w.subject for w in out}
        values = {n: v for n, v in result.parameters.items() if n not in flagged}
        finite = {n: s for n, s in std.items() if s is not None and np.isfinite(s)}
        out += uncertainty_warnings(values, finite, "propagated", source)
    if target_std_hz is not None:
        out += target_miss_warnings(result, target_std_hz)
    return tuple(out)


def target_misses_sigma(result: UpdatingResult, target_std_hz: ArrayLike) -> NDArray[np.float64]:
    """Per target, (f_model − f_target)/σ: the updated model's paired frequency's miss in
    units of the target's standard deviation (NaN where σ is not a positive number)."""
    sigma = np.asarray(target_std_hz, dtype=float)
    miss = result.frequencies_hz("final") - result.targets.frequencies_hz
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(sigma > 0, miss / sigma, np.nan)


def misses_left_by_a_step(result: UpdatingResult, target_std_hz: ArrayLike,
                          weights: ArrayLike | None = None) -> NDArray[np.float64]:
    """Per target, what :func:`target_misses_sigma` would be after one more Gauss–Newton
    step on the run's weighted frequency residual (``w_i (f_i/f_t,i − 1)²``), linearised with
    the run's last sensitivity: the part of the miss no change of the run's parameters can
    remove — the model's own error. The mode-shape terms are left out, so a run that also
    weighs shapes is credited with reaching frequencies it trades against them. Without a
    sensitivity (the start met the run's tolerance), the misses as they are: no step is known.
    ``weights``: the step's weights instead of the run's ``w`` (the same length)."""
    z = target_misses_sigma(result, target_std_hz)
    if result.sensitivity is None:
        return z
    targets = result.targets
    n = targets.n_modes
    scale = np.array([abs(v) if v != 0 else 1.0 for v in result.parameters.values()])  # like with like
    s = np.asarray(result.sensitivity, dtype=float)[:n] * scale[None, :]
    root_w = np.sqrt(np.asarray(targets.weights if weights is None else weights, dtype=float))
    relative = result.frequencies_hz("final") / targets.frequencies_hz - 1.0
    step = np.linalg.lstsq(s * root_w[:, None], -root_w * relative, rcond=None)[0]
    sigma = np.asarray(target_std_hz, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(sigma > 0, (relative + s @ step) * targets.frequencies_hz / sigma, np.nan)


def target_miss_warnings(result: UpdatingResult, target_std_hz: ArrayLike,
                         limit: float = MISS_LIMIT_SIGMA) -> list[TrustWarning]:
    """``targets_missed``, ``stopped_short`` and ``unfitted_target_missed`` (module
    docstring) for a converged run; nothing when every target is met within ``limit`` σ or
    the run did not converge (its own warning says so)."""
    if not result.converged:
        return []
    z = target_misses_sigma(result, target_std_hz)
    targets = result.targets
    final = result.frequencies_hz("final")
    far = [i for i in np.argsort(-np.nan_to_num(np.abs(z))) if np.abs(z[i]) > limit]
    fitted = [i for i in far if targets.weights[i] > 0]
    unfitted = [i for i in far if targets.weights[i] <= 0]
    parameters = "{" + ", ".join(result.parameters) + "}"
    source = result.name or result.method
    note = f" (σ: the target's standard deviation; beyond {limit:g}σ is beyond its noise)"

    def misses(indices: list[int]) -> str:
        return "; ".join(f"{targets.labels[i]} {targets.frequencies_hz[i]:.6g} Hz → {final[i]:.6g} Hz "
                         f"({100 * (final[i] / targets.frequencies_hz[i] - 1):+.2g} %, {z[i]:+.3g}σ)" for i in indices)

    out = []
    if fitted:
        left = misses_left_by_a_step(result, target_std_hz)
        plural, them = ("s", "them") if len(fitted) > 1 else ("", "it")
        weighted = [i for i in range(targets.n_modes) if targets.weights[i] > 0]
        # whether any change meets them: the step that minimises the misses in σ over the weighted targets
        relative_std = np.asarray(target_std_hz, dtype=float) / targets.frequencies_hz
        with np.errstate(divide="ignore"):
            by_noise = np.where((targets.weights > 0) & (relative_std > 0), 1.0 / relative_std**2, 0.0)
        best = misses_left_by_a_step(result, target_std_hz, by_noise)
        # every weighted target, not only those missed now: the step that meets these may move another past its noise
        if result.sensitivity is not None and any(np.abs(best[i]) > limit for i in weighted):
            out.append(TrustWarning("targets", "targets_missed",
                                    f"misses its weighted target{plural}: {misses(fitted)}; no change of {parameters} "
                                    f"meets {them}, and the ± propagated from the targets' uncertainty leaves out this "
                                    "model error" + note, source))
        elif result.sensitivity is not None and any(np.abs(left[i]) > limit for i in weighted):
            out.append(TrustWarning("targets", "targets_missed",
                                    f"misses its weighted target{plural}: {misses(fitted)}; a change of {parameters} "
                                    f"meets every weighted target within its noise, but not at the run's weights, which "
                                    f"trade a target known finely against others beyond its noise: weigh each target by "
                                    f"1/(its relative std)² ([targets] weights)" + note, source))
        else:
            whose = "targets'" if plural else "target's"
            finest = min(relative_std[i] for i in fitted)
            tighten = (f"set [eigensensitivity] frequency_tolerance below {finest:.2g} (the targets' relative std)"
                       if result.method == "eigensensitivity" else "tighten [optimisation] ftol and xtol")
            out.append(TrustWarning("targets", "stopped_short",
                                    f"stopped short of its target{plural}: {misses(fitted)}, within its stopping "
                                    f"tolerance but beyond the {whose} noise: " + (
                                        f"one more step of {parameters} would meet {them}, and its ± is smaller than "
                                        "where it stopped" if result.sensitivity is not None else
                                        f"it met its tolerance at its start, before any step, so whether a change of "
                                        f"{parameters} meets {them} is not known") + f"; {tighten}" + note, source))
    if unfitted:
        plural = "s" if len(unfitted) > 1 else ""
        out.append(TrustWarning("targets", "unfitted_target_missed",
                                f"misses {misses(unfitted)}, {'targets' if plural else 'a target'} of weight 0 it was not fitted to: the "
                                "updated model does not hold where it was not fitted" + note, source))
    return out
