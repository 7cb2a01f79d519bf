"""Uncertainty of identified parameters by Monte Carlo over the noise model.

The noise model is the one of METHODS §8: every measured receptance carries circular
complex normal noise of standard deviation ``fraction·|H|``. Given an estimator (a
function of the measured curves) and the noise fraction — known, or estimated from the
low-force sweep by :func:`nlupdate.identification.data.estimate_noise_fraction` — the
measured data are perturbed ``n_samples`` times with fresh noise of that level and
re-identified. To first order in the noise the spread of those estimates around the
point estimate is the sampling spread of the estimator, so each parameter is reported
as the point estimate, the Monte-Carlo mean ± standard deviation and the 95 % percentile
interval of the samples (``benchmarks/reproduce_source.py`` measures the coverage of
that interval over independent noise seeds).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Mapping

import numpy as np

from nlupdate.identification.data import FRFLevels
from nlupdate.progress import ProgressCallback, no_progress


@dataclass(frozen=True)
class ParameterStatistics:
    """One parameter: point estimate, Monte-Carlo mean, std and 95 % interval (SI)."""

    value: float
    mean: float
    std: float
    ci95: tuple[float, float]

    def as_dict(self) -> dict[str, Any]:
        return {"value": self.value, "mean": self.mean, "std": self.std, "ci95": list(self.ci95)}


@dataclass(frozen=True)
class Uncertainty:
    """Monte-Carlo statistics of every parameter and how they were obtained."""

    parameters: dict[str, ParameterStatistics]
    noise_fraction: float
    n_samples: int
    n_failed: int
    seed: int

    def as_dict(self) -> dict[str, Any]:
        return {
            "method": "Monte Carlo over the noise model (METHODS §8): data perturbed with circular complex "
                      "normal noise of std noise_fraction·|H| and re-identified; ci95 = 2.5–97.5 % percentiles",
            "noise_fraction": self.noise_fraction,
            "n_samples": self.n_samples,
            "n_failed": self.n_failed,
            "seed": self.seed,
        }


def _one_sample(estimate: Callable, data: FRFLevels, fraction: float, seed: int) -> Mapping[str, float] | None:
    try:
        value = estimate(data.with_noise(fraction, np.random.default_rng(seed)))
    except (ValueError, np.linalg.LinAlgError, FloatingPointError):
        return None
    return value if isinstance(value, Mapping) else value.parameters()


def monte_carlo(
    estimate: Callable[[FRFLevels], Any],
    data: FRFLevels,
    point: dict[str, float],
    noise_fraction: float,
    n_samples: int = 100,
    seed: int = 0,
    progress: ProgressCallback = no_progress,
) -> Uncertainty:
    """Statistics of ``estimate(perturbed data)`` over ``n_samples`` noise draws.

    ``estimate`` returns a mapping of named values, or an object whose ``parameters()``
    does (an identification result); ``point`` names the values to report.

    Samples are drawn from ``seed`` and identified in order (``progress("Monte-Carlo
    samples", done, n_samples)`` after each). Samples whose identification
    fails are counted in ``n_failed``; a parameter with fewer than 2 successful samples gets NaN statistics.
    """
    if n_samples < 2:
        raise ValueError(f"n_samples must be at least 2, got {n_samples}")
    if not np.isfinite(noise_fraction) or noise_fraction < 0:
        raise ValueError(f"noise_fraction must be a finite number ≥ 0, got {noise_fraction}")
    seeds = np.random.SeedSequence(seed).generate_state(n_samples)
    samples = []
    for done, sample_seed in enumerate(seeds, start=1):
        samples.append(_one_sample(estimate, data, float(noise_fraction), int(sample_seed)))
        progress("Monte-Carlo samples", done, n_samples)
    good = [s for s in samples if s is not None]
    stats = {}
    for name, value in point.items():
        values = np.array([s[name] for s in good if name in s and np.isfinite(s[name])])
        if values.size >= 2:
            low, high = np.percentile(values, [2.5, 97.5])
            with np.errstate(over="ignore", invalid="ignore"):
                mean, std = float(values.mean()), float(values.std(ddof=1))
            stats[name] = ParameterStatistics(float(value), mean, std, (float(low), float(high)))
        else:
            stats[name] = ParameterStatistics(float(value), float("nan"), float("nan"), (float("nan"), float("nan")))
    return Uncertainty(stats, float(noise_fraction), n_samples, n_samples - len(good), seed)
