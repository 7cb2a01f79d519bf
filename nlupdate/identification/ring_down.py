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
   over a window of ``periods`` periods of the band's centre frequency): the decay rate
   ``σ = −d ln|z|/dt`` and the damped frequency ``ω_d = dθ/dt`` (rad/s);
5. the natural frequency and damping ratio are those of the poles ``−σ ± iω_d``:
   ``ω = √(σ² + ω_d²)``, ``ζ = σ/ω`` — exact for a linear mode (its free decay is
   ``e^{−ζωt}cos(ω√(1−ζ²)t)``, and an LTI filter leaves ``e^{st}`` an exponential of the
   same s), and to first order the brief's ``ω = dθ/dt``, ``ζ = −(da/dt)/(a·ω)``;
6. the modal amplitude is ``a = |z|/|φ_r|`` (m·√kg) with φ_r the mass-normalised shape at
   the sensor (1/√kg); without a shape, a is in the response's units (``shape = 1``).

Trimming rule (stated, not tuned). The record's two ends are dropped over
``t_trim = t_filter + t_window/2``: ``t_filter`` is the half-length of the forward–backward
filter's impulse response, the time from its peak after which it stays below 10⁻³ of that
peak (computed from the designed filter, so it grows as the band narrows, ≈ order/bandwidth),
and ``t_window`` the smoothing window (its edge fits are one-sided). The Hilbert transform's
own end effects lie within the same span. Samples whose envelope is below ``snr`` times
the in-band noise are dropped too: the noise is estimated from what the band-pass removed,
``x − y``, taken white: its in-band standard deviation is ``std(x − y)·√(B/(f_N − B))``
(B the bandwidth, f_N the Nyquist frequency; harmonics of the response count as noise,
which errs on the safe side). The noise also sets how well the decay rate is known: a
straight-line fit of ``ln|z|`` over the window ``T_w`` with about ``B·T_w`` independent
values, each of standard deviation ``noise/|z|``, has the slope's standard error
``(noise/|z|)·√(12/(B·T_w))/T_w``; samples where it exceeds ``damping_precision`` (default
5 %) of σ are dropped, as are samples with ``σ ≤ 0`` (not decaying).

Default band: the largest peak f_p of the Hann-windowed spectrum (the mean removed), and
half-width ``max(0.25 f_p, 3 w)`` where w is the peak's half-width at a tenth of its height
(a decaying mode's line is a Lorentzian of half-width σ/2π at half power; a backbone that
moves the frequency widens it). Another mode within that band must be kept out with an
explicit ``band_hz``.

Samples. :meth:`RingDownEstimate.samples` keeps one sample per smoothing window (the
estimates within one window are not independent) as
:class:`~nlupdate.identification.amplitude_modal_fit.ModalSamples` for the backbone fits
(``force_n`` is 0: a free decay has no force).

Reference. Averaging (Krylov–Bogoliubov) of ``m ẍ + c ẋ + k x + g = 0`` with g a
hysteretic or nonlinear force of describing function ν(A) (A the displacement amplitude)
gives the slow flow ``Ȧ = −(c ω + Im ν(A)) A/(2 m ω)``, ``θ̇ = ω(A)`` with
``ω(A)² = k/m + Re ν(A)/m``: the free decay follows the equivalent linear system
``m ẍ + (c + Im ν/ω) ẋ + (k + Re ν) x = 0``, whose natural frequency is ω(A) and damping ratio
``ζ(A) = c/(2 m ω(A)) + Im ν(A)/(2 m ω(A)²)``; the modal amplitude of an SDOF is ``a = A√m``
(φ = 1/√m). This is the modal Iwan model's backbone of :mod:`nlupdate.model.amplitude_modal`
(viscous linear damping). Feldman, *Hilbert transform applications in mechanical
vibration* (Wiley 2011, ch. 6: FREEVIB); Londoño, Neild & Cooper, "Identification of
backbone curves of nonlinear systems from resonance decay responses", J. Sound Vib. 348
(2015) 224–238.
"""
from __future__ import annotations

import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import scipy.signal
from numpy.typing import ArrayLike, NDArray

from nlupdate.identification.amplitude_modal_fit import ModalSamples
from nlupdate.input_files import decode_text, read_input_bytes, sniff
from nlupdate.measurement.frf_table import MeasurementTableError

#: the filter's impulse response counts as ended below this fraction of its peak
IMPULSE_FLOOR = 1e-3


class RingDownError(MeasurementTableError):
    """A ring-down record cannot be analysed as given (the message names the record and what is wrong)."""


@dataclass(frozen=True, eq=False)
class RingDownEstimate:
    """Envelope estimates of a ring-down after trimming, one per retained time sample.

    ``amplitude`` modal amplitude (m·√kg; response units when ``shape`` is 1 and not given),
    ``frequency_hz`` natural frequency, ``damping_ratio``; ``band_hz`` the band-pass band,
    ``trim_s`` the time dropped at each end, ``window_s`` the smoothing window,
    ``noise`` the in-band noise standard deviation (response units), ``shape`` |φ_r|."""

    time_s: NDArray[np.float64]
    amplitude: NDArray[np.float64]
    frequency_hz: NDArray[np.float64]
    damping_ratio: NDArray[np.float64]
    band_hz: tuple[float, float]
    trim_s: float
    window_s: float
    noise: float
    shape: float
    source: str = "<ring-down>"

    def samples(self) -> ModalSamples:
        """One sample per smoothing window (module docstring), largest amplitude first."""
        if self.time_s.size == 0:
            raise RingDownError(f"{self.source}: no part of the decay is left after trimming {self.trim_s:.3g} s at each "
                                f"end and dropping the envelope below the noise: record a longer decay or widen the band")
        step = max(1, int(round(self.window_s / np.median(np.diff(self.time_s)))) if self.time_s.size > 1 else 1)
        keep = np.arange(0, self.time_s.size, step)
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


def _filter_half_length(sos: NDArray, sample_rate_hz: float, limit: int) -> float:
    """Time (s) after which the forward–backward impulse response stays below
    :data:`IMPULSE_FLOOR` of its peak."""
    n = 2 * limit + 1
    impulse = np.zeros(n)
    impulse[limit] = 1.0
    h = np.abs(scipy.signal.sosfiltfilt(sos, impulse))
    above = np.nonzero(h > IMPULSE_FLOOR * h.max())[0]
    return float(max(above[-1] - limit, limit - above[0]) / sample_rate_hz)


def estimate_ring_down(time_s: ArrayLike, response: ArrayLike, band_hz: tuple[float, float] | None = None,
                       shape: float | None = None, periods: float = 5.0, order: int = 4, snr: float = 20.0,
                       damping_precision: float = 0.05,
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
    # the analytic band-pass: x shifted down by the band's centre, low-passed (zero phase), shifted back
    middle = 0.5 * (low + high)
    sos = scipy.signal.butter(order, 0.5 * (high - low), btype="lowpass", fs=fs, output="sos")
    shift = np.exp(2j * np.pi * middle * (t - t[0]))
    z = 2 * scipy.signal.sosfiltfilt(sos, x / shift) * shift
    y = z.real
    envelope = np.abs(z)
    centre = np.sqrt(low * high)
    window = int(round(periods * fs / centre)) | 1
    if window < 5 or window > x.size:
        raise RingDownError(f"{source}: a smoothing window of {periods:g} periods at {centre:.4g} Hz is {window} samples; "
                            f"the record has {x.size}: expected 5 ≤ window ≤ the record")
    dt = 1 / fs
    with np.errstate(divide="ignore"):
        log_a = np.log(envelope)
    log_a = np.where(np.isfinite(log_a), log_a, np.log(np.max(envelope)) - 700)
    theta = np.unwrap(np.angle(z))
    smooth_log = scipy.signal.savgol_filter(log_a, window, 2)
    sigma = -scipy.signal.savgol_filter(log_a, window, 2, deriv=1, delta=dt)
    omega_d = scipy.signal.savgol_filter(theta, window, 2, deriv=1, delta=dt)
    omega = np.hypot(sigma, omega_d)
    trim = _filter_half_length(sos, fs, x.size) + window / 2 / fs
    bandwidth = high - low
    residual = x - y
    noise = float(1.4826 * np.median(np.abs(residual - np.median(residual))) * np.sqrt(bandwidth / max(fs / 2 - bandwidth, bandwidth)))
    amplitude = np.exp(smooth_log)
    window_s = window / fs
    with np.errstate(divide="ignore", invalid="ignore"):
        sigma_error = noise / amplitude * np.sqrt(12 / (bandwidth * window_s)) / window_s
        precise = sigma_error <= damping_precision * sigma
    keep = (t >= t[0] + trim) & (t <= t[-1] - trim) & (amplitude >= snr * noise) & (sigma > 0) & precise
    phi = 1.0 if shape is None else abs(float(shape))
    return RingDownEstimate(t[keep], amplitude[keep] / phi, omega[keep] / (2 * np.pi), sigma[keep] / omega[keep],
                            (float(low), float(high)), float(trim), window_s, noise, phi, source)


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
            raise RingDownError(f"{path}: holds channels {channels}; choose one with --channel NAME")
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


def read_ring_down(path: str | Path, channel: str | None = None) -> RingDownRecord:
    """One channel of a ring-down record, read through the input gate: a CSV file (``time_s``
    and one numeric column per channel) or a MATLAB file (v5 or v7.3: vector variables
    ``time_s`` and one per channel, at the top level or in the only struct); ``channel``
    names it when there are several."""
    path = Path(path)
    data = read_input_bytes(path, "ring-down file")
    kind = sniff(data[:4096])
    suffix = path.suffix.lower()
    if suffix == ".csv" and kind == "text":
        text = decode_text(data, path, "ring-down file")
        try:
            frame = pd.read_csv(io.StringIO(text))
        except (pd.errors.ParserError, pd.errors.EmptyDataError, ValueError) as error:
            raise RingDownError(f"{path}: not a readable CSV file ({error})") from None
        frame.columns = [str(c).strip() for c in frame.columns]
        for name in frame.columns:
            if not pd.api.types.is_numeric_dtype(frame[name]):
                raise RingDownError(f"{path}: column {name!r} is not numeric; expected time_s and one number per "
                                    f"channel on every row")
        return _pick_channel({c: frame[c].to_numpy(dtype=float) for c in frame.columns}, channel, path)
    if suffix == ".mat" and kind in ("mat5", "hdf5"):
        from nlupdate.measurement.matfile import mat_variables

        variables = mat_variables(data, path, kind, "ring-down file")
        columns = {name: value for name, value in variables.items()
                   if isinstance(value, np.ndarray) and value.size > 1 and value.squeeze().ndim == 1
                   and np.issubdtype(value.dtype, np.number)}
        return _pick_channel(columns, channel, path)
    raise RingDownError(f"{path}: a {suffix or 'suffix-less'} file holding {kind}; ring-downs are read from .csv "
                        f"(time_s and one column per channel) or .mat")


# ------------------------------------------------------------------------------ samples of several sources
def join_samples(parts: list[ModalSamples]) -> ModalSamples:
    """One set of samples from several sources at the same modal-amplitude scale (each with
    its shape given: FRF samples whose shape is to be fitted cannot join others)."""
    if any(p.shape_free for p in parts):
        raise RingDownError("joining FRF samples with ring-down samples needs the mode shape at the excited coordinate "
                            "(--shape NAME=VALUE): without it their modal amplitudes have no common scale")
    if len(parts) == 1:
        return parts[0]
    return ModalSamples(np.concatenate([p.amplitude for p in parts]), np.concatenate([p.frequency_hz for p in parts]),
                        np.concatenate([p.damping_ratio for p in parts]), np.concatenate([p.force_n for p in parts]),
                        parts[0].input_shape)


def backbone_points(parts: list[tuple[str, ModalSamples]]) -> pd.DataFrame:
    """Every source's samples, one row each: ``source``, ``modal_amplitude`` (m·√kg),
    ``natural_frequency_hz``, ``damping_ratio``."""
    return pd.concat([pd.DataFrame({"source": name, "modal_amplitude": s.amplitude,
                                    "natural_frequency_hz": s.frequency_hz, "damping_ratio": s.damping_ratio})
                      for name, s in parts], ignore_index=True)


def backbone_curve(model, samples: ModalSamples, count: int = 50) -> pd.DataFrame:
    """The fitted model's backbone at ``count`` modal amplitudes spaced geometrically over the
    samples' range: ``modal_amplitude``, ``natural_frequency_hz``, ``damping_ratio`` and their
    band columns ``*_low``/``*_high``. The backbone fits carry no covariance, so the band columns
    are NaN (not estimated) rather than a guess."""
    a = np.geomspace(float(samples.amplitude.min()), float(samples.amplitude.max()), count)
    f, z = model.frequency_hz(a), model.damping(a)
    nan = np.full(a.size, np.nan)
    return pd.DataFrame({"modal_amplitude": a, "natural_frequency_hz": f, "natural_frequency_hz_low": nan,
                         "natural_frequency_hz_high": nan, "damping_ratio": z, "damping_ratio_low": nan,
                         "damping_ratio_high": nan})
