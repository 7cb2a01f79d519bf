"""``nlupdate amplitude``: an amplitude-dependent modal model of one mode from any mix of tests
(stepped sine, response-controlled runs, phase resonance, ring-downs, impacts).

From a modal table (CSV: force level, mode, natural frequency, damping ratio per row) and the
mode's mass-normalised shape at the excited coordinate (--shape NAME=VALUE, 1/√kg), or from a
measured-FRF table (driving point, several force levels; the shape then comes from the modal
constant found with the other modes' share from every level at once unless given), fit the natural frequency and damping ratio against
modal amplitude (--backbone iwan: a modal Iwan joint; jenkins: its Jenkins limit; polynomial: of
--order) and write
DIR/amplitude_model.json (usable as [targets] amplitude_models in a study: its linear limit),
DIR/backbone.png and DIR/damping.png. With --forces and --freqs it also writes the FRFs the
model predicts at those levels (DIR/predicted_frf.parquet, single-nonlinear-mode theory) and,
for an FRF table, DIR/predicted_frf.png against the measured curves.

Other test types, each repeatable and each enough on its own (docs/ring-down.md): a free
decay (--ring-down FILE; --channel NAME when it holds several; --band the mode's band-pass),
response-controlled stepped-sine runs (--response-controlled FILE, .mat or .uff: one sample per
held amplitude), phase-resonance points (--phase-resonance FILE, .csv, .mat or .uff: one sample
per level, the damping from the force needed at resonance) and impact or low-level records (--impact FILE: the linear
limit by a complex exponential fit of the quietest part of the decay). Several sources are
fitted jointly, each weighted by its own noise, and DIR/consistency.csv names those that
disagree with the joint fit beyond their uncertainty. DIR/backbone_points.csv holds every
source's samples and DIR/backbone.csv the fitted backbone over their range.
"""
from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from nlupdate.app.cli import CliError, add_command, positive_int
from nlupdate.app.cli.amplitude_sources import DECLARED, add_source_options, read_sources
from nlupdate.app.cli.measured import add_measured_options, measured_tables, parse_band, print_notes, sources
from nlupdate.app.cli.output import add_overwrite_option, checked_output
from nlupdate.app.cli.progress_bar import terminal_progress
from nlupdate.app.cli.simulate import force_levels, frequency_grid
from nlupdate.core.identification.amplitude_joint import (
    BandCut, FitOptions, backbone_table, fit_sources, measured_source,
)
from nlupdate.core.identification.amplitude_modal_fit import FIT_BACKBONES
from nlupdate.core.identification.backbone_samples import BOOTSTRAP_DEFAULT, TEST_TYPES
from nlupdate.core.identification.modal_samples import SHAPE_FORM, usable_shape
from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.measurement.frf_files import write_frf_table
from nlupdate.files import atomic_directory
from nlupdate.reporting.amplitude_report import amplitude_lines, plot_amplitude_fit
from nlupdate.reporting.figures import level_colours, save_figure


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = add_command(subparsers, "amplitude", __doc__)
    add_measured_options(parser, "of the FRFs (lines outside it are left out before the fit; default: the excited "
                                 "band of the lowest level, where the coherence is ≥ 0.8 or the FRF is smooth) or of a "
                                 "modal table's modes (default: all); of a ring-down, its band-pass (default: around "
                                 "the spectrum's largest peak)",
                         modal=True, required=False)
    add_source_options(parser)
    parser.add_argument("--hold-out", choices=TEST_TYPES, metavar="TYPE",
                        help="fit without the sources of this test type and predict them (DIR/held_out.csv: each "
                             "sample's frequency and damping, a phase-resonance point's amplitude): "
                             f"{', '.join(TEST_TYPES)}")
    parser.add_argument("--input-dof", help="excited coordinate (default: the table's only one)")
    parser.add_argument("--response-dof", help="response coordinate of FRFs (default: the input, the driving point, "
                                               "if measured; else the table's only response: a transfer FRF)")
    parser.add_argument("--shape", action="append", default=[], metavar="NAME=VALUE",
                        help="mass-normalised mode shape (1/√kg) at a coordinate; needed at the input for a modal table")
    parser.add_argument("--mode", type=positive_int, default=DECLARED.mode, help=f"mode number in a modal table (default {DECLARED.mode})")
    parser.add_argument("--backbone", choices=FIT_BACKBONES, default=DECLARED.backbone,
                        help=f"backbone model (default {DECLARED.backbone}; jenkins: the Iwan joint in its Jenkins limit, stuck below "
                             "its slip amplitude, for a joint that sticks and slips at one force)")
    parser.add_argument("--order", type=positive_int, default=DECLARED.order, help=f"polynomial order (default {DECLARED.order})")
    parser.add_argument("--bootstrap", type=int, metavar="N",
                        help=f"refits of a residual bootstrap for the bands of backbone.csv (default {BOOTSTRAP_DEFAULT}: "
                             f"about a second per refit; 0: no bands, NaN)")
    parser.add_argument("--forces", help="levels to predict FRFs at, comma-separated (in the reference unit: N, or V "
                                         "for FRFs per volt)")
    parser.add_argument("--freqs", help="frequency grid (Hz) of the predictions: START:STOP:COUNT or F1,F2,…")
    parser.add_argument("--out", required=True, metavar="DIR", help="output directory (appears when complete)")
    add_overwrite_option(parser)
    parser.set_defaults(run=run)


def _shapes(texts: list[str]) -> dict[str, float]:
    shapes = {}
    for text in texts:
        name, _, value = text.partition("=")
        try:
            shapes[name.strip()] = float(value)
        except ValueError:
            raise CliError(f"--shape {text!r}: expected NAME=VALUE (mass-normalised shape in 1/√kg)") from None
        if not name.strip() or not usable_shape(shapes[name.strip()]):
            raise CliError(f"--shape {text!r}: expected NAME=VALUE with {SHAPE_FORM}")
    return shapes


def _plot_prediction(predicted, data: FRFLevels, path: Path, unit: str = "N") -> Path:
    """|H| the model predicts (lines) against the measured curves (dots) over the predicted
    band; a level measured and predicted shares its colour."""
    f_low, f_high = float(predicted["frequency_hz"].min()), float(predicted["frequency_hz"].max())
    fig = Figure(figsize=(8, 5))
    ax = fig.subplots()
    colours = dict(zip(data.levels, level_colours(len(data.levels), 0.1, 0.9)))
    for level, f, h in zip(data.levels, data.frequencies, data.receptances):
        band = (f >= f_low) & (f <= f_high)
        ax.semilogy(f[band], np.abs(h[band]), ".", ms=3, color=colours[level], label=f"measured {level:g} {unit}")
    for level, curve in predicted[predicted["response_dof"].astype(str) == data.response_dof].groupby("force_level_n"):
        h = curve["h_real"].to_numpy() + 1j * curve["h_imag"].to_numpy()
        match = [c for lv, c in colours.items() if np.isclose(lv, level, rtol=1e-9)]
        ax.semilogy(curve["frequency_hz"], np.abs(h), "-", lw=1.4, color=match[0] if match else "black",
                    label=f"model {level:g} {unit}")
    ax.set_xlim(f_low, f_high)
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel(f"|H| (m/{unit})")
    ax.set_title("amplitude-dependent modal model (lines) against the measurement (dots)", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    return save_figure(fig, path)


def run(args: argparse.Namespace) -> int:
    out = checked_output(args.out, args.overwrite, folder=True)
    if (args.forces is None) != (args.freqs is None):
        raise CliError("--forces and --freqs go together (the levels and the grid of the predicted FRFs)")
    shapes = _shapes(args.shape)
    if not (args.measured or args.ring_down or args.response_controlled or args.phase_resonance or args.impact):
        raise CliError("give the mode's data: --measured FILE (FRFs or a modal table) and/or --ring-down FILE, "
                       "--response-controlled FILE, --phase-resonance FILE, --impact FILE")
    options = FitOptions(args.backbone, args.order, args.mode, args.bootstrap, args.hold_out)
    rings, channel = read_sources(args, shapes)
    measured = None
    if args.measured:
        table, whole, notes = measured_tables(args, modal=True, find_band=True)
        print_notes(notes)
        cut = None if whole is None else BandCut(parse_band(args.band), whole)
        measured = measured_source(table, shapes, options, sources(args), args.input_dof, args.response_dof, cut)
    fit = fit_sources(rings, channel, shapes, options, measured, sources(args) if args.measured else "")
    predicted = None
    if args.forces is not None and not fit.samples.modal:
        raise CliError(f"--forces: the model's amplitudes are {channel}'s own, not modal (no --shape {channel}=VALUE): "
                       f"an FRF at a force needs the mass-normalised shape at the driven coordinate")
    if args.forces is not None:
        predicted = fit.model.frf_table(frequency_grid(args.freqs), force_levels(args.forces), fit.input_dof)
        if fit.unit != "N":
            predicted["reference_unit"] = fit.unit  # FRFs per volt, as the measurement
    with atomic_directory(out, on_exists="replace") as archive:
        folder = archive.path
        with terminal_progress() as progress:
            fit = dataclasses.replace(fit, curve=backbone_table(fit, progress))
        fit.write(folder)
        plot_amplitude_fit(fit, folder)
        if predicted is not None:
            write_frf_table(predicted, folder / "predicted_frf.parquet")
            if fit.data is not None:
                _plot_prediction(predicted, fit.data, folder / "predicted_frf.png", fit.unit)
    for line in amplitude_lines(fit):
        print(line)
    print(f"wrote {out / 'amplitude_model.json'}, backbone.png, damping.png, backbone.csv and backbone_points.csv"
          + (", consistency.csv" if fit.agreement is not None else "") + (", held_out.csv" if fit.held else "")
          + (" and the predicted FRFs" if predicted is not None else ""))
    return 0
