"""Uncertainty of identified parameters by Monte Carlo over the noise model.

The noise model is the one of docs/methods.md §8: every measured receptance carries circular
complex normal noise of standard deviation ``fraction·|H|``. Given an estimator (a
function of the measured curves) and the noise fraction — known, or estimated from the
low-force sweep by :func:`nlupdate.core.identification.data.estimate_noise_fraction` — the
measured data are perturbed ``n_samples`` times with fresh noise of that level and
re-identified. To first order in the noise the spread of those estimates around the
point estimate is the sampling spread of the estimator, so each parameter is reported
as the point estimate, the Monte-Carlo mean ± standard deviation, the samples' median and
a 95 % interval (``benchmarks/reproduce_source.py`` measures its coverage over independent
noise seeds).

The interval (:mod:`nlupdate.core.identification.bands`) is the basic bootstrap one: the
samples' deviations from their median, reflected about the estimate (centred at
``value − (median − value)``), widened by the model-form error when the fit's residual is
above the noise (leave-one-level-out refits, or the residual ratio), one-sided for a value
on a limit, and always holding the estimate. The samples carry the noise of the data
*and* the added noise, so an estimator whose result moves with the noise (a biased one —
above all a model that does not describe the data, whose fit then depends on the noise
realisation) has its samples centred away from the estimate, on the far side from the
noise-free value: the raw percentile interval then holds neither (BRB cubic+jenkins k3
7.80e10 outside [8.06, 9.19]e10; a linear mode extracted with the nonlinearity misplaced,
docs/methods.md §4, at 89.24 Hz with its samples in [89.19, 89.21] Hz). That shift,
``median − value``, is reported (:attr:`ParameterStatistics.shift`) and warned about when
it exceeds the interval's half-width (:func:`nlupdate.core.identification.trust.shift_warnings`).

Curves the estimate returns beside its
numbers (a fitted describing function over amplitude, an extracted FRF over frequency)
get a 95 % band the same way (:class:`CurveBand`).
"""
from __future__ import annotations

import re
from collections import Counter
from dataclasses import dataclass, field
from typing import Any, Callable, Collection, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.identification.bands import Bound, band, band_arrays
from nlupdate.core.identification.data import FRFLevels
from nlupdate.progress import ProgressCallback, no_progress


@dataclass(frozen=True)
class ParameterStatistics:
    """One parameter: point estimate, Monte-Carlo mean, std and median, and the 95 %
    interval of the point estimate (module docstring; SI); count: the samples behind them;
    bound: the limit it sits on (its interval then one-sided), if any."""

    value: float
    mean: float
    std: float
    ci95: tuple[float, float]
    median: float = float("nan")
    count: int = 0
    bound: Bound | None = None

    @property
    def shift(self) -> float:
        """median of the samples − point estimate: how far the estimate moves when noise is
        added (0 for an unbiased estimator, to within the sampling error)."""
        return self.median - self.value

    def as_dict(self) -> dict[str, Any]:
        return {"value": self.value, "mean": self.mean, "std": self.std, "ci95": list(self.ci95),
                "mc_median": self.median, **({"bound": self.bound.as_dict()} if self.bound else {})}


#: The most sample curves a :class:`CurveBand` keeps in memory at once (a 95 % band is
#: well determined long before; the rest of the samples still count for the numbers).
MAX_CURVE_SAMPLES = 2000

Pair = tuple[NDArray[np.float64], NDArray[np.float64]]


@dataclass(frozen=True, eq=False)
class CurveBand:
    """The 95 % band of a complex curve z(x) (:func:`~nlupdate.core.identification.bands.band_arrays`
    on every x: the Monte-Carlo samples reflected about the point curve, widened by the
    leave-one-level-out curves when the fit is not at the noise, holding the point curve).

    Each of ``real``, ``imag``, ``magnitude`` and ``phase_offset_deg`` is a (low, high)
    pair of arrays on ``x``: the band of Re z, Im z, |z| and of the phase of z relative to
    the point estimate (degrees, in (−180, 180]: add it to the point curve's phase). NaN
    where fewer than two samples have a finite value. ``n_samples``: the curves that went
    into it. Units: those of z and x (N/m over m for a describing function, m/N over Hz for
    a receptance).
    """

    x: NDArray[np.float64]
    real: Pair
    imag: Pair
    magnitude: Pair
    phase_offset_deg: Pair
    n_samples: int

    @classmethod
    def of(cls, x: NDArray, point: NDArray, samples: NDArray, residual_ratio: float | None = None,
           jackknife: NDArray | None = None) -> "CurveBand":
        """The band of ``samples`` (one complex curve per row) around the ``point`` curve;
        ``residual_ratio`` and ``jackknife`` (the leave-one-level-out curves, one per row)
        as for a value (:func:`~nlupdate.core.identification.bands.band_arrays`)."""
        size = np.size(x)
        point = np.asarray(point, dtype=complex).reshape(size)
        samples = np.asarray(samples, dtype=complex).reshape(-1, size)
        jack = np.zeros((0, size), dtype=complex) if jackknife is None else \
            np.asarray(jackknife, dtype=complex).reshape(-1, size)
        with np.errstate(divide="ignore", invalid="ignore"):
            offset, jack_offset = (np.degrees(np.angle(c / point[None, :])) for c in (samples, jack))

        def part(value: NDArray, values: NDArray, refits: NDArray) -> Pair:
            return band_arrays(value, np.where(np.isfinite(values), values, np.nan), residual_ratio, refits)

        return cls(np.asarray(x, dtype=float), part(point.real, samples.real, jack.real),
                   part(point.imag, samples.imag, jack.imag), part(np.abs(point), np.abs(samples), np.abs(jack)),
                   part(np.zeros(size), offset, jack_offset), int(samples.shape[0]))


@dataclass(frozen=True)
class Uncertainty:
    """Monte-Carlo statistics of every parameter and how they were obtained.

    failures: why samples failed, message → count (a failed sample is left out as a
    whole: its parameters and curves). curves: the 95 % band of each curve the estimate
    returned, by name. residual_ratio: the fit's residual over the noise the intervals
    allowed for (None: not known, taken as at the noise); jackknife_fits: the
    leave-one-level-out refits behind the model-form part (0: none).
    """

    parameters: dict[str, ParameterStatistics]
    noise_fraction: float
    n_samples: int
    n_failed: int
    seed: int
    failures: dict[str, int] = field(default_factory=dict)
    curves: dict[str, CurveBand] = field(default_factory=dict)
    residual_ratio: float | None = None
    jackknife_fits: int = 0

    def failure_reasons(self) -> list[tuple[str, int]]:
        """(reason, count) of the failed samples, most frequent first: a failure's message without
        its exception name and its parenthesised numbers (a band's edges), so one reason is
        counted once whatever the numbers."""
        grouped: Counter[str] = Counter()
        for message, count in self.failures.items():
            grouped[re.sub(r" \([^()]*\)", "", message.split(": ", 1)[-1])] += count
        return grouped.most_common()

    def as_dict(self) -> dict[str, Any]:
        return {
            "method": "Monte Carlo over the noise model (docs/methods.md §8): data perturbed with circular complex "
                      "normal noise of std noise_fraction·|H| and re-identified; ci95 = the basic bootstrap interval "
                      "(the samples' deviations from mc_median reflected about the value), widened by the model-form "
                      "error when residual_ratio > 1 (leave-one-level-out refits: t·σ_J·√(1 − 1/R²); without them "
                      "the deviations times R), one-sided for a value on a limit (bound), and holding the value; "
                      "mc_median − value is how far the estimate moves with the noise (docs/methods.md §4, Intervals)",
            "noise_fraction": self.noise_fraction,
            "n_samples": self.n_samples,
            "n_failed": self.n_failed,
            "failures": dict(self.failures),
            "seed": self.seed,
            "residual_ratio": self.residual_ratio,
            "jackknife_fits": self.jackknife_fits,
        }


def _one_sample(estimate: Callable, data: FRFLevels, fraction: float, seed: int) -> Mapping[str, Any] | str:
    """The sample's values, or why it failed (one line)."""
    try:
        value = estimate(data.with_noise(fraction, np.random.default_rng(seed)))
    except (ValueError, np.linalg.LinAlgError, ArithmeticError) as error:  # ArithmeticError: 1/0, overflow too
        return f"{type(error).__name__}: {error}".splitlines()[0]
    return value if isinstance(value, Mapping) else value.parameters()


def monte_carlo(
    estimate: Callable[[FRFLevels], Any],
    data: FRFLevels,
    point: dict[str, float],
    noise_fraction: float,
    n_samples: int = 100,
    seed: int = 0,
    progress: ProgressCallback = no_progress,
    curves: Mapping[str, tuple[NDArray, NDArray]] | None = None,
    residual_ratio: float | None = None,
    jackknife: Sequence[Mapping[str, Any]] = (),
    bounds: Mapping[str, Bound] | None = None,
    positive: Collection[str] = (),
) -> Uncertainty:
    """Statistics of ``estimate(perturbed data)`` over ``n_samples`` noise draws.

    ``estimate`` returns a mapping of named values, or an object whose ``parameters()``
    does (an identification result); ``point`` names the values to report. ``curves``:
    name → (x, point-estimate curve) of complex curves the mapping also holds (each on
    that x); each gets a :class:`CurveBand` from the first :data:`MAX_CURVE_SAMPLES`
    samples that return it with the point curve's shape.

    ``residual_ratio`` (the fit's residual over the noise), ``jackknife`` (the values of
    each leave-one-level-out refit) and ``bounds`` (the limits values sit on, by name) set
    each parameter's interval beside the samples (:func:`~nlupdate.core.identification.bands.band`);
    the intervals of the ``positive`` names stop at 0.

    Samples are drawn from ``seed`` and identified in order (``progress("Monte-Carlo
    samples", done, n_samples)`` after each). Samples whose identification
    fails are counted in ``n_failed`` and their reasons in ``failures``; a parameter with
    fewer than 2 successful samples gets NaN statistics.
    """
    if n_samples < 2:
        raise ValueError(f"n_samples must be at least 2, got {n_samples}")
    if not np.isfinite(noise_fraction) or noise_fraction < 0:
        raise ValueError(f"noise_fraction must be a finite number ≥ 0, got {noise_fraction}")
    seeds = np.random.SeedSequence(seed).generate_state(n_samples)
    curves = dict(curves or {})
    good: list[Mapping[str, float]] = []
    failures: Counter[str] = Counter()
    sample_curves: dict[str, list[NDArray]] = {name: [] for name in curves}
    for done, sample_seed in enumerate(seeds, start=1):
        sample = _one_sample(estimate, data, float(noise_fraction), int(sample_seed))
        if isinstance(sample, str):
            failures[sample] += 1
        else:
            for name, (_, point_curve) in curves.items():
                curve = sample.get(name)
                if curve is not None and np.shape(curve) == np.shape(point_curve) and \
                        len(sample_curves[name]) < MAX_CURVE_SAMPLES:
                    sample_curves[name].append(np.asarray(curve, dtype=complex))
            good.append({k: v for k, v in sample.items() if k not in curves})
        progress("Monte-Carlo samples", done, n_samples)
    stats = {}
    bounds = dict(bounds or {})
    for name, value in point.items():
        values = np.array([s[name] for s in good if name in s and np.isfinite(s[name])])
        refits = [float(j[name]) for j in jackknife if name in j]
        interval = band(float(value), values, residual_ratio, refits, bounds.get(name), name in positive)
        if values.size >= 2:
            with np.errstate(over="ignore", invalid="ignore"):
                mean, std = float(values.mean()), float(values.std(ddof=1))
            stats[name] = ParameterStatistics(float(value), mean, std, interval, float(np.median(values)),
                                              int(values.size), bounds.get(name))
        else:
            stats[name] = ParameterStatistics(float(value), float("nan"), float("nan"), interval,
                                              bound=bounds.get(name))
    bands = {name: CurveBand.of(x, point_curve, np.array(sample_curves[name]).reshape(-1, np.size(x)), residual_ratio,
                                np.array([j[name] for j in jackknife if np.shape(j.get(name)) == np.shape(point_curve)])
                                .reshape(-1, np.size(x)))
             for name, (x, point_curve) in curves.items()}
    return Uncertainty(stats, float(noise_fraction), n_samples, n_samples - len(good), seed,
                       dict(failures.most_common()), bands, residual_ratio, len(jackknife))
