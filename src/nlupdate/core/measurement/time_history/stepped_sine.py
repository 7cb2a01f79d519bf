"""Stepped-sine FRFs: one first-harmonic estimate per dwell of a controller-logged frequency.

Per dwell the excitation frequency is refined from the logged value by least squares on the
reference (within ±2 frequency bins of the dwell); the transient is cut by the rule of
:mod:`~nlupdate.core.measurement.time_history.harmonic_fit`. A dwell should last several
time constants ``1/(ζω_r)`` of the mode it excites (at a resonance of ζ = 1 % and 20 Hz,
eight of them, 6.4 s, leave 0.1 % of the transient in the estimate). Then the first harmonic
(with the DC term and the harmonics 2 and 3) of force and response is fitted by least
squares over the kept samples: ``H = X₁/F₁``; ``harmonic_distortion = √Σ_{h=2,3}|X_h|² /
|X₁|``; ``h_std`` from the fit residuals (``|δX|² = 4σ²/N`` for N samples of residual
variance σ², added relatively for X and F); ``level_achieved = |F₁|``. A dwell that had not
settled is warned about. A harmonic distortion of the response or the reference above 10 %
(:data:`DISTORTION_WARNING`: clipping, a saturated channel, a strong nonlinearity) is warned
about, and a dwell where it exceeds 100 % (:data:`DISTORTION_LIMIT`: the harmonics outweigh
the first) is left out with a warning; a channel that is 0 at every sample is refused.
"""
from __future__ import annotations

import math

import numpy as np

from nlupdate.core.measurement.time_history.harmonic_fit import (
    DISTORTION_LIMIT, DISTORTION_WARNING, HARMONICS, MIN_SETTLE_PERIODS, check_reference_harmonic, check_sample_rate,
    distortion_of, fit_least_squares, harmonic_basis, phasors_of, refined_frequency, settled_start, to_receptance,
)
from nlupdate.core.measurement.time_history.records import TimeHistoryError, TimeRecord


def _dwells(record: TimeRecord) -> list[tuple[slice, float, float | None]]:
    """(samples, logged frequency, logged level) of every dwell."""
    f = record.frequency_hz
    level = record.level if record.level is not None else np.zeros_like(f)
    change = np.flatnonzero((np.diff(f) != 0) | (np.diff(level) != 0)) + 1
    edges = np.concatenate([[0], change, [f.size]])
    return [(slice(a, b), float(f[a]), None if record.level is None else float(level[a]))
            for a, b in zip(edges[:-1], edges[1:]) if b - a >= 16 and f[a] > 0]


def stepped_sine_frf(record: TimeRecord, power: int) -> tuple[list[dict], list[str]]:
    """Rows (one per dwell and response) of the stepped-sine estimate; notes."""
    rows, notes = [], []
    dwells = _dwells(record)
    for _, logged, _ in dwells:
        check_sample_rate(record, logged)
    for span, logged, level in dwells:
        t, force = record.time_s[span], record.reference[span]
        frequency = refined_frequency(t, force, logged)
        starts = [settled_start(t, x[span], frequency) for x in record.responses.values()]
        start = max(s for s, _ in starts)
        if any(ok is None for _, ok in starts):
            periods = frequency * t.size * (t[1] - t[0])
            notes.append(f"{record.source}: the dwell at {logged:g} Hz lasts {periods:.3g} periods, fewer than the "
                         f"{MIN_SETTLE_PERIODS} periods the transient rule needs to tell whether it settled; its FRF "
                         f"may hold the transient (dwell several time constants 1/(ζω_r))")
        elif not all(ok for _, ok in starts):
            notes.append(f"{record.source}: the dwell at {logged:g} Hz had not settled before its last quarter; its "
                         f"FRF may hold the transient")
        t, force = t[start:], force[start:]
        basis = harmonic_basis(t, frequency, HARMONICS)
        f_coefficients, f_variance = fit_least_squares(basis, force)
        f_phasors = phasors_of(f_coefficients, HARMONICS)
        check_reference_harmonic(record, logged, t, force, f_phasors[0])
        where = f"{record.source}: the dwell at {logged:g} Hz"
        if distortion_of(f_phasors) > DISTORTION_LIMIT:
            notes.append(f"{where} left out: the reference's harmonic distortion is {100 * distortion_of(f_phasors):.3g} %, "
                         f"above {100 * DISTORTION_LIMIT:g} %: its first harmonic does not describe the excitation")
            continue
        if distortion_of(f_phasors) > DISTORTION_WARNING:
            notes.append(f"{where}: the reference's harmonic distortion is {100 * distortion_of(f_phasors):.3g} % (above "
                         f"{100 * DISTORTION_WARNING:g} %): a clipped or saturated force or amplifier channel?")
        dwell_rows = []
        for name, signal in record.responses.items():
            x_coefficients, x_variance = fit_least_squares(basis, signal[span][start:])
            x_phasors = phasors_of(x_coefficients, HARMONICS)
            if not np.any(signal[span][start:]):
                raise TimeHistoryError(f"{where}: the response '{name}' is 0 at every sample of the dwell; expected a "
                                       f"measured signal")
            distortion = distortion_of(x_phasors)
            if distortion > DISTORTION_LIMIT:
                notes.append(f"{where} left out: the harmonic distortion of '{name}' is {100 * distortion:.3g} %, above "
                             f"{100 * DISTORTION_LIMIT:g} %: its first harmonic does not describe the response")
                dwell_rows = None
                break
            if distortion > DISTORTION_WARNING:
                notes.append(f"{where}: the harmonic distortion of '{name}' is {100 * distortion:.3g} % (above "
                             f"{100 * DISTORTION_WARNING:g} %): the first-harmonic FRF describes the response only in "
                             f"part (a strong nonlinearity, or a clipped or saturated channel)")
            h = x_phasors[0] / f_phasors[0]
            relative = math.sqrt(4 * x_variance / (t.size * abs(x_phasors[0]) ** 2)
                                 + 4 * f_variance / (t.size * abs(f_phasors[0]) ** 2))
            dwell_rows.append({"frequency_hz": frequency, "response_dof": name, "h": h, "h_std": abs(h) * relative,
                               "level_achieved": abs(f_phasors[0]), "level_key": level,
                               "harmonic_distortion": distortion})
        rows += dwell_rows or []
    if dwells and not rows:
        raise TimeHistoryError(f"{record.source}: every dwell was left out, the first because {notes[-1].split(' left out: ')[-1]}")
    for row in rows:
        row["h"] = to_receptance(row["h"], row["frequency_hz"], power)
        row["h_std"] = row["h_std"] / (2 * np.pi * row["frequency_hz"]) ** power
    return rows, notes
