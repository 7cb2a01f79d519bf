"""Options every command that reads measured data shares: what the reference is, the
levels of files that do not hold them, and the band.

``--reference-unit N|V`` states the reference of the FRFs (V: the excitation voltage,
FRFs and levels per volt); ``--reference-calibration N_PER_V`` converts per-volt data to
newtons; ``--level FILE=VALUE`` gives the level of a file that does not hold it (repeat
per file); ``--coordinates FILE=RESPONSE,INPUT`` names the coordinates of a file that
does not (MATLAB stepped-sine runs); ``--band LOW:HIGH`` limits the work to a band (Hz).
"""
from __future__ import annotations

import argparse
import math

from nlupdate.cli import CliError
from nlupdate.measurement.units import ReadOptions, ReferenceUnitError


def add_reference_options(parser: argparse.ArgumentParser) -> None:
    """``--reference-unit``, ``--reference-calibration``, ``--level`` and ``--coordinates``."""
    parser.add_argument("--reference-unit", choices=("N", "V"),
                        help="unit of the FRFs' reference: N (force) or V (excitation voltage: FRFs and levels per volt; "
                             "default: as the file says)")
    parser.add_argument("--reference-calibration", type=float, metavar="N_PER_V",
                        help="newtons per volt of a voltage reference: converts per-volt data to per-newton")
    parser.add_argument("--level", action="append", default=[], metavar="FILE=VALUE",
                        help="level of a file that does not hold it (in the reference unit); repeat per file")
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


def read_options(args: argparse.Namespace) -> ReadOptions:
    """The :class:`~nlupdate.measurement.units.ReadOptions` the options state."""
    levels = {}
    for entry in args.level:
        name, sep, value = entry.rpartition("=")
        try:
            number = float(value)
        except ValueError:
            number = float("nan")
        if not sep or not name or not (math.isfinite(number) and number > 0):
            raise CliError(f"--level {entry!r}: expected FILE=VALUE with a level > 0 in the reference unit")
        levels[name] = number
    coordinates = {}
    for entry in getattr(args, "coordinates", []):
        name, sep, value = entry.rpartition("=")
        names = tuple(part.strip() for part in value.split(","))
        if not sep or not name or len(names) != 2 or not all(names):
            raise CliError(f"--coordinates {entry!r}: expected FILE=RESPONSE,INPUT, e.g. run.mat=tip:uz,tip:uz")
        coordinates[name] = names
    try:
        return ReadOptions(args.reference_unit, args.reference_calibration, levels, coordinates)
    except ReferenceUnitError as error:
        raise CliError(f"--reference-calibration: {error}") from None
