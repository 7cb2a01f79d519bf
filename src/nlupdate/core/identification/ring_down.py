"""Backbone samples of one mode from a free decay (ring-down): the Hilbert-transform method.

A structure set vibrating in one mode and let go decays along its backbone: at each
instant its envelope a(t) and phase θ(t) give the natural frequency and damping ratio at
that amplitude. From one channel's record ``(time_s, response)``:

1. the mean is removed (a slider that locks leaves an offset);
2. the mode's band [f_low, f_high] (given, or found from the spectrum: below) is isolated
   and made analytic in one step: the record is shifted down by the band's centre f_c
   (``x·e^{−2πi f_c t}``), low-passed by a Butterworth filter of ``order`` and cut-off
   (f_high − f_low)/2 run forward and back (``scipy.signal.sosfiltfilt``: zero phase, so
   the envelope and phase are not delayed), and shifted back, times 2: ``z = y + i·H[y]``
   with y the band-passed record. This is the Hilbert transform of the band-passed record
   (``scipy.signal.hilbert``) without its 1/t kernel: an FFT Hilbert transform of a
   record that starts large and ends small spreads the abrupt start over the whole record
   (as ≈ x(0)/(πω t)), which swamps the envelope where it has decayed by 10³;
3. ``|z|`` is the envelope and the unwrapped angle θ the phase;
4. ``ln|z|`` and θ are smoothed and differentiated by Savitzky–Golay filters (quadratic,
   over a window of ``periods`` × 2^k periods of the band's centre frequency, k = 0 …
   :data:`WINDOW_DOUBLINGS`): the decay rate ``σ = −d ln|z|/dt`` and the damped frequency
   ``ω_d = dθ/dt`` (rad/s). Each sample takes the shortest window that passes the checks
   below (a short window resolves a backbone that changes fast, a long one averages noise);
5. the natural frequency and damping ratio are those of the poles ``−σ ± iω_d``:
   ``ω = √(σ² + ω_d²)``, ``ζ = σ/ω`` — exact for a linear mode (its free decay is
   ``e^{−ζωt}cos(ω√(1−ζ²)t)``, and an LTI filter leaves ``e^{st}`` an exponential of the
   same s), and to first order the brief's ``ω = dθ/dt``, ``ζ = −(da/dt)/(a·ω)``;
6. the modal amplitude is ``a = |z|/|φ_r|`` (m·√kg) with φ_r the mass-normalised shape at
   the sensor (1/√kg); without a shape, a is in the response's units (``shape = 1``).

Trimming rule (stated, not tuned). The forward–backward filter's impulse response h,
computed from the designed filter (its length grows as the band narrows, ≈ order/bandwidth),
sets the end effects: the record's end is dropped over the lag after which |h| stays below
:data:`IMPULSE_FLOOR` (10⁻³) of its peak; the start, where a ring-down is largest, over the
lag after which the start's transient — |h| times the envelope at the start — stays below
that fraction of the envelope there (a fast decay needs a longer trim: the transient of the
large start outlives the signal). With a smoothing window of length T_w, another T_w/2 is
dropped at each end, as the smoothing's fits there are one-sided.

Noise. Samples whose envelope is below ``snr`` times the in-band noise are dropped: the
noise is estimated from what the band-pass removed, ``r = x − y``, taken white: its in-band
standard deviation is ``1.4826·MAD(r)·√(B/(f_N − B))`` (B the bandwidth, f_N the Nyquist
frequency; the median absolute deviation, so that the harmonics of the large start do not
count as noise over the whole record). The noise also sets how
well the decay rate is known: a straight-line fit of ``ln|z|`` over ``T_w`` with about
``B·T_w`` independent values, each of standard deviation ``noise/|z|``, has the slope's
standard error ``(noise/|z|)·√(12/(B·T_w))/T_w``; a window is used at a sample only where
that is at most ``damping_precision`` (default 2 %) of σ, where σ > 0 (decaying), and where
the window twice as long gives a σ within ``2·damping_precision`` of it and a natural
frequency within :data:`FREQUENCY_AGREEMENT` (5·10⁻⁴) of it (the backbone is resolved: the
frequency, far less noisy than σ, shows a window that straddles a sharp change such as a
joint sticking); samples no window passes are dropped.

Default band: the largest peak f_p of the Hann-windowed spectrum (the mean removed), and
half-width ``max(0.25 f_p, 3 w)`` where w is the peak's half-width at a tenth of its height
(a decaying mode's line is a Lorentzian of half-width σ/2π at half power; a backbone that
moves the frequency widens it). The band should be wide: the Butterworth low-pass is flat
only well inside its cut-off, and a frequency near a band edge is attenuated by an amount
that changes as it moves, which biases σ (an SDOF moving over 10.0–10.5 Hz: 1.9 % in ζ with
7.8–13 Hz, no sample passing the checks with 9.5–11 Hz). Another mode within that band
must be kept out with an explicit ``band_hz``.

Samples. :meth:`RingDownEstimate.samples` keeps samples a window apart (the estimates
within one window are not independent) as
:class:`~nlupdate.core.identification.modal_samples.ModalSamples` for the backbone fits
(``force_n`` is 0: a free decay has no force).

Limits (measured, tests/test_ring_down.py; SDOF at 10 Hz, ζ_lin = 0.5 %, joint stiffness
0.1 k). Noise-free, against the describing-function backbone below: an Iwan joint
(χ = −0.5, β = 0.5) within 0.004 % in frequency and 1.4 % in ζ over a factor 5 of
amplitude in microslip; a Jenkins joint within 0.04 % and 3.4 % in macroslip (amplitude
≥ 2.5 × its slip amplitude), but up to 10 % in ζ within [1, 2.5] × the slip amplitude. There
the record itself differs from the periodic motion the backbone describes (harmonic balance
with 15 harmonics lies on the closed form within 0.7 %): its own logarithmic decrement
(turning points one period apart) is up to 9 % above it — a free decay through stick–slip
dissipates more per cycle (tests/test_test_type_truth.py) — and differs from this estimate by
at most 2.3 % over 0.5–8.4 × the slip amplitude; the estimate does not
change with the window (½ to 2 periods) or the band (7.6–12.7 or 4–17 Hz), and its envelope
matches the turning points within 0.1 %. With noise, longer windows are taken; without the
frequency agreement they straddled that change (0.5 % noise: 26 % in ζ and 0.37 % in
frequency there), with it the Jenkins record with 0.5 % noise keeps 2.7–7.3 × the slip
amplitude, within 0.03 % and 4.2 % (3 seeds). White noise of 1 % of the initial amplitude
(1000 samples/s) leaves the Iwan record precise over a factor 1.9 of amplitude (ζ within
3.3–4.4 %, 3 seeds) and nothing of the Jenkins one; 2 % leaves nothing of either.

Reference. Averaging (Krylov–Bogoliubov) of ``m ẍ + c ẋ + k x + g = 0`` with g a
hysteretic or nonlinear force of describing function ν(A) (A the displacement amplitude)
gives the slow flow ``Ȧ = −(c ω + Im ν(A)) A/(2 m ω)``, ``θ̇ = ω(A)`` with
``ω(A)² = k/m + Re ν(A)/m``: the free decay follows the equivalent linear system
``m ẍ + (c + Im ν/ω) ẋ + (k + Re ν) x = 0``, whose natural frequency is ω(A) and damping ratio
``ζ(A) = c/(2 m ω(A)) + Im ν(A)/(2 m ω(A)²)``; the modal amplitude of an SDOF is ``a = A√m``
(φ = 1/√m). This is the modal Iwan model's backbone of :mod:`nlupdate.core.model.amplitude_modal`
(viscous linear damping). Feldman, *Hilbert transform applications in mechanical
vibration* (Wiley 2011, ch. 6: FREEVIB); Londoño, Neild & Cooper, "Identification of
backbone curves of nonlinear systems from resonance decay responses", J. Sound Vib. 348
(2015) 224–238.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import scipy.signal
from numpy.typing import ArrayLike, NDArray

from nlupdate.core.identification.modal_samples import ModalSamples
from nlupdate.core.measurement.frf_table import MeasurementTableError
from nlupdate.core.measurement.time_history import csv_frame
from nlupdate.input_files import read_input_bytes, sniff

#: the filter's impulse response counts as ended below this fraction of its peak
IMPULSE_FLOOR = 1e-3

#: largest relative difference of the natural frequency between a window and the one twice as long
FREQUENCY_AGREEMENT = 5e-4

#: the smoothing window is tried at ``periods`` × 2^k periods, k = 0 … this
WINDOW_DOUBLINGS = 4


class RingDownError(MeasurementTableError):
    """A ring-down record cannot be analysed as given (the message names the record and what is wrong)."""


@dataclass(frozen=True, eq=False)
class RingDownEstimate:
    """Envelope estimates of a ring-down after trimming, one per retained time sample.

    ``amplitude`` modal amplitude (m·√kg; response units when ``shape`` is 1 and not given),
    ``frequency_hz`` natural frequency, ``damping_ratio``; ``band_hz`` the band-pass band,
    ``trim_s`` the time (s) dropped at the (start, end) with the shortest window, ``window_s`` each
    sample's smoothing window (s), ``noise`` the in-band noise standard deviation (response
    units), ``shape`` |φ_r|."""

    time_s: NDArray[np.float64]
    amplitude: NDArray[np.float64]
    frequency_hz: NDArray[np.float64]
    damping_ratio: NDArray[np.float64]
    band_hz: tuple[float, float]
    trim_s: tuple[float, float]
    window_s: NDArray[np.float64]
    noise: float
    shape: float
    source: str = "<ring-down>"

    def samples(self) -> ModalSamples:
        """Samples a window apart (module docstring), largest amplitude first: from the first
        retained time, the next sample is the first at least its own window later."""
        if self.time_s.size == 0:
            raise RingDownError(f"{self.source}: no part of the decay is left after trimming {self.trim_s[0]:.3g} s at "
                                f"the start and {self.trim_s[1]:.3g} s at the end and dropping the envelope where the "
                                f"noise hides its decay: record a longer or less noisy decay, or give the band")
        keep, next_time = [], -np.inf
        for i, (time, window) in enumerate(zip(self.time_s, self.window_s)):
            if time >= next_time:
                keep.append(i)
                next_time = time + window
        keep = np.array(keep)
        return ModalSamples(self.amplitude[keep], self.frequency_hz[keep], self.damping_ratio[keep],
                            np.zeros(keep.size), self.shape)


def _uniform_rate(time_s: NDArray, source: str) -> float:
    steps = np.diff(time_s)
    if time_s.size < 16 or not np.all(np.isfinite(time_s)) or np.any(steps <= 0):
        raise RingDownError(f"{source}: time_s must hold 16 or more finite, increasing times (s)")
    dt = float(np.median(steps))
    if np.max(np.abs(steps - dt)) > 1e-3 * dt:
        raise RingDownError(f"{source}: time_s is not uniformly sampled (steps from {steps.min():.6g} to "
                            f"{steps.max():.6g} s); resample it at one rate")
    return 1.0 / dt


def default_band(response: NDArray, sample_rate_hz: float) -> tuple[float, float]:
    """The band around the spectrum's largest peak (module docstring), in Hz."""
    x = response - np.mean(response)
    spectrum = np.abs(np.fft.rfft(x * np.hanning(x.size), n=4 * x.size))
    f = np.fft.rfftfreq(4 * x.size, 1 / sample_rate_hz)
    spectrum[0] = 0.0
    peak = int(np.argmax(spectrum))
    below = np.nonzero(spectrum[:peak] < 0.1 * spectrum[peak])[0]
    above = np.nonzero(spectrum[peak:] < 0.1 * spectrum[peak])[0]
    low = f[below[-1]] if below.size else 0.0
    high = f[peak + above[0]] if above.size else f[-1]
    fp = float(f[peak])
    half = max(0.25 * fp, 3 * max(fp - low, high - fp))
    return max(fp - half, 0.02 * fp), min(fp + half, 0.95 * sample_rate_hz / 2)


def _filter_tail(sos: NDArray, length: int) -> NDArray[np.float64]:
    """The forward–backward filter's impulse response |h| at lags 0 … length−1 (samples),
    relative to its peak and made monotone (the largest |h| at that lag or beyond)."""
    impulse = np.zeros(2 * length + 1)
    impulse[length] = 1.0
    h = np.abs(scipy.signal.sosfiltfilt(sos, impulse))
    side = np.maximum(h[length:], h[length::-1])[:length] / h.max()
    return np.maximum.accumulate(side[::-1])[::-1]


def _trims(tail: NDArray, envelope: NDArray) -> tuple[int, int]:
    """Samples dropped at the (start, end) of the record (module docstring): the end while the
    tail is above :data:`IMPULSE_FLOOR`; the start while the start's transient, the tail
    scaled by the envelope at the start, is above that fraction of the envelope there."""
    end = int(np.argmax(tail <= IMPULSE_FLOOR)) if np.any(tail <= IMPULSE_FLOOR) else tail.size
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = tail * envelope[0] / envelope[: tail.size]
    loud = np.nonzero(~(ratio <= IMPULSE_FLOOR))[0]
    return (int(loud[-1]) + 1 if loud.size else 0), end


def analytic_band_pass(time_s: NDArray, x: NDArray, band_hz: tuple[float, float], sample_rate_hz: float,
                       order: int = 4) -> tuple[NDArray[np.complex128], NDArray]:
    """``(z, sos)``: the analytic signal of ``x`` band-passed to ``band_hz`` (module docstring,
    step 2: shifted down by the band's centre, low-passed forward and back by the Butterworth
    ``sos`` of ``order``, shifted back, times 2)."""
    low, high = band_hz
    sos = scipy.signal.butter(order, 0.5 * (high - low), btype="lowpass", fs=sample_rate_hz, output="sos")
    shift = np.exp(2j * np.pi * 0.5 * (low + high) * (time_s - time_s[0]))
    return 2 * scipy.signal.sosfiltfilt(sos, x / shift) * shift, sos


def estimate_ring_down(time_s: ArrayLike, response: ArrayLike, band_hz: tuple[float, float] | None = None,
                       shape: float | None = None, periods: float = 2.0, order: int = 4, snr: float = 20.0,
                       damping_precision: float = 0.02,
                       source: str = "<ring-down>") -> RingDownEstimate:
    """Envelope, natural frequency and damping ratio of a free decay (module docstring).

    ``time_s`` (s, uniform) and ``response`` (any unit: m, or m/s or m/s² for a mode whose
    frequency varies little — the envelope's units are the response's) of one channel;
    ``band_hz`` the mode's band (default: around the largest peak); ``shape`` |φ_r| (1/√kg)
    at the sensor; ``periods`` the smoothing window in periods of the band centre;
    ``order`` the Butterworth order; ``snr`` the envelope-to-noise ratio below which
    samples are dropped; ``damping_precision`` the largest standard error of the decay
    rate, relative, that the noise may cause in a retained sample (module docstring)."""
    t = np.asarray(time_s, dtype=float).ravel()
    x = np.asarray(response, dtype=float).ravel()
    if t.shape != x.shape:
        raise RingDownError(f"{source}: time_s has {t.size} values and the response {x.size}; expected one per time")
    if not np.all(np.isfinite(x)):
        raise RingDownError(f"{source}: the response holds NaN or infinite values; expected finite numbers")
    fs = _uniform_rate(t, source)
    if shape is not None and not (np.isfinite(shape) and shape != 0):
        raise RingDownError(f"{source}: shape {shape}: expected the finite, non-zero mass-normalised shape (1/√kg)")
    x = x - np.mean(x)
    if not np.any(x):
        raise RingDownError(f"{source}: the response is constant; a ring-down decays from a vibration")
    low, high = default_band(x, fs) if band_hz is None else (float(band_hz[0]), float(band_hz[1]))
    if not 0 < low < high < fs / 2:
        raise RingDownError(f"{source}: band {low:g}–{high:g} Hz: expected 0 < low < high < the Nyquist frequency "
                            f"{fs / 2:g} Hz")
    z, sos = analytic_band_pass(t, x, (low, high), fs, order)
    y = z.real
    envelope = np.abs(z)
    start, end = _trims(_filter_tail(sos, x.size), envelope)
    centre = np.sqrt(low * high)
    shortest = int(round(periods * fs / centre)) | 1
    if shortest < 5 or shortest > x.size:
        raise RingDownError(f"{source}: a smoothing window of {periods:g} periods at {centre:.4g} Hz is {shortest} "
                            f"samples; the record has {x.size}: expected 5 ≤ window ≤ the record")
    with np.errstate(divide="ignore"):
        log_a = np.log(envelope)
    log_a = np.where(np.isfinite(log_a), log_a, np.log(np.max(envelope)) - 700)
    theta = np.unwrap(np.angle(z))
    bandwidth = high - low
    residual = x - y
    noise = float(1.4826 * np.median(np.abs(residual - np.median(residual)))
                  * np.sqrt(bandwidth / max(fs / 2 - bandwidth, bandwidth)))
    # per sample, the shortest window whose noise leaves σ precise enough (module docstring)
    amplitudes, sigmas, omegas, lengths, goods = [], [], [], [], []
    for window in ((shortest - 1) * 2**k + 1 for k in range(WINDOW_DOUBLINGS + 1)):
        if window > x.size:
            break
        window_s = window / fs
        amplitude = np.exp(scipy.signal.savgol_filter(log_a, window, 2))
        sigma = -scipy.signal.savgol_filter(log_a, window, 2, deriv=1, delta=1 / fs)
        omega_d = scipy.signal.savgol_filter(theta, window, 2, deriv=1, delta=1 / fs)
        half = window // 2
        with np.errstate(divide="ignore", invalid="ignore"):
            sigma_error = noise / amplitude * np.sqrt(12 / (bandwidth * window_s)) / window_s
            inside = (np.arange(x.size) >= start + half) & (np.arange(x.size) < x.size - end - half)
            goods.append(inside & (amplitude >= snr * noise) & (sigma > 0)
                         & (sigma_error <= damping_precision * sigma))
        amplitudes.append(amplitude)
        sigmas.append(sigma)
        omegas.append(np.hypot(sigma, omega_d))
        lengths.append(window_s)
    # resolution: a window is used only where the window twice as long agrees with it
    chosen = np.full(x.size, -1)
    for k in range(len(lengths) - 1):
        with np.errstate(invalid="ignore"):
            resolved = ((np.abs(sigmas[k + 1] - sigmas[k]) <= 2 * damping_precision * sigmas[k])
                        & (np.abs(omegas[k + 1] - omegas[k]) <= FREQUENCY_AGREEMENT * omegas[k]))
        chosen = np.where((chosen < 0) & goods[k] & goods[k + 1] & resolved, k, chosen)
    keep = np.nonzero(chosen >= 0)[0]
    pick = chosen[keep]
    amplitude, sigma, omega = (np.asarray(v)[pick, keep] for v in (amplitudes, sigmas, omegas))
    phi = 1.0 if shape is None else abs(float(shape))
    return RingDownEstimate(t[keep], amplitude / phi, omega / (2 * np.pi), sigma / omega, (float(low), float(high)),
                            ((start + shortest // 2) / fs, (end + shortest // 2) / fs), np.asarray(lengths)[pick],
                            noise, phi, source)


# ------------------------------------------------------------------------------ reading
@dataclass(frozen=True)
class RingDownRecord:
    """One channel of a ring-down file: ``time_s`` (s) and ``response``."""

    source: str
    channel: str
    time_s: NDArray[np.float64]
    response: NDArray[np.float64]


def _pick_channel(columns: dict[str, NDArray], channel: str | None, path: Path) -> RingDownRecord:
    if "time_s" not in columns:
        raise RingDownError(f"{path}: no 'time_s' column/variable; a ring-down record holds time_s (s) and one column "
                            f"per channel")
    time_s = np.asarray(columns["time_s"], dtype=float).ravel()
    channels = [name for name in columns if name != "time_s"]
    if not channels:
        raise RingDownError(f"{path}: holds time_s only; expected one column per response channel beside it")
    if channel is None:
        if len(channels) > 1:
            raise RingDownError(f"{path}: holds channels {channels}; choose one with --channel NAME (in a study, "
                                f"the reading table's channel)")
        channel = channels[0]
    if channel not in channels:
        raise RingDownError(f"{path}: no channel {channel!r}; it holds {channels}")
    try:
        values = np.asarray(columns[channel], dtype=float).ravel()
    except (TypeError, ValueError):
        raise RingDownError(f"{path}: channel {channel!r} is not numeric; expected the response at each time") from None
    if values.size != time_s.size:
        raise RingDownError(f"{path}: channel {channel!r} has {values.size} values and time_s {time_s.size}; expected "
                            f"one per time")
    return RingDownRecord(str(path), channel, time_s, values)


def read_channels(path: str | Path, what: str = "ring-down file") -> dict[str, NDArray[np.float64]]:
    """The columns of a time record, read through the input gate: a CSV file (``time_s`` and
    one numeric column per channel) or a MATLAB file (v5 or v7.3: vector variables ``time_s``
    and one per channel, at the top level or in the only struct; ``time`` stands for
    ``time_s`` when a text variable ``units`` starts with ``s``, as in the Brake–Reuss beam's
    ``HammerImpact.mat``: ``'s, m/s^2'``) or a universal file (``.uff``/``.unv``: datasets 58
    of function type 1, time records, as test systems export them; a response is named
    ``NODE:DIR`` and the hammer's record ``force``:
    :func:`~nlupdate.core.measurement.time_history.records.uff_time_columns`)."""
    path = Path(path)
    data = read_input_bytes(path, what)
    kind = sniff(data[:4096])
    if kind == "binary" and data.lstrip(b"\r\n ").startswith(b"-1"):
        kind = "uff"  # binary datasets 58 (58b)
    suffix = path.suffix.lower()
    if suffix == ".csv" and kind == "text":
        frame = csv_frame(data, path, what, RingDownError)
        frame.columns = [str(c).strip() for c in frame.columns]
        for name in frame.columns:
            if not pd.api.types.is_numeric_dtype(frame[name]):
                raise RingDownError(f"{path}: column {name!r} is not numeric; expected time_s and one number per "
                                    f"channel on every row")
        return {c: frame[c].to_numpy(dtype=float) for c in frame.columns}
    if suffix == ".mat" and kind in ("mat5", "hdf5"):
        from nlupdate.core.measurement.matfile import mat_variables

        variables = mat_variables(data, path, kind, what)
        columns = {name: value for name, value in variables.items()
                   if isinstance(value, np.ndarray) and value.size > 1 and value.squeeze().ndim == 1
                   and np.issubdtype(value.dtype, np.number)}
        units = variables.get("units")
        if "time_s" not in columns and "time" in columns and isinstance(units, str) \
                and units.split(",")[0].strip() == "s":
            columns = {"time_s": columns.pop("time"), **columns}
        return columns
    if suffix in (".uff", ".unv") and kind in ("uff", "text"):
        from nlupdate.core.measurement.time_history.records import uff_time_columns

        return uff_time_columns(data, path)
    raise RingDownError(f"{path}: a {suffix or 'suffix-less'} file holding {kind}; {what}s are read from .csv "
                        f"(time_s and one column per channel), .mat or .uff/.unv (dataset 58, function type 1)")


def read_ring_down(path: str | Path, channel: str | None = None) -> RingDownRecord:
    """One channel of a ring-down record (:func:`read_channels`); ``channel`` names it when
    there are several."""
    return _pick_channel(read_channels(path), channel, Path(path))

