"""The measured-FRF table of one test's time records: the excitation told or detected, one estimator.

Each level's ``force_level_n`` is the mean achieved first-harmonic reference amplitude over
its dwells (its spread is reported); the table records ``excitation``, and for a sweep its
``sweep_direction``.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from nlupdate.core.measurement.frf_table import validate_frf_table
from nlupdate.core.measurement.time_history.broadband import random_frf
from nlupdate.core.measurement.time_history.records import TimeHistoryError, TimeRecord
from nlupdate.core.measurement.time_history.stepped_sine import stepped_sine_frf
from nlupdate.core.measurement.time_history.sweep import sine_sweep_frf
from nlupdate.notices import NlupdateWarning

EXCITATION_CHOICES = ("auto", "stepped_sine", "sine_sweep", "random", "burst")
RESPONSE_QUANTITIES = {"displacement": 0, "velocity": 1, "acceleration": 2}


@dataclass
class FRFEstimate:
    """The measured-FRF table estimated from time records and what the estimation found."""

    table: pd.DataFrame
    excitation: str
    levels: list[dict] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)


def detect_excitation(record: TimeRecord) -> str:
    """``stepped_sine`` with a logged frequency; else ``sine_sweep`` when the reference's
    envelope (|analytic signal|) varies by less than 25 % (coefficient of variation), ``random``
    otherwise."""
    if record.frequency_hz is not None:
        return "stepped_sine"
    import scipy.signal  # imported where used: it costs 0.3 s

    envelope = np.abs(scipy.signal.hilbert(record.reference - record.reference.mean()))
    trimmed = envelope[envelope.size // 20: -envelope.size // 20 or None]
    return "sine_sweep" if trimmed.std() < 0.25 * trimmed.mean() else "random"


def estimate_frf(records: list[TimeRecord], input_dof: str, excitation: str = "auto",
                 response_quantity: str = "displacement", window_cycles: float = 10.0,
                 resolution_hz: float | None = None) -> FRFEstimate:
    """The measured-FRF table of ``records`` (one or more files of one test; package docstring)."""
    if excitation not in EXCITATION_CHOICES:
        raise TimeHistoryError(f"excitation {excitation!r}: expected one of {list(EXCITATION_CHOICES)}")
    if response_quantity not in RESPONSE_QUANTITIES:
        raise TimeHistoryError(f"response quantity {response_quantity!r}: expected one of {list(RESPONSE_QUANTITIES)}")
    power = RESPONSE_QUANTITIES[response_quantity]
    units = {r.reference_unit for r in records}
    if len(units) > 1:
        raise TimeHistoryError("the files mix force (N) and voltage (V) references")
    unit = units.pop()
    kinds = {detect_excitation(r) if excitation == "auto" else excitation for r in records}
    if len(kinds) > 1:
        raise TimeHistoryError(f"the files hold different excitations {sorted(kinds)}; estimate them separately")
    kind = kinds.pop()
    frames, notes, levels, direction = [], [], [], "unknown"
    for number, record in enumerate(records):
        if kind == "stepped_sine":
            if record.frequency_hz is None:
                raise TimeHistoryError(f"{record.source}: a stepped-sine record needs the controller's 'frequency_hz' "
                                       f"column (the dwell frequency of each sample)")
            rows, more = stepped_sine_frf(record, power)
            notes += more
        elif kind == "sine_sweep":
            rows, direction, more = sine_sweep_frf(record, power, window_cycles)
            notes += more
        else:
            rows = random_frf(record, power, resolution_hz)
            rms = float(np.sqrt(np.mean((record.reference - record.reference.mean()) ** 2)))
            for row in rows:
                row["level_key"], row["level_achieved"] = ("rms", number), rms
        if not rows:
            raise TimeHistoryError(f"{record.source}: no dwell of at least 16 samples at a frequency > 0")
        frame = pd.DataFrame(rows)
        frame["group"] = [(number, key) if key is None or kind != "stepped_sine" else ("level", key)
                          for key in frame["level_key"]]
        frames.append(frame)
    frame = pd.concat(frames, ignore_index=True)
    level_of = {}
    for group, rows in frame.groupby("group", sort=False):
        achieved = rows.drop_duplicates("frequency_hz")["level_achieved"].to_numpy()
        level_of[group] = float(achieved.mean())
        levels.append({"level": level_of[group], "spread": float(achieved.std()), "min": float(achieved.min()),
                       "max": float(achieved.max()), "lines": int(achieved.size)})
    frame["force_level_n"] = [level_of[g] for g in frame["group"]]
    table = pd.DataFrame({
        "frequency_hz": frame["frequency_hz"].to_numpy(float), "force_level_n": frame["force_level_n"].to_numpy(float),
        "response_dof": frame["response_dof"].astype(str), "input_dof": input_dof,
        "h_real": np.real(frame["h"].to_numpy(complex)), "h_imag": np.imag(frame["h"].to_numpy(complex)),
        "excitation": kind,
    })
    for column in ("coherence", "averages", "h_std", "level_achieved", "harmonic_distortion"):
        if column in frame.columns and frame[column].notna().all():
            table[column] = frame[column].to_numpy(float)
    if kind == "sine_sweep":
        table["sweep_direction"] = direction
    if unit == "V":
        table["reference_unit"] = "V"
    duplicated = table.duplicated(["frequency_hz", "force_level_n", "response_dof"], keep="first")
    if duplicated.any():
        notes.append(f"{int(duplicated.sum())} repeated (frequency, level) line(s) kept once (the first)")
        table = table[~duplicated.to_numpy()]
    for note in notes:
        warnings.warn(note, NlupdateWarning, stacklevel=2)
    return FRFEstimate(validate_frf_table(table.reset_index(drop=True), source="estimated FRF"), kind, levels, notes)

