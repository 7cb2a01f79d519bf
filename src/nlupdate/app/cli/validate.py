"""``nlupdate validate``: fit on some force levels, predict the others, compare with the baseline.

Judges a model where it was not fitted (docs/methods.md §10). For each held-out level
(--hold-out each: every level in turn; top: the highest, an extrapolation; or levels
like 0.49,0.97) the model is fitted on the other levels of the driving-point curve and
predicts the held-out curve over its measured band; its resonance frequency, damping
ratio (a modal circle fit) and peak are compared with the measured ones and with the log-amplitude
baseline (interpolation between the kept levels), each with a 95 % band (jackknife over
the kept levels plus the test's repeatability, stated beside every error). Writes
DIR/predicted_frf.parquet (the first model's curves in the measured-FRF table schema plus
h_abs_low and h_abs_high; predicted_frf_<model>.parquet for the others), DIR/validation.json (held_out: one entry per level and model),
DIR/held_out_<level>.png per level and DIR/validation.png (errors per level and model).
Response-controlled runs in a MATLAB stepped-sine file (--response-controlled auto, the
default) are predicted from all force-controlled levels at their held amplitude and
compared the same way: validation.json's response_controlled list and
DIR/response_controlled.png; --response-controlled kept adds them to the evidence every
fit keeps instead (a different test at the amplitudes it holds; the held-out levels are
still force-controlled ones). --hold-out-type TYPE holds out a whole test type instead
(stepped sine, ring-down, phase resonance, …: the sources of ``nlupdate amplitude``):
the amplitude-dependent modal model fitted on the others predicts it (docs/validation.md,
"A whole test type held out"). --impact FILE with levels held out: the mode's linear limit
from the impact's quietest decay is kept beside the levels as one more sample of the lines
models' backbone and damping curve at zero amplitude (lines, lines-background; auto
chooses between them).
"""
from __future__ import annotations

import argparse
import dataclasses
import re
import sys

import pandas as pd

from nlupdate.app.cli import CliError, add_command
from nlupdate.app.cli.measured import add_measured_options, measured_table, parse_band, print_notes, read_options
from nlupdate.app.cli.output import add_overwrite_option, checked_output
from nlupdate.app.cli.progress_bar import terminal_progress
from nlupdate.app.cli.settings_options import add_setting_options, setting_values, with_flags
from nlupdate.app.cli.validate_type import add_type_options, run_held_type
from nlupdate.files import atomic_directory
from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.impact import LinearLimit
from nlupdate.core.identification.ring_down import RingDownError
from nlupdate.core.measurement.frf_table import MeasurementTableError, frf_table, table_input, validate_frf_table
from nlupdate.reporting.figures import save_figure
from nlupdate.reporting.jsonfile import write_json
from nlupdate.reporting.validation_plots import held_out_figure, response_controlled_figure, summary_figure
from nlupdate.reporting.validation_text import said_line, validation_lines
from nlupdate.core.validation.held_response import validate_measured
from nlupdate.core.validation.impact_limit import LIMIT_MODELS, impact_linear_limit, refused_model
from nlupdate.core.validation.models import AUTO_CANDIDATES, MODELS
from nlupdate.study.spec import ValidationSpec


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = add_command(subparsers, "validate", __doc__)
    add_measured_options(parser, "the curves are cut to before any fit (default: every measured line); of a ring-down, "
                                 "its band-pass", required=False)
    add_setting_options(parser, ValidationSpec)  # --hold-out, --input-dof, --response-controlled: [validation]'s
    parser.add_argument("--model", default="auto", metavar="NAMES",
                        help=f"models, comma-separated: {', '.join(MODELS)}, prd:ELEMENTS (e.g. prd:cubic+jenkins) or "
                             f"auto (default: the one of {', '.join(AUTO_CANDIDATES)} that predicts the kept levels "
                             f"from each other best; for a level outside the kept range the best whose prediction "
                             f"stays in the physical range, else baseline, with a warning)")
    add_type_options(parser)
    parser.add_argument("--out", required=True, metavar="DIR", help="output directory (appears when complete)")
    add_overwrite_option(parser)
    parser.set_defaults(run=run)


def _models(text: str) -> list[str]:
    """``--model`` split on commas; ``prd:`` element lists join their elements with ``+``."""
    names = [name.strip().replace("+", ",") for name in text.split(",") if name.strip()]
    if not names:
        raise CliError("--model: name at least one model")
    return names


def _curve(table: pd.DataFrame, input_dof: str | None, sources: str) -> FRFLevels:
    try:
        input_dof = table_input(table, input_dof, "--input-dof")
    except MeasurementTableError as error:
        raise CliError(f"{sources}: {error}") from None
    if input_dof not in set(table["response_dof"].astype(str)):
        raise CliError(f"{sources}: no driving-point FRF at {input_dof} (response_dof "
                       f"{', '.join(sorted(set(table['response_dof'].astype(str))))}); validate needs it")
    return FRFLevels.from_table(table, input_dof, input_dof)


def predicted_table(results, data: FRFLevels) -> pd.DataFrame:
    """One curve per held-out level of one model (a valid measured-FRF table), with its
    95 % |H| band (``h_abs_low``, ``h_abs_high``)."""
    tables = []
    for result in results:
        table = validate_frf_table(frf_table(result.frequency_hz, result.level, data.response_dof, data.input_dof,
                                             result.predicted), source="the predicted curves")
        tables.append(table.assign(reference_unit=data.reference_unit, h_abs_low=result.abs_low,
                                   h_abs_high=result.abs_high))
    return pd.concat(tables, ignore_index=True)


def _slug(model: str) -> str:
    return re.sub(r"[^A-Za-z0-9]+", "-", model).strip("-")


def _plot_name(level: float, model: str, several: bool) -> str:
    name = f"held_out_{level:g}" + (f"_{_slug(model)}" if several else "")
    return name.replace(".", "p") + ".png"


def linear_limit(args: argparse.Namespace, data: FRFLevels, models: list[str]) -> LinearLimit:
    """The linear limit of the one ``--impact`` record (``--channel``) in ``--band`` or the
    measured lines' band (:func:`~nlupdate.core.validation.impact_limit.impact_linear_limit`);
    CliError for several records or a model that cannot keep it."""
    if len(args.impact) != 1:
        raise CliError(f"--impact: give one record with held-out levels, got {len(args.impact)}")
    refused = refused_model(models)
    if refused:
        raise CliError(f"--impact: model {refused} cannot keep a linear limit beside the levels (only "
                       f"{', '.join(LIMIT_MODELS)})")
    path = args.impact[0]
    try:
        fit = impact_linear_limit(path, args.channel, parse_band(args.band), data)
    except RingDownError as error:
        raise CliError(f"{path}: {error}") from None
    print(f"{path}: linear limit {fit.frequency_hz:.6g} ± {fit.frequency_std_hz:.2g} Hz, damping ratio "
          f"{100 * fit.damping_ratio:.4g} ± {100 * fit.damping_std:.2g} % ({', '.join(fit.channels)}, band "
          f"{fit.band_hz[0]:.4g}–{fit.band_hz[1]:.4g} Hz), kept beside the levels")
    return fit


def run(args: argparse.Namespace) -> int:
    out = checked_output(args.out, args.overwrite, folder=True)
    if args.hold_out_type:
        return run_held_type(args, out, _curve)
    if not args.measured:
        raise CliError("--measured FILE: the measured FRFs whose levels are held out (or --hold-out-type TYPE)")
    models = _models(args.model)
    table, notes = measured_table(args, find_band=True)
    print_notes(notes)
    data = _curve(table, args.input_dof, ", ".join(args.measured))
    if args.impact:
        data = dataclasses.replace(data, linear_limit=linear_limit(args, data, models))
    spec = ValidationSpec(**setting_values(args, ValidationSpec))
    try:
        with terminal_progress() as progress:
            validation = validate_measured(data, spec.hold_out, models, spec.response_controlled, args.measured,
                                           read_options(args), progress)
    except ValueError as error:
        raise CliError(with_flags(str(error), ValidationSpec)) from None
    if validation.kept_runs:
        print(f"keeping {len(validation.kept_runs)} response-controlled run(s) beside the force-controlled levels")
    unit = data.reference_unit
    several = len(models) > 1
    with atomic_directory(out, on_exists="replace") as archive:
        folder = archive.path
        for k, model in enumerate(models):  # auto's choice may differ per level: its rows together
            rows = [r for r in validation.held_out if r.requested == model]
            name = "predicted_frf.parquet" if k == 0 else f"predicted_frf_{_slug(model)}.parquet"
            predicted_table(rows, data).to_parquet(folder / name, index=False)
        summary = validation.summary()
        write_json(summary, folder / "validation.json")
        evidence = " + ".join(([f"{len(validation.kept_runs)} response-controlled runs"] if validation.kept_runs else [])
                              + (["the impact's linear limit"] if data.linear_limit is not None else []))
        for result in validation.held_out:
            save_figure(held_out_figure(result, unit, evidence),
                        folder / _plot_name(result.level, result.requested, several))
        save_figure(summary_figure(validation), folder / "validation.png")
        if validation.response_controlled:
            save_figure(response_controlled_figure(validation), folder / "response_controlled.png")
    for line in validation.said(unit):  # the verdict, then what qualifies the numbers: warnings on stderr
        print(said_line(line), file=sys.stderr if line.warns else sys.stdout)
    for line in validation_lines(validation, unit):
        print(line)
    print(f"wrote {out / 'validation.json'}, {out / 'predicted_frf.parquet'} and the plots")
    return 0
