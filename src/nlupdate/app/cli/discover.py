"""``nlupdate discover``: which effect the model is missing, where — added, with proof.

Reads a model file and measurements at several force levels (a measured-FRF table:
.parquet, .csv, .uff or .mat; or a modal table: .csv with columns force_level_n, mode,
natural_frequency_hz, damping_ratio), tries the candidate effects at every place the
model offers and writes ``DIR/discovery.json``, ``DIR/augmented_model.toml`` (the model with
the effect added) and plots. The folder appears only when complete. Method and outputs:
docs/discovery.md.
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from nlupdate.app.cli import CliError, add_command, non_negative_float, positive_int
from nlupdate.app.cli.harmonics import add_harmonic_options, harmonic_settings
from nlupdate.app.cli.output import add_overwrite_option, checked_output, writable_folder
from nlupdate.app.cli.run import add_execution_options, prefect_errors
from nlupdate.core.discovery import DiscoveryOptions, ModelSolveError, discover
from nlupdate.core.discovery.candidates import CRITERIA
from nlupdate.core.discovery.effects import EFFECT_NAMES
from nlupdate.core.measurement.frf_table import SWEEP_DIRECTIONS
from nlupdate.core.discovery.outputs import JSON_NAME as DISCOVERY_JSON, write_discovery
from nlupdate.core.measurement.units import parameter_unit, table_reference_unit, units_block
from nlupdate.reporting.jsonfile import write_json
from nlupdate.app.cli.measured import add_measured_options, measured_table, print_notes, sources
from nlupdate.core.model.model_file import load_system
from nlupdate.files import atomic_directory
from nlupdate.core.response.method import RESPONSE_METHODS


#: the discovery's own defaults, which the options show and pass on
DEFAULTS = DiscoveryOptions()


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = add_command(subparsers, "discover", __doc__)
    parser.add_argument("--model", required=True, metavar="MODEL.toml", help="model file ([model] + [[nonlinear]])")
    add_measured_options(parser, "to compare model and test in: measured lines outside it are left out before any step, "
                                 "a modal table keeps the modes inside it (default: the excited band of the lowest "
                                 "level: where the coherence is ≥ 0.8, or, without coherence, where the FRF is smooth)",
                         modal=True)
    where = parser.add_mutually_exclusive_group(required=True)
    where.add_argument("--out", metavar="DIR", help="output directory, in this process (appears when complete)")
    where.add_argument("--archive", metavar="ROOT",
                       help="run as a Prefect flow (candidate fits as cached parallel tasks) and archive the run under "
                            "ROOT/discovery-<model>/<UTC time>-<hash>/")
    parser.add_argument("--effects", help=f"comma-separated subset of the library (default all: {','.join(EFFECT_NAMES)})")
    parser.add_argument("--criterion", choices=CRITERIA, default=DEFAULTS.criterion,
                        help=f"information criterion (default {DEFAULTS.criterion})")
    parser.add_argument("--max-effects", type=positive_int, default=DEFAULTS.max_effects,
                        help=f"most effects to add (default {DEFAULTS.max_effects})")
    parser.add_argument("--noise-fraction", type=non_negative_float,
                        help="FRF noise std / |H| (default: estimated from the measured FRFs)")
    parser.add_argument("--sweep", choices=SWEEP_DIRECTIONS,
                        help="how the test reached each frequency (default: the table's sweep_direction column, else "
                             "unknown); every point is compared with the model's nearest stable solution, the direction "
                             "only marks points that follow another branch")
    parser.add_argument("--method", choices=RESPONSE_METHODS, default="continuation",
                        help="how the model is simulated against measured FRFs (default continuation: describing "
                             "function; hb: harmonic balance); the candidates' fits are describing-function fits")
    parser.add_argument("--frequency-uncertainty", type=non_negative_float, default=DEFAULTS.frequency_uncertainty,
                        help=f"modal table: relative std of the natural frequencies (default "
                             f"{DEFAULTS.frequency_uncertainty:g})")
    parser.add_argument("--damping-uncertainty", type=non_negative_float, default=DEFAULTS.damping_uncertainty,
                        help=f"modal table: relative std of the damping ratios (default {DEFAULTS.damping_uncertainty:g})")
    add_overwrite_option(parser)
    add_harmonic_options(parser)
    add_execution_options(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    started = time.perf_counter()
    settings = harmonic_settings(args)
    if args.out is not None:
        out = checked_output(args.out, args.overwrite, folder=True, kind="discovery",
                             inputs=[args.model, *args.measured])
        args.interrupt_note = f"nothing was written to {out}"
    else:
        writable_folder(Path(args.archive), "--archive")
    system = load_system(args.model)
    if args.archive is not None:
        if args.band is not None or args.reference_unit or args.reference_calibration or args.level \
                or args.coordinates or len(args.measured) != 1:
            raise CliError("--band, --reference-unit, --reference-calibration, --level, --coordinates and several "
                           "--measured files apply to --out runs; the archived flow reads one measured file as it is")
        table = None
    else:
        table, notes = measured_table(args, modal=True, find_band=True)
        print_notes(notes)
    try:
        options = DiscoveryOptions(
            effects=None if not args.effects else tuple(n.strip() for n in args.effects.split(",") if n.strip()),
            criterion=args.criterion, max_effects=args.max_effects, noise_fraction=args.noise_fraction,
            sweep=args.sweep, frequency_uncertainty=args.frequency_uncertainty,
            damping_uncertainty=args.damping_uncertainty, harmonic_balance=settings,
        )
        if args.archive is not None:
            from nlupdate.orchestration.flows.run import run_discovery_flow
            from nlupdate.orchestration.flows.runners import Execution

            with prefect_errors(args, start_server=True):
                folder = run_discovery_flow(args.model, args.measured[0], options, args.archive,
                                            Execution(args.workers, args.dask, args.dask_address), args.cache_dir,
                                            args.no_cache)
            print(f"archive: {folder}\nreport:  {folder / 'report.md'}")
            return 0
        result = discover(system, table, options, source=sources(args))
    except ModelSolveError as error:
        raise CliError(f"{args.model}: {error}") from None
    with atomic_directory(args.out, on_exists="replace" if args.overwrite else "error", kind="discovery") as archive:
        write_discovery(result, archive.path)
        unit = "N" if "natural_frequency_hz" in table.columns else table_reference_unit(table)
        if unit != "N":  # the JSON says what its levels and parameters are measured in
            summary = json.loads((archive.path / DISCOVERY_JSON).read_text())
            write_json({**summary, "units": units_block(unit)}, archive.path / DISCOVERY_JSON)
    found = ", ".join(
        f"{e.name} on {result.place(e.dofs)} "
        f"({', '.join(f'{k} = {v:.4g} {parameter_unit(k, unit)}'.rstrip() for k, v in e.parameters.items())})"
        for e in result.effects
    ) or "none"
    print(result.summary())  # how far from the noise, and what not to trust, before the effects and numbers
    for warning in result.warnings:
        if warning != result.summary():
            print(f"warning: {warning}")
    print(f"effects found: {found}")
    print(f"gap (mean 1 − FRAC): before {result.gap_before.gap:.4g}, after {result.gap_after.gap:.4g}; "
          f"stopped: {result.stop_reason}")
    for step in result.steps:
        if step.note and step.note != result.stop_reason:
            print(f"note: iteration {step.iteration}: {step.note}")
    for note in result.restarts:
        print(f"note: {note}")
    print(f"wrote {archive.final} in {time.perf_counter() - started:.1f} s")
    return 0
