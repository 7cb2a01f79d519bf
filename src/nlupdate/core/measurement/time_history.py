"""First-harmonic FRFs from measured time histories: stepped-sine dwells, sine sweeps, random/burst.

Length: three estimators (stepped sine, sine sweep, random) that share the record
reading, the units and the least-squares harmonic fit; the rules below are their
documentation.

A time record holds the sample times ``time_s`` (s), the reference — the excitation
``force`` (N) or the amplifier ``voltage`` (V) — and one signal per response coordinate
(displacement in m by default; velocity or acceleration are converted, ``H = V/(iω)``,
``A/(iω)²``). Conventions: ``x(t) = Re(X e^{iωt})`` for every first harmonic, H = X/F.

Stepped sine (a ``frequency_hz`` column logged by the controller: one dwell per constant
value, and a ``level`` column when several levels share a file)
    Per dwell the excitation frequency is refined from the logged value by least squares
    on the reference (within ±2 frequency bins of the dwell). **Transient rule**: the
    dwell is cut into blocks of whole periods (at least 4 periods, at most 16 blocks), the
    response's first harmonic is fitted in each; the steady value is the mean of the
    blocks of the last quarter of the dwell, with scatter s; the transient ends at the first
    block after which every block lies within ``max(3 s, 2e-3·|steady|)`` of the steady
    value, and everything before it is discarded. A dwell should last several time
    constants ``1/(ζω_r)`` of the mode it excites (at a resonance of ζ = 1 % and 20 Hz,
    eight of them, 6.4 s, leave 0.1 % of the transient in the estimate). Then the first harmonic (with the DC
    term and the harmonics 2 and 3) of force and response is fitted by least squares over
    the kept samples: ``H = X₁/F₁``; ``harmonic_distortion = √Σ_{h=2,3}|X_h|² / |X₁|``;
    ``h_std`` from the fit residuals (``|δX|² = 4σ²/N`` for N samples of residual
    variance σ², added relatively for X and F); ``level_achieved = |F₁|``. A dwell whose
    transient had not settled before its last quarter, or whose third quarter differs from
    its last by more than ``max(3 s, 1 %)`` (still moving), is warned about, and so is a
    dwell shorter than 16 periods (:data:`MIN_SETTLE_PERIODS`: too few blocks for the rule
    to tell; nothing is discarded). A record whose sample rate puts harmonic 3 of a dwell
    at or above the Nyquist frequency is refused (the fit would alias; a time column in ms
    instead of s does that).
    **Checks**: the reference's first harmonic must carry at least half its power
    (:data:`REFERENCE_POWER_SHARE`; else the logged frequency or the sample rate is wrong
    and the record is refused, naming the frequency the reference does oscillate at); a
    harmonic distortion of the response or the reference above 10 %
    (:data:`DISTORTION_WARNING`: clipping, a saturated channel, a strong nonlinearity) is
    warned about, and a dwell where it exceeds 100 % (:data:`DISTORTION_LIMIT`: the
    harmonics outweigh the first) is left out with a warning; a channel that is 0 at
    every sample is refused.
Sine sweep (no ``frequency_hz`` column, a reference of constant envelope)
    The reference's instantaneous phase φ(t) is the unwrapped phase of its analytic signal
    (Hilbert transform), smoothed by a quadratic in t over each window; in windows of
    ``window_cycles`` periods (default 10), spaced by half a window, force and response
    are fitted by least squares on ``cos φ, sin φ`` and the same times ``(t − t_c)`` (an
    amplitude changing linearly across the window) plus a constant: ``H = X(t_c)/F(t_c)``
    at the instantaneous frequency ``φ̇(t_c)/2π``. **Sweep-rate limit**: the response lags
    the excitation by its group delay, ``1/(ζω_r)`` at a resonance, so a sweep at r Hz/s
    measures the steady-state FRF at a frequency shifted by about ``r/(2πζ f_r)``; against
    the half-power half-bandwidth ``ζ f_r`` that is a relative error of about
    ``r/(2π (ζ f_r)²)``. tests/test_time_history.py measures it on a linear SDOF
    (f_r = 20 Hz, ζ = 5 %, 18–22 Hz, complex FRF against the steady state): 0.8 % at
    ``r = 0.05 (ζ f_r)²``, 1.6 % at 0.1, 3.2 % at 0.2, 12 % at 0.8 — proportional to the
    rate. Keep ``r ≤ 0.1·(ζ f_r)²`` Hz/s (:data:`SWEEP_RATE_LIMIT`) for 2 %; a faster sweep
    shifts and lowers the resonance in the sweep direction.
Random / burst (a reference whose envelope varies)
    H1 = G_fx/G_ff with Welch averages (Hann window, half overlap), the ordinary coherence
    ``γ² = |G_fx|²/(G_ff G_xx)``, ``averages`` = number of segments and
    ``h_std = |H|·√((1 − γ²)/(γ² n_d))`` (Bendat & Piersol); the level is the reference's
    RMS. The 0 Hz line is left out.

Each level's ``force_level_n`` is the mean achieved first-harmonic reference amplitude
over its dwells (its spread is reported); the table records ``excitation``, and for a
sweep its ``sweep_direction``.
"""
from __future__ import annotations

import io
import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
import scipy.optimize
from numpy.typing import NDArray

from nlupdate.input_files import check_parquet_size, decode_text, read_input_bytes, sniff
from nlupdate.core.measurement.frf_table import MeasurementTableError, validate_frf_table
from nlupdate.notices import NlupdateWarning

EXCITATION_CHOICES = ("auto", "stepped_sine", "sine_sweep", "random", "burst")
RESPONSE_QUANTITIES = {"displacement": 0, "velocity": 1, "acceleration": 2}
#: sweep rates r ≤ SWEEP_RATE_LIMIT·(ζ f_r)² Hz/s keep the swept FRF within 2 % of the steady state
SWEEP_RATE_LIMIT = 0.1
#: a dwell shorter than this (4 blocks of at least 4 periods) is too short for the transient rule
MIN_SETTLE_PERIODS = 16
#: a dwell whose response or reference has a harmonic distortion (√Σ_{h=2,3}|X_h|²/|X₁|) above
#: DISTORTION_WARNING is warned about; above DISTORTION_LIMIT (harmonics as large as the first)
#: the dwell is left out: its first harmonic does not describe the signal
DISTORTION_WARNING = 0.10
DISTORTION_LIMIT = 1.0
#: the reference's first harmonic at the dwell frequency carries at least this share of its power
REFERENCE_POWER_SHARE = 0.5
_SETTLE_TOLERANCE = 2e-3
_MOVING_TOLERANCE = 1e-2
_HARMONICS = 3
_RESERVED = ("time_s", "force", "voltage", "frequency_hz", "level")


class TimeHistoryError(MeasurementTableError):
    """A time record cannot be turned into FRFs as asked (the message names the file and what is wrong)."""


@dataclass(frozen=True)
class TimeRecord:
    """One measured time record (SI; the reference in N or V)."""

    source: str
    time_s: NDArray[np.float64]
    reference: NDArray[np.float64]
    reference_unit: str
    responses: dict[str, NDArray[np.float64]]
    frequency_hz: NDArray[np.float64] | None = None
    level: NDArray[np.float64] | None = None

    @property
    def sample_rate_hz(self) -> float:
        return float((self.time_s.size - 1) / (self.time_s[-1] - self.time_s[0]))


@dataclass
class FRFEstimate:
    """The measured-FRF table estimated from time records and what the estimation found."""

    table: pd.DataFrame
    excitation: str
    levels: list[dict] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)


# ------------------------------------------------------------------------------ reading
def _record_from_columns(columns: dict[str, np.ndarray], source: str, sample_rate_hz: float | None = None,
                         reference: str | None = None) -> TimeRecord:
    """A record from named columns. Names are matched without regard to case (``Force``
    is ``force``). Without ``time_s`` the samples are taken as evenly spaced at
    ``sample_rate_hz`` (or at the value of a constant column ``fs``, as some benchmark
    exports carry it). With both a ``force`` and a ``voltage`` column the force is the
    reference unless ``reference`` says ``voltage``; the other one is not a response.
    Trailing samples where every signal is exactly 0 (padding some exports add) are dropped."""
    columns = {str(name).strip().lower() if str(name).strip().lower() in _RESERVED + ("fs",) else str(name).strip():
               value for name, value in columns.items()}
    if columns and all(np.asarray(v).size == 0 for v in columns.values()):
        raise TimeHistoryError(f"{source}: no samples: the columns {sorted(columns)} hold no values (a header "
                               f"without data rows)")
    if sample_rate_hz is not None and not (math.isfinite(sample_rate_hz) and sample_rate_hz > 0):
        raise TimeHistoryError(f"{source}: sample rate {sample_rate_hz:g} Hz: expected a number > 0 (Hz)")
    if "time_s" not in columns:
        rate = sample_rate_hz
        if rate is None and "fs" in columns:
            rate = _fs_column(columns["fs"], source)
        if rate is None:
            raise TimeHistoryError(f"{source}: no 'time_s' column (sample times in s) and no sample rate (give "
                                   f"--sample-rate HZ); found {sorted(columns)}")
        columns["time_s"] = np.arange(len(next(iter(columns.values())))) / rate
    columns.pop("fs", None)
    present = [name for name in ("force", "voltage") if name in columns]
    if not present:
        raise TimeHistoryError(f"{source}: expected a reference column, 'force' (N) or 'voltage' (V); found "
                               f"neither among {sorted(columns)}")
    chosen = reference or present[0]
    if chosen not in present:
        raise TimeHistoryError(f"{source}: no '{chosen}' column to take as the reference; found {present}")
    for other in present:
        if other != chosen:
            columns.pop(other)
    numbers = {}
    for name, values in columns.items():
        array = np.asarray(values)
        if array.dtype == object or array.dtype.kind in "USb":
            raise TimeHistoryError(f"{source}: column '{name}' holds {array.dtype.kind == 'b' and 'booleans' or 'text'}; "
                                   f"expected numbers")
        array = array.astype(float).ravel()
        bad = np.flatnonzero(~np.isfinite(array))
        if bad.size:
            raise TimeHistoryError(f"{source}: column '{name}', sample {bad[0]}: {array[bad[0]]!r} is not a finite number")
        numbers[name] = array
    lengths = {name: v.size for name, v in numbers.items()}
    if len(set(lengths.values())) > 1:
        shown = ", ".join(f"'{name}' {size}" for name, size in lengths.items())
        raise TimeHistoryError(f"{source}: the columns differ in length ({shown} samples); expected one value per "
                               f"sample in every column")
    signals = np.vstack([v for name, v in numbers.items() if name != "time_s"])
    nonzero = np.flatnonzero(np.any(signals != 0, axis=0))
    end = int(nonzero[-1]) + 1 if nonzero.size else 0
    if end < signals.shape[1]:  # some exports pad records with zeros: drop the padding
        numbers = {name: v[:end] for name, v in numbers.items()}
    time = numbers["time_s"]
    if time.size < 16 or np.any(np.diff(time) <= 0):
        raise TimeHistoryError(f"{source}: 'time_s' must increase strictly over at least 16 samples")
    steps = np.diff(time)
    if np.ptp(steps) > 1e-6 * np.mean(steps):
        raise TimeHistoryError(f"{source}: 'time_s' is not evenly sampled (steps {steps.min():.6g}…{steps.max():.6g} s)")
    responses = {name: v for name, v in numbers.items() if name not in _RESERVED}
    if not responses:
        raise TimeHistoryError(f"{source}: no response column (one per response coordinate, named by its header)")
    for name in (chosen, *responses):
        if not np.any(numbers[name]):
            what = "the reference" if name == chosen else "the response"
            raise TimeHistoryError(f"{source}: column '{name}' ({what}) is 0 at every sample: nothing was recorded "
                                   f"on that channel; expected a measured signal")
    return TimeRecord(source, time, numbers[chosen], "N" if chosen == "force" else "V", responses,
                      numbers.get("frequency_hz"), numbers.get("level"))


def _fs_column(values: object, source: str) -> float:
    """The sample rate (Hz) a constant ``Fs`` column states; an error naming the column
    when it varies or is not a number > 0."""
    array = np.asarray(values)
    try:
        array = array.astype(float).ravel()
    except (TypeError, ValueError):
        raise TimeHistoryError(f"{source}: column 'Fs' (sample rate) holds text; expected one number > 0 in Hz, the "
                               f"same in every row") from None
    finite = array[np.isfinite(array)]
    if finite.size < array.size or np.ptp(array) != 0:
        shown = f"{finite.min():g}…{finite.max():g} Hz" if finite.size else "no finite value"
        raise TimeHistoryError(f"{source}: column 'Fs' (sample rate) varies ({shown}); expected one number > 0 in Hz, "
                               f"the same in every row (or a 'time_s' column, or --sample-rate HZ)")
    if not array[0] > 0:
        raise TimeHistoryError(f"{source}: column 'Fs' (sample rate) is {array[0]:g}; expected a number > 0 in Hz")
    return float(array[0])


def _uff_record(data: bytes, path: Path) -> TimeRecord:
    from nlupdate.core.measurement.uff import check_directions, name_from_node, uff_datasets

    indices, datasets = uff_datasets(data, path)
    records = [(i, d) for i, d in zip(indices, datasets) if d.get("func_type") == 1]
    if not records:
        raise TimeHistoryError(f"{path}: no time record (dataset 58, function type 1)")
    columns: dict[str, np.ndarray] = {}
    time = None
    for index, dataset in records:
        where = f"{path}, dataset {index}"
        check_directions(dataset, where)
        if dataset.get("abscissa_spec_data_type") not in (17, 0, 1):
            raise TimeHistoryError(f"{where}: abscissa specific data type {dataset.get('abscissa_spec_data_type')}; a "
                                   f"time record has 17 (time, s)")
        t = np.asarray(dataset["x"], dtype=float)
        if time is None:
            time = t
        elif t.size != time.size or not np.allclose(t, time, rtol=1e-9, atol=1e-12):
            raise TimeHistoryError(f"{where}: its time axis differs from the first record's")
        ordinate = dataset.get("ordinate_spec_data_type")
        label = str(dataset.get("ordinate_axis_units_lab", "") or "").strip()
        values = np.real(np.asarray(dataset["data"], dtype=complex))
        if ordinate in (9, 13) or label == "N":
            name = "force"
        elif label in ("V", "mV"):
            name, values = "voltage", values * (1e-3 if label == "mV" else 1.0)
        elif ordinate in (8, 11, 12):
            sign = -1.0 if dataset["rsp_dir"] < 0 else 1.0
            name, values = name_from_node(dataset["rsp_node"], dataset["rsp_dir"]), sign * values
        else:
            raise TimeHistoryError(f"{where}: ordinate specific data type {ordinate} (label {label!r}); expected a "
                                   f"force (13), a voltage (label 'V') or a response (8, 11, 12)")
        if name in columns:
            raise TimeHistoryError(f"{where}: a second '{name}' record")
        columns[name] = values
    return _record_from_columns({"time_s": time, **columns}, str(path))


def read_time_record(path: str | Path, sample_rate_hz: float | None = None, reference: str | None = None) -> TimeRecord:
    """A time record from CSV, parquet, UFF 58 (function type 1) or MATLAB (module
    docstring of :mod:`nlupdate.core.measurement.matfile`), read through the input gate;
    ``sample_rate_hz`` and ``reference`` as for :func:`_record_from_columns`."""
    path = Path(path)
    suffix = path.suffix.lower()
    data = read_input_bytes(path, "time-history file")
    kind = sniff(data[:4096])
    if kind == "binary" and data.lstrip(b"\r\n ").startswith(b"-1"):
        kind = "uff"
    if suffix == ".csv" and kind == "text":
        frame = csv_frame(data, path, "time-history file", TimeHistoryError)
        if len(frame.columns) == 1 and ";" in str(frame.columns[0]):
            raise TimeHistoryError(f"{path}: columns are separated by ';'; nlupdate reads comma-separated values with "
                                   f"'.' as the decimal point")
        return _record_from_columns({c: frame[c].to_numpy() for c in frame.columns}, str(path), sample_rate_hz,
                                    reference)
    if suffix == ".parquet" and kind == "parquet":
        check_parquet_size(data, path, "time-history file")
        try:
            frame = pd.read_parquet(io.BytesIO(data))
        except Exception as error:
            raise TimeHistoryError(f"{path}: not a readable parquet file ({error})") from None
        return _record_from_columns({c: frame[c].to_numpy() for c in frame.columns}, str(path), sample_rate_hz,
                                    reference)
    if suffix in (".uff", ".unv") and kind in ("uff", "text"):
        return _uff_record(data, path)
    if suffix == ".mat" and kind in ("mat5", "hdf5"):
        from nlupdate.core.measurement.matfile import mat_variables

        variables = mat_variables(data, path, kind, "time-history file")
        columns = {name: value for name, value in variables.items()
                   if isinstance(value, np.ndarray) and value.size > 1 and value.squeeze().ndim == 1}
        return _record_from_columns(columns, str(path), sample_rate_hz, reference)
    raise TimeHistoryError(f"{path}: a {suffix or 'suffix-less'} file holding {kind}; time histories are read from "
                           f".csv, .parquet, .uff/.unv (dataset 58, function type 1) or .mat")


# ------------------------------------------------------------------------------ estimation
def _harmonic_basis(t: NDArray, frequency_hz: float, harmonics: int) -> NDArray:
    w = 2 * np.pi * frequency_hz * t
    columns = [np.ones_like(t)]
    for h in range(1, harmonics + 1):
        columns += [np.cos(h * w), np.sin(h * w)]
    return np.column_stack(columns)


def _fit(basis: NDArray, signal: NDArray) -> tuple[NDArray, float]:
    """Least-squares coefficients and the residual variance."""
    coefficients, *_ = np.linalg.lstsq(basis, signal, rcond=None)
    residual = signal - basis @ coefficients
    return coefficients, float(residual @ residual / max(signal.size - basis.shape[1], 1))


def _phasors(coefficients: NDArray, harmonics: int) -> NDArray[np.complex128]:
    """X_h = c_h − i s_h for h = 1..harmonics (x = Σ Re(X_h e^{ihωt}))."""
    return np.array([coefficients[2 * h - 1] - 1j * coefficients[2 * h] for h in range(1, harmonics + 1)])


def _refined_frequency(t: NDArray, reference: NDArray, logged_hz: float) -> float:
    span = 2.0 / (t[-1] - t[0])  # two frequency bins of the dwell

    def misfit(f: float) -> float:
        return _fit(_harmonic_basis(t, f, 1), reference)[1]

    if not logged_hz > 0:
        return logged_hz
    result = scipy.optimize.minimize_scalar(misfit, bounds=(max(logged_hz - span, 1e-9), logged_hz + span),
                                            method="bounded", options={"xatol": 1e-9 * logged_hz})
    return float(result.x) if result.fun <= misfit(logged_hz) else logged_hz


def _settled_start(t: NDArray, x: NDArray, frequency_hz: float) -> tuple[int, bool | None]:
    """Index where the transient rule (module docstring) says the dwell is settled, and
    whether it settled before the last quarter (None: the dwell is shorter than
    :data:`MIN_SETTLE_PERIODS`, too short for the rule to tell; nothing is discarded)."""
    period_samples = max(int(round(1.0 / (frequency_hz * (t[1] - t[0])))), 1)
    periods = int(t.size // period_samples)
    per_block = max(4, int(math.ceil(periods / 16)))
    n_blocks = periods // per_block
    if n_blocks < 4:
        return 0, None
    size = per_block * period_samples
    values = []
    for b in range(n_blocks):
        span = slice(b * size, (b + 1) * size)
        coefficients, _ = _fit(_harmonic_basis(t[span], frequency_hz, 1), x[span])
        values.append(coefficients[1] - 1j * coefficients[2])
    values = np.asarray(values)
    tail = values[(3 * n_blocks) // 4:]
    steady, scatter = tail.mean(), np.abs(tail - tail.mean()).std() if tail.size > 1 else 0.0
    tolerance = max(3 * scatter, _SETTLE_TOLERANCE * abs(steady))
    outside = np.flatnonzero(np.abs(values - steady) > tolerance)
    first = int(outside[-1] + 1) if outside.size else 0
    before = values[n_blocks // 2: (3 * n_blocks) // 4]
    still_moving = before.size > 0 and abs(before.mean() - steady) > max(3 * scatter, _MOVING_TOLERANCE * abs(steady))
    return first * size, first <= (3 * n_blocks) // 4 and not still_moving


def _to_receptance(h: NDArray, frequency_hz: NDArray, power: int) -> NDArray:
    return h / (1j * 2 * np.pi * np.asarray(frequency_hz)) ** power if power else h


def _dwells(record: TimeRecord) -> list[tuple[slice, float, float | None]]:
    """(samples, logged frequency, logged level) of every dwell."""
    f = record.frequency_hz
    level = record.level if record.level is not None else np.zeros_like(f)
    change = np.flatnonzero((np.diff(f) != 0) | (np.diff(level) != 0)) + 1
    edges = np.concatenate([[0], change, [f.size]])
    return [(slice(a, b), float(f[a]), None if record.level is None else float(level[a]))
            for a, b in zip(edges[:-1], edges[1:]) if b - a >= 16 and f[a] > 0]


def _check_sample_rate(record: TimeRecord, logged_hz: float) -> None:
    """:class:`TimeHistoryError` unless harmonics 1 to :data:`_HARMONICS` of a dwell lie
    below the Nyquist frequency (above it the fit aliases; a time column in ms instead of s
    puts every dwell there)."""
    rate = 1.0 / float(record.time_s[1] - record.time_s[0])
    if _HARMONICS * logged_hz >= rate / 2:
        raise TimeHistoryError(f"{record.source}: the dwell at {logged_hz:g} Hz needs a sample rate above "
                               f"{2 * _HARMONICS * logged_hz:g} Hz (harmonics 1–{_HARMONICS} below the Nyquist "
                               f"frequency); 'time_s' gives {rate:.6g} Hz — are the times in seconds?")


def _distortion(phasors: NDArray[np.complex128]) -> float:
    """√Σ_{h≥2}|X_h|² / |X₁| (inf when the first harmonic is 0)."""
    first = abs(phasors[0])
    higher = float(np.sqrt(np.sum(np.abs(phasors[1:]) ** 2)))
    return higher / first if first > 0 else math.inf


def _check_reference_harmonic(record: TimeRecord, logged_hz: float, t: NDArray, force: NDArray,
                              first: complex) -> None:
    """:class:`TimeHistoryError` unless the reference's first harmonic at the dwell frequency
    carries at least :data:`REFERENCE_POWER_SHARE` of its (mean-free) power: a wrong logged
    frequency or sample rate puts the fit where the excitation is not."""
    where = f"{record.source}: the dwell at {logged_hz:g} Hz"
    varying = force - force.mean()
    power = float(np.mean(varying**2))
    if power == 0:
        raise TimeHistoryError(f"{where}: the reference is constant ({force.mean():g}) over the dwell: no excitation "
                               f"recorded; expected a sine at the dwell frequency")
    share = 0.5 * abs(first) ** 2 / power
    if share < REFERENCE_POWER_SHARE:
        spectrum = np.abs(np.fft.rfft(varying))
        spectrum[0] = 0.0
        dominant = float(np.fft.rfftfreq(varying.size, t[1] - t[0])[np.argmax(spectrum)])
        raise TimeHistoryError(
            f"{where}: the reference's first harmonic at that frequency carries {100 * share:.2g} % of its power "
            f"(expected ≥ {100 * REFERENCE_POWER_SHARE:g} %); the reference oscillates at about {dominant:.4g} Hz — "
            f"is the logged 'frequency_hz' or the sample rate wrong?")


def stepped_sine_frf(record: TimeRecord, power: int) -> tuple[list[dict], list[str]]:
    """Rows (one per dwell and response) of the stepped-sine estimate; notes."""
    rows, notes = [], []
    dwells = _dwells(record)
    for _, logged, _ in dwells:
        _check_sample_rate(record, logged)
    for span, logged, level in dwells:
        t, force = record.time_s[span], record.reference[span]
        frequency = _refined_frequency(t, force, logged)
        starts = [_settled_start(t, x[span], frequency) for x in record.responses.values()]
        start = max(s for s, _ in starts)
        if any(ok is None for _, ok in starts):
            periods = frequency * t.size * (t[1] - t[0])
            notes.append(f"{record.source}: the dwell at {logged:g} Hz lasts {periods:.3g} periods, fewer than the "
                         f"{MIN_SETTLE_PERIODS} periods the transient rule needs to tell whether it settled; its FRF "
                         f"may hold the transient (dwell several time constants 1/(ζω_r))")
        elif not all(ok for _, ok in starts):
            notes.append(f"{record.source}: the dwell at {logged:g} Hz had not settled before its last quarter; its "
                         f"FRF may hold the transient")
        t, force = t[start:], force[start:]
        basis = _harmonic_basis(t, frequency, _HARMONICS)
        f_coefficients, f_variance = _fit(basis, force)
        f_phasors = _phasors(f_coefficients, _HARMONICS)
        _check_reference_harmonic(record, logged, t, force, f_phasors[0])
        where = f"{record.source}: the dwell at {logged:g} Hz"
        if _distortion(f_phasors) > DISTORTION_LIMIT:
            notes.append(f"{where} left out: the reference's harmonic distortion is {100 * _distortion(f_phasors):.3g} %, "
                         f"above {100 * DISTORTION_LIMIT:g} %: its first harmonic does not describe the excitation")
            continue
        if _distortion(f_phasors) > DISTORTION_WARNING:
            notes.append(f"{where}: the reference's harmonic distortion is {100 * _distortion(f_phasors):.3g} % (above "
                         f"{100 * DISTORTION_WARNING:g} %): a clipped or saturated force or amplifier channel?")
        dwell_rows = []
        for name, signal in record.responses.items():
            x_coefficients, x_variance = _fit(basis, signal[span][start:])
            x_phasors = _phasors(x_coefficients, _HARMONICS)
            if not np.any(signal[span][start:]):
                raise TimeHistoryError(f"{where}: the response '{name}' is 0 at every sample of the dwell; expected a "
                                       f"measured signal")
            distortion = _distortion(x_phasors)
            if distortion > DISTORTION_LIMIT:
                notes.append(f"{where} left out: the harmonic distortion of '{name}' is {100 * distortion:.3g} %, above "
                             f"{100 * DISTORTION_LIMIT:g} %: its first harmonic does not describe the response")
                dwell_rows = None
                break
            if distortion > DISTORTION_WARNING:
                notes.append(f"{where}: the harmonic distortion of '{name}' is {100 * distortion:.3g} % (above "
                             f"{100 * DISTORTION_WARNING:g} %): the first-harmonic FRF describes the response only in "
                             f"part (a strong nonlinearity, or a clipped or saturated channel)")
            h = x_phasors[0] / f_phasors[0]
            relative = math.sqrt(4 * x_variance / (t.size * abs(x_phasors[0]) ** 2)
                                 + 4 * f_variance / (t.size * abs(f_phasors[0]) ** 2))
            dwell_rows.append({"frequency_hz": frequency, "response_dof": name, "h": h, "h_std": abs(h) * relative,
                               "level_achieved": abs(f_phasors[0]), "level_key": level,
                               "harmonic_distortion": distortion})
        rows += dwell_rows or []
    if dwells and not rows:
        raise TimeHistoryError(f"{record.source}: every dwell was left out, the first because {notes[-1].split(' left out: ')[-1]}")
    for row in rows:
        row["h"] = _to_receptance(row["h"], row["frequency_hz"], power)
        row["h_std"] = row["h_std"] / (2 * np.pi * row["frequency_hz"]) ** power
    return rows, notes


def _instantaneous_phase(t: NDArray, reference: NDArray) -> NDArray:
    import scipy.signal  # imported where used: it costs 0.3 s (it imports scipy.stats)

    analytic = scipy.signal.hilbert(reference - reference.mean())
    return np.unwrap(np.angle(analytic))


def sine_sweep_frf(record: TimeRecord, power: int, window_cycles: float = 10.0) -> tuple[list[dict], str, list[str]]:
    """Rows of the sweep estimate, the sweep direction and notes (module docstring)."""
    t, force = record.time_s, record.reference
    phase = _instantaneous_phase(t, force)
    rows = []
    fs = record.sample_rate_hz
    frequencies = []
    instantaneous = np.abs(np.gradient(phase, t)) / (2 * np.pi)
    smoothing = max(3, int(fs / max(np.median(instantaneous), 1e-9)))
    instantaneous = np.convolve(instantaneous, np.ones(smoothing) / smoothing, mode="same")
    centre = int(round(0.5 * window_cycles * fs / max(instantaneous[smoothing], 1e-9)))
    while centre < t.size:
        half = int(round(0.5 * window_cycles * fs / max(instantaneous[centre], 1e-9)))
        if half < 8 or centre + half > t.size:
            break
        span = slice(max(centre - half, 0), centre + half)
        tc = t[centre]
        dt = t[span] - tc
        quadratic = np.polyfit(dt, phase[span], 2)
        phi = np.polyval(quadratic, dt)
        frequency = quadratic[1] / (2 * np.pi)
        basis = np.column_stack([np.cos(phi), np.sin(phi), dt * np.cos(phi), dt * np.sin(phi), np.ones_like(dt)])
        f_coefficients, _ = _fit(basis, force[span])
        force_phasor = (f_coefficients[0] - 1j * f_coefficients[1]) * np.exp(1j * quadratic[2])
        for name, signal in record.responses.items():
            x_coefficients, _ = _fit(basis, signal[span])
            x_phasor = (x_coefficients[0] - 1j * x_coefficients[1]) * np.exp(1j * quadratic[2])
            rows.append({"frequency_hz": frequency, "response_dof": name,
                         "h": _to_receptance(x_phasor / force_phasor, frequency, power),
                         "level_achieved": abs(force_phasor), "level_key": None})
        frequencies.append(frequency)
        centre += max(half, 1)
    if len(frequencies) < 2:
        raise TimeHistoryError(f"{record.source}: the record is shorter than two windows of {window_cycles:g} cycles")
    direction = "up" if frequencies[-1] > frequencies[0] else "down"
    rate = abs(np.polyfit(t[: instantaneous.size], instantaneous, 1)[0])
    slowest = math.sqrt(rate / SWEEP_RATE_LIMIT)
    note = (f"{record.source}: sweep rate {rate:.3g} Hz/s ({direction}): the swept FRF is within 2 % of the stepped-sine "
            f"FRF only for modes with ζ·f_r ≥ {slowest:.3g} Hz (r ≤ {SWEEP_RATE_LIMIT:g}·(ζ f_r)²); a less damped or "
            f"lower mode is shifted and lowered in the sweep direction")
    return rows, direction, [note]


def random_frf(record: TimeRecord, power: int, resolution_hz: float | None = None) -> list[dict]:
    """Rows of the H1 estimate (module docstring)."""
    fs = record.sample_rate_hz
    n = record.time_s.size
    nperseg = 2 ** int(math.floor(math.log2(n / 8))) if resolution_hz is None else int(round(fs / resolution_hz))
    if nperseg < 16 or nperseg > n:
        raise TimeHistoryError(f"{record.source}: {n} samples are too few for an H1 estimate at that resolution "
                               f"(segments of {nperseg} samples)")
    import scipy.signal  # imported where used: it costs 0.3 s

    f, g_ff = scipy.signal.welch(record.reference, fs=fs, window="hann", nperseg=nperseg)
    segments = 1 + (n - nperseg) // (nperseg // 2)
    keep = f > 0
    rows = []
    for name, signal in record.responses.items():
        _, g_fx = scipy.signal.csd(record.reference, signal, fs=fs, window="hann", nperseg=nperseg)
        _, g_xx = scipy.signal.welch(signal, fs=fs, window="hann", nperseg=nperseg)
        h1 = g_fx / g_ff  # scipy's csd(x, y) is conj(X)·Y: G_fx with x(t) = Re(X e^{iωt})
        coherence = np.clip(np.abs(g_fx) ** 2 / (g_ff * g_xx), 0.0, 1.0)
        h_std = np.abs(h1) * np.sqrt((1 - coherence) / (np.maximum(coherence, 1e-12) * segments))
        h = _to_receptance(h1[keep], f[keep], power)
        for fk, hk, gk, sk in zip(f[keep], h, coherence[keep], h_std[keep] / (2 * np.pi * f[keep]) ** power):
            rows.append({"frequency_hz": fk, "response_dof": name, "h": hk, "coherence": gk, "averages": segments,
                         "h_std": sk, "level_key": None})
    return rows


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
    """The measured-FRF table of ``records`` (one or more files of one test; module docstring)."""
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


def csv_frame(data: bytes, path: Path, what: str, error: type[ValueError]) -> pd.DataFrame:
    """The table of a CSV file's bytes (decoded as :func:`decode_text` does); ``error`` with
    one line naming ``path`` when pandas cannot read it. Time histories and ring-down
    records share it."""
    text = decode_text(data, path, what)
    try:
        return pd.read_csv(io.StringIO(text))
    except (pd.errors.ParserError, pd.errors.EmptyDataError, ValueError) as problem:
        raise error(f"{path}: not a readable CSV file ({problem})") from None
