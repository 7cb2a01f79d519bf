"""Random and burst FRFs: the H1 estimate with Welch averages.

H1 = G_fx/G_ff with Welch averages (Hann window, half overlap), the ordinary coherence
``γ² = |G_fx|²/(G_ff G_xx)``, ``averages`` = number of segments and
``h_std = |H|·√((1 − γ²)/(γ² n_d))`` (Bendat & Piersol); the level is the reference's
RMS. The 0 Hz line is left out.
"""
from __future__ import annotations

import math

import numpy as np

from nlupdate.core.measurement.time_history.harmonic_fit import to_receptance
from nlupdate.core.measurement.time_history.records import TimeHistoryError, TimeRecord


def random_frf(record: TimeRecord, power: int, resolution_hz: float | None = None) -> list[dict]:
    """Rows of the H1 estimate (module docstring)."""
    fs = record.sample_rate_hz
    n = record.time_s.size
    nperseg = 2 ** int(math.floor(math.log2(n / 8))) if resolution_hz is None else int(round(fs / resolution_hz))
    if nperseg < 16 or nperseg > n:
        raise TimeHistoryError(f"{record.source}: {n} samples are too few for an H1 estimate at that resolution "
                               f"(segments of {nperseg} samples)")
    import scipy.signal  # imported where used: it costs 0.3 s

    f, g_ff = scipy.signal.welch(record.reference, fs=fs, window="hann", nperseg=nperseg)
    segments = 1 + (n - nperseg) // (nperseg // 2)
    keep = f > 0
    rows = []
    for name, signal in record.responses.items():
        _, g_fx = scipy.signal.csd(record.reference, signal, fs=fs, window="hann", nperseg=nperseg)
        _, g_xx = scipy.signal.welch(signal, fs=fs, window="hann", nperseg=nperseg)
        h1 = g_fx / g_ff  # scipy's csd(x, y) is conj(X)·Y: G_fx with x(t) = Re(X e^{iωt})
        coherence = np.clip(np.abs(g_fx) ** 2 / (g_ff * g_xx), 0.0, 1.0)
        h_std = np.abs(h1) * np.sqrt((1 - coherence) / (np.maximum(coherence, 1e-12) * segments))
        h = to_receptance(h1[keep], f[keep], power)
        for fk, hk, gk, sk in zip(f[keep], h, coherence[keep], h_std[keep] / (2 * np.pi * f[keep]) ** power):
            rows.append({"frequency_hz": fk, "response_dof": name, "h": hk, "coherence": gk, "averages": segments,
                         "h_std": sk, "level_key": None})
    return rows

