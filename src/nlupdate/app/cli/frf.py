"""``nlupdate frf``: first-harmonic FRFs per level from measured time histories.

Reads one or more time records (CSV or parquet with columns time_s, the reference
force (N) or voltage (V), optional frequency_hz and level logged by a stepped-sine
controller, and one column per response coordinate; UFF 58 time records, function type
1; MATLAB files with the same variable names) and writes the measured-FRF table
(.parquet, .csv or .uff): stepped-sine dwells (transient discarded, first harmonic by
least squares, harmonic distortion reported), sine sweeps (first harmonic tracked along
the instantaneous frequency; keep the sweep rate below 0.5·(ζ f_r)² Hz/s for 2 %) or
random/burst excitation (H1 with coherence). The methods and their limits:
docs/measured-data.md.
"""
from __future__ import annotations

import argparse

from nlupdate.app.cli import CliError, add_command, non_negative_float
from nlupdate.app.cli.measured import add_band_option, parse_band
from nlupdate.app.cli.output import add_overwrite_option, checked_output
from nlupdate.core.measurement.frf_files import is_frf_table, table_suffix, write_frf_table
from nlupdate.core.measurement.time_history import (
    EXCITATION_CHOICES, RESPONSE_QUANTITIES, TimeHistoryError, estimate_frf, read_time_record,
)
from nlupdate.core.measurement.units import calibrated, table_reference_unit


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = add_command(subparsers, "frf", __doc__)
    parser.add_argument("records", nargs="+", metavar="TIMEFILE", help="time records (.csv, .parquet, .uff, .mat)")
    parser.add_argument("--out", required=True, metavar="FRF", help="measured-FRF table to write (.parquet, .csv, .uff)")
    parser.add_argument("--input-dof", help="name of the excited coordinate (default: the reference column's name)")
    parser.add_argument("--excitation", choices=EXCITATION_CHOICES, default="auto",
                        help="how the test excited the structure (default auto: stepped sine with a frequency_hz "
                             "column, else sine sweep or random from the reference's envelope)")
    parser.add_argument("--response-quantity", choices=tuple(RESPONSE_QUANTITIES), default="displacement",
                        help="what the response columns measure, in SI (default displacement, m)")
    parser.add_argument("--window-cycles", type=non_negative_float, default=10.0,
                        help="sine sweep: window length in cycles of the instantaneous frequency (default 10)")
    parser.add_argument("--resolution", type=non_negative_float, metavar="HZ",
                        help="random/burst: frequency resolution (default: 8 segments of the record)")
    parser.add_argument("--sample-rate", type=non_negative_float, metavar="HZ",
                        help="sample rate of records without a time_s column (default: their constant 'Fs' column)")
    parser.add_argument("--reference", choices=("force", "voltage"),
                        help="the reference column when a record has both (default force)")
    parser.add_argument("--reference-unit", choices=("N", "V"),
                        help="as the other commands: N takes the force column as the reference, V the voltage "
                             "(FRFs and levels per volt); the same as --reference force|voltage")
    parser.add_argument("--reference-calibration", type=non_negative_float, metavar="N_PER_V",
                        help="newtons per volt of a voltage reference: write the FRFs per newton")
    add_band_option(parser, "of the FRFs written: lines outside it are left out (a random or burst estimate covers "
                            "0 Hz to half the sample rate; default: every line estimated)")
    add_overwrite_option(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    out = checked_output(args.out, args.overwrite, folder=False, inputs=args.records, replaceable_file=is_frf_table)
    table_suffix(out)
    if args.window_cycles < 2:
        raise CliError(f"--window-cycles {args.window_cycles:g}: expected at least 2 cycles")
    band = parse_band(args.band)
    for option, value in (("--sample-rate", args.sample_rate), ("--reference-calibration", args.reference_calibration)):
        if value is not None and not value > 0:
            raise CliError(f"{option} {value:g}: expected a number > 0")
    reference = args.reference
    if args.reference_unit is not None:
        stated = {"N": "force", "V": "voltage"}[args.reference_unit]
        if reference is not None and reference != stated:
            raise CliError(f"--reference {reference} and --reference-unit {args.reference_unit} contradict each other")
        reference = stated
    args.interrupt_note = f"nothing was written to {out}"
    records = [read_time_record(path, args.sample_rate, reference) for path in args.records]
    input_dof = args.input_dof or ("force" if records[0].reference_unit == "N" else "voltage")
    if args.input_dof is None:
        print(f"default input_dof: {input_dof} (the reference column)")
    try:
        estimate = estimate_frf(records, input_dof, args.excitation, args.response_quantity, args.window_cycles,
                                args.resolution)
    except TimeHistoryError as error:
        raise CliError(str(error)) from None
    table = estimate.table
    if band is not None:
        inside = (table["frequency_hz"] >= band[0]) & (table["frequency_hz"] <= band[1])
        if not inside.any():
            raise CliError(f"--band {args.band}: no line estimated between {band[0]:g} and {band[1]:g} Hz (estimated "
                           f"{table['frequency_hz'].min():g}–{table['frequency_hz'].max():g} Hz)")
        print(f"band {band[0]:g}–{band[1]:g} Hz (--band): {int((~inside).sum())} of {len(table)} lines outside it "
              f"left out")
        table = table[inside].reset_index(drop=True)
    unit = table_reference_unit(table)
    if args.reference_calibration is not None:
        if unit != "V":
            raise CliError("--reference-calibration applies to a voltage reference; these records have a force column")
        table, unit = calibrated(table, args.reference_calibration, str(out)), "N"
    per = f"m/{unit}"
    print(f"excitation: {estimate.excitation.replace('_', ' ')}; reference in {unit}, FRFs in {per}")
    factor = args.reference_calibration or 1.0
    for level in estimate.levels:
        what = "RMS" if estimate.excitation in ("random", "burst") else "first-harmonic amplitude"
        print(f"level {level['level'] * factor:.6g} {unit} ({what}; spread {level['spread'] * factor:.3g}, "
              f"{level['min'] * factor:.6g}…{level['max'] * factor:.6g} over {level['lines']} lines)")
    if "harmonic_distortion" in table.columns:
        worst = table.loc[table["harmonic_distortion"].idxmax()]
        print(f"harmonic distortion of the response: up to {100 * worst['harmonic_distortion']:.3g} % "
              f"({worst['frequency_hz']:g} Hz, {worst['response_dof']})")
    if "coherence" in table.columns:
        print(f"coherence: median {table['coherence'].median():.3g}, min {table['coherence'].min():.3g}")
    write_frf_table(table, out)
    print(f"wrote {out} ({len(table)} lines, {table['force_level_n'].nunique()} level(s))")
    return 0
