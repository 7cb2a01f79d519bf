"""The least-squares harmonic fit of a dwell, its transient rule and its checks.

Conventions: ``x(t) = Re(X e^{iωt})`` for every harmonic, H = X/F.

**Transient rule**: the dwell is cut into blocks of whole periods (at least 4 periods, at
most 16 blocks), the response's first harmonic is fitted in each; the steady value is the
mean of the blocks of the last quarter of the dwell, with scatter s; the transient ends at
the first block after which every block lies within ``max(3 s, 2e-3·|steady|)`` of the
steady value, and everything before it is discarded. A dwell whose transient had not
settled before its last quarter, or whose third quarter differs from its last by more than
``max(3 s, 1 %)`` (still moving), is flagged, and so is a dwell shorter than 16 periods
(:data:`MIN_SETTLE_PERIODS`: too few blocks for the rule to tell; nothing is discarded).

**Checks**: a record whose sample rate puts harmonic 3 of a dwell at or above the Nyquist
frequency is refused (the fit would alias; a time column in ms instead of s does that); the
reference's first harmonic must carry at least half its power
(:data:`REFERENCE_POWER_SHARE`; else the logged frequency or the sample rate is wrong and the
record is refused, naming the frequency the reference does oscillate at); the harmonic
distortion ``√Σ_{h=2,3}|X_h|² / |X₁|`` is compared with :data:`DISTORTION_WARNING` and
:data:`DISTORTION_LIMIT` by the stepped-sine estimator.
"""
from __future__ import annotations

import math

import numpy as np
import scipy.optimize
from numpy.typing import NDArray

from nlupdate.core.measurement.time_history.records import TimeHistoryError, TimeRecord

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
#: the harmonics fitted per dwell (1 to HARMONICS, with the DC term)
HARMONICS = 3


def harmonic_basis(t: NDArray, frequency_hz: float, harmonics: int) -> NDArray:
    """Columns 1, cos hωt, sin hωt (h = 1..harmonics) at the times ``t`` (s)."""
    w = 2 * np.pi * frequency_hz * t
    columns = [np.ones_like(t)]
    for h in range(1, harmonics + 1):
        columns += [np.cos(h * w), np.sin(h * w)]
    return np.column_stack(columns)


def fit_least_squares(basis: NDArray, signal: NDArray) -> tuple[NDArray, float]:
    """Least-squares coefficients and the residual variance."""
    coefficients, *_ = np.linalg.lstsq(basis, signal, rcond=None)
    residual = signal - basis @ coefficients
    return coefficients, float(residual @ residual / max(signal.size - basis.shape[1], 1))


def phasors_of(coefficients: NDArray, harmonics: int) -> NDArray[np.complex128]:
    """X_h = c_h − i s_h for h = 1..harmonics (x = Σ Re(X_h e^{ihωt}))."""
    return np.array([coefficients[2 * h - 1] - 1j * coefficients[2 * h] for h in range(1, harmonics + 1)])


def refined_frequency(t: NDArray, reference: NDArray, logged_hz: float) -> float:
    """The reference's frequency (Hz) refined by least squares within ±2 frequency bins of the logged one."""
    span = 2.0 / (t[-1] - t[0])  # two frequency bins of the dwell

    def misfit(f: float) -> float:
        return fit_least_squares(harmonic_basis(t, f, 1), reference)[1]

    if not logged_hz > 0:
        return logged_hz
    result = scipy.optimize.minimize_scalar(misfit, bounds=(max(logged_hz - span, 1e-9), logged_hz + span),
                                            method="bounded", options={"xatol": 1e-9 * logged_hz})
    return float(result.x) if result.fun <= misfit(logged_hz) else logged_hz


def settled_start(t: NDArray, x: NDArray, frequency_hz: float) -> tuple[int, bool | None]:
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
        coefficients, _ = fit_least_squares(harmonic_basis(t[span], frequency_hz, 1), x[span])
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


def to_receptance(h: NDArray, frequency_hz: NDArray, power: int) -> NDArray:
    """``h`` divided by (iω)^power: mobility (1) or accelerance (2) to receptance."""
    return h / (1j * 2 * np.pi * np.asarray(frequency_hz)) ** power if power else h


def check_sample_rate(record: TimeRecord, logged_hz: float) -> None:
    """:class:`TimeHistoryError` unless harmonics 1 to :data:`HARMONICS` of a dwell lie
    below the Nyquist frequency (above it the fit aliases; a time column in ms instead of s
    puts every dwell there)."""
    rate = 1.0 / float(record.time_s[1] - record.time_s[0])
    if HARMONICS * logged_hz >= rate / 2:
        raise TimeHistoryError(f"{record.source}: the dwell at {logged_hz:g} Hz needs a sample rate above "
                               f"{2 * HARMONICS * logged_hz:g} Hz (harmonics 1–{HARMONICS} below the Nyquist "
                               f"frequency); 'time_s' gives {rate:.6g} Hz — are the times in seconds?")


def distortion_of(phasors: NDArray[np.complex128]) -> float:
    """√Σ_{h≥2}|X_h|² / |X₁| (inf when the first harmonic is 0)."""
    first = abs(phasors[0])
    higher = float(np.sqrt(np.sum(np.abs(phasors[1:]) ** 2)))
    return higher / first if first > 0 else math.inf


def check_reference_harmonic(record: TimeRecord, logged_hz: float, t: NDArray, force: NDArray,
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

