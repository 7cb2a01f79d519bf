"""The one group of options every command that reads measured FRFs shares, and the reading.

``--measured FILE [FILE ...]`` names the files (.parquet, .csv, .uff/.unv, .mat; one, one
per level or run, or a test system's export holding several runs — and, where a command
allows it, a modal table). ``--reference-unit N|V`` states the reference of the FRFs
(V: the excitation voltage, FRFs and levels per volt); ``--reference-calibration
N_PER_V`` converts per-volt data to newtons; ``--level KEY=VALUE`` gives the level (in
the reference unit) of a file (``FILE=VALUE``), of one run of a file
(``FILE#RUN=VALUE``) or of a run wherever it is (``RUN=VALUE``; RUN as the
"no level" error lists it); ``--coordinates FILE=RESPONSE,INPUT`` names the coordinates
of a file that does not (MATLAB stepped-sine runs); ``--band LOW:HIGH`` limits the work to
a band (Hz): the measured lines outside it are left out *before* any step.

Commands call :func:`add_measured_options` and :func:`measured_table`; the notes it
returns (what was read, the reference unit, the band) are printed with
:func:`print_notes`, so every output says volts when the reference is a voltage.
docs/measured-data.md describes the files, runs and levels.
"""
from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Iterable

import numpy as np
import pandas as pd

from nlupdate.app.cli import CliError
from nlupdate.core.measurement.band import excited_band_of_table, in_band, table_within
from nlupdate.core.measurement.units import (
    ReadOptions, ReferenceUnitError, table_reference_unit, validate_reads_runs_apart,
)

LEVEL_HELP = ("level (in the reference unit) of a file that does not hold it: FILE=VALUE; of one run of a file "
              "holding several: FILE#RUN=VALUE; or of a run by its name: RUN=VALUE (RUN as the 'no level' error "
              "lists it); repeat per file or run")


def add_measured_options(parser: argparse.ArgumentParser, band_help: str, *, modal: bool = False,
                         required: bool = True) -> None:
    """``--measured FILE [FILE ...]`` and the reference, level, coordinate and band options.

    ``band_help`` ends the ``--band`` help (what the band is for and its default);
    ``modal``: the command also takes a modal table (.csv) as ``--measured``.
    """
    what = "measured FRFs (.parquet, .csv, .uff/.unv, .mat): one file, one per level or run, or an export holding " \
           "several runs"
    if modal:
        what += "; or one modal table (.csv: force_level_n, mode, natural_frequency_hz, damping_ratio)"
    parser.add_argument("--measured", required=required, nargs="+", metavar="FILE", help=what)
    add_reference_options(parser)
    add_band_option(parser, band_help)


def add_reference_options(parser: argparse.ArgumentParser) -> None:
    """``--reference-unit``, ``--reference-calibration``, ``--level`` and ``--coordinates``."""
    parser.add_argument("--reference-unit", choices=("N", "V"),
                        help="unit of the FRFs' reference: N (force) or V (excitation voltage: FRFs and levels per volt; "
                             "default: as the file says)")
    parser.add_argument("--reference-calibration", type=float, metavar="N_PER_V",
                        help="newtons per volt of a voltage reference: converts per-volt data to per-newton")
    parser.add_argument("--level", action="append", default=[], metavar="KEY=VALUE", help=LEVEL_HELP)
    parser.add_argument("--coordinates", action="append", default=[], metavar="FILE=RESPONSE,INPUT",
                        help="response and input coordinates of a file that does not name them (MATLAB stepped-sine "
                             "runs); NODE:-DIR states a sensor or force along the negative direction; repeat per file")


def add_band_option(parser: argparse.ArgumentParser, what: str) -> None:
    parser.add_argument("--band", metavar="LOW:HIGH", help=f"frequency band in Hz {what}")


def parse_band(text: str | None, option: str = "--band") -> tuple[float, float] | None:
    """``"LOW:HIGH"`` (or ``LOW,HIGH``) in Hz, LOW < HIGH, both ≥ 0."""
    if text is None:
        return None
    parts = text.replace(",", ":").split(":")
    try:
        low, high = (float(p) for p in parts)
    except ValueError:
        raise CliError(f"{option} {text!r}: expected LOW:HIGH in Hz, e.g. 70:110") from None
    if not (math.isfinite(low) and math.isfinite(high) and 0 <= low < high):
        raise CliError(f"{option} {text!r}: expected LOW:HIGH in Hz with 0 ≤ LOW < HIGH")
    return low, high


def parse_levels(entries: Iterable[str], option: str = "--level", unit: str = "the reference unit") -> dict[str, float]:
    """The ``KEY=VALUE`` entries of ``option`` (KEY: FILE, FILE#RUN or RUN; VALUE > 0 in ``unit``) as a dict."""
    levels: dict[str, float] = {}
    for entry in entries:
        name, sep, value = entry.rpartition("=")
        try:
            number = float(value)
        except ValueError:
            number = float("nan")
        if not sep or not name.strip() or not (math.isfinite(number) and number > 0):
            raise CliError(f"{option} {entry!r}: expected FILE=VALUE, FILE#RUN=VALUE or RUN=VALUE with a level > 0 "
                           f"in {unit}")
        if name in levels and levels[name] != number:
            raise CliError(f"{option} {entry!r}: {name!r} was given the level {levels[name]:g} already")
        levels[name] = number
    return levels


def read_options(args: argparse.Namespace) -> ReadOptions:
    """The :class:`~nlupdate.core.measurement.units.ReadOptions` the options state."""
    levels = parse_levels(getattr(args, "level", []))
    coordinates = {}
    for entry in getattr(args, "coordinates", []):
        name, sep, value = entry.rpartition("=")
        names = tuple(part.strip() for part in value.split(","))
        if not sep or not name or len(names) != 2 or not all(names):
            raise CliError(f"--coordinates {entry!r}: expected FILE=RESPONSE,INPUT, e.g. run.mat=tip:uz,tip:uz")
        coordinates[name] = names
    try:
        return ReadOptions(getattr(args, "reference_unit", None), getattr(args, "reference_calibration", None), levels,
                           coordinates, _runs_read_apart(args))
    except ReferenceUnitError as error:
        raise CliError(f"--reference-calibration: {error}") from None


def _runs_read_apart(args: argparse.Namespace) -> tuple[str, ...]:
    """The files whose response-controlled runs the command reads as such: ``amplitude``'s
    ``--response-controlled FILE``s; ``validate``'s MATLAB ``--measured`` files unless
    ``--response-controlled off``; none for a command without the option."""
    held = getattr(args, "response_controlled", "off")
    if isinstance(held, (list, tuple)):
        return tuple(map(str, held))
    return validate_reads_runs_apart(getattr(args, "measured", None) or [], str(held))


def _uses_frf_options(args: argparse.Namespace) -> bool:
    return bool(getattr(args, "reference_unit", None) or getattr(args, "reference_calibration", None)
                or getattr(args, "level", None) or getattr(args, "coordinates", None))


def measured_table(args: argparse.Namespace, known_dofs: Iterable[str] | None = None, *, modal: bool = False,
                   find_band: bool = False) -> tuple[pd.DataFrame, list[str]]:
    """(the measured table ``--measured`` names, read with the options and cut to ``--band``;
    the notes to print with :func:`print_notes`): :func:`measured_tables` without the whole table."""
    table, _, notes = measured_tables(args, known_dofs, modal=modal, find_band=find_band)
    return table, notes


def measured_tables(args: argparse.Namespace, known_dofs: Iterable[str] | None = None, *, modal: bool = False,
                    find_band: bool = False) -> tuple[pd.DataFrame, pd.DataFrame | None, list[str]]:
    """(the measured table ``--measured`` names, read with the options and cut to ``--band``;
    the FRF table as it is without ``--band`` — cut to its excited band with ``find_band`` —
    when ``--band`` left out some of its lines, else None; the notes to print with
    :func:`print_notes`).

    The table is a measured-FRF table (all files as one, :func:`read_frf_tables`), or —
    with ``modal`` and a single modal-table file — a modal table (modes outside the band
    left out). What the reader notices (a z-axis level typed in the unit the reference
    contradicts, mobility converted …) goes out as warnings (the CLI prints them on stderr)
    as it is found. ``find_band``: without ``--band``, an FRF table is cut to its excited band
    (:func:`excited_band_of_table`) when that is narrower than what was measured (a
    full-band export). Notes: the files and levels read with the reference (volts stated),
    the band. Errors are one line (:class:`CliError` or ``ValueError``).
    """
    from nlupdate.core.measurement.frf_files import read_frf_tables
    from nlupdate.core.measurement.modal_table import is_modal_table_file, read_modal_table

    paths = list(args.measured)
    band = parse_band(getattr(args, "band", None))
    notes: list[str] = []
    whole = None
    if modal and any(is_modal_table_file(p) for p in paths):
        if len(paths) != 1:
            raise CliError(f"--measured {' '.join(paths)}: a modal table is read alone (one file)")
        if _uses_frf_options(args):
            raise CliError(f"{paths[0]}: a modal table states its levels in N; --reference-unit, "
                           f"--reference-calibration, --level and --coordinates apply to measured FRFs")
        table = read_modal_table(paths[0])
        column = "natural_frequency_hz"
    else:
        options = read_options(args)
        table = read_frf_tables(paths, known_dofs, options)  # its notices go out as warnings, as they come
        notes.append(describe_frf_table(table, paths, options.reference_calibration))
        column = "frequency_hz"
    if band is not None:
        inside = pd.Series(in_band(table[column], band), index=table.index)
        if not inside.any():
            lo, hi = float(table[column].min()), float(table[column].max())
            what = "mode" if column != "frequency_hz" else "line"
            raise CliError(f"--band {args.band}: {', '.join(paths)} has no {what} "
                           f"between {band[0]:g} and {band[1]:g} Hz (measured {lo:g}–{hi:g} Hz)")
        if not inside.all():
            notes.append(f"band {band[0]:g}–{band[1]:g} Hz (--band): {int((~inside).sum())} of {len(table)} measured "
                         f"rows outside it left out before any step")
            if column == "frequency_hz":
                whole = _excited(table, find_band)[0]
                whole = None if in_band(whole[column], band).all() else whole
        table = table[inside].reset_index(drop=True)
    elif find_band and column == "frequency_hz":
        table, note = _excited(table, True)
        notes += [note] if note else []
    return table, whole, notes


def _excited(table: pd.DataFrame, find_band: bool) -> tuple[pd.DataFrame, str | None]:
    """(an FRF table cut to its excited band when ``find_band`` and that is narrower than what
    was measured — a full-band export —, the note saying so or None)."""
    if not find_band:
        return table, None
    found, reason = excited_band_of_table(table)
    cut, left_out = table_within(table, found)
    if not left_out:
        return table, None
    return cut, (f"band {found[0]:g}–{found[1]:g} Hz found ({reason}): {left_out} of {len(table)} measured rows "
                 f"outside it left out before any step (choose another with --band LOW:HIGH)")


def describe_frf_table(table: pd.DataFrame, paths: list[str], calibration: float | None = None) -> str:
    """One line: files, levels with their unit, band and pairs of a measured-FRF table; for a
    voltage reference it says that FRFs and levels are per volt."""
    unit = table_reference_unit(table)
    levels = np.unique(table["force_level_n"].to_numpy(float))
    shown = ", ".join(f"{v:g}" for v in levels[:8]) + (", …" if levels.size > 8 else "")
    pairs = table[["response_dof", "input_dof"]].drop_duplicates().shape[0]
    files = paths[0] if len(paths) == 1 else f"{len(paths)} files"
    line = (f"measured: {files}: {levels.size} level(s) {shown} {unit}, {float(table['frequency_hz'].min()):g}–"
            f"{float(table['frequency_hz'].max()):g} Hz, {pairs} response/input pair(s)")
    if unit == "V":
        line += ("; reference: excitation voltage — levels in V, FRFs in m/V, parameters per volt (V where N would "
                 "stand)")
    elif calibration is not None:
        line += f"; reference: voltage calibrated with {calibration:g} N/V — levels in N, FRFs in m/N"
    return line


def print_notes(notes: Iterable[str]) -> None:
    """Print the notes of :func:`measured_table`, one line each."""
    for note in notes:
        print(note if note.startswith("measured: ") else f"note: {note}")


def sources(args: argparse.Namespace) -> str:
    """The ``--measured`` files as one string, for messages."""
    return ", ".join(str(Path(p)) for p in args.measured)
