"""Held-out levels of a second public real data set: a nonlinear beam's lock-in stepped-sine runs.

    NLUPDATE_TRANSMITTER_BEAM=FOLDER python benchmarks/validation_transmitter_beam.py [--models ...] [--write-docs]
    python benchmarks/validation_transmitter_beam.py --data FOLDER --export beam.csv

The data: ``forced_data.mat`` of github.com/haller-group/SSMLearn
(``examples/experiment_nonlinear_beam_oblique/nonlinear_beam_experiments/``, AGPL-3.0),
the transmitter beam of the ETH Zürich gravitational-coupling experiment (T. Brack et al.,
Nat. Phys. 18, 952–957, 2022): its first bending mode (≈ 42.8 Hz) measured at four
excitation amplitudes, 0.1, 0.2, 0.3 and 0.45 V, 40 lines each (42.705–42.834 Hz, steps of
3.29 mHz), the response demodulated by a lock-in amplifier (Zurich Instruments MFLI) and
averaged over 10 readings per line. Not in this repository: FOLDER is where you put the file
(docs/measured-data.md, "Data not in the repository").

:func:`lockin_table` turns the file into a measured-FRF table (docs/measured-data.md): per
line H = v/(iω·V_exc) in m/V, with v = 0.04·√2·(X1 + iY1) m/s the response velocity
amplitude from the lock-in's RMS in-phase and quadrature outputs (V) as the SSMLearn example
converts them (``4 · range · √2`` mm/s per V, range 10), V_exc the excitation amplitude as
logged (V) and x(t) = Re(X e^{iωt}) (the MFLI demodulates s(t) = √2·R·cos(ωt + θ),
X + iY = R·e^{iθ}). ``--export`` writes it as CSV, which every command reads with
``--reference-unit V``. The one curve (vibrometer over drive) is named ``beam`` for both
coordinates: validate's one-mode models see only its modal constant, which is positive here
(the mobility's phase runs +84° → −79° through the resonance).

Prints the measured resonance, damping ratio (circle fit), half-power lines and peak per level, then
(:mod:`benchmarks.validation_table`) the ``--hold-out each`` and ``--hold-out top`` tables,
model × level with the baseline beside, how many of the values lie in their band and how
many of those in uninformative bands, and the test's repeatability. ``--write-docs`` writes
the output into its block of docs/validation.md (benchmarks/docs_block.py).
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import warnings
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
import scipy.io

if __package__ in (None, ""):  # run as a script: make the repository root importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks import docs_block  # noqa: E402
from benchmarks.validation_table import print_validation_tables  # noqa: E402

if TYPE_CHECKING:
    from nlupdate.core.identification.data import FRFLevels

FILE_NAME = "forced_data.mat"
ENVIRONMENT_VARIABLE = "NLUPDATE_TRANSMITTER_BEAM"
ROOT = Path(__file__).resolve().parents[1]
DEFAULT_FOLDER = ROOT / "tests" / "data" / "transmitter_beam"
#: response velocity amplitude (m/s) per volt of the lock-in's RMS output: 4 · range (10) mm/s
#: per V, × √2 from RMS to amplitude (the SSMLearn example's conversion)
VELOCITY_PER_VOLT = 0.04 * np.sqrt(2.0)
#: the channels of ``forced_data.Results`` the table is made of
CHANNELS = ("Frequency_of_MFLI_avg__Hz_", "Amplitude_of_Excitation__V_", "X1_avg__V_", "Y1_avg__V_",
            "X1_std_dev", "Y1_std_dev", "Number_of_Points_Avg")
COORDINATE = "beam"


def lockin_table(path: str | os.PathLike) -> pd.DataFrame:
    """The measured-FRF table (receptance in m/V per excitation volt, levels in V, ``h_std``
    the standard deviation of the 10 averaged readings over √10) of ``path``, a MATLAB file
    holding the struct ``forced_data`` whose ``Results`` channels (each a struct with ``data``)
    are :data:`CHANNELS`. A missing variable or channel raises ValueError naming the file and it."""
    path = Path(path)
    content = scipy.io.loadmat(path, squeeze_me=True, struct_as_record=False)
    if "forced_data" not in content:
        raise ValueError(f"{path}: no variable 'forced_data' (expected the struct of lock-in results of the "
                         f"SSMLearn nonlinear-beam experiment)")
    results = getattr(content["forced_data"], "Results", None)
    if results is None:
        raise ValueError(f"{path}: forced_data has no field 'Results' (the lock-in's averaged results per line)")
    channels = {}
    for name in CHANNELS:
        channel = getattr(results, name, None)
        if channel is None or not hasattr(channel, "data"):
            raise ValueError(f"{path}: forced_data.Results has no channel '{name}' with a field 'data'")
        channels[name] = np.atleast_1d(np.asarray(channel.data, dtype=float))
    sizes = {v.size for v in channels.values()}
    if len(sizes) != 1:
        raise ValueError(f"{path}: forced_data.Results channels differ in length "
                         f"({', '.join(f'{k} {v.size}' for k, v in channels.items())}); expected one value per line")
    frequency = channels["Frequency_of_MFLI_avg__Hz_"]
    level = channels["Amplitude_of_Excitation__V_"]
    iw = 2j * np.pi * frequency
    h = VELOCITY_PER_VOLT * (channels["X1_avg__V_"] + 1j * channels["Y1_avg__V_"]) / (level * iw)
    h_std = (VELOCITY_PER_VOLT * np.hypot(channels["X1_std_dev"], channels["Y1_std_dev"])
             / np.sqrt(channels["Number_of_Points_Avg"]) / (level * np.abs(iw)))
    return pd.DataFrame({"frequency_hz": frequency, "force_level_n": level, "response_dof": COORDINATE,
                         "input_dof": COORDINATE, "h_real": h.real, "h_imag": h.imag, "h_std": h_std,
                         "excitation": "stepped_sine", "reference_unit": "V"})


def data_folder(folder: str | os.PathLike | None = None) -> Path:
    """Where ``FILE_NAME`` is looked for: ``folder``, else $NLUPDATE_TRANSMITTER_BEAM, else
    :data:`DEFAULT_FOLDER` (tests/data/transmitter_beam, where a copy with its licence would go)."""
    return Path(folder or os.environ.get(ENVIRONMENT_VARIABLE) or DEFAULT_FOLDER)


def data_file(folder: str | os.PathLike | None = None) -> Path:
    """``FILE_NAME`` in :func:`data_folder`; SystemExit saying where to get it when absent."""
    path = data_folder(folder) / FILE_NAME
    if not path.is_file():
        raise SystemExit(f"{FILE_NAME} not found in {path.parent}: put the file of github.com/haller-group/SSMLearn, "
                         f"examples/experiment_nonlinear_beam_oblique/nonlinear_beam_experiments/{FILE_NAME}, in a "
                         f"folder and give it with --data or {ENVIRONMENT_VARIABLE}")
    return path


def measured_levels(csv: Path) -> "FRFLevels":
    """The exported table read back as every command reads it (``--reference-unit V``)."""
    from nlupdate.core.identification.data import FRFLevels
    from nlupdate.core.measurement.frf_files import read_frf_table
    from nlupdate.core.measurement.units import ReadOptions

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        table = read_frf_table(csv, options=ReadOptions(reference_unit="V"))
    return FRFLevels.from_table(table, COORDINATE, COORDINATE)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", help=f"folder holding {FILE_NAME} (default: ${ENVIRONMENT_VARIABLE}, else "
                                       f"tests/data/transmitter_beam)")
    parser.add_argument("--export", metavar="CSV", help="write the measured-FRF table as CSV and stop")
    parser.add_argument("--models", default="lines,amplitude-polynomial,amplitude-iwan,auto")
    docs_block.add_option(parser)
    args = parser.parse_args(argv)
    table = lockin_table(data_file(args.data))
    if args.export:
        table.to_csv(args.export, index=False)
        levels = ", ".join(f"{v:g}" for v in sorted(set(table["force_level_n"])))
        print(f"wrote {args.export}: {len(table)} lines, levels {levels} V")
        return 0
    with docs_block.writing_docs(args.write_docs, "validation_transmitter_beam.py", argv,
                                 ROOT / "docs" / "validation.md"):
        print_tables(table, [m.strip() for m in args.models.split(",") if m.strip()])
    return 0


def print_tables(table: pd.DataFrame, models: list[str]) -> None:
    """The measured resonances per level, then the held-out tables of ``models``."""
    from nlupdate.core.validation.resonance import resonance

    with tempfile.TemporaryDirectory() as folder:
        csv = Path(folder) / "transmitter_beam.csv"
        table.to_csv(csv, index=False)
        data = measured_levels(csv)
    print(f"Transmitter beam (SSMLearn), excitation amplitudes {', '.join(f'{v:g}' for v in data.levels)} V, "
          f"{data.frequencies[0].size} lines each")
    print("\n| level (V) | resonance (Hz) | damping ratio (%) | half-power lines | peak |H| (m/V) |")
    print("|---|---|---|---|---|")
    for level, f, h in zip(data.levels, data.frequencies, data.receptances):
        r = resonance(f, h)
        print(f"| {level:g} | {r.resonance_hz:.4f} | {100 * r.damping_ratio:.4f} | {r.half_power_lines} | "
              f"{r.peak_abs:.4e} |")
    print()
    print_validation_tables(data, models, "V")


if __name__ == "__main__":
    sys.exit(main())
