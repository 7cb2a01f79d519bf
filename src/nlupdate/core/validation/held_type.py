"""Hold out a whole test type: fit the amplitude-dependent modal model on the other types and
predict the held-out type's own observables (docs/validation.md, "A whole test type held out").

The sources are those of ``nlupdate amplitude`` (stepped sine, response-controlled runs, phase
resonance, ring-downs, impacts), each a list of backbone samples
(:class:`~nlupdate.core.identification.modal_samples.ModalSamples`). The kept sources are
fitted jointly, each weighted by its own noise
(:func:`~nlupdate.core.identification.backbone_samples.source_noise`; one source alone with the
fit's default weights, as ``nlupdate amplitude`` does). What is predicted:

* ring-down, response-controlled, impact: each sample's natural frequency and damping ratio at
  its modal amplitude (the amplitude-dependent model's backbone and damping curve); an impact
  below every kept sample measures the linear limit, and is compared with the model's: its
  frequency and damping at zero amplitude (``predicted_at_modal_amplitude`` 0, an
  extrapolation the entry states, ``extrapolation``);
* phase resonance: the same, and the modal amplitude the model holds at each point's force
  (``2ζ(a)ω(a)²a = |φ_f|F``);
* stepped sine: each force level's FRF over its measured lines, each line at the force the
  shaker achieved there (single-nonlinear-mode theory,
  :func:`~nlupdate.core.validation.models.frf_at_forces`, the mode alone: the other
  modes' share is not added), read by the same resonance estimator as the measured curve
  (:mod:`nlupdate.core.validation.resonance`, the two read alike: resonance frequency, damping ratio,
  peak |H|).

Errors are relative (predicted / measured − 1); a resonance frequency's also in Hz. A sample
is ``within_fit`` when its modal amplitude lies inside the range the kept sources cover
(interpolated, not extrapolated); a stepped-sine level when its predicted peak amplitude does.
95 % bands (``low``, ``high``; ``inside``: the measured value within), where one exists:
about a stepped-sine level's predicted resonance and damping ratio, ± 1.96 × the test's
repeatability (:func:`~nlupdate.core.validation.held_out.repeatability`: the scatter of every
measured level's resonance and damping about a line in log amplitude — the test's own scatter
no model follows); about a sample's predicted frequency and damping, the residual bootstrap
of the kept sources' fit (``backbone.csv``'s band of ``nlupdate amplitude``) widened on each
side, in quadrature, by 1.96 × the held source's own noise
(:func:`~nlupdate.core.identification.backbone_samples.source_noise`: its scatter, at least
1e-5 in frequency and 1 % in damping), where the sample lies within the fitted amplitudes, and
about an impact's predicted linear limit (the bootstrap of the refits' own linear limits: the
kept fit's noise carried to a = 0 by the model's form, not that form's error below its
samples). Without resamples, or outside, there is none (absent). An impact's measured
frequency and damping have their own 95 % band (``measured_low``, ``measured_high``): ± 1.96
standard errors of its pole (:class:`~nlupdate.core.identification.impact.LinearLimit`).

Whether a band tests anything is judged by the one rule of ``--hold-out LEVELS``
(:mod:`nlupdate.core.validation.compared`: a band wider than twice the test's spread of the
quantity and than the test's resolution 2·1.96·σ is *uninformative*; validation.json's
``informative``). Here the test is the held-out type: the spread is over its own measured
values (a held stepped sine: its levels' resonance, damping ratio and peak |H|; held samples:
their natural frequency and damping ratio), σ its own scatter — a stepped sine's
repeatability, a sample source's noise (:func:`source_noise`: the same σ that widens the
sample's band) times the measured value for the frequency (Hz), the relative one for the
damping ratio (judged in its logarithm). A held type of one value (a single impact) has no
spread of its own: its spread is then the kept sources' — the values the prediction is made
from (their natural frequencies, Hz, and damping ratios, ln) — and its resolution its own
stated standard error (the pole's). A band wider than twice what the kept tests measured
holds, wherever it lies, every value they measured and so any linear limit the data make
plausible: it tests nothing. The BRB's hammer pole (80.5797 ± 0.0006 Hz) held out from the
force-controlled levels and response-controlled runs (80.04–80.50 Hz): the Iwan fit's
band 79.89–81.10 Hz (1.21 Hz, 500 × the pole's) is uninformative (widest 0.92 Hz), the
polynomial's 79.95–80.64 Hz (0.69 Hz) is not flagged; before, neither was judged.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np
import pandas as pd

from nlupdate.core.identification.amplitude_modal_fit import fit_amplitude_model
from nlupdate.core.identification.modal_samples import ModalSamples, samples_from_frfs
from nlupdate.core.identification.backbone_samples import (
    TEST_TYPES, bootstrap_bands, check_common_scale, held_out_errors, join_samples, own_fit_for, source_noise,
)
from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.model.amplitude_modal import AmplitudeModalModel, AmplitudeModelError
from nlupdate.core.validation.compared import QUANTITIES, Compared, measured_spread, widest_band
from nlupdate.core.validation.held_out import Validation, repeatability
from nlupdate.core.validation.models import frf_at_forces
from nlupdate.core.validation.resonance import read_alike, resonance
from nlupdate.core.validation.verdict import Said, held_type_said

#: the test types a whole of which can be held out (a modal table is no test)
HELD_TYPES = tuple(t for t in TEST_TYPES if t != "modal-table")
#: the model names a type hold-out takes, and the amplitude backbone each fits
BACKBONE_OF_MODEL = {"auto": "iwan", "amplitude-iwan": "iwan", "amplitude-polynomial": "polynomial",
                     "amplitude-jenkins": "jenkins"}

#: (source name, samples, stated relative (frequency, damping) standard deviations or None, test type)
Source = tuple[str, ModalSamples, "tuple[float, float] | None", str]



class MissingShape(AmplitudeModelError):
    """A source's modal amplitudes need the mass-normalised shape at ``coordinate``, which was not given."""

    def __init__(self, coordinate: str, message: str):
        super().__init__(message)
        self.coordinate = coordinate


def stepped_sine_source(name: str, data: FRFLevels, shapes: Mapping[str, float]) -> Source:
    """The stepped sine ``data`` (named ``name``) as a source of the type hold-out: one sample
    per level at the shape given at its input (:class:`MissingShape` without one)."""
    if data.input_dof not in shapes:
        raise MissingShape(data.input_dof, f"the stepped sine's modal amplitude needs the mass-normalised shape "
                                           f"(1/√kg) at its input {data.input_dof!r}")
    return name, samples_from_frfs(data, shapes[data.input_dof]), None, "stepped-sine"


@dataclass(frozen=True, eq=False)
class HeldType:
    """One held-out test type: the model fitted without it, the modal amplitudes (m·√kg) the
    kept sources cover, per-sample predictions (:func:`held_out_errors`' table; empty for
    stepped sine) and per-level predictions of a held stepped sine (one row per level:
    ``level``, ``within_fit``, and measured/predicted/low/high of ``resonance_hz``,
    ``damping_ratio``, ``peak_abs``; empty otherwise)."""

    test_type: str
    model: AmplitudeModalModel
    fitted_on: tuple[tuple[str, str, int], ...]
    fitted_range: tuple[float, float]
    samples: pd.DataFrame
    levels: pd.DataFrame

    def summary(self) -> dict:
        """validation.json's ``held_out_type`` entry."""
        out = {"test_type": self.test_type,
               "fitted_on": [{"source": s, "test_type": t, "samples": n} for s, t, n in self.fitted_on],
               "fitted_modal_amplitude": list(self.fitted_range),
               "model": self.model.to_dict(), "samples": [], "levels": []}
        for row in self.samples.to_dict("records"):
            entry = {"source": row["source"], "modal_amplitude": row["modal_amplitude"],
                     "within_fit": bool(row["within_fit"])}
            if row["test_type"] == "impact":
                entry["predicted_at_modal_amplitude"] = float(row["predicted_at_amplitude"])
                if row["predicted_at_amplitude"] == 0:
                    own = self.model.frequency_hz(row["modal_amplitude"]), self.model.damping(row["modal_amplitude"])
                    entry["extrapolation"] = (
                        f"the impact {row['source']} at modal amplitude {row['modal_amplitude']:.3g} m·√kg lies below "
                        f"every kept sample ({self.fitted_range[0]:.3g}–{self.fitted_range[1]:.3g} m·√kg): its "
                        f"linear limit is compared with the model's at zero amplitude, an extrapolation (the model "
                        f"at the impact's own amplitude: {float(own[0]):.6g} Hz, {100 * float(own[1]):.4g} %)")
            for name, column in (("natural_frequency_hz", "predicted_frequency_hz"),
                                 ("damping_ratio", "predicted_damping_ratio")):
                entry[name] = _compared(row[name], row[column], row.get(f"{column}_low"), row.get(f"{column}_high"),
                                        row.get(f"{name}_low"), row.get(f"{name}_high"), row.get(f"{name}_widest"),
                                        name == "damping_ratio")
            if np.isfinite(row["predicted_amplitude"]):
                entry["modal_amplitude_held"] = _compared(row["modal_amplitude"], row["predicted_amplitude"])
            out["samples"].append(entry)
        for row in self.levels.to_dict("records"):
            entry = {"level": row["level"], "within_fit": bool(row["within_fit"]),
                     "half_power_lines": int(row["half_power_lines"])}
            for name in QUANTITIES:
                entry[name] = _compared(row[f"{name}_measured"], row[f"{name}_predicted"], row.get(f"{name}_low"),
                                        row.get(f"{name}_high"), widest=row.get(f"{name}_widest"),
                                        log=name != "resonance_hz")
            out["levels"].append(entry)
        out["worst_within_fit"] = self.worst()
        return out

    def said(self, unit: str) -> list[Said]:
        """What it says before its table, levels in ``unit`` (:func:`~nlupdate.core.validation.verdict.held_type_said`
        of :meth:`summary`)."""
        return held_type_said(self.summary(), unit)

    def worst(self) -> dict[str, float]:
        """Largest |relative error| of each predicted quantity over what lies within the fit."""
        worst: dict[str, float] = {}
        inside = self.samples[self.samples["within_fit"]] if len(self.samples) else self.samples
        for name, column in (("natural_frequency_hz", "frequency_error"), ("damping_ratio", "damping_error"),
                             ("modal_amplitude_held", "amplitude_error")):
            if len(inside) and inside[column].notna().any():
                worst[name] = float(inside[column].abs().max())
        levels = self.levels[self.levels["within_fit"]] if len(self.levels) else self.levels
        for name in QUANTITIES:
            if len(levels):
                errors = levels[f"{name}_predicted"] / levels[f"{name}_measured"] - 1
                if errors.notna().any():
                    worst[name] = float(errors.abs().max())
        return worst


def _number(value: float | None) -> float:
    return float("nan") if value is None else float(value)


def _compared(measured: float, predicted: float, low: float | None = None, high: float | None = None,
              measured_low: float | None = None, measured_high: float | None = None, widest: float | None = None,
              log: bool = False) -> dict:
    """One quantity's entry: measured, predicted, their difference and ratio − 1; the
    prediction's band (``low``, ``high``, ``inside``: the measured value within) and whether
    it tests anything (``informative``, ``widest_informative_band``, ``band_width_scale``:
    :class:`~nlupdate.core.validation.compared.Compared`, ``widest`` its widest informative
    band, ``log`` judged in the logarithm), and the measured value's own band
    (``measured_low``, ``measured_high``) where given and finite."""
    judged = Compared(float(measured), float(predicted), _number(low), _number(high), _number(widest), log)
    out = {"measured": float(measured), "predicted": float(predicted),
           "error": float(predicted - measured), "relative_error": float(predicted / measured - 1)}
    if judged.inside is not None:
        out.update({key: value for key, value in judged.as_dict().items() if key not in out}, inside=judged.inside)
    if measured_low is not None and measured_high is not None and np.isfinite(measured_low) and np.isfinite(
            measured_high):
        out.update(measured_low=float(measured_low), measured_high=float(measured_high))
    return out


def held_spread(samples: pd.DataFrame, levels: pd.DataFrame) -> dict[str, float]:
    """The held type's spread of each quantity over its measured values
    (:func:`~nlupdate.core.validation.compared.measured_spread`, module docstring): the levels'
    resonance, damping ratio and peak |H|, or the samples' natural frequency (under
    ``resonance_hz``: Hz, as the resonance) and damping ratio."""
    if len(levels):
        return measured_spread({name: levels[f"{name}_measured"].to_numpy() for name in QUANTITIES})
    return measured_spread({"resonance_hz": samples["natural_frequency_hz"].to_numpy(),
                            "damping_ratio": samples["damping_ratio"].to_numpy()})


def sample_widest(samples: pd.DataFrame, noise: np.ndarray,
                  kept: ModalSamples | None = None) -> dict[str, np.ndarray]:
    """Per held sample the widest informative band of its natural frequency (Hz) and damping
    ratio (ln) (:func:`~nlupdate.core.validation.compared.widest_band`): twice the held type's
    spread, or its resolution 2·1.96·σ — ``noise`` (samples × 2) the held source's relative
    (frequency, damping) standard deviations. A single held value: twice the spread of the
    ``kept`` samples the prediction is made from instead (module docstring); NaN without."""
    spread = held_spread(samples, pd.DataFrame())
    if len(samples) == 1 and kept is not None:
        spread = measured_spread({"resonance_hz": kept.frequency_hz, "damping_ratio": kept.damping_ratio})
    frequency = samples["natural_frequency_hz"].to_numpy()
    out = {}
    for k, (name, key) in enumerate((("natural_frequency_hz", "resonance_hz"), ("damping_ratio", "damping_ratio"))):
        sigma = noise[:, k] * frequency if name == "natural_frequency_hz" else noise[:, k]
        out[name] = np.array([widest_band(name, spread[key], s, ()) if np.isfinite(spread[key]) else np.nan
                              for s in sigma])
    return out


def _weights(kept: Sequence[Source], backbone: str, shapes: Sequence[tuple[str, float]]) -> tuple:
    """Per-sample relative standard deviations (frequency, damping) of the kept sources: each
    source's own noise; one source alone: the fit's defaults, as ``nlupdate amplitude``."""
    if len(kept) == 1:
        return 1e-3, 0.05
    noises = [source_noise(s, stated, own_fit_for(backbone, shapes)) for _, s, stated, _ in kept]
    return tuple(np.concatenate([np.full(s.amplitude.size, n[k]) for (_, s, _, _), n in zip(kept, noises)])
                 for k in (0, 1))


def fit_sources(kept: Sequence[Source], shapes: Sequence[tuple[str, float]], backbone: str = "iwan",
                order: int = 2, mode: int = 1) -> AmplitudeModalModel:
    """The amplitude model of the kept sources jointly, each weighted by its noise (module
    docstring)."""
    samples = join_samples([s for _, s, _, _ in kept], [name for name, _, _, _ in kept], dict(shapes))
    if samples.amplitude.size < 2:
        raise AmplitudeModelError("the sources kept give one sample (an impact's linear limit): a backbone needs "
                                  "more; keep another test type")
    return fit_amplitude_model(samples, shapes, backbone, order, *_weights(kept, backbone, shapes), mode=mode)


def sample_bands(model: AmplitudeModalModel, kept: Sequence[Source], shapes: Sequence[tuple[str, float]],
                 backbone: str, order: int, amplitude: np.ndarray, resamples: int) -> dict[str, tuple]:
    """95 % bands (low, high) of the predicted natural frequency and damping ratio at
    ``amplitude`` (m·√kg): the residual bootstrap of ``backbone.csv``
    (:func:`~nlupdate.core.identification.backbone_samples.bootstrap_bands`, ``resamples``
    refits of the kept sources) at those amplitudes; NaN outside the fitted amplitudes, but at
    0 (the linear limit) the refits' own."""
    fitted = join_samples([s for _, s, _, _ in kept])
    stds = _weights(kept, backbone, shapes)
    amplitude = np.asarray(amplitude, dtype=float)
    bands = bootstrap_bands(model, fitted, amplitude, lambda draw: fit_amplitude_model(
        draw, shapes, backbone, order, *stds, mode=model.mode), resamples, noise=stds)
    shown = (amplitude == 0) | ((amplitude >= fitted.amplitude.min() * (1 - 1e-9))
                                & (amplitude <= fitted.amplitude.max() * (1 + 1e-9)))
    return {name: tuple(np.where(shown, side, np.nan) for side in band)
            for name, band in zip(("natural_frequency_hz", "damping_ratio"), bands)}


def stepped_sine_levels(model: AmplitudeModalModel, data: FRFLevels, fitted_range: tuple[float, float]) -> pd.DataFrame:
    """Each level's measured and predicted resonance (module docstring), with the test's
    repeatability band about the predicted resonance and damping ratio (NaN with fewer than
    three levels)."""
    repeat = repeatability(data)
    rows = []
    transfer = model.shape(data.response_dof) / model.shape(data.input_dof)  # φ_r/φ_f
    for level in data.levels:
        f, h = data.curve(level)
        force = data.force_at(level, f)  # each line at the force the shaker achieved there
        shown, curve = resonance(f, h), resonance(f, transfer * frf_at_forces(model, f, force, data.input_dof))
        measured, predicted = read_alike(shown, curve), read_alike(curve, shown)  # one estimator on both
        at_peak = float(np.interp(predicted.resonance_hz, f, force))
        amplitude = predicted.peak_abs * at_peak / abs(model.shape(data.response_dof))  # a = |X_r|/|φ_r|
        row = {"level": float(level), "half_power_lines": measured.half_power_lines,
               "within_fit": bool(fitted_range[0] * (1 - 1e-9) <= amplitude <= fitted_range[1] * (1 + 1e-9))}
        for name in QUANTITIES:
            row[f"{name}_measured"], row[f"{name}_predicted"] = getattr(measured, name), getattr(predicted, name)
        if np.isfinite(repeat.resonance_hz):
            for name, sigma in (("resonance_hz", repeat.resonance_hz), ("damping_ratio", repeat.damping_ratio)):
                row[f"{name}_low"], row[f"{name}_high"] = (getattr(predicted, name) - 1.96 * sigma,
                                                           getattr(predicted, name) + 1.96 * sigma)
        row["lines_hz"] = f
        rows.append(row)
    levels = pd.DataFrame(rows)
    spread = held_spread(pd.DataFrame(), levels)  # the rule of --hold-out LEVELS (module docstring)
    for name in QUANTITIES:
        levels[f"{name}_widest"] = [widest_band(name, spread[name], repeat.test_std[name], f)
                                    for f in levels["lines_hz"]]
    return levels.drop(columns="lines_hz")


def hold_out_type(sources: Sequence[Source], test_type: str, shapes: Sequence[tuple[str, float]],
                  data: FRFLevels | None = None, backbone: str = "iwan", order: int = 2,
                  resamples: int = 0) -> HeldType:
    """Fit on every source not of ``test_type`` and predict those of it (module docstring);
    ``data``: the stepped-sine curves, needed when ``test_type`` is ``stepped-sine``;
    ``resamples``: bootstrap refits for the bands of sample predictions (0: none)."""
    check_common_scale([s for _, s, _, _ in sources], [name for name, _, _, _ in sources], dict(shapes))  # held too
    held = [s for s in sources if s[3] == test_type]
    kept = [s for s in sources if s[3] != test_type]
    if not held:
        raise AmplitudeModelError(f"hold-out type {test_type}: no source of that type is given")
    if not kept:
        raise AmplitudeModelError(f"hold-out type {test_type}: every source is of that type; give another to fit")
    model = fit_sources(kept, shapes, backbone, order)
    fitted = join_samples([s for _, s, _, _ in kept]).amplitude
    fitted_range = (float(fitted.min()), float(fitted.max()))
    if test_type == "stepped-sine":
        if data is None:
            raise AmplitudeModelError("hold-out type stepped-sine: the measured curves are needed")
        samples, levels = pd.DataFrame(), stepped_sine_levels(model, data, fitted_range)
    else:
        samples = held_out_errors(model, [(name, s, kind) for name, s, _, kind in held], fitted_range)
        levels = pd.DataFrame()
        if test_type == "impact":  # each pole's own standard errors (module docstring)
            errors = np.concatenate([np.tile(np.asarray(st if st is not None else (np.nan, np.nan), float),
                                              (s.amplitude.size, 1)) for _, s, st, _ in held])
            for k, name in enumerate(("natural_frequency_hz", "damping_ratio")):
                samples[f"{name}_low"] = samples[name] * (1 - 1.96 * errors[:, k])
                samples[f"{name}_high"] = samples[name] * (1 + 1.96 * errors[:, k])
        noise = np.concatenate([np.tile(source_noise(s, stated), (s.amplitude.size, 1))  # the held test's scatter
                                for _, s, stated, _ in held])
        for name, widest in sample_widest(samples, noise, join_samples([s for _, s, _, _ in kept])).items():
            samples[f"{name}_widest"] = widest
        if resamples > 0:
            bands = sample_bands(model, kept, shapes, backbone, order, samples["predicted_at_amplitude"].to_numpy(),
                                 resamples)
            for k, (name, column) in enumerate((("natural_frequency_hz", "predicted_frequency_hz"),
                                                ("damping_ratio", "predicted_damping_ratio"))):
                test = 1.96 * samples[column].to_numpy() * noise[:, k]
                predicted, (low, high) = samples[column].to_numpy(), bands[name]
                floor = 0.0 if name == "damping_ratio" else -np.inf  # a damping ratio is not negative
                samples[f"{column}_low"] = np.maximum(predicted - np.hypot(predicted - low, test), floor)
                samples[f"{column}_high"] = predicted + np.hypot(high - predicted, test)
    return HeldType(test_type, model, tuple((name, kind, int(s.amplitude.size)) for name, s, _, kind in kept),
                    fitted_range, samples, levels)


@dataclass(frozen=True, eq=False)
class TypedValidation(Validation):
    """A study's ``[validation]`` with a whole test type held out as well
    (``hold_out_type``): ``validation.json`` gains ``held_out_type`` (:meth:`HeldType.summary`),
    as ``nlupdate validate --hold-out-type`` writes it."""

    held_type: HeldType | None = None

    def warnings(self) -> list[Said]:
        """The held-out levels' warnings, then the held-out type's (:meth:`HeldType.said`)."""
        held = [] if self.held_type is None else [line for line in self.held_type.said(self.reference_unit) if line.warns]
        return super().warnings() + held

    def summary(self) -> dict:
        out = super().summary()
        return out if self.held_type is None else {**out, "held_out_type": self.held_type.summary()}
