"""Backbone samples of one mode from several sources, and the tables ``nlupdate amplitude`` writes.

Samples (:class:`~nlupdate.core.identification.amplitude_modal_fit.ModalSamples`) from a modal
table, FRFs, ring-downs (:mod:`nlupdate.core.identification.ring_down`) and response-controlled
runs (:mod:`nlupdate.core.identification.response_controlled`) join into one set when they share
the scale of the modal amplitude (the mode shape given); ``backbone_points.csv`` lists every
source's samples and ``backbone.csv`` the fitted model over their range.

Bands of ``backbone.csv``. The backbone fits give no covariance; the band is a residual
bootstrap: the samples' relative misfits ``f_i/f(a_i) − 1`` and ``ζ_i/ζ(a_i) − 1`` are drawn
with replacement onto the fitted curves at the same amplitudes, the model is refitted to
each draw, and ``*_low``/``*_high`` are the 2.5th and 97.5th percentiles of the refitted
curves (a 95 % interval of the fit, given the model; ring-down samples are a smoothing window
apart, so their misfits are about independent). Without resamples the band columns are NaN.
"""
from __future__ import annotations

from typing import Callable

import numpy as np
import pandas as pd

from nlupdate.core.identification.amplitude_modal_fit import ModalSamples
from nlupdate.core.model.amplitude_modal import AmplitudeModalModel, AmplitudeModelError


def join_samples(parts: list[ModalSamples]) -> ModalSamples:
    """One set of samples from several sources at the same modal-amplitude scale (each with
    its shape given: FRF samples whose shape is to be fitted cannot join others)."""
    if any(p.shape_free for p in parts):
        raise AmplitudeModelError("joining FRF samples with other sources needs the mode shape at the excited "
                                  "coordinate (--shape NAME=VALUE): without it their modal amplitudes have no common "
                                  "scale")
    if len(parts) == 1:
        return parts[0]
    return ModalSamples(np.concatenate([p.amplitude for p in parts]), np.concatenate([p.frequency_hz for p in parts]),
                        np.concatenate([p.damping_ratio for p in parts]), np.concatenate([p.force_n for p in parts]),
                        parts[0].input_shape)


def backbone_points(parts: list[tuple[str, ModalSamples]]) -> pd.DataFrame:
    """Every source's samples, one row each: ``source``, ``modal_amplitude`` (m·√kg),
    ``natural_frequency_hz``, ``damping_ratio``."""
    return pd.concat([pd.DataFrame({"source": name, "modal_amplitude": s.amplitude,
                                    "natural_frequency_hz": s.frequency_hz, "damping_ratio": s.damping_ratio})
                      for name, s in parts], ignore_index=True)


def backbone_curve(model: AmplitudeModalModel, samples: ModalSamples, count: int = 50,
                   refit: Callable[[ModalSamples], AmplitudeModalModel] | None = None, resamples: int = 0,
                   seed: int = 0) -> pd.DataFrame:
    """The fitted model's backbone at ``count`` modal amplitudes spaced geometrically over the
    samples' range: ``modal_amplitude``, ``natural_frequency_hz``, ``damping_ratio`` and their
    band columns ``*_low``/``*_high`` from ``resamples`` bootstrap refits by ``refit`` (module
    docstring; NaN without them)."""
    a = np.geomspace(float(samples.amplitude.min()), float(samples.amplitude.max()), count)
    f, z = model.frequency_hz(a), model.damping(a)
    bands = {name: np.full(a.size, np.nan) for name in ("f_low", "f_high", "z_low", "z_high")}
    if refit is not None and resamples > 0:
        curves = _bootstrap(model, samples, a, refit, resamples, seed)
        (bands["f_low"], bands["f_high"]), (bands["z_low"], bands["z_high"]) = (
            np.percentile(c, [2.5, 97.5], axis=0) for c in curves)
    return pd.DataFrame({"modal_amplitude": a, "natural_frequency_hz": f, "natural_frequency_hz_low": bands["f_low"],
                         "natural_frequency_hz_high": bands["f_high"], "damping_ratio": z,
                         "damping_ratio_low": bands["z_low"], "damping_ratio_high": bands["z_high"]})


def _bootstrap(model: AmplitudeModalModel, samples: ModalSamples, amplitude: np.ndarray,
               refit: Callable[[ModalSamples], AmplitudeModalModel], resamples: int,
               seed: int) -> tuple[np.ndarray, np.ndarray]:
    """(frequency, damping ratio) of the refitted curves at ``amplitude``, one row per resample."""
    rng = np.random.default_rng(seed)
    f_fit, z_fit = model.frequency_hz(samples.amplitude), model.damping(samples.amplitude)
    misfit_f, misfit_z = samples.frequency_hz / f_fit - 1, samples.damping_ratio / z_fit - 1
    n = samples.amplitude.size
    frequencies, dampings = [], []
    for _ in range(resamples):
        pick = rng.integers(0, n, n)  # a sample's two misfits together
        draw = ModalSamples(samples.amplitude, f_fit * (1 + misfit_f[pick]), z_fit * (1 + misfit_z[pick]),
                            samples.force_n, samples.input_shape)
        refitted = refit(draw)
        frequencies.append(refitted.frequency_hz(amplitude))
        dampings.append(refitted.damping(amplitude))
    return np.array(frequencies), np.array(dampings)
