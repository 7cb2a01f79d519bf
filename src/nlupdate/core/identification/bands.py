"""95 % bands of identified values: noise, model-form error and bounds (docs/methods.md §4, "Intervals").

An identified value θ̂ has three sources of evidence about its error, combined here:

* **Noise** — Monte-Carlo re-identifications θ̃ of the data with fresh noise of the
  measured level (:mod:`nlupdate.core.identification.uncertainty`). Their deviations from
  θ̂ stand in for θ̂'s own deviation from what noise-free data would give (a parametric
  bootstrap), so the interval is the *basic* bootstrap one, ``[2θ̂ − q₉₇.₅, 2θ̂ − q₂.₅]``:
  centred at ``θ̂ − (median − θ̂)``. A model that does not describe the data has an
  estimate that moves with the noise (adding noise moved BRB's cubic+jenkins k3 from
  7.80e10 to a median of 8.6e10); the noisy estimate is then off by about that shift from
  the noise-free one, on the other side, and the band is centred there. The raw
  percentile interval ``[q₂.₅, q₉₇.₅]`` is centred on the *doubly* noisy median: it held
  BRB's k3 = 7.80e10 outside [8.06, 9.19]e10.
* **Model form** — when the fit's residual is R > 1 times the noise, the misfit is not
  noise and the value depends on which levels were fitted. The leave-one-level-out refits
  θ₍ⱼ₎ (a jackknife over the levels, ``σ_J² = (n−1)/n·Σ(θ₍ⱼ₎ − θ̄)²``) measure that; the
  share of their variance the noise does not already explain is ``1 − 1/R²``, so the
  model-form standard deviation is ``σ_M = σ_J·√(1 − 1/R²)`` and it enters with Student's
  t for n − 1 degrees of freedom. Without a jackknife (fewer than three refits) the noise
  deviations are scaled by R instead (the residual-scaled covariance, Birge's ratio).
  With R ≤ 1 (the fit is at the noise) the band is the noise band.
* **Bounds** — a value on a limit of its parameter (an Iwan χ at −1 or 0, a parameter
  fixed because the data cannot show it, a log-parameter on the fit's box) is bounded by
  the data on one side only: the band runs from the limit to the far end of the
  noise and model-form band or of the samples, or, when that has no width (every refit on the limit too),
  to the parameter's other limit (the data do not determine it). :class:`Bound` names it.

Whatever the parts, the band always contains θ̂.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any, Callable, Mapping, Sequence

import numpy as np
import scipy.stats
from numpy.typing import ArrayLike, NDArray

#: A value within this share of its interval's width from an end sits on that end.
INTERVAL_END_TOLERANCE = 1e-3
#: Fewer leave-one-level-out refits than this: the residual-scaled fallback.
MIN_JACKKNIFE = 3


@dataclass(frozen=True)
class Bound:
    """A limit a value sits on: ``side`` ``lower`` or ``upper`` (the value cannot go below /
    above ``limit``; empty: the side the Monte-Carlo samples leave free), ``far``: the
    parameter's other limit (±inf when it has none; NaN: inf above a lower limit, 0 below an
    upper one, as for a positive parameter), ``why``: one phrase naming the limit;
    ``open``: the data say nothing on the free side either (a value fixed, or a lower bound
    by construction): the band reaches ``far`` whatever the samples."""

    side: str
    limit: float
    far: float
    why: str
    open: bool = False

    def as_dict(self) -> dict[str, object]:
        return {"side": self.side, "limit": self.limit, "far": self.far, "why": self.why, "open": self.open}


def band_arrays(value: ArrayLike, samples: ArrayLike, residual_ratio: float | None = None,
                jackknife: ArrayLike | None = None) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The 95 % band (low, high) of each entry of ``value`` (shape (m,); module docstring)
    from its Monte-Carlo ``samples`` (n, m), the fit's ``residual_ratio`` R (None or ≤ 1:
    at the noise) and its leave-one-level-out refits ``jackknife`` (k, m). NaN where fewer
    than two samples are finite and no refits widen it."""
    value = np.atleast_1d(np.asarray(value, dtype=float))
    m = value.size
    samples = np.asarray(samples, dtype=float).reshape(-1, m)
    jack = np.full((0, m), np.nan) if jackknife is None else np.asarray(jackknife, dtype=float).reshape(-1, m)
    ratio = float(residual_ratio) if residual_ratio is not None and np.isfinite(residual_ratio) else 1.0
    excess = 1.0 - 1.0 / ratio**2 if ratio > 1 else 0.0
    finite = np.isfinite(samples)
    has = finite.sum(axis=0) >= 2
    with warnings.catch_warnings(), np.errstate(invalid="ignore", over="ignore"):
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN columns: NaN, as documented
        low_q, median, high_q = (np.nanpercentile(np.where(finite, samples, np.nan), [2.5, 50.0, 97.5], axis=0)
                                 if samples.shape[0] else np.full((3, m), np.nan))
        centre = np.where(has, 2 * value - median, value)
        below, above = np.where(has, high_q - median, np.nan), np.where(has, median - low_q, np.nan)
        count = np.isfinite(jack).sum(axis=0)
        mean = np.nanmean(np.where(np.isfinite(jack), jack, np.nan), axis=0) if jack.shape[0] else np.full(m, np.nan)
        sigma = np.sqrt((count - 1) / np.maximum(count, 1) * np.nansum((jack - mean) ** 2, axis=0))
        sigma = np.where(count >= MIN_JACKKNIFE, sigma, np.nan)
        if excess:
            birge = ~np.isfinite(sigma)  # no jackknife: the residual-scaled noise band
            below, above = np.where(birge, ratio * below, below), np.where(birge, ratio * above, above)
            model = scipy.stats.t.ppf(0.975, np.maximum(count - 1, 1)) * sigma * np.sqrt(excess)
            use = np.isfinite(model)
            below = np.where(use, np.where(np.isnan(below), model, np.hypot(below, model)), below)
            above = np.where(use, np.where(np.isnan(above), model, np.hypot(above, model)), above)
        low, high = centre - below, centre + above
    return np.where(np.isfinite(low), np.minimum(low, value), np.nan), \
        np.where(np.isfinite(high), np.maximum(high, value), np.nan)


def band(value: float, samples: ArrayLike, residual_ratio: float | None = None,
         jackknife: ArrayLike = (), bound: Bound | None = None, positive: bool = False) -> tuple[float, float]:
    """The 95 % band (low, high) of ``value`` (module docstring): ``samples`` its
    Monte-Carlo re-identifications, ``residual_ratio`` R the fit's residual over the noise
    (None or ≤ 1: at the noise), ``jackknife`` its leave-one-level-out refits, ``bound`` the
    limit it sits on (``side`` empty: the side the samples leave free); ``positive``: the
    value cannot be negative (a stiffness, a slip force, a frequency), the band stops at 0.
    NaN without samples or refits to draw it from."""
    values = np.asarray(samples, dtype=float)
    values = values[np.isfinite(values)]
    lows, highs = band_arrays([value], values[:, None], residual_ratio, np.asarray(jackknife, dtype=float)[:, None])
    low, high = float(lows[0]), float(highs[0])
    if positive and low < 0 <= value:
        low = 0.0
    if bound is not None and np.isfinite(value):
        side = bound.side or ("upper" if values.size and np.max(values) <= value and np.min(values) < value else "lower")
        far = bound.far if not np.isnan(bound.far) else (np.inf if side == "lower" else 0.0)
        tiny = float("inf") if bound.open else 1e-9 * max(abs(value), abs(bound.limit), 1e-300)
        if side == "lower":  # the free side reaches the samples' far end too (reflected, it would cross the limit)
            high = max(high, float(np.percentile(values, 97.5))) if values.size >= 2 else high
            low, high = bound.limit, (high if np.isfinite(high) and high - value > tiny else far)
        else:
            low = min(low, float(np.percentile(values, 2.5))) if values.size >= 2 else low
            low, high = (low if np.isfinite(low) and value - low > tiny else far), bound.limit
    return float(low), float(high)


def parameter_bounds(model: Any, values: Mapping[str, float], at_bound: Sequence[str] = ()) -> dict[str, Bound]:
    """The limits the identified ``values`` of a physical ``model``
    (:class:`~nlupdate.core.identification.dfmodels.PhysicalModel`) sit on, by name:

    * an interval parameter (an Iwan joint's χ ∈ (−1, 0)) within
      :data:`INTERVAL_END_TOLERANCE` of an end;
    * the parameters an Iwan refit fixed because no level reaches macroslip
      (:func:`~nlupdate.core.identification.dfmodels.iwan_identifiability`): β at 0, and K_T
      and F_S, which are then lower bounds;
    * ``at_bound``: parameters that ended on the fit's box (the side left to the samples).

    Empty for any other model."""
    from nlupdate.core.identification.dfmodels import PhysicalModel

    if not isinstance(model, PhysicalModel):
        return {}
    out: dict[str, Bound] = {}
    for name in at_bound:
        if name in values:
            out[name] = Bound("", float(values[name]), float("nan"),
                              "ended on the fit's box (log-parameters stay within a factor 1e6 of their start)")
    inside, low, high = model._intervals()
    for name, is_interval, lo, hi in zip(model.names, inside, low, high):
        value = values.get(name)
        if not is_interval or value is None:
            continue
        if value - lo <= INTERVAL_END_TOLERANCE * (hi - lo):
            out[name] = Bound("lower", float(lo), float(hi), f"at the end {lo:g} of its interval ({lo:g}, {hi:g})")
        elif hi - value <= INTERVAL_END_TOLERANCE * (hi - lo):
            out[name] = Bound("upper", float(hi), float(lo), f"at the end {hi:g} of its interval ({lo:g}, {hi:g})")
    fixed = dict(model.fixed)
    for name in fixed:
        if not name.startswith("beta"):
            continue
        suffix = name[len("beta"):]
        why = "no measured level reaches the Iwan joint's macroslip"
        out[name] = Bound("lower", 0.0, float("inf"), f"fixed at 0: {why}", open=True)
        for other in (f"kt{suffix}", f"slip_force{suffix}"):
            if other in values:
                out[other] = Bound("lower", float(values[other]), float("inf"),
                                   f"a lower bound: {why} (beta fixed at 0, phi_max at the largest amplitude)",
                                   open=True)
    return out


def leave_one_level_out(refit: Callable[[float], Mapping[str, Any]],
                        levels: Sequence[float]) -> tuple[list[Mapping[str, Any]], dict[str, list[float]]]:
    """``refit(level)`` (the values identified without that level) for each of ``levels``:
    (the values of every refit that succeeded, why the others failed: message → levels)."""
    values: list[Mapping[str, Any]] = []
    failures: dict[str, list[float]] = {}
    for level in levels:
        try:
            values.append(refit(float(level)))
        except (ValueError, ArithmeticError, np.linalg.LinAlgError) as error:
            failures.setdefault(f"{type(error).__name__}: {error}".splitlines()[0], []).append(float(level))
    return values, failures


def positive_names(model: Any, values: Mapping[str, float]) -> set[str]:
    """The names among ``values`` that cannot be negative: the positive parameters of a
    physical ``model`` and the linear modes' ``linear_f<i>_hz`` and ``linear_eta<i>``."""
    from nlupdate.core.identification.dfmodels import PhysicalModel

    out = {name for name in values if name.startswith(("linear_f", "linear_eta"))}
    if isinstance(model, PhysicalModel):
        out |= {name for _, name, positive in model._all_slots() if positive and name in values}
    return out
