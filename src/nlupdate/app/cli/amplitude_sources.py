"""The samples ``nlupdate amplitude`` reads from each test type besides ``--measured``.

One ``(source, samples, stated noise)`` per file: ``--ring-down`` (the envelope method,
docs/ring-down.md), ``--response-controlled`` (a one-mode fit per held run),
``--phase-resonance`` (the force balance at each point) and ``--impact`` (the linear limit
by a complex exponential fit of the quietest part of the decay). The amplitudes of ring-down
and impact records are in the response's units (``--response-unit``, m by default) divided by
the shape at the channel when given, then made displacement.
"""
from __future__ import annotations

import argparse
import dataclasses

import numpy as np

from nlupdate.app.cli import CliError
from nlupdate.app.cli.measured import parse_band, parse_levels, read_options
from nlupdate.core.identification.amplitude_modal_fit import ModalSamples
from nlupdate.core.identification.backbone_samples import displacement_samples, join_samples
from nlupdate.core.identification.impact import decay_segments, fit_linear_limit, split_force
from nlupdate.core.identification.phase_resonance import read_phase_resonance, samples_from_phase_resonance
from nlupdate.core.identification.response_controlled import read_response_controlled, samples_from_held_runs
from nlupdate.core.identification.ring_down import RingDownError, estimate_ring_down, read_channels, read_ring_down

Source = tuple[str, ModalSamples, "tuple[float, float] | None", str]


def add_source_options(parser: argparse.ArgumentParser, response_controlled: bool = True) -> None:
    """The test-type options; ``response_controlled`` False leaves out ``--response-controlled``
    (``nlupdate validate`` reads those runs from its ``--measured`` MATLAB files)."""
    parser.add_argument("--ring-down", action="append", default=[], metavar="FILE",
                        help="free decay of the mode (.csv: time_s and one column per channel; or .mat); repeatable")
    parser.add_argument("--ring-down-fit", choices=("envelope", "segments"), default="envelope",
                        help="how a ring-down is read: envelope (differentiated envelope and phase, default) or "
                             "segments (a complex exponential fit of each part over which the envelope falls by 1.5: "
                             "fewer samples, robust to noise)")
    if response_controlled:
        parser.add_argument("--response-controlled", action="append", default=[], metavar="FILE",
                            help="response-controlled stepped-sine runs (.mat, as --measured's MATLAB runs; "
                                 "--coordinates for a sensor along −DIR; or .uff/.unv: an FRF or spectra of response "
                                 "and force per run, the held amplitude in the run name, e.g. 'ResponseControl 20 "
                                 "m/s2', 'Rc5ms2', 'a=0.5 g'): one sample per held amplitude; repeatable")
        parser.add_argument("--held-amplitude", action="append", default=[], metavar="KEY=VALUE",
                            help="held amplitude of a response-controlled UFF run whose name does not state it, in the "
                                 "unit of its response record (m/s^2 for an accelerance): FILE#RUN=VALUE, RUN=VALUE, "
                                 "or FILE=VALUE for a file of one run; repeat per run")
    parser.add_argument("--phase-resonance", action="append", default=[], metavar="FILE",
                        help="phase-resonance points (.csv: frequency_hz, force_n, response_amplitude, "
                             "response_phase_deg, optional response_unit, response_dof, input_dof; .mat runs; or "
                             ".uff/.unv: per level one frequency line, spectra of response and force or an FRF and "
                             "its force): one sample per level; needs --shape at its response (and input) coordinate; "
                             "repeatable")
    parser.add_argument("--impact", action="append", default=[], metavar="FILE",
                        help="impact or low-level free decay (.csv or .mat: time_s, one column per channel, optional "
                             "force): the linear limit from the quietest part of the decay; all channels jointly, or "
                             "--channel; repeatable")
    parser.add_argument("--response-unit", default="m",
                        help="unit of the --ring-down and --impact records: m (default), mm, m/s, mm/s, m/s^2, g, …; "
                             "their amplitudes are made displacement")
    parser.add_argument("--channel", help="the ring-down and impact files' channel (default: a ring-down's only one, "
                                          "an impact's every one); its --shape, if given, makes the amplitude modal")


def _units_note(channel: str, shapes: dict[str, float], unit: str) -> str:
    return "" if channel in shapes else f"; no --shape {channel}=VALUE: amplitudes in m (of {unit}), not modal"


def read_sources(args: argparse.Namespace, shapes: dict[str, float]) -> tuple[list[Source], str]:
    """((file, samples, stated (frequency, damping) relative standard deviations or None, test
    type) of each file, the coordinate of the last): module docstring; a response-controlled file's
    shape is given or from its lowest run's modal constant."""
    out: list[Source] = []
    channel = ""
    band = parse_band(args.band)
    unit = args.response_unit
    for path in args.ring_down:
        record = read_ring_down(path, args.channel)
        if args.ring_down_fit == "segments":
            parts = decay_segments(record.time_s, {record.channel: record.response}, band, shapes.get(record.channel),
                                   source=path)
            samples = displacement_samples(join_samples([part.samples() for part in parts]), unit)
            stated = (float(np.median([p.frequency_std_hz / p.frequency_hz for p in parts])),
                      float(np.median([p.damping_std / p.damping_ratio for p in parts])))
            print(f"{path}: channel {record.channel}, {len(parts)} segment(s) over {parts[0].window_s[0]:.3g}–"
                  f"{parts[-1].window_s[1]:.3g} s, each a complex exponential fit (median standard errors "
                  f"{stated[0]:.2g} in frequency, {100 * stated[1]:.2g} % in damping)"
                  f"{_units_note(record.channel, shapes, unit)}")
            out.append((path, samples, stated, "ring-down"))
            channel = record.channel
            continue
        estimate = estimate_ring_down(record.time_s, record.response, band, shapes.get(record.channel), source=path)
        samples = displacement_samples(estimate.samples(), unit)
        print(f"{path}: channel {record.channel}, band {estimate.band_hz[0]:.4g}–{estimate.band_hz[1]:.4g} Hz, "
              f"{estimate.trim_s[0]:.3g} s and {estimate.trim_s[1]:.3g} s trimmed at the start and end, "
              f"{samples.amplitude.size} samples (a smoothing window apart: {estimate.window_s.min():.3g}–"
              f"{estimate.window_s.max():.3g} s){_units_note(record.channel, shapes, unit)}")
        out.append((path, samples, None, "ring-down"))
        channel = record.channel
    for path in args.impact:
        try:
            time_s, responses, force = split_force(read_channels(path, "impact record"), args.channel)
        except RingDownError as error:
            raise CliError(f"{path}: {error}") from None
        first = next(iter(responses))
        fit = fit_linear_limit(time_s, responses, band, shapes.get(first), force, source=path)
        samples = displacement_samples(fit.samples(), unit)
        print(f"{path}: linear limit {fit.frequency_hz:.6g} ± {fit.frequency_std_hz:.2g} Hz, damping ratio "
              f"{100 * fit.damping_ratio:.4g} ± {100 * fit.damping_std:.2g} % (complex exponential fit of "
              f"{', '.join(fit.channels)} over {fit.window_s[0]:.3g}–{fit.window_s[1]:.3g} s, band "
              f"{fit.band_hz[0]:.4g}–{fit.band_hz[1]:.4g} Hz){_units_note(first, shapes, unit)}")
        out.append((path, samples, (fit.frequency_std_hz / fit.frequency_hz, fit.damping_std / fit.damping_ratio),
                    "impact"))
        channel = first
    held = dataclasses.replace(read_options(args), levels=parse_levels(
        getattr(args, "held_amplitude", []), "--held-amplitude", "the unit of the run's response record"))
    for path in args.response_controlled:
        runs = read_response_controlled(path, held)
        channel = runs[0].response_dof
        samples = samples_from_held_runs(runs, shapes.get(channel))
        print(f"{path}: {len(runs)} response-controlled run(s) at {channel}, held {1e6 * runs[0].held_m:.3g}–"
              f"{1e6 * runs[-1].held_m:.3g} µm, one-mode fit of each" + ("" if channel in shapes else
                                                                         f"; shape {samples.input_shape:.4g} 1/√kg "
                                                                         f"from the lowest run's modal constant"))
        out.append((path, samples, None, "response-controlled"))
    for path in args.phase_resonance:
        points = read_phase_resonance(path, read_options(args))
        missing = [dof for dof in (points.response_dof, points.input_dof) if dof not in shapes]
        if missing:
            raise CliError(f"{path}: give --shape {missing[0]}=VALUE: the damping at phase resonance, "
                           f"ζ = |φ_f φ_r| F/(2Ω²|X_r|), needs the mass-normalised shape (1/√kg) at the response "
                           f"and the force")
        samples = samples_from_phase_resonance(points, shapes[points.response_dof], shapes[points.input_dof])
        print(f"{path}: {samples.amplitude.size} phase-resonance point(s) at {points.response_dof} (force at "
              f"{points.input_dof}), {points.force_n.min():.4g}–{points.force_n.max():.4g} N")
        out.append((path, samples, None, "phase-resonance"))
        channel = points.input_dof
    return out, channel
