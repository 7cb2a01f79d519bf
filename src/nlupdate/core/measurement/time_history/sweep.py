"""Sine-sweep FRFs: windowed first-harmonic fits along the reference's instantaneous phase.

A sweep record has no ``frequency_hz`` column and a reference of constant envelope. The
reference's instantaneous phase φ(t) is the unwrapped phase of its analytic signal (Hilbert
transform), smoothed by a quadratic in t over each window; in windows of ``window_cycles``
periods (default 10), spaced by half a window, force and response are fitted by least squares
on ``cos φ, sin φ`` and the same times ``(t − t_c)`` (an amplitude changing linearly across the
window) plus a constant: ``H = X(t_c)/F(t_c)`` at the instantaneous frequency ``φ̇(t_c)/2π``.

**Sweep-rate limit**: the response lags the excitation by its group delay, ``1/(ζω_r)`` at a
resonance, so a sweep at r Hz/s measures the steady-state FRF at a frequency shifted by about
``r/(2πζ f_r)``; against the half-power half-bandwidth ``ζ f_r`` that is a relative error of
about ``r/(2π (ζ f_r)²)``. tests/test_time_history.py measures it on a linear SDOF (f_r = 20
Hz, ζ = 5 %, 18–22 Hz, complex FRF against the steady state): 0.8 % at ``r = 0.05 (ζ f_r)²``,
1.6 % at 0.1, 3.2 % at 0.2, 12 % at 0.8 — proportional to the rate. Keep ``r ≤ 0.1·(ζ
f_r)²`` Hz/s (:data:`SWEEP_RATE_LIMIT`) for 2 %; a faster sweep shifts and lowers the
resonance in the sweep direction. The table records the ``sweep_direction``.
"""
from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.measurement.time_history.harmonic_fit import fit_least_squares, to_receptance
from nlupdate.core.measurement.time_history.records import TimeHistoryError, TimeRecord

#: sweep rates r ≤ SWEEP_RATE_LIMIT·(ζ f_r)² Hz/s keep the swept FRF within 2 % of the steady state
SWEEP_RATE_LIMIT = 0.1


def _instantaneous_phase(t: NDArray, reference: NDArray) -> NDArray:
    """The unwrapped phase (rad) of the reference's analytic signal."""
    import scipy.signal  # imported where used: it costs 0.3 s (it imports scipy.stats)

    analytic = scipy.signal.hilbert(reference - reference.mean())
    return np.unwrap(np.angle(analytic))


def sine_sweep_frf(record: TimeRecord, power: int, window_cycles: float = 10.0) -> tuple[list[dict], str, list[str]]:
    """Rows of the sweep estimate, the sweep direction and notes (module docstring)."""
    t, force = record.time_s, record.reference
    phase = _instantaneous_phase(t, force)
    rows = []
    fs = record.sample_rate_hz
    frequencies = []
    instantaneous = np.abs(np.gradient(phase, t)) / (2 * np.pi)
    smoothing = max(3, int(fs / max(np.median(instantaneous), 1e-9)))
    instantaneous = np.convolve(instantaneous, np.ones(smoothing) / smoothing, mode="same")
    centre = int(round(0.5 * window_cycles * fs / max(instantaneous[smoothing], 1e-9)))
    while centre < t.size:
        half = int(round(0.5 * window_cycles * fs / max(instantaneous[centre], 1e-9)))
        if half < 8 or centre + half > t.size:
            break
        span = slice(max(centre - half, 0), centre + half)
        tc = t[centre]
        dt = t[span] - tc
        quadratic = np.polyfit(dt, phase[span], 2)
        phi = np.polyval(quadratic, dt)
        frequency = quadratic[1] / (2 * np.pi)
        basis = np.column_stack([np.cos(phi), np.sin(phi), dt * np.cos(phi), dt * np.sin(phi), np.ones_like(dt)])
        f_coefficients, _ = fit_least_squares(basis, force[span])
        force_phasor = (f_coefficients[0] - 1j * f_coefficients[1]) * np.exp(1j * quadratic[2])
        for name, signal in record.responses.items():
            x_coefficients, _ = fit_least_squares(basis, signal[span])
            x_phasor = (x_coefficients[0] - 1j * x_coefficients[1]) * np.exp(1j * quadratic[2])
            rows.append({"frequency_hz": frequency, "response_dof": name,
                         "h": to_receptance(x_phasor / force_phasor, frequency, power),
                         "level_achieved": abs(force_phasor), "level_key": None})
        frequencies.append(frequency)
        centre += max(half, 1)
    if len(frequencies) < 2:
        raise TimeHistoryError(f"{record.source}: the record is shorter than two windows of {window_cycles:g} cycles")
    direction = "up" if frequencies[-1] > frequencies[0] else "down"
    rate = abs(np.polyfit(t[: instantaneous.size], instantaneous, 1)[0])
    slowest = math.sqrt(rate / SWEEP_RATE_LIMIT)
    note = (f"{record.source}: sweep rate {rate:.3g} Hz/s ({direction}): the swept FRF is within 2 % of the stepped-sine "
            f"FRF only for modes with ζ·f_r ≥ {slowest:.3g} Hz (r ≤ {SWEEP_RATE_LIMIT:g}·(ζ f_r)²); a less damped or "
            f"lower mode is shifted and lowered in the sweep direction")
    return rows, direction, [note]

