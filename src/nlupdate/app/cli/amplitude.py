"""``nlupdate amplitude``: an amplitude-dependent modal model of one mode from a modal table or FRFs
(or ring-downs and response-controlled runs).

From a modal table (CSV: force level, mode, natural frequency, damping ratio per row) and the
mode's mass-normalised shape at the excited coordinate (--shape NAME=VALUE, 1/√kg), or from a
measured-FRF table (driving point, several force levels; the shape then comes from a one-mode
fit of the lowest level unless given), fit the natural frequency and damping ratio against
modal amplitude (--backbone iwan: a modal Iwan joint; polynomial: of --order) and write
DIR/amplitude_model.json (usable as [targets] amplitude_models in a study: its linear limit)
and DIR/backbone.png. With --forces and --freqs it also writes the FRFs the model predicts at
those levels (DIR/predicted_frf.parquet, single-nonlinear-mode theory) and, for an FRF table,
DIR/predicted_frf.png against the measured curves.

A free decay (--ring-down FILE, repeatable; --channel NAME when it holds several; --band the
mode's band-pass) is enough input on its own, or joins the FRFs or modal table (then with the
shape at the excited coordinate). Response-controlled stepped-sine runs (--response-controlled
FILE.mat) give one sample per held amplitude from a one-mode fit of each run, and phase-resonance
points (--phase-resonance FILE, .csv or .mat: frequency, force, response and phase per level) one
sample per level, the damping from the force needed at resonance (docs/ring-down.md for all three). DIR/backbone_points.csv holds every source's samples and DIR/backbone.csv the fitted
backbone over their range.
"""
from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from nlupdate.app.cli import CliError, add_command, positive_int
from nlupdate.app.cli.output import add_overwrite_option, checked_output
from nlupdate.files import atomic_directory
from nlupdate.core.identification.amplitude_modal_fit import (
    amplitude_model_from_frfs, fit_amplitude_model, samples_from_frfs, samples_from_modal_table,
)
from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.phase_resonance import read_phase_resonance, samples_from_phase_resonance
from nlupdate.core.identification.response_controlled import read_response_controlled, samples_from_held_runs
from nlupdate.core.identification.backbone_samples import backbone_curve, backbone_points, join_samples
from nlupdate.core.identification.ring_down import estimate_ring_down, read_ring_down
from nlupdate.app.cli.measured import add_measured_options, measured_table, parse_band, print_notes, read_options, sources
from nlupdate.core.measurement.frf_files import write_frf_table
from nlupdate.core.measurement.units import table_reference_unit
from nlupdate.core.model.amplitude_modal import BACKBONES, write_amplitude_model
from nlupdate.reporting.figures import level_colours, save_figure
from nlupdate.app.cli.simulate import force_levels, frequency_grid


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = add_command(subparsers, "amplitude", __doc__)
    add_measured_options(parser, "of the FRFs (lines outside it are left out before the fit; default: the excited "
                                 "band of the lowest level, where the coherence is ≥ 0.8 or the FRF is smooth) or of a "
                                 "modal table's modes (default: all); of a ring-down, its band-pass (default: around "
                                 "the spectrum's largest peak)",
                         modal=True, required=False)
    parser.add_argument("--ring-down", action="append", default=[], metavar="FILE",
                        help="free decay of the mode (.csv: time_s and one column per channel; or .mat); repeatable")
    parser.add_argument("--response-controlled", action="append", default=[], metavar="FILE",
                        help="response-controlled stepped-sine runs (.mat, as --measured's MATLAB runs; "
                             "--coordinates for a sensor along −DIR): one sample per held amplitude; repeatable")
    parser.add_argument("--phase-resonance", action="append", default=[], metavar="FILE",
                        help="phase-resonance points (.csv: frequency_hz, force_n, response_amplitude, "
                             "response_phase_deg, optional response_unit, response_dof, input_dof; or .mat runs): one "
                             "sample per level; needs --shape at its response (and input) coordinate; repeatable")
    parser.add_argument("--channel", help="the ring-down files' channel (default: their only one); its --shape, if "
                                          "given, makes the amplitude modal")
    parser.add_argument("--input-dof", help="excited coordinate (default: the table's only one)")
    parser.add_argument("--response-dof", help="response coordinate of FRFs (default: the input, the driving point, "
                                               "if measured; else the table's only response: a transfer FRF)")
    parser.add_argument("--shape", action="append", default=[], metavar="NAME=VALUE",
                        help="mass-normalised mode shape (1/√kg) at a coordinate; needed at the input for a modal table")
    parser.add_argument("--mode", type=positive_int, default=1, help="mode number in a modal table (default 1)")
    parser.add_argument("--backbone", choices=BACKBONES, default="iwan", help="backbone model (default iwan)")
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


def _plot_backbone(model, samples, path: Path) -> Path:
    fig = Figure(figsize=(10, 4))
    ax_f, ax_z = fig.subplots(1, 2)
    a = np.geomspace(samples.amplitude.min() / 3, samples.amplitude.max() * 3, 300)
    f, z = model.frequency_hz(a), model.damping(a)
    ax_f.semilogx(samples.amplitude, samples.frequency_hz, ".", label="measured")
    ax_f.semilogx(a, f, "-", label=f"{model.backbone} backbone")
    ax_z.semilogx(samples.amplitude, 100 * samples.damping_ratio, ".", label="measured")
    ax_z.semilogx(a, 100 * z, "-", label=f"{model.backbone} damping curve")
    for ax, label in ((ax_f, "natural frequency (Hz)"), (ax_z, "damping ratio (%)")):
        ax.set_xlabel("modal amplitude a (m·√kg)")
        ax.set_ylabel(label)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(f"mode {model.mode}: linear limit {model.natural_frequency_hz:.4g} Hz, "
                 f"ζ₀ = {100 * model.damping_ratio:.3g} %", fontsize=10)
    fig.tight_layout()
    return save_figure(fig, path)


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


def _ring_down_samples(args: argparse.Namespace, shapes: dict[str, float]) -> tuple[list[tuple[str, object]], str]:
    """((file, samples) of each --ring-down and --response-controlled, the coordinate of the last):
    the shape at a ring-down's channel, when given, makes its amplitude modal; a response-controlled
    file's shape is given or from its lowest run's modal constant."""
    out, channel = [], ""
    band = parse_band(args.band)
    for path in args.ring_down:
        record = read_ring_down(path, args.channel)
        estimate = estimate_ring_down(record.time_s, record.response, band, shapes.get(record.channel), source=path)
        samples = estimate.samples()
        units = "" if record.channel in shapes else \
            f"; no --shape {record.channel}=VALUE: amplitudes in the response's units"
        print(f"{path}: channel {record.channel}, band {estimate.band_hz[0]:.4g}–{estimate.band_hz[1]:.4g} Hz, "
              f"{estimate.trim_s[0]:.3g} s and {estimate.trim_s[1]:.3g} s trimmed at the start and end, "
              f"{samples.amplitude.size} samples (a smoothing window apart: {estimate.window_s.min():.3g}–"
              f"{estimate.window_s.max():.3g} s){units}")
        out.append((path, samples))
        channel = record.channel
    for path in args.response_controlled:
        runs = read_response_controlled(path, read_options(args))
        channel = runs[0].response_dof
        samples = samples_from_held_runs(runs, shapes.get(channel))
        print(f"{path}: {len(runs)} response-controlled run(s) at {channel}, held {1e6 * runs[0].held_m:.3g}–"
              f"{1e6 * runs[-1].held_m:.3g} µm, one-mode fit of each" + ("" if channel in shapes else
                                                                         f"; shape {samples.input_shape:.4g} 1/√kg "
                                                                         f"from the lowest run's modal constant"))
        out.append((path, samples))
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
        out.append((path, samples))
        channel = points.input_dof
    return out, channel


def run(args: argparse.Namespace) -> int:
    out = checked_output(args.out, args.overwrite, folder=True)
    if (args.forces is None) != (args.freqs is None):
        raise CliError("--forces and --freqs go together (the levels and the grid of the predicted FRFs)")
    shapes = _shapes(args.shape)
    data = None
    if not (args.measured or args.ring_down or args.response_controlled or args.phase_resonance):
        raise CliError("give the mode's data: --measured FILE (FRFs or a modal table) and/or --ring-down FILE, "
                       "--response-controlled FILE, --phase-resonance FILE")
    rings, channel = _ring_down_samples(args, shapes)
    if not args.measured:  # the sensor's coordinate stands for the input of any predicted FRF (a driving point)
        samples, input_dof = join_samples([s for _, s in rings]), channel
        model = fit_amplitude_model(samples, ((channel, samples.input_shape),), args.backbone, args.order,
                                    mode=args.mode)
        unit, points = "N", rings
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
        points = [(sources(args), samples)] + rings
        if rings:  # the measured samples and the ring-downs, fitted together at the given shape
            samples = join_samples([samples] + [s for _, s in rings])
            model = fit_amplitude_model(samples, model.shapes, args.backbone, args.order, mode=args.mode)
    resamples = (200 if args.backbone == "polynomial" else 0) if args.bootstrap is None else args.bootstrap
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
        _plot_backbone(model, samples, folder / "backbone.png")
        backbone_curve(model, samples, refit=lambda draw: fit_amplitude_model(
            draw, model.shapes, args.backbone, args.order, mode=args.mode), resamples=resamples).to_csv(
            folder / "backbone.csv", index=False)
        backbone_points(points).to_csv(folder / "backbone_points.csv", index=False)
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
    print(f"wrote {out / 'amplitude_model.json'}, the backbone plot, backbone.csv and backbone_points.csv"
          + (" and the predicted FRFs" if predicted is not None else ""))
    return 0
