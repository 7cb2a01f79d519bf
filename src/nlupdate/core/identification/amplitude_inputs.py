"""The backbone samples of one mode from each test type besides stepped sine, read from files:
what ``nlupdate amplitude`` and a study's ``[amplitude]`` table both read (one function,
:func:`read_sources`).

One ``(source, samples, stated noise, test type)`` per file: a ring-down (the envelope
method, the segments or the decay fit: ``ring_down_fit``, docs/ring-down.md), response-
controlled runs (a one-mode fit per held run), phase-resonance points (the force balance at
each point; CSV, MAT or UFF) and an impact (the linear limit by a complex exponential fit of
the quietest part of the decay). The amplitudes of ring-down and impact records are in the
response's units (``response_unit``, m by default) divided by the shape at the channel when
given, then made displacement (m, m·√kg with the shape).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from nlupdate.core.identification.backbone_samples import displacement_samples, join_samples
from nlupdate.core.identification.decay_fit import fit_decay
from nlupdate.core.identification.impact import decay_segments, fit_linear_limit, split_force
from nlupdate.core.identification.modal_samples import ModalSamples
from nlupdate.core.identification.phase_resonance import read_phase_resonance, samples_from_phase_resonance
from nlupdate.core.identification.response_controlled import read_response_controlled, samples_from_held_runs
from nlupdate.core.identification.ring_down import RingDownError, estimate_ring_down, read_channels, read_ring_down
from nlupdate.core.measurement.units import ReadOptions

#: (file, samples, stated (frequency, damping) relative standard deviations or None, test type)
Source = tuple[str, ModalSamples, "tuple[float, float] | None", str]
#: how a ring-down is read (docs/ring-down.md)
RING_DOWN_FITS = ("envelope", "segments", "decay")


class SourceError(ValueError):
    """A source file that cannot give backbone samples as given (one line naming the file)."""


@dataclass(frozen=True)
class SourceFiles:
    """The files of each test type and how to read them.

    ring_down, impact, response_controlled, phase_resonance: files (as given: relative paths
    resolve against the working directory); ring_down_fit: one of :data:`RING_DOWN_FITS`;
    band: the mode's band-pass (Hz) or None (found); response_unit: the unit of the ring-down
    and impact records; channel: their channel (None: a ring-down's only one, an impact's
    every one); held: the held amplitude of response-controlled UFF runs whose names do not
    state it (``FILE#RUN``, ``RUN`` or ``FILE`` → value in their response record's unit);
    options: the measured-data options (coordinates, reference unit) of the MATLAB and UFF files.
    """

    ring_down: tuple[str, ...] = ()
    impact: tuple[str, ...] = ()
    response_controlled: tuple[str, ...] = ()
    phase_resonance: tuple[str, ...] = ()
    ring_down_fit: str = "envelope"
    band: tuple[float, float] | None = None
    response_unit: str = "m"
    channel: str | None = None
    held: Mapping[str, float] = field(default_factory=dict)
    options: ReadOptions = field(default_factory=ReadOptions)

    @property
    def any(self) -> bool:
        return bool(self.ring_down or self.impact or self.response_controlled or self.phase_resonance)


def _units_note(channel: str, shapes: Mapping[str, float], unit: str) -> str:
    return "" if channel in shapes else f"; no shape at {channel}: amplitudes in m (of {unit}), not modal"


def _record_samples(samples: ModalSamples, channel: str, shapes: Mapping[str, float], unit: str) -> ModalSamples:
    """A ring-down's or impact's samples as displacement, not modal without a shape at ``channel``."""
    return dataclasses.replace(displacement_samples(samples, unit), modal=channel in shapes, channel=channel)


def read_sources(files: SourceFiles, shapes: Mapping[str, float]) -> tuple[list[Source], str, list[str]]:
    """(the sources of every file, the coordinate of the last one, a note per file saying what
    was read): module docstring; a response-controlled file's shape is given or from its lowest
    run's modal constant. Errors are one line (:class:`SourceError` or the readers' ValueError)."""
    out: list[Source] = []
    notes: list[str] = []
    channel = ""
    band, unit = files.band, files.response_unit
    for path in files.ring_down:
        record = read_ring_down(path, files.channel)
        channel = record.channel
        if files.ring_down_fit == "decay":
            fit = fit_decay(record.time_s, record.response, band, shapes.get(channel), source=path)
            samples = _record_samples(fit.samples(), channel, shapes, unit)
            stated = fit.stated_noise()
            notes.append(f"{path}: channel {channel}, decay fit over {fit.window_s[0]:.3g}–{fit.window_s[1]:.3g} s, "
                         f"{samples.amplitude.size} samples where its damping is known to 1.5 % (largest standard "
                         f"errors {stated[0]:.2g} in frequency, {100 * stated[1]:.2g} % in damping)"
                         f"{_units_note(channel, shapes, unit)}")
        elif files.ring_down_fit == "segments":
            parts = decay_segments(record.time_s, {channel: record.response}, band, shapes.get(channel), source=path)
            samples = _record_samples(join_samples([part.samples() for part in parts]), channel, shapes, unit)
            stated = (float(np.median([p.frequency_std_hz / p.frequency_hz for p in parts])),
                      float(np.median([p.damping_std / p.damping_ratio for p in parts])))
            notes.append(f"{path}: channel {channel}, {len(parts)} segment(s) over {parts[0].window_s[0]:.3g}–"
                         f"{parts[-1].window_s[1]:.3g} s, each a complex exponential fit (median standard errors "
                         f"{stated[0]:.2g} in frequency, {100 * stated[1]:.2g} % in damping)"
                         f"{_units_note(channel, shapes, unit)}")
        elif files.ring_down_fit == "envelope":
            estimate = estimate_ring_down(record.time_s, record.response, band, shapes.get(channel), source=path)
            samples, stated = _record_samples(estimate.samples(), channel, shapes, unit), None
            notes.append(f"{path}: channel {channel}, band {estimate.band_hz[0]:.4g}–{estimate.band_hz[1]:.4g} Hz, "
                         f"{estimate.trim_s[0]:.3g} s and {estimate.trim_s[1]:.3g} s trimmed at the start and end, "
                         f"{samples.amplitude.size} samples (a smoothing window apart: {estimate.window_s.min():.3g}–"
                         f"{estimate.window_s.max():.3g} s){_units_note(channel, shapes, unit)}")
        else:
            raise SourceError(f"ring-down fit {files.ring_down_fit!r}: expected one of {list(RING_DOWN_FITS)}")
        out.append((path, samples, stated, "ring-down"))
    for path in files.impact:
        try:
            time_s, responses, force = split_force(read_channels(path, "impact record"), files.channel)
        except RingDownError as error:
            raise SourceError(f"{path}: {error}") from None
        first = next(iter(responses))
        fit = fit_linear_limit(time_s, responses, band, shapes.get(first), force, source=path)
        samples = _record_samples(fit.samples(), first, shapes, unit)
        notes.append(f"{path}: linear limit {fit.frequency_hz:.6g} ± {fit.frequency_std_hz:.2g} Hz, damping ratio "
                     f"{100 * fit.damping_ratio:.4g} ± {100 * fit.damping_std:.2g} % (complex exponential fit of "
                     f"{', '.join(fit.channels)} over {fit.window_s[0]:.3g}–{fit.window_s[1]:.3g} s, band "
                     f"{fit.band_hz[0]:.4g}–{fit.band_hz[1]:.4g} Hz){_units_note(first, shapes, unit)}")
        out.append((path, samples, (fit.frequency_std_hz / fit.frequency_hz, fit.damping_std / fit.damping_ratio),
                    "impact"))
        channel = first
    held = dataclasses.replace(files.options, levels=dict(files.held))
    for path in files.response_controlled:
        runs = read_response_controlled(path, held)
        channel = runs[0].response_dof
        samples = samples_from_held_runs(runs, shapes.get(channel))
        notes.append(f"{path}: {len(runs)} response-controlled run(s) at {channel}, held {1e6 * runs[0].held_m:.3g}–"
                     f"{1e6 * runs[-1].held_m:.3g} µm, one-mode fit of each" + (
                         "" if channel in shapes else
                         f"; shape {samples.input_shape:.4g} 1/√kg from the lowest run's modal constant"))
        out.append((path, samples, None, "response-controlled"))
    for path in files.phase_resonance:
        points = read_phase_resonance(path, files.options)
        missing = [dof for dof in (points.response_dof, points.input_dof) if dof not in shapes]
        if missing:
            raise SourceError(f"{path}: give the shape at {missing[0]} (1/√kg; --shape {missing[0]}=VALUE, in a study "
                              f"[amplitude] shapes): the damping at phase resonance, "
                              f"ζ = |φ_f φ_r| F/(2Ω²|X_r|), needs the mass-normalised shape at the response and "
                              f"the force")
        samples = samples_from_phase_resonance(points, shapes[points.response_dof], shapes[points.input_dof])
        notes.append(f"{path}: {samples.amplitude.size} phase-resonance point(s) at {points.response_dof} (force at "
                     f"{points.input_dof}), {points.force_n.min():.4g}–{points.force_n.max():.4g} N")
        out.append((path, samples, None, "phase-resonance"))
        channel = points.input_dof
    return out, channel, notes
