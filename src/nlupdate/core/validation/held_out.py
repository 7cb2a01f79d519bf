"""Fit on some levels, predict the others (docs/methods.md §10): :func:`validate`.

For each held-out level the chosen model is fitted on the kept levels and predicts the held-out
curve over its measured band; the curve's resonance frequency, damping ratio (circle fit) and peak
(:mod:`nlupdate.core.validation.resonance`, the same estimator on measured and predicted curves) are
compared, beside the log-amplitude baseline (:mod:`nlupdate.core.validation.baseline`).

95 % bands. A prediction is uncertain because the kept levels are few and the model may not be the
right form, and a new measurement scatters about any smooth trend. Both are taken from the data:

* model: the jackknife over the kept levels — the model refitted with each kept level left out,
  ``σ_J² = (n−1)/n · Σ (x_j − x̄)²`` for every predicted quantity and every line of |H| (it
  carries model-form error: a model that fits some levels and not others moves when they are
  dropped), n − 1 degrees of freedom. A model that cannot be refitted without a kept level
  (``amplitude-iwan`` on three), and a quantity fewer than three refits give (a refit's curve
  peaking at a jump has no damping ratio), take the misfit at the kept levels instead (RMS,
  in-sample: :func:`kept_misfit`). Neither measures a level outside the kept ones: every refit
  extrapolates the same form (:attr:`CurveComparison.extrapolation` says so);
* test: the repeatability — the scatter of the measured levels about a trend in log amplitude
  (``σ_R``, residual standard deviation, N − 2 degrees of freedom: the test's own run-to-run and
  level-to-level variation no smooth model can follow): of the resonance about a straight line,
  of the damping ratio and the peak, relative, about a power law (:class:`Repeatability`); for
  |H| the measurement noise ε|H|.

The resonance's band is ``[x̂ − t·√(σ_J−² + σ_R²), x̂ + t·√(σ_J+² + σ_R²)]``, σ_J− and σ_J+ the
jackknife spread of the refits below and above their mean (:func:`_sides`: equal to σ_J for an even
scatter; refits skewed one way, as the resonance of a predicted jump is, widen that side); the
damping ratio and the peak, positive and scattering by a fraction of themselves, take the same in
their logarithm, ``x̂·exp(−t·…)``, ``x̂·exp(+t·…)`` — never below 0. The |H| band takes the refits'
spread of |H| below and above at each line the same way. t is Student's two-sided 95 % factor at
the Welch–Satterthwaite degrees of freedom of the two parts (few levels, few degrees of freedom:
t = 4.3 at two). Coverage is measured (benchmarks/validate_band_coverage.py).
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
from nlupdate.core.run_cache import one_run
from nlupdate.progress import ProgressCallback, no_progress
from nlupdate.core.validation.baseline import baseline_fits, baseline_frf
from nlupdate.core.validation.auto_choice import (ModelChoice, choose_model, extrapolated, level_extrapolation,
                                                  outside_physical_range)
from nlupdate.core.validation.compared import QUANTITIES, Compared, measured_spread, widest_band
from nlupdate.core.validation.models import BASELINE, model_fitter
from nlupdate.core.validation.resonance import Resonance, read_alike, resonance
from nlupdate.core.validation.verdict import Judged

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
    extrapolation: str = ""  #: the warning when it lies outside what the kept data cover, else ''

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
                "note": self.note, **({"extrapolation": self.extrapolation} if self.extrapolation else {})}


@dataclass(frozen=True)
class Repeatability:
    """The test's own scatter (1σ) over ``levels`` measured curves (NaN with fewer than
    three): of the resonance (Hz) and the damping ratio (points) about a trend in log
    amplitude (:func:`repeatability`), and, relative (1σ of the natural log, a fraction), of the damping ratio and the
    peak |H| about the same trend in log amplitude (a power law) — joint damping grows as a power of amplitude, and
    a positive quantity scatters by a fraction of itself."""

    resonance_hz: float
    damping_ratio: float
    levels: int
    damping_relative: float = float("nan")
    peak_relative: float = float("nan")
    #: the trend's polynomial degree in log amplitude (its degrees of freedom: levels − degree − 1)
    degree: int = 1
    #: the spread of each quantity over the curves (:func:`~nlupdate.core.validation.compared.measured_spread`:
    #: Hz; ln(max/min) of the damping ratio and the peak) — the band an uninformative one exceeds
    resonance_spread_hz: float = float("nan")
    damping_spread: float = float("nan")
    peak_spread: float = float("nan")

    @property
    def dof(self) -> int:
        return max(self.levels - self.degree - 1, 0)

    @property
    def test_std(self) -> dict[str, float]:
        """Per quantity the scatter its band and its resolution take: Hz for the resonance, relative
        (1σ of ln) for the damping ratio and the peak."""
        return {"resonance_hz": self.resonance_hz, "damping_ratio": self.damping_relative,
                "peak_abs": self.peak_relative}

    def as_dict(self) -> dict:
        return {"resonance_hz_std": self.resonance_hz, "damping_ratio_std": self.damping_ratio,
                "damping_ratio_relative_std": self.damping_relative, "peak_abs_relative_std": self.peak_relative,
                "levels": self.levels, "trend_degree": self.degree,
                "spread": {"resonance_hz": self.resonance_spread_hz,
                           "damping_ratio_ln_max_over_min": self.damping_spread,
                           "peak_abs_ln_max_over_min": self.peak_spread},
                "method": "residual standard deviation of each measured curve's resonance and damping "
                          "ratio about a polynomial of trend_degree in log(response amplitude at resonance), and of "
                          "log(damping ratio) and log(peak |H|) about the same, levels - degree - 1 degrees of "
                          "freedom"}


@dataclass(frozen=True, eq=False)
class Validation(Judged):
    """Every held-out level under every model, the test's repeatability and, for ``auto``,
    the choice made (one per held-out level); what it says and its largest errors: :class:`Judged`."""

    held_out: tuple[HeldOut, ...]
    repeatability: Repeatability
    choices: dict[float, ModelChoice] = field(default_factory=dict)
    reference_unit: str = "N"
    #: response-controlled runs predicted from all force-controlled levels
    #: (:func:`nlupdate.core.validation.held_response.with_held_runs`), and what could not be
    response_controlled: tuple = ()
    response_controlled_notes: tuple[str, ...] = ()
    #: the response-controlled runs kept beside the levels as backbone evidence (names)
    kept_runs: tuple[str, ...] = ()
    #: the repeatability the response-controlled runs' bands use (levels and runs pooled)
    runs_repeatability: Repeatability | None = None
    #: the mode's linear limit from another test (an impact) kept beside the levels, or None
    linear_limit: Any = None

    def summary(self) -> dict:
        """The ``validation.json`` content: the reference unit, the repeatability, auto's
        choices, one entry per held-out level and model (:meth:`HeldOut.as_dict`), where
        predicted one per response-controlled run and model, and the linear limit kept."""
        limit = self.linear_limit
        return {"reference_unit": self.reference_unit, "repeatability": self.repeatability.as_dict(),
                "auto_choices": {f"{level:g}": c.as_dict() for level, c in self.choices.items()},
                "bands": "95 %: jackknife over the kept levels and the test's repeatability "
                         "(nlupdate.core.validation.held_out); informative false: wider than twice the test's spread "
                         "of the quantity over its curves and than its resolution 2 x 1.96 sigma (a resonance band: "
                         "or than the measured lines), so in band tests nothing (nlupdate.core.validation.compared)",
                "held_out": [r.as_dict() for r in self.held_out],
                **({"kept_response_controlled_runs": list(self.kept_runs)} if self.kept_runs else {}),
                **({"response_controlled_repeatability": self.runs_repeatability.as_dict()}
                   if self.runs_repeatability is not None else {}),
                **({"response_controlled": [r.as_dict() for r in self.response_controlled]}
                   if self.response_controlled else {}),
                **({"response_controlled_notes": list(self.response_controlled_notes)}
                   if self.response_controlled_notes else {}),
                **({"linear_limit": {"source": limit.source, "frequency_hz": limit.frequency_hz,
                                     "frequency_std_hz": limit.frequency_std_hz, "damping_ratio": limit.damping_ratio,
                                     "damping_std": limit.damping_std}} if limit is not None else {})}

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


#: From this many measured curves on, the repeatability's trend in log amplitude is a parabola
#: (a joint's backbone may turn: the BRB's falls, then rises), not a straight line.
PARABOLA_FROM = 6

#: appended to a level's extrapolation warning when the ``amplitude-polynomial`` model predicts it
#: above the kept levels: its backbone is held beyond the largest kept sample (the transmitter
#: beam's 0.45 V prediction kinked at 42.725 and 42.787 Hz, where its response crossed it)
FLAT_BEYOND = ("; the polynomial backbone and damping curve are held at their values at the largest kept sample "
               "beyond it, so the prediction is flat in amplitude there (its FRF kinks where the response crosses "
               "that amplitude)")


def resonance_amplitudes(data: FRFLevels) -> NDArray[np.float64]:
    """Per level of ``data`` the response amplitude its curve reached at resonance (m for a
    receptance): the peak |H| times the force achieved at the resonance frequency (the level
    where none is recorded) — what a response-controlled run's held amplitude is. At the
    nominal level instead, the BRB's two lowest levels, whose shaker force sags 27 % and
    19 % at resonance, were put that much above the amplitude they reached."""
    out = []
    for level, f, h in zip(data.levels, data.frequencies, data.receptances):
        r = resonance(f, h)
        out.append(r.peak_abs * float(data.force_at(level, [r.resonance_hz])[0]))
    return np.array(out)


def repeatability(data: FRFLevels, runs: Sequence = ()) -> Repeatability:
    """:class:`Repeatability` of the measured levels and of the response-controlled ``runs``
    (each at its held amplitude), pooled: the trend a straight line in log amplitude, a
    parabola from :data:`PARABOLA_FROM` curves on (N − 3 degrees of freedom then); a level's
    amplitude is :func:`resonance_amplitudes`'."""
    shown = ([resonance(f, h) for f, h in zip(data.frequencies, data.receptances)]
             + [resonance(run.frequency_hz, run.h) for run in runs])
    amplitude = np.concatenate([resonance_amplitudes(data), [run.held_m for run in runs]])
    degree = 2 if len(shown) >= PARABOLA_FROM else 1
    out = []
    for values in ([r.resonance_hz for r in shown], [r.damping_ratio for r in shown],
                   np.log([r.damping_ratio for r in shown]), np.log([r.peak_abs for r in shown])):
        y = np.array(values)
        good = np.isfinite(y) & np.isfinite(amplitude) & (amplitude > 0)
        if good.sum() < degree + 2:
            out.append(float("nan"))
            continue
        x = np.log(amplitude[good])
        residual = y[good] - np.polyval(np.polyfit(x, y[good], degree), x)
        out.append(float(np.sqrt(np.sum(residual**2) / (good.sum() - degree - 1))))
    spread = measured_spread({name: [getattr(r, name) for r in shown] for name in QUANTITIES})
    return Repeatability(out[0], out[1], len(shown), out[2], out[3], degree, *spread.values())


def _metrics(r: Resonance, other: Resonance | None = None) -> dict[str, float]:
    r = read_alike(r, other)  # a curve's quantities, its damping read alike with the curve compared with it
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


def _t95(parts: Sequence[tuple[float, float]]) -> tuple[float, float]:
    """(the combined standard deviation of independent parts (σ, degrees of freedom), the
    two-sided 95 % Student factor at their Welch–Satterthwaite degrees of freedom); parts
    with σ NaN or 0 are left out, (0, NaN) when none is left."""
    kept = [(sigma, dof) for sigma, dof in parts if np.isfinite(sigma) and sigma > 0 and dof > 0]
    if not kept:
        return 0.0, float("nan")
    total = float(np.sqrt(sum(sigma**2 for sigma, _ in kept)))
    dof = total**4 / sum(sigma**4 / dof for sigma, dof in kept)
    return total, float(scipy.stats.t.ppf(0.975, dof))


def _sides(samples: NDArray) -> tuple[NDArray, NDArray]:
    """(below, above): the jackknife standard deviation of the refits ``samples`` (along
    axis 0) split by side of their mean x̄ — ``σ_below² = 2·(m−1)/m · Σ_{x_j < x̄} (x_j − x̄)²``
    over the m finite refits, ``σ_above`` the same above, so ``(σ_below² + σ_above²)/2 = σ_J²``
    and an even scatter gives both sides the jackknife's σ_J; refits skewed one way (a
    predicted jump that one refit puts much later, a backbone that bends further without
    one level) widen the band on that side. NaN with fewer than three. (Taken about the
    prediction instead of x̄, the jackknife's bias enters the width: the simulated coverage
    rose to 98–100 % at 1.3× the width, benchmarks/validate_band_coverage.py.)"""
    finite = np.isfinite(samples)
    count = finite.sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.nanmean(np.where(finite, samples, np.nan), axis=0)
        deviation = np.where(finite, samples - mean, 0.0)
        scale = np.where(count >= 3, 2 * (count - 1) / np.maximum(count, 1), np.nan)
        return (np.sqrt(scale * np.sum(np.minimum(deviation, 0.0) ** 2, axis=0)),
                np.sqrt(scale * np.sum(np.maximum(deviation, 0.0) ** 2, axis=0)))


def bands(frequency_hz: NDArray, measured: dict[str, float], predicted: NDArray, curves: list, repeat: Repeatability,
          noise: float, misfit: dict[str, tuple[float, int]] | None = None, shown: Resonance | None = None
          ) -> tuple[dict[str, Compared], NDArray, NDArray]:
    """(each quantity measured, predicted and its 95 % band; the |H| band low and high) of a
    prediction ``predicted`` whose jackknife refits gave ``curves`` (module docstring);
    ``misfit`` (quantity → (σ, dof)): the model's misfit at the kept levels, the model term
    of a quantity fewer than three refits give (without it: no band, never the test's term
    alone). Each side takes the refits' spread on that side (:func:`_sides`). The prediction and
    each refit are read alike with the measured curve (its resonance ``shown``: :func:`_metrics`)."""
    f = frequency_hz
    values = _metrics(resonance(f, predicted), shown)
    jack_values = [_metrics(resonance(f, curve), shown) for curve in curves]
    n = len(curves)
    # resonance in Hz; damping ratio and peak, positive, in log (a band that never reaches 0,
    # asymmetric as a relative scatter is)
    test_std = repeat.test_std
    test_dof = repeat.dof
    spread = {"resonance_hz": repeat.resonance_spread_hz, "damping_ratio": repeat.damping_spread,
              "peak_abs": repeat.peak_spread}
    compared = {}
    for name in QUANTITIES:
        log = name != "resonance_hz"
        jack = np.array([v[name] for v in jack_values], dtype=float)
        centre = values[name]
        with np.errstate(invalid="ignore", divide="ignore"):
            jack = np.log(jack) if log else jack
        finite = int(np.isfinite(jack).sum())
        halves = []
        for side in [float(x[0]) for x in _sides(jack[:, None])] if finite >= 3 else [None, None]:
            model = (side, finite - 1) if side is not None else (misfit or {}).get(name, (np.nan, 0))
            total, t = _t95([model, (test_std[name], test_dof)])
            halves.append(t * total if (side is not None or misfit) and np.isfinite(t) else float("nan"))
        low, high = ((centre * np.exp(-halves[0]), centre * np.exp(halves[1])) if log
                     else (centre - halves[0], centre + halves[1]))
        compared[name] = Compared(measured[name], centre, low, high, widest_band(name, spread[name], test_std[name], f),
                                  log)
    # the test's own scatter of the resonance moves the curve along f by σ_f: the larger change of
    # |H| at each line when the curve is shifted either way (a jump moves, it does not grow), so
    # the band does not pinch to nothing where the refitted curves happen to cross
    sigma_f = repeat.resonance_hz if np.isfinite(repeat.resonance_hz) else 0.0
    size = np.abs(predicted)
    shift = np.maximum(np.abs(np.interp(f - sigma_f, f, size) - size), np.abs(np.interp(f + sigma_f, f, size) - size))
    if n >= 3:
        t = float(scipy.stats.t.ppf(0.975, n - 1))
        below, above = _sides(np.array([np.abs(curve) for curve in curves]))
        abs_low = t * np.sqrt(below**2 + (noise * size) ** 2 + shift**2)
        abs_high = t * np.sqrt(above**2 + (noise * size) ** 2 + shift**2)
    elif misfit and test_dof > 0:  # no jackknife: the model's relative misfit of the peak, the test's scatter
        relative, dof = misfit.get("peak_abs", (0.0, 0))
        t = float(scipy.stats.t.ppf(0.975, max(min(dof, test_dof), 1)))
        abs_low = abs_high = t * np.sqrt((relative * size) ** 2 + (noise * size) ** 2 + shift**2)
    else:
        abs_low = abs_high = np.full(f.shape, np.nan)
    return compared, np.maximum(size - abs_low, 0.0), size + abs_high


def needs_misfit(frequency_hz: NDArray, curves: list) -> bool:
    """Whether the band of refits ``curves`` needs :func:`kept_misfit`: a quantity that fewer
    than three of them give (:func:`bands`)."""
    if len(curves) < 3:
        return True
    values = [_metrics(resonance(frequency_hz, curve)) for curve in curves]
    return any(sum(np.isfinite(v[name]) for v in values) < 3 for name in QUANTITIES)


def kept_misfit(fitted, data: FRFLevels, levels: Sequence[float]) -> dict[str, tuple[float, int]]:
    """The model's misfit at the levels it was fitted on: per quantity the RMS difference of
    its prediction from the measurement (Hz; for the damping ratio and the peak, of their
    logs) and the number of levels — in-sample, so at most optimistic, the model term of a
    band where there is no jackknife (a model that needs every kept level)."""
    errors: dict[str, list[float]] = {name: [] for name in QUANTITIES}
    for level in levels:
        f, h = data.curve(level)
        shown, curve = resonance(f, h), resonance(f, fitted(f, level, data.force_at(level, f)))
        predicted, measured = _metrics(curve, shown), _metrics(shown, curve)
        for name in QUANTITIES:
            log = name != "resonance_hz"
            d = np.log(predicted[name] / measured[name]) if log else predicted[name] - measured[name]
            if np.isfinite(d):
                errors[name].append(float(d))
    return {name: (float(np.sqrt(np.mean(np.square(e)))), len(e)) for name, e in errors.items() if e}


def refits(fit, levels: Sequence[float], data: FRFLevels, predict) -> tuple[list, str]:
    """(the curves ``predict(fit(kept))`` of the jackknife over ``levels`` — each left out of
    them in turn, the fit on the rest — a note naming the fits that failed, and that there is
    no jackknife with fewer than three)."""
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
        note += ("no jackknife (fewer than three refits): the band's model term is the model's misfit at the "
                 "levels it was fitted on")
    return curves, note.rstrip("; ")


def predict_held_out(data: FRFLevels, level: float, model: str, repeat: Repeatability, requested: str = "",
                     runs: Sequence = ()) -> HeldOut:
    """One held-out level under one model (module docstring), ``runs`` (response-controlled,
    :class:`~nlupdate.core.identification.response_controlled.HeldRun`) kept beside the levels."""
    kept_levels = tuple(float(v) for v in data.levels if not np.isclose(v, level, rtol=1e-9))
    kept = data.subset(list(kept_levels))
    f, h = data.curve(level)
    fit = model_fitter(model, runs)
    force = data.force_at(level, f)  # the force achieved at each line: measured, an input like Ω
    fitted = fit(kept)
    predicted = fitted(f, level, force)
    curves, note = refits(fit, kept_levels, data, lambda inner: inner(f, level, force))
    note = fitted.noted(note)
    if model != BASELINE and extrapolated(kept, level):
        why = outside_physical_range(kept, fitted, level)
        if why is not None:
            note = "; ".join(filter(None, [f"the extrapolation leaves the physical range: {why}", note]))
    misfit = kept_misfit(fitted, data, kept_levels) if needs_misfit(f, curves) else None
    base = baseline_frf(baseline_fits(data, kept_levels), level, f)
    extrapolation = level_extrapolation(kept, level)
    if extrapolation and model == "amplitude-polynomial" and level > max(kept_levels):
        extrapolation += FLAT_BEYOND
    return HeldOut(level=float(level), kept=kept_levels, model=model, requested=requested or model, note=note,
                   extrapolation=extrapolation, **curve_comparison(data, f, h, predicted, curves,
                                                                                      base, repeat, misfit))


def curve_comparison(data: FRFLevels, f: NDArray, h: NDArray, predicted: NDArray, curves: list, base: NDArray,
                     repeat: Repeatability, misfit: dict[str, tuple[float, int]] | None = None) -> dict[str, Any]:
    """The comparison fields of a :class:`CurveComparison`: measured ``h`` against ``predicted``
    (with the band of the refitted ``curves``, or of the model's ``misfit`` at its kept levels
    without them: :func:`bands`) and against the baseline's curve ``base`` over the lines ``f``
    (Hz), each pair read alike; the noise from ``h``, or the lowest level's when ``h`` is too short."""
    shown, model_r, base_r = (resonance(f, curve) for curve in (h, predicted, base))
    noise = _noise(f, h, _noise(data.frequencies[0], data.receptances[0], 0.01))
    compared, abs_low, abs_high = bands(f, _metrics(shown, model_r), predicted, curves, repeat, noise, misfit, shown)
    base_m, base_p = _metrics(shown, base_r), _metrics(base_r, shown)
    return dict(compared=compared, baseline={name: Compared(base_m[name], base_p[name]) for name in QUANTITIES},
                residual_to_noise=_residual_to_noise(h, predicted, noise),
                baseline_residual_to_noise=_residual_to_noise(h, base, noise),
                half_power_lines=shown.half_power_lines, frequency_hz=f, measured=h, predicted=predicted,
                abs_low=abs_low, abs_high=abs_high, baseline_frf=base)


@one_run()  # its models, refits and comparisons share the kept levels' shares and curves' resonances
def validate(data: FRFLevels, hold_out: str | Sequence[float] = "each", models: Sequence[str] = ("auto",),
             progress: ProgressCallback = no_progress, runs: Sequence = ()) -> Validation:
    """Every level ``hold_out`` names, predicted by every model of ``models`` (``auto``:
    :func:`~nlupdate.core.validation.auto_choice.choose_model` on that level's kept levels) from the
    others, and from the response-controlled ``runs`` when given (a different test, kept as
    backbone evidence: :data:`~nlupdate.core.validation.models.WITH_RUNS`). Needs at least two
    kept levels per held-out level."""
    levels = hold_out_levels(data, hold_out)
    if data.levels.size - 1 < 2:
        raise ValueError(f"validation needs at least three measured levels (two kept); there are {data.levels.size}")
    repeat = repeatability(data, runs)
    results, choices = [], {}
    total = len(levels) * len(models)
    for level in levels:
        for requested in models:
            name = requested
            if requested == "auto":
                kept = data.subset([v for v in data.levels if not np.isclose(v, level, rtol=1e-9)])
                choices[level] = choose_model(kept, runs, level)
                name = choices[level].name
            results.append(predict_held_out(data, level, name, repeat, requested, runs))
            progress("held-out levels", len(results), total)
    return Validation(tuple(results), repeat, choices, data.reference_unit,
                      kept_runs=tuple(run.name for run in runs), linear_limit=data.linear_limit)
