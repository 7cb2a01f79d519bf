"""The samples ``nlupdate amplitude`` reads from each test type besides ``--measured``.

One ``(source, samples, stated noise)`` per file: ``--ring-down`` (the envelope method, the
segments or the decay fit: ``--ring-down-fit``, docs/ring-down.md), ``--response-controlled``
(a one-mode fit per held run),
``--phase-resonance`` (the force balance at each point; CSV, MAT or UFF) and ``--impact`` (the linear limit
by a complex exponential fit of the quietest part of the decay). The amplitudes of ring-down
and impact records are in the response's units (``--response-unit``, m by default) divided by
the shape at the channel when given, then made displacement.
"""
from __future__ import annotations

import argparse

from nlupdate.app.cli import CliError
from nlupdate.app.cli.measured import parse_band, parse_levels, read_options
from nlupdate.core.identification.amplitude_inputs import RING_DOWN_FITS, Source, SourceError, SourceFiles
from nlupdate.core.identification.amplitude_inputs import read_sources as read_test_sources
from nlupdate.study.amplitude import AmplitudeSpec

#: the defaults of the options a study's ``[amplitude]`` table shares: its declaration's
DECLARED = AmplitudeSpec()


def add_source_options(parser: argparse.ArgumentParser, response_controlled: bool = True) -> None:
    """The test-type options; ``response_controlled`` False leaves out ``--response-controlled``
    (``nlupdate validate`` reads those runs from its ``--measured`` MATLAB files)."""
    parser.add_argument("--ring-down", action="append", default=[], metavar="FILE",
                        help="free decay of the mode (.csv: time_s and one column per channel; or .mat); repeatable")
    parser.add_argument("--ring-down-fit", choices=RING_DOWN_FITS, default=DECLARED.ring_down_fit,
                        help=f"how a ring-down is read (default {DECLARED.ring_down_fit}): envelope "
                             "(differentiated envelope and phase), segments (a complex exponential fit of each part over which the envelope falls by 1.5: "
                             "fewer samples, robust to noise) or decay (the averaged decay equations fitted to the "
                             "whole record: samples where ζ is known to 1.5 %%, for noisy records)")
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
    parser.add_argument("--response-unit", default=DECLARED.response_unit,
                        help=f"unit of the --ring-down and --impact records (default {DECLARED.response_unit}): m, mm, m/s, mm/s, "
                             "m/s^2, g, …; "
                             "their amplitudes are made displacement")
    parser.add_argument("--channel", help="the ring-down and impact files' channel (default: a ring-down's only one, "
                                          "an impact's every one); its --shape, if given, makes the amplitude modal")


def source_files(args: argparse.Namespace) -> SourceFiles:
    """The test-type files and how to read them, as the options state them."""
    held = parse_levels(getattr(args, "held_amplitude", []), "--held-amplitude", "the unit of the run's response record")
    if held and not getattr(args, "response_controlled", []):
        raise CliError(f"--held-amplitude {args.held_amplitude[0]}: expected nothing without --response-controlled "
                       f"FILE (the held amplitude of its runs; no other source reads it)")
    return SourceFiles(tuple(args.ring_down), tuple(args.impact), tuple(getattr(args, "response_controlled", [])),
                       tuple(args.phase_resonance), args.ring_down_fit, parse_band(args.band), args.response_unit,
                       args.channel, held, read_options(args))


def read_sources(args: argparse.Namespace, shapes: dict[str, float]) -> tuple[list[Source], str]:
    """((file, samples, stated (frequency, damping) relative standard deviations or None, test
    type) of each file, the coordinate of the last), each file's note printed:
    :func:`nlupdate.core.identification.amplitude_inputs.read_sources`."""
    try:
        found, channel, notes = read_test_sources(source_files(args), shapes)
    except SourceError as error:
        raise CliError(str(error)) from None
    for note in notes:
        print(note)
    return found, channel
