"""Backbone samples of one mode from several sources, and the tables ``nlupdate amplitude`` writes.

Samples (:class:`~nlupdate.core.identification.modal_samples.ModalSamples`) from a modal
table, FRFs, ring-downs (:mod:`nlupdate.core.identification.ring_down`) and response-controlled
runs (:mod:`nlupdate.core.identification.response_controlled`) join into one set when they share
the scale of the modal amplitude (the mode shape given); ``backbone_points.csv`` lists every
source's samples and ``backbone.csv`` the fitted model over their range.

Bands of ``backbone.csv``. The backbone fits give no covariance; the band is a residual
bootstrap: the samples' relative misfits ``f_i/f(a_i) − 1`` and ``ζ_i/ζ(a_i) − 1`` are drawn
with replacement onto the fitted curves at the same amplitudes, the model is refitted to
each draw, and ``*_low``/``*_high`` are the basic bootstrap interval of the refitted curves
(their 2.5–97.5 % deviations reflected about the fitted curve, which the band always holds:
:func:`~nlupdate.core.identification.bands.band_arrays`; a 95 % interval of the fit, given
the model; the misfits drawn carry any model-form error; ring-down samples are a smoothing
window apart, so their misfits are about independent). Fewer than
:data:`MIN_SCATTER_SAMPLES` samples cannot show their own scatter — a quadratic through four
leaves one degree of freedom, and its misfits are a fraction of the noise: on four samples of
a closed-form backbone with 5 % noise in ζ the residual bootstrap's bands held the truth at 27
% of the amplitudes, 4 % wide (tests/test_amplitude_extrapolation.py) — so their misfits are
drawn from the noise the fit assumed (normal, ``noise``: the defaults 1e-3 and 5 % or a
source's stated errors) instead. From :data:`MIN_SCATTER_SAMPLES` on, the misfits drawn are
scaled by :func:`small_sample_scale`, ``√(n/(n − p))·t₀.₉₇₅(n − p)/1.96`` (p the parameters
fitted to the quantity): n misfits about a curve of p parameters spread only √((n − p)/n) of
the noise (the leverage correction of the residual bootstrap), and that spread is known from
n − p degrees of freedom (Student's t, as a regression's interval of its mean response). Six
samples of a quadratic — a stepped sine's six levels — took 2.3 × the raw misfits, twelve
1.33 ×, fifty 1.06 ×. On six samples of a closed-form backbone inside the polynomial family
(5e-5 and 0.5 % noise, 200 seeds) the raw misfits' bands held the truth at 72 % (frequency)
and 71 % (damping) of the points, the scaled ones at 95 % and 90.5 %
(tests/test_bootstrap_small_samples.py); on the Iwan SDOF of tests/test_validate_held_type.py
(its ring-down held out, predicted from the six-level stepped sine at 0.5 % noise, 8 seeds)
the ring-down's frequencies were inside their bands at 71 % of the samples, now 96 %.
Without resamples the band columns are NaN. A fitted
damping curve held at 0 at a sample (ζ is kept ≥ 0) leaves no relative misfit there: refused
(:class:`AmplitudeModelError`, one line naming the amplitude).

Joint fit of several sources (stepped sine, response-controlled runs, phase resonance,
ring-downs, impacts). Each source is weighted by its own noise: the relative standard
deviations of its frequencies and damping ratios are the scatter of their logarithms about a
quadratic in ln a fitted to that source alone (``√(Σr²/(n − 3))``, n ≥ 5 samples; in ln ζ, as
damping that grows as a power of a is no quadratic in ln a) — with the ``iwan`` backbone about
its own Iwan fit (``√(Σr²/(n − 3))``: six phase-resonance points of the Iwan SDOF, 2.8 % noisy
in ζ, scatter 11–15 % about a quadratic, which misses ζ(a)'s kink at φ_max) and with the
``jenkins`` backbone about its own Jenkins fit (``√(Σr²/(n − 2))``: a quadratic cannot follow the
stick–slip kink, and took the 1–3 % scatter of six phase-resonance points of a Jenkins SDOF
for 40 % in ζ and 0.7 % in frequency, so the noisier ring-down outweighed them: held out,
the steady-state types were predicted 5.4 % off in damping away from the kink; about their
own fits, 3.0 %) —, or the
standard errors a source states (an impact's pole), or, for fewer samples, the fit's defaults
(1e-3 and 5 %); floors of :data:`NOISE_FLOOR` keep one smooth source from taking all the
weight. Consistency: each source's mean relative misfit in frequency and in damping is
compared with its standard error (its noise/√n); the source farthest beyond
:data:`DISAGREEMENT` standard errors is named and the rest refitted without it, until the
sources left agree — a source off by a test-type effect (e.g. ring-down damping above
stepped-sine damping: shaker–structure interaction; a wrong force calibration) is named
alone rather than dragging the joint fit away from all the others. The model written is
still the joint fit of every source.

A source whose amplitudes no other agreeing source reaches is **not checked**
(``compared_with`` ``none``, NaN scores): the joint fit follows it there, so its misfit says
nothing — the Brake–Reuss beam's impact pole (80.5797 ± 0.0006 Hz at 3.6e-6 m·√kg, every
other source at 2.7e-5 and above) scored +0.04 standard errors whether its frequency was moved
by +50, 0 or −50 of them (the joint fit's linear limit went 80.61 → 80.64 → 80.69 Hz with it),
and an Iwan SDOF's impact moved by 50 scored +0.004. Scoring each source against the fit of
the others alone with its own standard error (leave one out) is no remedy: the others' fit
has errors of its own where they are sparse, and on the Iwan truth it named the exact
ring-down (+1 % in damping, 4.2 standard errors against the phase-resonance points' fit) and
put a true impact a decade below the other samples 35 standard errors off.
"""
from __future__ import annotations

from typing import Callable, Mapping, Sequence

import numpy as np
import pandas as pd

from nlupdate.core.identification.amplitude_modal_fit import default_resamples, fit_amplitude_model
from nlupdate.core.identification.bands import band_arrays
from nlupdate.core.identification.joint_band import joint_fixed
from nlupdate.core.identification.modal_samples import ModalSamples
from nlupdate.core.measurement.units import RESPONSE_UNIT_LABELS
from nlupdate.core.model.amplitude_modal import AmplitudeModalModel, AmplitudeModelError
from nlupdate.progress import ProgressCallback, no_progress

#: smallest relative standard deviation a source is given, (frequency, damping ratio)
NOISE_FLOOR = (1e-5, 0.01)
#: default relative standard deviations of a source with too few samples to show its scatter
DEFAULT_NOISE = (1e-3, 0.05)
#: a source's mean misfit beyond this many standard errors disagrees with the joint fit
DISAGREEMENT = 3.0
#: fewer samples than this cannot show their own scatter (module docstring)
MIN_SCATTER_SAMPLES = 5
#: the backbones whose sources' noise is their scatter about their own fit (module docstring)
OWN_FIT_BACKBONES = ("jenkins", "iwan")


def _per_quantity(model: AmplitudeModalModel) -> int:
    """Parameters per fitted quantity (frequency, damping) of a modal-joint fit: the ``jenkins``
    backbone's 4 (β, χ fixed: :func:`~nlupdate.core.identification.joint_band.joint_fixed`) or
    the Iwan's 6, over two quantities."""
    return 2 if model.joint is not None and joint_fixed(model) else 3


def _fitted_per_quantity(model: AmplitudeModalModel) -> tuple[int, int]:
    """Parameters fitted to the frequencies and to the damping ratios: a polynomial backbone's
    f₀ (ζ₀) and its coefficients, a modal-joint fit's :func:`_per_quantity` each."""
    if model.joint is not None:
        return _per_quantity(model), _per_quantity(model)
    return 1 + len(model.frequency_coefficients), 1 + len(model.damping_coefficients)


def small_sample_scale(n: int, parameters: int) -> float:
    """Factor on the misfits a residual bootstrap draws from n samples of a fit with
    ``parameters`` per quantity (module docstring, "Bands"): ``√(n/(n − p))`` (the misfits'
    spread is √((n − p)/n) of the noise's) times ``t₀.₉₇₅(n − p)/1.96`` (the noise known from n − p
    degrees of freedom only); NaN without a degree of freedom."""
    dof = n - parameters
    if dof < 1:
        return float("nan")
    import scipy.stats  # here: importing it costs 0.3 s

    return float(np.sqrt(n / dof) * scipy.stats.t.ppf(0.975, dof) / scipy.stats.norm.ppf(0.975))


#: the refits :func:`bootstrap_refits` takes when none are asked for, as the options' help and the docs say it
BOOTSTRAP_DEFAULT = (f"{default_resamples('polynomial')} for the polynomial backbone, {default_resamples('iwan')} for "
                     f"the others")


def bootstrap_refits(bootstrap: int | None, backbone: str) -> int:
    """The residual-bootstrap refits for a fit's 95 % bands: ``bootstrap`` as asked, or the
    ``backbone``'s default (:func:`~nlupdate.core.identification.amplitude_modal_fit.default_resamples`)
    when None; ValueError (one line, naming ``--bootstrap``) below 0."""
    refits = default_resamples(backbone) if bootstrap is None else bootstrap
    if refits < 0:
        raise ValueError(f"--bootstrap {refits}: expected a number of refits ≥ 0")
    return refits


def check_common_scale(parts: Sequence[ModalSamples], names: Sequence[str] = (),
                       shapes: Mapping[str, float] | None = None) -> None:
    """Refuse (one line) records read without the mode shape at their channel (``modal``
    False: amplitudes in m at that channel) joining modal samples: no common amplitude scale.
    ``names``: each part's source (a file), named in the refusal with the records' channel
    (:attr:`ModalSamples.channel`) and the ``shapes`` given (coordinate → 1/√kg)."""
    if len({p.modal for p in parts}) < 2:
        return
    loose = [(name, p.channel) for name, p in zip(names, parts) if not p.modal]
    files = ", ".join(dict.fromkeys(name for name, _ in loose)) or "a ring-down or impact record"
    channels = list(dict.fromkeys(channel for _, channel in loose if channel))
    channel = channels[0] if len(channels) == 1 else ""
    given = ", ".join(f"{name}={value:g}" for name, value in (shapes or {}).items()) or "none"
    option = channel or "CHANNEL"
    raise AmplitudeModelError(
        f"{files}: no mode shape at {'channel ' + channel if channel else 'its channel'}, so its amplitudes are in m, "
        f"not modal, and cannot join the modal samples of the other sources; give --shape {option}=VALUE "
        f"(mass-normalised, 1/√kg; shapes given: {given} — one sensor named two ways, a record's channel and an FRF's "
        f"coordinate such as {option}:y, needs its shape under both)")


def join_samples(parts: list[ModalSamples], names: Sequence[str] = (),
                 shapes: Mapping[str, float] | None = None) -> ModalSamples:
    """One set of samples from several sources at the same modal-amplitude scale (each with
    its shape given: FRF samples whose shape is to be fitted cannot join others; records
    without one neither, :func:`check_common_scale`, ``names`` and ``shapes`` naming them)."""
    if any(p.shape_free for p in parts):
        raise AmplitudeModelError("joining FRF samples with other sources needs the mode shape at the excited "
                                  "coordinate (--shape NAME=VALUE): without it their modal amplitudes have no common "
                                  "scale")
    check_common_scale(parts, names, shapes)
    if len(parts) == 1:
        return parts[0]
    return ModalSamples(np.concatenate([p.amplitude for p in parts]), np.concatenate([p.frequency_hz for p in parts]),
                        np.concatenate([p.damping_ratio for p in parts]), np.concatenate([p.force_n for p in parts]),
                        parts[0].input_shape, modal=parts[0].modal, channel=parts[0].channel)


def backbone_points(parts: list[tuple[str, ModalSamples] | tuple[str, ModalSamples, str]]) -> pd.DataFrame:
    """Every source's samples, one row each: ``source``, ``test_type`` (when the parts give
    one), ``modal_amplitude`` (m·√kg), ``natural_frequency_hz``, ``damping_ratio``."""
    return pd.concat([pd.DataFrame({"source": part[0], **({"test_type": part[2]} if len(part) > 2 else {}),
                                    "modal_amplitude": part[1].amplitude, "natural_frequency_hz": part[1].frequency_hz,
                                    "damping_ratio": part[1].damping_ratio})
                      for part in parts], ignore_index=True)


def backbone_curve(model: AmplitudeModalModel, samples: ModalSamples, count: int = 50,
                   refit: Callable[[ModalSamples], AmplitudeModalModel] | None = None, resamples: int = 0,
                   seed: int = 0, progress: ProgressCallback = no_progress, noise: tuple = DEFAULT_NOISE
                   ) -> pd.DataFrame:
    """The fitted model's backbone at ``count`` modal amplitudes spaced geometrically over the
    samples' range: ``modal_amplitude``, ``natural_frequency_hz``, ``damping_ratio`` and their
    band columns ``*_low``/``*_high`` from ``resamples`` bootstrap refits by ``refit`` (module
    docstring; NaN without them; ``noise``: the relative (frequency, damping) standard deviations
    the fit assumed, per sample or one each, drawn from for fewer than :data:`MIN_SCATTER_SAMPLES`
    samples); ``progress("bootstrap refits", done, resamples)`` after each."""
    a = np.geomspace(float(samples.amplitude.min()), float(samples.amplitude.max()), count)
    f, z = model.frequency_hz(a), model.damping(a)
    bands = {name: np.full(a.size, np.nan) for name in ("f_low", "f_high", "z_low", "z_high")}
    if refit is not None and resamples > 0:
        (bands["f_low"], bands["f_high"]), (bands["z_low"], bands["z_high"]) = bootstrap_bands(
            model, samples, a, refit, resamples, seed, progress, noise)
    return pd.DataFrame({"modal_amplitude": a, "natural_frequency_hz": f, "natural_frequency_hz_low": bands["f_low"],
                         "natural_frequency_hz_high": bands["f_high"], "damping_ratio": z,
                         "damping_ratio_low": bands["z_low"], "damping_ratio_high": bands["z_high"]})


def bootstrap_bands(model: AmplitudeModalModel, samples: ModalSamples, amplitude: np.ndarray,
                    refit: Callable[[ModalSamples], AmplitudeModalModel], resamples: int, seed: int = 0,
                    progress: ProgressCallback = no_progress, noise: tuple = DEFAULT_NOISE) -> tuple[tuple, tuple]:
    """((low, high) of the natural frequency, (low, high) of the damping ratio): the 95 %
    bands of ``backbone.csv`` (module docstring) at ``amplitude`` (m·√kg; 0 gives the linear
    limit's: each refit's own, as :meth:`AmplitudeModalModel.frequency_hz` reads a = 0)."""
    curves = _bootstrap(model, samples, amplitude, refit, resamples, seed, progress, noise)
    return tuple(band_arrays(point, c) for point, c in zip((model.frequency_hz(amplitude), model.damping(amplitude)),
                                                          curves))


def _bootstrap(model: AmplitudeModalModel, samples: ModalSamples, amplitude: np.ndarray,
               refit: Callable[[ModalSamples], AmplitudeModalModel], resamples: int,
               seed: int, progress: ProgressCallback = no_progress, noise: tuple = DEFAULT_NOISE
               ) -> tuple[np.ndarray, np.ndarray]:
    """(frequency, damping ratio) of the refitted curves at ``amplitude``, one row per resample:
    the samples' own misfits drawn with replacement, or, for fewer than
    :data:`MIN_SCATTER_SAMPLES`, misfits drawn from ``noise`` (module docstring)."""
    rng = np.random.default_rng(seed)
    f_fit, z_fit = model.frequency_hz(samples.amplitude), model.damping(samples.amplitude)
    if not np.all(z_fit > 0):  # ζ is kept ≥ 0: a curve held at 0 there has no relative misfit to draw
        at = ", ".join(f"{a:.3g}" for a in samples.amplitude[~(z_fit > 0)])
        raise AmplitudeModelError(f"bootstrap band: the fitted damping curve is 0 at modal amplitude {at} m·√kg, so "
                                  f"the samples' relative misfits there are undefined; another backbone, or no band "
                                  f"(--bootstrap 0)")
    n = samples.amplitude.size
    scale_f, scale_z = (small_sample_scale(n, p) for p in _fitted_per_quantity(model))
    misfit_f = scale_f * (samples.frequency_hz / f_fit - 1)
    misfit_z = scale_z * (samples.damping_ratio / z_fit - 1)
    f_std, z_std = (np.broadcast_to(np.asarray(std, float), (n,)) for std in noise)
    frequencies, dampings = [], []
    for done in range(1, resamples + 1):
        if n < MIN_SCATTER_SAMPLES or not np.isfinite(scale_f * scale_z):  # too few to show their scatter:
            df, dz = f_std * rng.standard_normal(n), z_std * rng.standard_normal(n)  # the noise the fit assumed
        else:
            pick = rng.integers(0, n, n)  # a sample's two misfits together
            df, dz = misfit_f[pick], misfit_z[pick]
        draw = ModalSamples(samples.amplitude, f_fit * (1 + df), z_fit * (1 + dz), samples.force_n,
                            samples.input_shape)
        refitted = refit(draw)
        frequencies.append(refitted.frequency_hz(amplitude))
        dampings.append(refitted.damping(amplitude))
        progress("bootstrap refits", done, resamples)
    return np.array(frequencies), np.array(dampings)


def displacement_samples(samples: ModalSamples, unit: str) -> ModalSamples:
    """Samples of a record in ``unit`` (m, m/s, m/s², … of
    :data:`~nlupdate.core.measurement.units.RESPONSE_UNIT_LABELS`) with their amplitudes as
    displacement: divided by ω^p (ω the sample's natural frequency, rad/s; p = 0, 1, 2) and
    scaled to metres. A free decay oscillates at its damped frequency ω√(1 − ζ²): the
    difference is of order ζ², below 10⁻⁴ for ζ < 1 %."""
    if unit not in RESPONSE_UNIT_LABELS:
        raise AmplitudeModelError(f"response unit {unit!r}: expected one of {', '.join(RESPONSE_UNIT_LABELS)}")
    power, factor = RESPONSE_UNIT_LABELS[unit]
    omega = 2 * np.pi * samples.frequency_hz
    return ModalSamples(samples.amplitude * factor / omega**power, samples.frequency_hz, samples.damping_ratio,
                        samples.force_n, samples.input_shape, modal=samples.modal,
                        channel=samples.channel)


def own_fit_for(backbone: str, shapes) -> Callable[[ModalSamples], AmplitudeModalModel] | None:
    """The fit :func:`source_noise` takes a source's scatter about for ``backbone``: the
    ``jenkins`` and ``iwan`` backbones' own (module docstring); None (a quadratic in ln a) for
    the polynomial."""
    if backbone not in OWN_FIT_BACKBONES:
        return None
    return lambda samples: fit_amplitude_model(samples, shapes, backbone)


def source_noise(samples: ModalSamples, stated: tuple[float, float] | None = None,
                 own_fit: Callable[[ModalSamples], AmplitudeModalModel] | None = None) -> tuple[float, float]:
    """(frequency, damping-ratio) relative standard deviations of one source (module
    docstring); ``own_fit`` (:func:`own_fit_for`): the scatter about it instead of a quadratic."""
    if stated is not None:
        f_std, z_std = stated
    elif samples.amplitude.size >= MIN_SCATTER_SAMPLES:
        x = np.log(samples.amplitude)
        model = None
        if own_fit is not None:
            try:
                model = own_fit(samples)
            except AmplitudeModelError:
                model = None
        spreads = []
        for y, fitted in ((samples.frequency_hz, None if model is None else model.frequency_hz(samples.amplitude)),
                          (samples.damping_ratio, None if model is None else model.damping(samples.amplitude))):
            if fitted is None:  # relative scatter: about ln y's own quadratic
                residual = np.log(y) - np.polyval(np.polyfit(x, np.log(y), 2), x)
                spreads.append(float(np.sqrt(np.sum(residual**2) / (y.size - 3))))
            else:  # about the source's own fit (Jenkins 4, Iwan 6 parameters for 2n values: 2 or 3 per quantity)
                residual = np.log(y / fitted)
                spreads.append(float(np.sqrt(np.sum(residual**2) / (y.size - _per_quantity(model)))))
        f_std, z_std = spreads
    else:
        f_std, z_std = DEFAULT_NOISE
    return max(f_std, NOISE_FLOOR[0]), max(z_std, NOISE_FLOOR[1])


def _scores(model: AmplitudeModalModel, parts: list[tuple[str, ModalSamples, str]],
            noises: list[tuple[float, float]]) -> list[dict]:
    rows = []
    for (name, samples, kind), (f_std, z_std) in zip(parts, noises):
        n = samples.amplitude.size
        df = float(np.mean(samples.frequency_hz / model.frequency_hz(samples.amplitude) - 1))
        dz = float(np.mean(samples.damping_ratio / model.damping(samples.amplitude) - 1))
        rows.append({"source": name, "test_type": kind, "samples": n, "frequency_offset": df,
                     "frequency_score": df / (f_std / np.sqrt(n)), "damping_offset": dz,
                     "damping_score": dz / (z_std / np.sqrt(n))})
    return rows


def consistency(model: AmplitudeModalModel, parts: list[tuple[str, ModalSamples, str]],
                noises: list[tuple[float, float]],
                refit: Callable[[list[int]], AmplitudeModalModel]) -> pd.DataFrame:
    """Which sources (file, samples, test type) agree (module docstring): against ``model``
    (the joint fit of all), the source whose mean misfit is the most standard errors away is
    named and the others are refitted without it (``refit``: the model of the sources at
    those indices), until every source left is within :data:`DISAGREEMENT` or cannot be
    fitted alone. One row per source: ``source``, ``test_type``, ``samples``, ``compared_with``
    (``agreeing sources``, or ``none`` when no other agreeing source reaches its amplitudes: not
    checked, NaN scores), the mean relative misfits ``frequency_offset``, ``damping_offset``
    (sample/model − 1) and each in standard errors (``*_score``) against the fit of the
    agreeing sources, and ``consistent`` (False only for a source named)."""
    kept = list(range(len(parts)))
    while True:
        rows = _scores(model, parts, noises)
        for i, row in enumerate(rows):  # nothing else at its amplitudes: not checked (module docstring)
            reached = _reached(parts[i][1], [parts[j][1] for j in kept if j != i])
            row["compared_with"] = "agreeing sources" if reached else "none"
            if not reached:
                row.update({key: np.nan for key in ("frequency_offset", "frequency_score", "damping_offset",
                                                    "damping_score")})
        score = [np.nan_to_num(max(abs(r["frequency_score"]), abs(r["damping_score"]))) for r in rows]
        worst = max(kept, key=lambda i: score[i])
        if score[worst] <= DISAGREEMENT or len(kept) <= 1:
            break
        try:
            candidate = refit([i for i in kept if i != worst])
        except AmplitudeModelError:  # what is left cannot be fitted on its own
            break
        kept.remove(worst)
        model = candidate
    for i, row in enumerate(rows):
        row["consistent"] = i in kept
    return pd.DataFrame(rows)[["source", "test_type", "samples", "compared_with", "frequency_offset",
                               "frequency_score", "damping_offset", "damping_score", "consistent"]]


def _reached(samples: ModalSamples, others: list[ModalSamples]) -> bool:
    """Whether any of ``samples`` lies within the amplitudes the ``others`` span (between
    their smallest and largest)."""
    if not others:
        return False
    low = min(float(o.amplitude.min()) for o in others) * (1 - 1e-9)
    high = max(float(o.amplitude.max()) for o in others) * (1 + 1e-9)
    return bool(np.any((samples.amplitude >= low) & (samples.amplitude <= high)))


#: the test types of ``nlupdate amplitude``'s sources (``test_type`` of backbone_points.csv)
TEST_TYPES = ("stepped-sine", "modal-table", "ring-down", "impact", "response-controlled", "phase-resonance")


def held_out_errors(model: AmplitudeModalModel, parts: list[tuple[str, ModalSamples, str]],
                    fitted: tuple[float, float]) -> pd.DataFrame:
    """What a model fitted without these sources predicts for them, one row per sample:
    ``source``, ``test_type``, ``modal_amplitude``, ``within_fit`` (the amplitude inside the
    ``fitted`` range of the samples the model was fitted to: interpolated, not extrapolated),
    measured and predicted natural frequency and damping ratio at that amplitude and their
    relative errors (``*_error``, predicted / measured − 1); for a phase-resonance sample also
    the amplitude the model holds at its force (``predicted_amplitude``, ``amplitude_error``;
    NaN for the others). ``predicted_at_amplitude``: the modal amplitude the prediction is
    read at — the sample's own, but for an impact below every fitted sample 0: an impact
    measures the linear limit, and the model's is its value at a = 0 (an extrapolation;
    ``within_fit`` False)."""
    frames = []
    for name, samples, kind in parts:
        a = samples.amplitude
        at = np.where(a < fitted[0] * (1 - 1e-9), 0.0, a) if kind == "impact" else a
        f, z = model.frequency_hz(at), model.damping(at)
        inside = (a >= fitted[0] * (1 - 1e-9)) & (a <= fitted[1] * (1 + 1e-9))
        frame = pd.DataFrame({"source": name, "test_type": kind, "modal_amplitude": a, "within_fit": inside,
                              "predicted_at_amplitude": at, "natural_frequency_hz": samples.frequency_hz,
                              "predicted_frequency_hz": f,
                              "frequency_error": f / samples.frequency_hz - 1, "damping_ratio": samples.damping_ratio,
                              "predicted_damping_ratio": z, "damping_error": z / samples.damping_ratio - 1,
                              "predicted_amplitude": np.nan, "amplitude_error": np.nan})
        if kind == "phase-resonance":  # the force's modal share as the model's first coordinate sees it
            force = samples.force_n * samples.input_shape / abs(model.shape(0))
            _, held = model.phase_resonance_point(force, 0)
            frame["predicted_amplitude"], frame["amplitude_error"] = held, held / a - 1
        frames.append(frame)
    return pd.concat(frames, ignore_index=True)
