"""Fit on some levels, predict the others (docs/methods.md §10): :func:`validate`.

For each held-out level the chosen model is fitted on the kept levels and predicts the
held-out curve over its measured band; the curve's resonance frequency, half-power damping
ratio and peak (:mod:`nlupdate.core.validation.resonance`, the same estimator on measured and
predicted curves) are compared, beside the log-amplitude baseline
(:mod:`nlupdate.core.validation.baseline`).

95 % bands. A prediction is uncertain because the kept levels are few and the model may
not be the right form, and a new measurement scatters about any smooth trend. Both are
taken from the data, nothing assumed:

* model: the jackknife over the kept levels — the model refitted with each kept level left
  out, ``σ_J² = (n−1)/n · Σ (x_j − x̄)²`` for every predicted quantity and every line of
  |H| (it carries model-form error: a model that fits some levels and not others moves
  when they are dropped);
* test: the repeatability — the scatter of the measured resonance and damping ratio of
  every measured level about a straight line in log amplitude (``σ_R``, residual standard
  deviation, n − 2 degrees of freedom; the test's own run-to-run and level-to-level
  variation no smooth model can follow); for |H| the measurement noise ε|H|.

The band is ``x̂ ± t₀.₉₇₅,ₙ₋₁ · √(σ_J² + σ_R²)`` (Student's t for n − 1 jackknife degrees of
freedom). With fewer than three kept levels there is no jackknife and the band is NaN
(said so in the result). Coverage is measured, not assumed (tests/test_validate.py).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np
import pandas as pd
import scipy.stats
from numpy.typing import NDArray

from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.measurement.noise import estimate_noise_fraction
from nlupdate.progress import ProgressCallback, no_progress
from nlupdate.core.validation.baseline import baseline_frf, fit_level
from nlupdate.core.validation.models import ModelChoice, choose_model, model_fitter
from nlupdate.core.validation.resonance import Resonance, resonance

QUANTITIES = ("resonance_hz", "damping_ratio", "peak_abs")


@dataclass(frozen=True)
class Compared:
    """One quantity of a held-out level: measured, predicted and its 95 % band (low, high)."""

    measured: float
    predicted: float
    low: float = float("nan")
    high: float = float("nan")

    @property
    def error(self) -> float:
        return self.predicted - self.measured

    @property
    def relative_error(self) -> float:
        return self.predicted / self.measured - 1

    @property
    def inside(self) -> bool | None:
        """Whether the measured value lies in the band (None without a band)."""
        if not (np.isfinite(self.low) and np.isfinite(self.high)):
            return None
        return bool(self.low <= self.measured <= self.high)

    def as_dict(self) -> dict[str, float]:
        return {"measured": self.measured, "predicted": self.predicted, "low": self.low, "high": self.high}


@dataclass(frozen=True, eq=False, kw_only=True)
class CurveComparison:
    """A predicted curve against its measurement: the compared quantities, the baseline's
    (``baseline``: measured and predicted only), the residuals over the noise, and the
    curves (frequency_hz, measured, predicted, its |H| band, the baseline's curve)."""

    model: str
    requested: str = ""
    compared: dict[str, Compared]
    baseline: dict[str, Compared]
    residual_to_noise: float
    baseline_residual_to_noise: float
    half_power_lines: int
    frequency_hz: NDArray[np.float64]
    measured: NDArray[np.complex128]
    predicted: NDArray[np.complex128]
    abs_low: NDArray[np.float64]
    abs_high: NDArray[np.float64]
    baseline_frf: NDArray[np.complex128]
    note: str = ""

    @property
    def label(self) -> str:
        """The model as asked for (``auto → lines`` when auto chose it)."""
        return f"auto → {self.model}" if self.requested == "auto" else self.model


@dataclass(frozen=True, eq=False, kw_only=True)
class HeldOut(CurveComparison):
    """One held-out level predicted by one model (``kept``: the levels it was fitted on)."""

    level: float
    kept: tuple[float, ...]

    def as_dict(self) -> dict:
        return {"level": self.level, "model": self.model, "requested": self.requested or self.model,
                "kept_levels": list(self.kept),
                **{name: c.as_dict() for name, c in self.compared.items()},
                "residual_to_noise": self.residual_to_noise, "half_power_lines": self.half_power_lines,
                "baseline": {**{name: {"measured": c.measured, "predicted": c.predicted}
                                for name, c in self.baseline.items()},
                             "residual_to_noise": self.baseline_residual_to_noise},
                "note": self.note}


@dataclass(frozen=True)
class Repeatability:
    """The test's own scatter (1σ) of resonance (Hz) and damping ratio about a straight line
    in log amplitude over ``levels`` measured levels (NaN with fewer than three)."""

    resonance_hz: float
    damping_ratio: float
    levels: int

    def as_dict(self) -> dict:
        return {"resonance_hz_std": self.resonance_hz, "damping_ratio_std": self.damping_ratio, "levels": self.levels,
                "method": "residual standard deviation of each level's measured resonance and half-power damping "
                          "ratio about a straight line in log(response amplitude at resonance), n - 2 degrees of "
                          "freedom"}


@dataclass(frozen=True, eq=False)
class Validation:
    """Every held-out level under every model, the test's repeatability and, for ``auto``,
    the choice made (one per held-out level)."""

    held_out: tuple[HeldOut, ...]
    repeatability: Repeatability
    choices: dict[float, ModelChoice] = field(default_factory=dict)
    reference_unit: str = "N"
    #: response-controlled runs predicted from all force-controlled levels
    #: (:func:`nlupdate.core.validation.held_response.with_held_runs`), and what could not be
    response_controlled: tuple = ()
    response_controlled_notes: tuple[str, ...] = ()

    def summary(self) -> dict:
        """The ``validation.json`` content: the reference unit, the repeatability, auto's
        choices, one entry per held-out level and model (:meth:`HeldOut.as_dict`) and, where
        predicted, one per response-controlled run and model."""
        return {"reference_unit": self.reference_unit, "repeatability": self.repeatability.as_dict(),
                "auto_choices": {f"{level:g}": {"model": c.name, "reason": c.reason, "scores": c.scores}
                                 for level, c in self.choices.items()},
                "bands": "95 %: jackknife over the kept levels and the test's repeatability "
                         "(nlupdate.core.validation.held_out)",
                "held_out": [r.as_dict() for r in self.held_out],
                **({"response_controlled": [r.as_dict() for r in self.response_controlled]}
                   if self.response_controlled else {}),
                **({"response_controlled_notes": list(self.response_controlled_notes)}
                   if self.response_controlled_notes else {})}

    def table(self) -> pd.DataFrame:
        """One row per held-out level and model: each quantity measured, predicted, its band
        and the baseline's prediction."""
        rows = []
        for r in self.held_out:
            row = {"level": r.level, "model": r.model, "requested": r.requested,
                   "residual_to_noise": r.residual_to_noise,
                   "baseline_residual_to_noise": r.baseline_residual_to_noise, "half_power_lines": r.half_power_lines}
            for name, c in r.compared.items():
                row.update({f"{name}_measured": c.measured, f"{name}_predicted": c.predicted, f"{name}_low": c.low,
                            f"{name}_high": c.high, f"{name}_baseline": r.baseline[name].predicted})
            rows.append(row)
        return pd.DataFrame(rows)


def hold_out_levels(data: FRFLevels, hold_out: str | Sequence[float]) -> tuple[float, ...]:
    """The levels ``hold_out`` names: ``each`` (every level in turn), ``top`` (the highest:
    extrapolation) or levels (each must be measured); ValueError otherwise."""
    levels = tuple(float(level) for level in data.levels)
    if isinstance(hold_out, str):
        if hold_out == "each":
            return levels
        if hold_out == "top":
            return (levels[-1],)
        try:
            hold_out = [float(v) for v in hold_out.split(",")]
        except ValueError:
            raise ValueError(f"hold-out {hold_out!r}: expected each, top or levels like 0.49,0.97") from None
    picked = []
    for value in hold_out:
        hit = [level for level in levels if np.isclose(level, value, rtol=1e-6)]
        if not hit:
            raise ValueError(f"hold-out level {value:g}: not measured; levels {list(levels)} {data.reference_unit}")
        picked.append(hit[0])
    return tuple(picked)


def repeatability(data: FRFLevels) -> Repeatability:
    """:class:`Repeatability` of the measured levels."""
    shown = [resonance(f, h) for f, h in zip(data.frequencies, data.receptances)]
    amplitude = np.array([r.peak_abs * level for r, level in zip(shown, data.levels)])
    out = []
    for values in ([r.resonance_hz for r in shown], [r.damping_ratio for r in shown]):
        y = np.array(values)
        good = np.isfinite(y) & np.isfinite(amplitude)
        if good.sum() < 3:
            out.append(float("nan"))
            continue
        x = np.log(amplitude[good])
        residual = y[good] - np.polyval(np.polyfit(x, y[good], 1), x)
        out.append(float(np.sqrt(np.sum(residual**2) / (good.sum() - 2))))
    return Repeatability(out[0], out[1], len(shown))


def _metrics(frequency_hz: NDArray, h: NDArray) -> dict[str, float]:
    r: Resonance = resonance(frequency_hz, h)
    return {"resonance_hz": r.resonance_hz, "damping_ratio": r.damping_ratio, "peak_abs": r.peak_abs}


def _noise(frequency_hz: NDArray, h: NDArray, fallback: float) -> float:
    try:
        return estimate_noise_fraction(frequency_hz, h)
    except ValueError:
        return fallback


def _residual_to_noise(measured: NDArray, predicted: NDArray, noise: float) -> float:
    ratio = np.abs(predicted - measured) / (noise * np.abs(measured))
    ratio = ratio[np.isfinite(ratio)]
    return float(np.sqrt(np.mean(ratio**2))) if ratio.size else float("nan")


def bands(frequency_hz: NDArray, measured: dict[str, float], predicted: NDArray, curves: list, repeat: Repeatability,
          noise: float) -> tuple[dict[str, Compared], NDArray, NDArray]:
    """(each quantity measured, predicted and its 95 % band; the |H| band low and high) of a
    prediction ``predicted`` whose jackknife refits gave ``curves`` (module docstring)."""
    f = frequency_hz
    values = _metrics(f, predicted)
    jack_values = [_metrics(f, curve) for curve in curves]
    jack_abs = [np.abs(curve) for curve in curves]
    n = len(curves)
    t = float(scipy.stats.t.ppf(0.975, n - 1)) if n >= 3 else float("nan")

    def spread(samples: NDArray) -> NDArray:
        """Jackknife standard deviation over the finite samples (NaN with fewer than three)."""
        finite = np.isfinite(samples)
        count = finite.sum(axis=0)
        mean = np.nanmean(np.where(finite, samples, np.nan), axis=0) if n else np.nan
        square = np.nansum(np.where(finite, (samples - mean) ** 2, np.nan), axis=0) if n else np.nan
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(count >= 3, np.sqrt((count - 1) / np.maximum(count, 1) * square), np.nan)

    test_std = {"resonance_hz": repeat.resonance_hz, "damping_ratio": repeat.damping_ratio, "peak_abs": 0.0}
    compared = {}
    for name in QUANTITIES:
        jack = float(spread(np.array([v[name] for v in jack_values]))) if n >= 3 else np.nan
        repeat_std = test_std[name] if np.isfinite(test_std[name]) else 0.0
        half = t * np.sqrt(jack**2 + repeat_std**2)
        compared[name] = Compared(measured[name], values[name], values[name] - half, values[name] + half)
    # the test's own scatter of the resonance moves the curve along f by σ_f: the larger change of
    # |H| at each line when the curve is shifted either way (a jump moves, it does not grow), so
    # the band does not pinch to nothing where the refitted curves happen to cross
    sigma_f = repeat.resonance_hz if np.isfinite(repeat.resonance_hz) else 0.0
    size = np.abs(predicted)
    shift = np.maximum(np.abs(np.interp(f - sigma_f, f, size) - size), np.abs(np.interp(f + sigma_f, f, size) - size))
    abs_half = t * np.sqrt(spread(np.array(jack_abs)) ** 2 + (noise * np.abs(predicted)) ** 2 + shift**2) \
        if n >= 3 else np.full(f.shape, np.nan)
    return compared, np.maximum(np.abs(predicted) - abs_half, 0.0), np.abs(predicted) + abs_half


def refits(fit, levels: Sequence[float], data: FRFLevels, predict) -> tuple[list, str]:
    """(the curves ``predict(fit(kept))`` of the jackknife over ``levels`` — each left out of
    them in turn, the fit on the rest — a note naming the fits that failed, and that there is
    no band with fewer than three)."""
    curves, failures, note = [], {}, ""
    if len(levels) >= 3:
        for dropped in levels:
            inner = data.subset([v for v in levels if v != dropped])
            try:
                curves.append(predict(fit(inner)))
            except (ValueError, ArithmeticError, np.linalg.LinAlgError) as error:
                failures.setdefault(str(error), []).append(dropped)
    for message, dropped in failures.items():
        note += f"the model could not be refitted without {', '.join(f'{v:g}' for v in dropped)} ({message}); "
    if len(curves) < 3:
        note += "no band: fewer than three jackknife fits (three kept levels needed)"
    return curves, note.rstrip("; ")


def baseline_fits(data: FRFLevels, levels: Sequence[float]) -> list:
    """The log-amplitude baseline's description of each of ``levels``
    (:func:`~nlupdate.core.validation.baseline.fit_level`, the force of each line)."""
    return [fit_level(v, *data.curve(v), data.force_at(v, data.curve(v)[0])) for v in levels]


def predict_held_out(data: FRFLevels, level: float, model: str, repeat: Repeatability, requested: str = "") -> HeldOut:
    """One held-out level under one model (module docstring)."""
    kept_levels = tuple(float(v) for v in data.levels if not np.isclose(v, level, rtol=1e-9))
    kept = data.subset(list(kept_levels))
    f, h = data.curve(level)
    fit = model_fitter(model)
    predicted = fit(kept)(f, level)
    curves, note = refits(fit, kept_levels, data, lambda fitted: fitted(f, level))
    base = baseline_frf(baseline_fits(data, kept_levels), level, f)
    return HeldOut(level=float(level), kept=kept_levels, model=model, requested=requested or model,
                   **curve_comparison(data, f, h, predicted, curves, base, repeat), note=note)


def curve_comparison(data: FRFLevels, f: NDArray, h: NDArray, predicted: NDArray, curves: list, base: NDArray,
                     repeat: Repeatability) -> dict[str, Any]:
    """The comparison fields of a :class:`CurveComparison`: measured ``h`` against
    ``predicted`` (with the band of the refitted ``curves``) and against the baseline's
    curve ``base`` over the lines ``f`` (Hz); the noise from ``h`` itself, or from the
    lowest level of ``data`` when ``h`` is too short to tell."""
    measured = _metrics(f, h)
    noise = _noise(f, h, _noise(data.frequencies[0], data.receptances[0], 0.01))
    compared, abs_low, abs_high = bands(f, measured, predicted, curves, repeat, noise)
    base_values = _metrics(f, base)
    return dict(compared=compared, baseline={name: Compared(measured[name], base_values[name]) for name in QUANTITIES},
                residual_to_noise=_residual_to_noise(h, predicted, noise),
                baseline_residual_to_noise=_residual_to_noise(h, base, noise),
                half_power_lines=resonance(f, h).half_power_lines, frequency_hz=f, measured=h, predicted=predicted,
                abs_low=abs_low, abs_high=abs_high, baseline_frf=base)


def validate(data: FRFLevels, hold_out: str | Sequence[float] = "each", models: Sequence[str] = ("auto",),
             progress: ProgressCallback = no_progress) -> Validation:
    """Every level ``hold_out`` names, predicted by every model of ``models`` (``auto``:
    :func:`~nlupdate.core.validation.models.choose_model` on that level's kept levels) from the
    others. Needs at least two kept levels per held-out level."""
    levels = hold_out_levels(data, hold_out)
    if data.levels.size - 1 < 2:
        raise ValueError(f"validation needs at least three measured levels (two kept); there are {data.levels.size}")
    repeat = repeatability(data)
    results, choices = [], {}
    total = len(levels) * len(models)
    for level in levels:
        for requested in models:
            name = requested
            if requested == "auto":
                kept = data.subset([v for v in data.levels if not np.isclose(v, level, rtol=1e-9)])
                choices[level] = choose_model(kept)
                name = choices[level].name
            results.append(predict_held_out(data, level, name, repeat, requested))
            progress("held-out levels", len(results), total)
    return Validation(tuple(results), repeat, choices, data.reference_unit)
