"""``nlupdate amplitude``: an amplitude-dependent modal model of one mode from any mix of tests
(stepped sine, response-controlled runs, phase resonance, ring-downs, impacts).

From a modal table (CSV: force level, mode, natural frequency, damping ratio per row) and the
mode's mass-normalised shape at the excited coordinate (--shape NAME=VALUE, 1/√kg), or from a
measured-FRF table (driving point, several force levels; the shape then comes from a one-mode
fit of the lowest level unless given), fit the natural frequency and damping ratio against
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
from nlupdate.app.cli.output import add_overwrite_option, checked_output
from nlupdate.app.cli.progress_bar import terminal_progress
from nlupdate.files import atomic_directory
from nlupdate.core.identification.amplitude_modal_fit import (
    FIT_BACKBONES, amplitude_model_from_frfs, fit_amplitude_model, samples_from_frfs, samples_from_modal_table,
)
from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.backbone_samples import (
    DISAGREEMENT, TEST_TYPES, backbone_curve, backbone_points, consistency, held_out_errors, join_samples,
    own_fit_for, source_noise,
)
from nlupdate.app.cli.amplitude_sources import add_source_options, read_sources
from nlupdate.app.cli.measured import add_measured_options, measured_table, print_notes, sources
from nlupdate.core.measurement.frf_files import write_frf_table
from nlupdate.core.measurement.units import table_reference_unit
from nlupdate.core.model.amplitude_modal import AmplitudeModalModel, write_amplitude_model
from nlupdate.reporting.backbone_plots import plot_sources
from nlupdate.reporting.figures import level_colours, save_figure
from nlupdate.app.cli.simulate import force_levels, frequency_grid


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
    parser.add_argument("--mode", type=positive_int, default=1, help="mode number in a modal table (default 1)")
    parser.add_argument("--backbone", choices=FIT_BACKBONES, default="iwan",
                        help="backbone model (default iwan; jenkins: the Iwan joint in its Jenkins limit, stuck below "
                             "its slip amplitude, for a joint that sticks and slips at one force)")
    parser.add_argument("--order", type=positive_int, default=2, help="polynomial order (default 2)")
    parser.add_argument("--bootstrap", type=int, metavar="N",
                        help="refits of a residual bootstrap for the bands of backbone.csv (default 200 for the "
                             "polynomial backbone, 0 for iwan: about a second per refit; 0: no bands, NaN)")
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
        if not name.strip() or not np.isfinite(shapes[name.strip()]) or shapes[name.strip()] == 0:
            raise CliError(f"--shape {text!r}: expected NAME=VALUE with a finite shape ≠ 0 (1/√kg)")
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


def _one_source_model(samples, shapes, args: argparse.Namespace) -> AmplitudeModalModel:
    """The fit to one source's samples; one sample (an impact's pole) is the linear limit
    alone, with no amplitude dependence (a polynomial of no terms)."""
    if samples.amplitude.size > 1:
        return fit_amplitude_model(samples, shapes, args.backbone, args.order, mode=args.mode)
    return AmplitudeModalModel(float(samples.frequency_hz[0]), float(samples.damping_ratio[0]), shapes,
                               reference_amplitude=float(samples.amplitude[0]), mode=args.mode,
                               note="the linear limit of one impact or low-level record: no amplitude dependence "
                                    "(join it with other test types for a backbone)")


def run(args: argparse.Namespace) -> int:
    out = checked_output(args.out, args.overwrite, folder=True)
    if (args.forces is None) != (args.freqs is None):
        raise CliError("--forces and --freqs go together (the levels and the grid of the predicted FRFs)")
    shapes = _shapes(args.shape)
    data = None
    if not (args.measured or args.ring_down or args.response_controlled or args.phase_resonance or args.impact):
        raise CliError("give the mode's data: --measured FILE (FRFs or a modal table) and/or --ring-down FILE, "
                       "--response-controlled FILE, --phase-resonance FILE, --impact FILE")
    rings, channel = read_sources(args, shapes)
    if not args.measured:  # the sensor's coordinate stands for the input of any predicted FRF (a driving point)
        samples, input_dof = join_samples([s for _, s, _, _ in rings]), channel
        shapes_fit = ((channel, samples.input_shape),)
        model, unit, points = None, "N", rings  # fitted below
    else:
        table, notes = measured_table(args, modal=True, find_band=True)
        print_notes(notes)
        unit = "N" if "natural_frequency_hz" in table.columns else table_reference_unit(table)
        if "natural_frequency_hz" in table.columns:
            inputs = sorted(set(table["input_dof"])) if "input_dof" in table.columns else []
            input_dof = args.input_dof or (inputs[0] if len(inputs) == 1 else None)
            if input_dof is None:
                raise CliError(f"{sources(args)}: name the excited coordinate with --input-dof")
            if input_dof not in shapes:
                raise CliError(f"--shape {input_dof}=VALUE: a modal table needs the mass-normalised shape at the "
                               f"excited coordinate {input_dof!r} (1/√kg) to know the modal amplitude of each level")
            samples = samples_from_modal_table(table, shapes[input_dof], args.mode, sources(args))
            model = fit_amplitude_model(samples, tuple(shapes.items()), args.backbone, args.order, mode=args.mode)
        else:
            inputs = sorted(set(table["input_dof"].astype(str)))
            input_dof = args.input_dof or (inputs[0] if len(inputs) == 1 else None)
            if input_dof is None:
                raise CliError(f"{sources(args)}: the table has input dofs {inputs}; choose one with --input-dof")
            responses = sorted(set(table.loc[table["input_dof"].astype(str) == input_dof, "response_dof"].astype(str)))
            response_dof = args.response_dof or (input_dof if input_dof in responses else
                                                 responses[0] if len(responses) == 1 else None)
            if response_dof is None:
                raise CliError(f"{sources(args)}: no driving-point FRF at {input_dof!r}; choose a response among "
                               f"{responses} with --response-dof")
            data = FRFLevels.from_table(table, response_dof, input_dof)
            samples = samples_from_frfs(data, shapes.get(input_dof))
            model = amplitude_model_from_frfs(data, args.backbone, shapes.get(input_dof), args.order, mode=args.mode)
            if samples.shape_free and model.joint is not None:  # the samples at the shape the fit found
                samples = samples.with_shape(model.shapes[0][1])
        points = [(sources(args), samples, None, "stepped-sine" if data is not None else "modal-table")] + rings
        shapes_fit = model.shapes
        if rings:  # the measured samples and the other sources, fitted together at the given shape
            samples = join_samples([s for _, s, _, _ in points])
    held = [p for p in points if p[3] == args.hold_out]
    if held:
        points = [p for p in points if p[3] != args.hold_out]
        if not points:
            raise CliError(f"--hold-out {args.hold_out}: every source is of that type; give another to fit")
        samples = join_samples([s for _, s, _, _ in points])
    elif args.hold_out:
        raise CliError(f"--hold-out {args.hold_out}: no source of that type is given")
    if len(points) == 1 and (model is None or held):
        model = _one_source_model(samples, shapes_fit, args)
    # several sources: one backbone fitted jointly, each source weighted by its own noise
    own_fit = own_fit_for(args.backbone, shapes_fit)
    noises = [source_noise(s, stated, own_fit) for _, s, stated, _ in points]

    def joint_fit(chosen: list[int]):
        """The model of the sources at ``chosen``, each weighted by its noise."""
        stds = [np.concatenate([np.full(points[i][1].amplitude.size, noises[i][k]) for i in chosen]) for k in (0, 1)]
        return fit_amplitude_model(join_samples([points[i][1] for i in chosen]), shapes_fit, args.backbone, args.order,
                                   *stds, mode=args.mode)

    f_std, z_std = (1e-3, 0.05)
    agreement = None
    if len(points) > 1:
        everything = list(range(len(points)))
        f_std, z_std = (np.concatenate([np.full(p[1].amplitude.size, n[k]) for p, n in zip(points, noises)])
                        for k in (0, 1))
        model = joint_fit(everything)
        agreement = consistency(model, [(name, s, kind) for name, s, _, kind in points], noises, joint_fit)
    resamples = (200 if args.backbone == "polynomial" else 0) if args.bootstrap is None else args.bootstrap
    if samples.amplitude.size == 1:
        resamples = 0  # one linear limit: nothing to resample
    if resamples < 0:
        raise CliError(f"--bootstrap {resamples}: expected a number of refits ≥ 0")
    predicted = None
    if args.forces is not None:
        predicted = model.frf_table(frequency_grid(args.freqs), force_levels(args.forces), input_dof)
        if unit != "N":
            predicted["reference_unit"] = unit  # FRFs per volt, as the measurement
    with atomic_directory(out, on_exists="replace") as archive:
        folder = archive.path
        write_amplitude_model(dataclasses.replace(model, reference_unit=unit), folder / "amplitude_model.json")
        with terminal_progress() as progress:
            curve = backbone_curve(model, samples, refit=lambda draw: fit_amplitude_model(
                draw, model.shapes, args.backbone, args.order, f_std, z_std, mode=args.mode), resamples=resamples,
                progress=progress)
        if samples.amplitude.size == 1 and points[0][2] is not None:  # an impact's pole: its own 95 % interval
            for column, relative in zip(("natural_frequency_hz", "damping_ratio"), points[0][2]):
                curve[f"{column}_low"], curve[f"{column}_high"] = (curve[column] * (1 + k * 1.96 * relative)
                                                                   for k in (-1, 1))
        curve.to_csv(folder / "backbone.csv", index=False)
        backbone_points([(name, s, kind) for name, s, _, kind in points]).to_csv(folder / "backbone_points.csv",
                                                                                 index=False)
        plot_sources(model, [(f"{name} ({kind})", s) for name, s, _, kind in points], curve, folder)
        if agreement is not None:
            agreement.to_csv(folder / "consistency.csv", index=False)
        if held:
            predicted_held = held_out_errors(model, [(name, s, kind) for name, s, _, kind in held],
                                             (float(samples.amplitude.min()), float(samples.amplitude.max())))
            predicted_held.to_csv(folder / "held_out.csv", index=False)
        if predicted is not None:
            write_frf_table(predicted, folder / "predicted_frf.parquet")
            if data is not None:
                _plot_prediction(predicted, data, folder / "predicted_frf.png", unit)
    print(f"mode {model.mode}: linear limit {model.natural_frequency_hz:.6g} Hz, damping ratio "
          f"{100 * model.damping_ratio:.4g} % ({model.backbone} backbone, {samples.amplitude.size} samples, modal "
          f"amplitudes {samples.amplitude.min():.3g}–{samples.amplitude.max():.3g} m·√kg)")
    if model.joint is not None:
        j = model.joint
        print(f"modal joint: kt = {j.kt:.6g} rad²/s², slip_force = {j.slip_force:.6g} {unit}/√kg, chi = {j.chi:.4g}, "
              f"beta = {j.beta:.4g}")
    if model.note:
        print(f"note: {model.note}")
    for warning in model.warnings:
        print(f"warning: {warning}")
    if resamples:
        print(f"note: backbone.csv's *_low/*_high bands: 95 % of {resamples} refits of a residual bootstrap")
    else:
        print("note: backbone.csv's *_low/*_high band columns are NaN (the backbone fits give no covariance); "
              "--bootstrap N refits N resamples for them")
    if agreement is not None:
        for row in agreement.itertuples():
            print(f"{row.source} ({row.test_type}): {row.samples} sample(s), mean misfit "
                  f"{100 * row.frequency_offset:+.3g} % in frequency "
                  f"({row.frequency_score:+.2g} standard errors), {100 * row.damping_offset:+.3g} % in damping "
                  f"({row.damping_score:+.2g})" + ("" if row.consistent else
                                                  " — DISAGREES with the other sources beyond its uncertainty"))
        odd = agreement.loc[~agreement["consistent"], "source"].tolist()
        if odd:
            print(f"warning: {', '.join(odd)} disagree(s) with the joint fit by more than {DISAGREEMENT:g} standard "
                  f"errors (consistency.csv): a test-type effect (e.g. shaker–structure interaction, a drift between "
                  f"tests) or a wrong shape or unit")
    if held:
        for source, all_rows in predicted_held.groupby("source", sort=False):
            for inside, rows in all_rows.groupby("within_fit", sort=False):
                worst = rows[["frequency_error", "damping_error", "amplitude_error"]].abs().max()
                print(f"held out {source} ({rows['test_type'].iloc[0]}): predicted within "
                      f"{100 * worst['frequency_error']:.3g} % in frequency and "
                      f"{100 * worst['damping_error']:.3g} % in "
                      f"damping ratio" + (f", {100 * worst['amplitude_error']:.3g} % in amplitude at its forces"
                                          if np.isfinite(worst["amplitude_error"]) else "")
                      + f" ({len(rows)} samples {'within' if inside else 'outside'} the fitted amplitudes)")
    print(f"wrote {out / 'amplitude_model.json'}, backbone.png, damping.png, backbone.csv and backbone_points.csv"
          + (", consistency.csv" if agreement is not None else "") + (", held_out.csv" if held else "")
          + (" and the predicted FRFs" if predicted is not None else ""))
    return 0
