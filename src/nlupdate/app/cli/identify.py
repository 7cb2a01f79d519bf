"""``nlupdate identify``: nonlinearity and linear FRF from FRFs measured at several force levels.

PRD (default) or DDF on one (response, input) pair of a measured-FRF table. Writes
``DIR/identification.json``, ``DIR/linear_frf.parquet`` (force_level_n = 0 means
"linear"), ``DIR/fit.png`` and ``DIR/linear_frf.png``; the folder is written atomically.
Every option left out is filled by a default that is printed and listed in the JSON
under ``defaults_used``. Methods: docs/methods.md.
"""
# The work is nlupdate.core.identification.pipeline.identify; this module maps options to its
# settings and writes the folder.
from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

from nlupdate.app.cli import CliError, add_command
from nlupdate.app.cli.output import add_overwrite_option, checked_output
from nlupdate.app.cli.progress_bar import terminal_progress
from nlupdate.core.correlation.metrics import frac
from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.pipeline import Identification, identify
from nlupdate.core.identification.settings import IdentificationSettings
from nlupdate.core.identification.dfmodels import parse_elements
from nlupdate.core.identification.partition import Placement, placements
from nlupdate.core.identification.trust import POOR_FIT_FACTOR, fit_verdict
from nlupdate.files import atomic_directory
from nlupdate.core.identification.summary import JSON_NAME
from nlupdate.reporting.figures import save_figure
from nlupdate.reporting.identification_plots import fit_figure, linear_frf_figure
from nlupdate.reporting.jsonfile import write_json
from nlupdate.app.cli.measured import add_measured_options, measured_table, parse_band, print_notes
from nlupdate.core.identification.prd import IdentificationError
from nlupdate.core.measurement.frf_files import write_frf_table
from nlupdate.core.measurement.frf_table import MeasurementTableError, measured_pair
from nlupdate.app.cli.settings_options import add_setting_options, setting_values, with_flags
from nlupdate.core.measurement.units import parameter_unit


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = add_command(subparsers, "identify", __doc__)
    add_measured_options(parser, "that every method uses; lines outside it are left out before any step (default: "
                                 "the excited band: where the coherence is ≥ the threshold, or, without coherence, "
                                 "where the FRF is smooth)")
    parser.add_argument("--input-dof", help="forced coordinate (default: the table's only input)")
    parser.add_argument("--response-dof", help="response coordinate of the nonlinearity (default: the input, driving "
                                               "point; or the input's only response)")
    add_setting_options(parser, IdentificationSettings)
    parser.add_argument("--out", required=True, metavar="DIR", help="output directory (appears when complete)")
    add_overwrite_option(parser)
    parser.set_defaults(run=run)


def settings_from_args(args: argparse.Namespace, table) -> tuple[IdentificationSettings, dict[str, object]]:
    """Identification settings for the command-line options (and the measured curve chosen here)."""
    try:
        response_dof, input_dof, defaults = measured_pair(table, args.input_dof, args.response_dof,
                                                          ("--input-dof", "--response-dof"))
    except MeasurementTableError as error:
        raise CliError(f"{', '.join(args.measured)}: {error}") from None
    try:
        settings = IdentificationSettings(response_dof=response_dof, input_dof=input_dof, band_hz=parse_band(args.band),
                                          **setting_values(args, IdentificationSettings))
    except ValueError as error:
        raise CliError(with_flags(str(error), IdentificationSettings)) from None
    return settings, dict(defaults)


def element_between(identification: Identification, table) -> list[Placement]:
    """When the placement check failed, the identified elements placed between the driven
    coordinate and each other measured response of the same input (the aa-partition form,
    :mod:`nlupdate.core.identification.partition`), best first; empty otherwise."""
    s = identification.settings
    model = parse_elements(s.elements)
    if identification.trustworthy or model is None or s.response_dof != s.input_dof:
        return []
    others = {}
    for dof in sorted(set(table.loc[table["input_dof"].astype(str) == s.input_dof, "response_dof"].astype(str))):
        if dof != s.response_dof:
            curves = FRFLevels.from_table(table, dof, s.input_dof)
            others[dof] = curves.within(identification.band_hz) if identification.band_hz is not None else curves
    if not others:
        return []
    at_q = FRFLevels.from_table(table, s.response_dof, s.input_dof)
    at_q = at_q.within(identification.band_hz) if identification.band_hz is not None else at_q
    return placements(at_q, others, model, s.linear_modes_hz, s.modal_band_fraction)


def write_identification(identification: Identification, data: FRFLevels, folder: Path,
                         between: list[Placement] = ()) -> list[str]:
    """``identification.json``, ``linear_frf.parquet``, ``fit.png`` and ``linear_frf.png``
    into ``folder`` (``between``: :func:`element_between`, in the JSON as
    ``element_between``); returns the file names."""
    s = identification.settings
    h = identification.linear_frf
    f_ref, h_ref = data.curve(identification.linear_from_level_n)
    if identification.band_hz is not None:  # the measured curve over the band the identification saw
        inside = (f_ref >= identification.band_hz[0]) & (f_ref <= identification.band_hz[1])
        f_ref, h_ref = f_ref[inside], h_ref[inside]
    summary = identification.summary()
    # FRAC on the extracted FRF's own grid (the band, coherent lines): the measured values at its lines
    summary["linear_frf"]["frac_vs_measured_at_that_level"] = frac(
        data.values(identification.linear_from_level_n, identification.linear_frequency_hz), h)
    if between:
        summary["element_between"] = [b.as_dict(s.response_dof, identification.noise_fraction) for b in between]
    files = [JSON_NAME, "linear_frf.parquet", "fit.png", "linear_frf.png"]
    summary["files"] = files
    title = f"{s.method.upper()} ({identification.result.estimator}), response {s.response_dof} / input {s.input_dof}"
    unit = identification.reference_unit
    write_json(summary, folder / JSON_NAME)
    linear = identification.linear_frf_table()
    if unit != "N":
        linear["reference_unit"] = unit
    write_frf_table(linear, folder / "linear_frf.parquet")
    level = identification.linear_from_level_n
    save_figure(fit_figure(identification, title, POOR_FIT_FACTOR), folder / "fit.png")
    save_figure(linear_frf_figure(identification, (f"{level:g} {unit}", f_ref, h_ref), title), folder / "linear_frf.png")
    return files


def run(args: argparse.Namespace) -> int:
    out = checked_output(args.out, args.overwrite, folder=True, kind="identification", inputs=args.measured)
    args.interrupt_note = f"nothing was written to {out}"
    table, notes = measured_table(args)
    print_notes(notes)
    settings, cli_defaults = settings_from_args(args, table)
    measured = ", ".join(args.measured)
    try:
        data = FRFLevels.from_table(table, settings.response_dof, settings.input_dof)
        with terminal_progress() as progress:
            identification = identify(data, settings, progress)
    except (IdentificationError, ValueError) as error:
        raise CliError(f"{measured}: {error}") from None
    unit = identification.reference_unit
    defaults = {**cli_defaults, **identification.defaults_used}
    identification = dataclasses.replace(identification, defaults_used=defaults)
    between = element_between(identification, table)
    with atomic_directory(out, on_exists="replace" if args.overwrite else "error", kind="identification") as folder:
        write_identification(identification, data, folder.path, between)
    out = folder.final
    # the bad news first (docs/commands.md): the levels' disagreement, every other warning and a
    # poor fit before the defaults and the numbers they qualify
    warnings = identification.warnings
    for warning in sorted(warnings, key=lambda w: (w.kind != "levels_disagree", w.kind != "diverged")):
        print(f"warning: {warning}")
    verdict, ratio = fit_verdict(identification.residual_noise_fraction, identification.noise_fraction)
    if verdict == "poor":
        print(f"fit: poor — the fit's residual is {ratio:.3g}× the noise level ({POOR_FIT_FACTOR:g}× at most for a "
              f"model that describes the data): {identification.model_description} misses part of the behaviour; "
              f"{out / 'fit.png'} shows the residual against amplitude")
    for key, value in defaults.items():
        print(f"default {key}: {value}")
    diverged = identification.diverged
    for name, stats in identification.uncertainty.parameters.items():
        if name in diverged:  # no estimate: what the number means, not the number
            print(diverged[name])
            continue
        suffix = f" {parameter_unit(name, unit)}" if parameter_unit(name, unit) else ""
        print(f"{name} = {stats.value:.6g}{suffix} (95 % [{stats.ci95[0]:.6g}, {stats.ci95[1]:.6g}]; Monte Carlo "
              f"std {stats.std:.3g}, median {stats.median:.6g})")
    for placement in between:
        fit = placement.fit
        values = ", ".join(f"{name} = {value:.4g} {parameter_unit(name, unit)}".rstrip()
                           for name, value in fit.parameters().items())
        print(f"placed between {placement.other_dof} and {settings.response_dof} (aa-partition form, docs/methods.md "
              f"§4): {values}; residual {100 * fit.residual_noise_fraction:.3g} % of |H| "
              f"({fit.residual_noise_fraction / max(identification.noise_fraction, 1e-12):.3g}× the noise); linear "
              f"modes of H_{settings.response_dof},{settings.response_dof}: "
              f"{', '.join(f'{f:.5g}' for f in placement.modes_hz) or 'none found'} Hz")
    print(f"wrote {out / JSON_NAME} and the linear FRF, fit and FRF plots")
    return 0
