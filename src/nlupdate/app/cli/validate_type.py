"""``nlupdate validate --hold-out-type TYPE``: a whole test type held out.

The amplitude-dependent modal model (``nlupdate amplitude``'s) is fitted on every other test
type given and predicts the held-out type's own observables
(:mod:`nlupdate.core.validation.held_type`): a ring-down's frequency and damping against
amplitude, the amplitude each phase-resonance force holds, each stepped-sine level's
resonance, damping and peak. The sources are read as ``nlupdate amplitude`` reads them
(:mod:`nlupdate.app.cli.amplitude_sources`); the stepped sine is ``--measured``, and with
``--response-controlled auto`` the response-controlled runs of its MATLAB files are a source
too. Writes DIR/validation.json (``held_out_type``) and DIR/held_out_type.png.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from nlupdate.app.cli import CliError
from nlupdate.app.cli.amplitude import _shapes
from nlupdate.app.cli.amplitude_sources import add_source_options, read_sources
from nlupdate.app.cli.measured import measured_table, print_notes
from nlupdate.core.identification.backbone_samples import BOOTSTRAP_DEFAULT, bootstrap_refits
from nlupdate.core.model.amplitude_modal import AmplitudeModelError
from nlupdate.core.validation.held_type import (BACKBONE_OF_MODEL, HELD_TYPES, MissingShape, hold_out_type,
                                               stepped_sine_source)
from nlupdate.files import atomic_directory
from nlupdate.reporting.figures import save_figure
from nlupdate.reporting.held_type_plots import held_type_figure
from nlupdate.reporting.jsonfile import write_json
from nlupdate.reporting.model_numbers import damping_text, linear_limit_text
from nlupdate.reporting.validation_text import held_type_rows, held_type_worst_line, said_line


def add_type_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--hold-out-type", choices=HELD_TYPES, metavar="TYPE",
                        help="hold out a whole test type instead of levels: fit the amplitude-dependent modal model on "
                             f"the other types and predict this one ({', '.join(HELD_TYPES)}); --model "
                             "amplitude-iwan (auto), amplitude-polynomial or amplitude-jenkins; needs --shape at the "
                             "sensors")
    add_source_options(parser, response_controlled=False)
    parser.add_argument("--bootstrap", type=int, metavar="N",
                        help=f"with --hold-out-type: refits of a residual bootstrap for the 95 %% bands of the held "
                             f"samples' predictions (default {BOOTSTRAP_DEFAULT}: about a second per refit; 0: no "
                             f"bands)")
    parser.add_argument("--shape", action="append", default=[], metavar="NAME=VALUE",
                        help="with --hold-out-type: mass-normalised mode shape (1/√kg) at a coordinate (the stepped "
                             "sine's input, a ring-down's channel), for one modal amplitude across the types")


def run_held_type(args: argparse.Namespace, out: Path, curve) -> int:
    """The type hold-out (module docstring); ``curve``: validate's reader of the driving-point
    curves from a measured table (table, input dof, sources) → FRFLevels."""
    backbone = BACKBONE_OF_MODEL.get(args.model)
    if backbone is None:
        raise CliError(f"--model {args.model}: with --hold-out-type, one of {', '.join(BACKBONE_OF_MODEL)}")
    try:
        resamples = bootstrap_refits(args.bootstrap, backbone)
    except ValueError as error:
        raise CliError(str(error)) from None
    shapes = _shapes(args.shape)
    sources, data = [], None
    if args.measured:
        table, notes = measured_table(args, find_band=True)
        print_notes(notes)
        data = curve(table, args.input_dof, ", ".join(args.measured))
        try:
            sources.append(stepped_sine_source(", ".join(args.measured), data, shapes))
        except MissingShape as error:
            raise CliError(f"--shape {error.coordinate}=VALUE: {error}") from None
    reader = argparse.Namespace(**vars(args))
    reader.response_controlled = ([p for p in args.measured or [] if p.lower().endswith(".mat")]
                                  if args.response_controlled != "off" else [])  # auto (None: the default), kept
    try:
        rings, _ = read_sources(reader, shapes)
        result = hold_out_type(sources + rings, args.hold_out_type, tuple(shapes.items()), data, backbone,
                               resamples=resamples)
    except (AmplitudeModelError, ValueError) as error:
        raise CliError(str(error)) from None
    unit = data.reference_unit if data is not None else "N"
    summary = result.summary()
    with atomic_directory(out, on_exists="replace") as archive:
        write_json({"held_out_type": summary}, archive.path / "validation.json")
        save_figure(held_type_figure(result, unit), archive.path / "held_out_type.png")
    for line in result.said(unit):  # the verdict, the model's warnings: before the numbers they qualify
        print(said_line(line), file=sys.stderr if line.warns else sys.stdout)
    kinds = ", ".join(f"{name} ({kind}, {n})" for name, kind, n in result.fitted_on)
    print(f"{args.hold_out_type} held out; {result.model.backbone} model fitted on {kinds}: "
          f"{linear_limit_text(result.model)}, {damping_text(result.model)}")
    for line in held_type_rows(summary, unit):
        print(line)
    if not len(result.levels):
        inside = int(result.samples["within_fit"].sum())
        print(f"{len(result.samples)} held-out samples, {inside} within the fitted amplitudes "
              f"{result.fitted_range[0]:.3g}–{result.fitted_range[1]:.3g} m·√kg")
    print(held_type_worst_line(summary["worst_within_fit"]))
    print(f"wrote {out / 'validation.json'} and {out / 'held_out_type.png'}")
    return 0
