"""Backbone samples of one mode from several sources, and the tables ``nlupdate amplitude`` writes.

Samples (:class:`~nlupdate.identification.amplitude_modal_fit.ModalSamples`) from a modal
table, FRFs, ring-downs (:mod:`nlupdate.identification.ring_down`) and response-controlled
runs (:mod:`nlupdate.identification.response_controlled`) join into one set when they share
the scale of the modal amplitude (the mode shape given); ``backbone_points.csv`` lists every
source's samples and ``backbone.csv`` the fitted model over their range.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from nlupdate.identification.amplitude_modal_fit import ModalSamples
from nlupdate.model.amplitude_modal import AmplitudeModalModel, AmplitudeModelError


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


def backbone_curve(model: AmplitudeModalModel, samples: ModalSamples, count: int = 50) -> pd.DataFrame:
    """The fitted model's backbone at ``count`` modal amplitudes spaced geometrically over the
    samples' range: ``modal_amplitude``, ``natural_frequency_hz``, ``damping_ratio`` and their
    band columns ``*_low``/``*_high``. The backbone fits carry no covariance, so the band columns
    are NaN (not estimated) rather than a guess."""
    a = np.geomspace(float(samples.amplitude.min()), float(samples.amplitude.max()), count)
    f, z = model.frequency_hz(a), model.damping(a)
    nan = np.full(a.size, np.nan)
    return pd.DataFrame({"modal_amplitude": a, "natural_frequency_hz": f, "natural_frequency_hz_low": nan,
                         "natural_frequency_hz_high": nan, "damping_ratio": z, "damping_ratio_low": nan,
                         "damping_ratio_high": nan})
