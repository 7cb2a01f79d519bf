"""Least-squares fit of the parameters of several effects from several starts.

Parameters are fitted through unknowns with the sign built in: ``log v`` for a positive
parameter, ``log(−v)`` for a negative one and ``v/s`` for a parameter of either sign (s =
the magnitude of its start). The residual function maps the effects' SI values to the
residual vector whose sum of squares is χ² (see :mod:`nlupdate.core.discovery.candidates`).
:func:`fit_at_place` fits one candidate at a place together with the effects found there
before (the "companions").
"""
from __future__ import annotations

from typing import Callable, Protocol, Sequence

import numpy as np
import scipy.optimize
from numpy.typing import NDArray

from nlupdate.core.discovery.candidates import CandidateFit, FoundEffect
from nlupdate.core.discovery.effects import NEGATIVE, POSITIVE, DFSamples, Effect
from nlupdate.core.discovery.starts import joint_starts

Residual = Callable[[list[NDArray[np.float64]]], NDArray[np.float64]]


class Linearised(Protocol):
    """A model solved at one set of values: its residual, and ∂r/∂θ (n_residuals,
    n_unknowns) where ``perturbed[j]`` are the values with unknown θ_j stepped by ``steps[j]``."""

    def residual(self) -> NDArray[np.float64]: ...

    def jacobian(self, perturbed: list[list[NDArray]], steps: NDArray) -> NDArray[np.float64]: ...


_LOG_LIMIT = 60.0  # unknowns of log-parameters stay within e^±60 of their start
_DIFF_STEP = 1e-7  # relative step of the unknowns in finite differences


class _Unknowns:
    """Map between the effects' SI values and the fitted unknown vector."""

    def __init__(self, effects: Sequence[Effect], start: Sequence[NDArray]) -> None:
        self.signs = [p.sign for effect in effects for p in effect.parameters]
        self.sizes = [len(effect.parameters) for effect in effects]
        flat = np.concatenate([np.atleast_1d(np.asarray(v, dtype=float)) for v in start])
        self.scales = np.where(np.abs(flat) > 0, np.abs(flat), 1.0)

    def encode(self, values: Sequence[NDArray]) -> NDArray[np.float64]:
        flat = np.concatenate([np.atleast_1d(np.asarray(v, dtype=float)) for v in values])
        out = np.empty_like(flat)
        for i, (sign, value) in enumerate(zip(self.signs, flat)):
            if sign in (POSITIVE, NEGATIVE):
                out[i] = np.log(max(sign * value, 1e-300))
            else:
                out[i] = value / self.scales[i]
        return out

    def decode(self, unknowns: NDArray) -> list[NDArray[np.float64]]:
        flat = np.array([
            sign * np.exp(u) if sign in (POSITIVE, NEGATIVE) else u * scale
            for sign, u, scale in zip(self.signs, unknowns, self.scales)
        ])
        return list(np.split(flat, np.cumsum(self.sizes)[:-1]))

    def bounds(self, x0: NDArray) -> tuple[NDArray, NDArray]:
        is_log = np.array([sign in (POSITIVE, NEGATIVE) for sign in self.signs])
        low = np.where(is_log, x0 - _LOG_LIMIT, -np.inf)
        high = np.where(is_log, x0 + _LOG_LIMIT, np.inf)
        return low, high


def fit_effects(
    residual: Residual, effects: Sequence[Effect], starts: Sequence[Sequence[NDArray]], max_nfev: int = 40, refine: int = 2,
    linearise: Callable[[list[NDArray]], Linearised] | None = None,
) -> tuple[list[NDArray[np.float64]], float, bool]:
    """Best SI values (one array per effect), χ² and success.

    Each start set holds one value array per effect; the ``refine`` starts of smallest χ²
    are refined by trust-region least squares. Non-finite residuals count as a large misfit
    so the search backs off from them. ``linearise(values)``: the model solved once at
    ``values``, giving the residual and its Jacobian (:class:`Linearised`); without it every
    Jacobian column is a forward difference of the whole residual.
    """

    def guarded(values: Sequence[NDArray]) -> NDArray[np.float64]:
        with np.errstate(all="ignore"):
            r = residual(list(values))
        return np.where(np.isfinite(r), r, 1e6)

    ranked = sorted(starts, key=lambda start: float(np.sum(guarded(start) ** 2)))
    best: tuple[float, list[NDArray], bool] | None = None
    for start in ranked[:refine]:
        unknowns = _Unknowns(effects, start)
        x0 = unknowns.encode(start)
        low, high = unknowns.bounds(x0)
        if linearise is None:
            fun, jac = (lambda u: guarded(unknowns.decode(u))), "2-point"
        else:
            fun, jac = _solved_once(linearise, unknowns)
        result = scipy.optimize.least_squares(
            fun, x0, jac=jac, bounds=(low, high), method="trf", max_nfev=max_nfev * (len(x0) + 1),
            diff_step=_DIFF_STEP, ftol=1e-6, xtol=1e-7,
        )
        values = unknowns.decode(result.x)
        chi2 = float(np.sum(guarded(values) ** 2))
        ok = bool(np.all(np.isfinite(result.x))) and result.status >= 0
        if best is None or chi2 < best[0]:
            best = (chi2, values, ok)
    assert best is not None, "fit_effects needs at least one start"
    return best[1], best[0], best[2]


def _solved_once(linearise: Callable[[list[NDArray]], Linearised], unknowns: _Unknowns):
    """Residual and Jacobian functions of the unknowns for least squares, sharing the solve
    at the last point asked for (least squares asks for the Jacobian where it has just
    evaluated the residual). Non-finite residuals are held at 1e6, their derivatives at 0."""
    last: list = [None, None]

    def solved(u: NDArray) -> Linearised:
        if last[0] is None or not np.array_equal(last[0], u):
            with np.errstate(all="ignore"):
                last[:] = [np.array(u), linearise(unknowns.decode(u))]
        return last[1]

    def fun(u: NDArray) -> NDArray[np.float64]:
        with np.errstate(all="ignore"):
            r = solved(u).residual()
        return np.where(np.isfinite(r), r, 1e6)

    def jac(u: NDArray) -> NDArray[np.float64]:
        steps = _DIFF_STEP * np.maximum(1.0, np.abs(u))
        perturbed = [unknowns.decode(u + step * unit) for step, unit in zip(steps, np.eye(u.size))]
        with np.errstate(all="ignore"):
            j = solved(u).jacobian(perturbed, steps)
            flat = ~np.isfinite(solved(u).residual())
        return np.where(np.isfinite(j) & ~flat[:, None], j, 0.0)

    return fun, jac


class Place(Protocol):
    """What :func:`fit_at_place` needs from a fitting context (FRF or modal)."""

    dofs: tuple[int, ...]
    companions: tuple[FoundEffect, ...]
    samples: DFSamples
    penalty: float

    @property
    def n_data(self) -> int: ...

    def residual(self, effects: Sequence[Effect], values: Sequence[NDArray]) -> NDArray[np.float64]: ...


def _without(samples: DFSamples, effects: Sequence[Effect], values: Sequence[NDArray]) -> DFSamples:
    """Samples minus the DFs of effects at given values."""
    taken = sum((e.nu(v, samples.amplitude, samples.omega) for e, v in zip(effects, values)), np.zeros_like(samples.nu))
    return DFSamples(samples.amplitude, samples.omega, samples.nu - taken, samples.std)


def fit_at_place(place: Place, effect: Effect) -> CandidateFit:
    """Fit ``effect`` at the place together with the companions (effects found there earlier)
    and score it against the current model (companions at their values, no candidate).

    Starts: the joint variable-projection starts of candidate and companions on the place's
    apparent DF (:func:`nlupdate.core.discovery.starts.joint_starts`), and the candidate's own
    starts on what the companions at their current values leave unexplained.
    """
    companions = [c.effect for c in place.companions]
    current = [np.array(c.values) for c in place.companions]
    effects = [effect] + companions
    baseline = float(np.sum(place.residual(companions, current) ** 2))
    starts = joint_starts(effects, place.samples)
    if companions:
        starts += [own + current for own in joint_starts([effect], _without(place.samples, companions, current))]
    # a place that solves once for residual and Jacobian (FRFContext) says so by linearise
    solve = getattr(place, "linearise", None)
    linearise = None if solve is None else (lambda v: solve(effects, v))
    values, chi2, success = fit_effects(lambda v: place.residual(effects, v), effects, starts, linearise=linearise)
    refitted = tuple(
        FoundEffect(c.effect, c.dofs, tuple(float(x) for x in v)) for c, v in zip(place.companions, values[1:])
    )
    return CandidateFit(
        effect=effect, dofs=place.dofs, values=tuple(float(x) for x in values[0]), chi2=chi2, baseline_chi2=baseline,
        n_data=place.n_data, score=chi2 - baseline + len(effect.parameters) * place.penalty, success=success,
        companions=refitted,
    )
