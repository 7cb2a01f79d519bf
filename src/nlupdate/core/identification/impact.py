"""The linear limit of one mode from an impact or a low-level free decay: a least-squares
complex exponential (LSCE) fit.

After a hammer impact (or any low-level excitation that stops) the structure decays freely;
at low amplitude the mode is linear, and its record is a sum of decaying exponentials whose
poles give the natural frequency and damping ratio of the linear limit. From the channels of
one record (``time_s`` and one column per response; a channel named ``force`` or ``force_n``
is the hammer's):

1. each response channel, its mean removed, is made analytic and band-passed to the mode's
   band by :func:`~nlupdate.core.identification.ring_down.analytic_band_pass` (the band
   given, or around the largest peak of the first channel) and shifted down to baseband,
   ``u = z·e^{−2πi f_c t}``: one exponential ``e^{(s − 2πi f_c)t}`` per mode in the band, only
   its positive-frequency pole;
2. the filter's end effects are trimmed by the ring-down rule (docs/ring-down.md); with a
   force channel the fit starts after the impact, where the force has fallen below 1 % of
   its peak for good; the fit ends where the envelope falls below ``snr`` (20) times the
   in-band noise (estimated as for a ring-down);
3. **the linear limit**: a joint makes the decay amplitude-dependent, so only the quietest
   part of the record is fitted — where the envelope of the first channel is at most
   ``span`` (3) times its value at the fit's end — and the sample is placed at that part's
   mean amplitude weighted by the squared envelope, ``Σa³/Σa²`` (the least squares of step 4
   weigh each step's decay by |u|²): the lowest-amplitude point of the backbone the record
   gives. A truly linear record gives the same pole from any part;
4. the baseband signals are taken every Δ = 1/B (B the bandwidth: the band-passed noise is
   then about independent from one value to the next) and fitted jointly (one set of poles
   for all channels) by linear prediction of order p (default 1: the band-passed analytic
   signal holds the one mode; a higher order takes noise or a second mode in the band, but on
   a decay whose frequency drifts, as a joint's does, it splits the drift between two poles),
   ``u_{n+p} + Σ_{j<p} α_j u_{n+j} = 0`` in least squares; the
   roots λ of ``λ^p + Σ α_j λ^j`` are ``e^{(s − 2πi f_c)Δ}``. The mode's pole is the decaying
   one that carries most of the fitted signal (amplitudes c_r of ``u_n = Σ c_r λ_r^n`` by
   least squares over all channels; energy ``Σ|c_r|²|λ_r|^{2n}``): the extra poles take
   noise and whatever else is in the band; ``ω = |s|``, ``ζ = −Re s/|s|``;
   The noise in the regressors biases ζ up (errors in variables): three-channel records with
   white noise of 2 % of each channel's peak gave ζ 0.4–8.6 % high (8 seeds; stated standard
   error 19 %, conservative: the band-passed noise is not quite independent a 1/B apart);
   0.5 % gave 0.3–5.9 % (stated 10 %): the fit ends where the envelope reaches 20 × the noise,
   so a noisier record is fitted over a shorter decay. Compensating the normal equations by the estimated noise overshot
   (−0.2 … −10 %), as the noise estimate also holds the other modes outside the band;
5. standard errors: the least-squares covariance ``σ²(AᴴA)⁻¹`` of α (σ² from the residual)
   carried to the root by ``dλ = −Σ_j λ^j dα_j / P'(λ)`` and on to f and ζ.

Reference: D. L. Brown, R. J. Allemang, R. Zimmerman, M. Mergeay, "Parameter estimation
techniques for modal analysis", SAE Technical Paper 790221 (1979); N. M. M. Maia, J. M. M.
Silva (eds.), *Theoretical and Experimental Modal Analysis*, Research Studies Press 1997,
§4.4 (the complex exponential method). sdypy-EMA's LSCF was considered: it imports
matplotlib.pyplot and tqdm at import time and picks poles from a stabilisation chart, for a
fit of one mode's pole.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.identification.amplitude_modal_fit import ModalSamples
from nlupdate.core.identification.ring_down import (
    RingDownError, _filter_tail, _trims, _uniform_rate, analytic_band_pass, default_band,
)

FORCE_CHANNELS = ("force", "force_n")
#: the impact is over once the force stays below this fraction of its peak
FORCE_END = 0.01


@dataclass(frozen=True)
class LinearLimit:
    """One mode's pole from a free decay: natural frequency (Hz), damping ratio and their
    standard errors; ``amplitude`` the envelope of the fitted part, mean weighted by its square (modal,
    m·√kg, or the response's units without a shape) and its range ``amplitude_range``;
    ``window_s`` the fitted part (s); ``band_hz``; ``channels`` fitted; ``order`` p; ``shape``
    |φ| (1/√kg) at the first channel (1 when not given)."""

    frequency_hz: float
    damping_ratio: float
    frequency_std_hz: float
    damping_std: float
    amplitude: float
    amplitude_range: tuple[float, float]
    window_s: tuple[float, float]
    band_hz: tuple[float, float]
    channels: tuple[str, ...]
    order: int
    source: str = "<impact>"
    shape: float = 1.0

    def samples(self) -> ModalSamples:
        """The linear limit as one backbone sample (no force; ``input_shape`` the |φ| given)."""
        return ModalSamples(np.array([self.amplitude]), np.array([self.frequency_hz]), np.array([self.damping_ratio]),
                            np.zeros(1), self.shape)


def _lsce(signals: list[NDArray], order: int) -> tuple[NDArray, NDArray, NDArray]:
    """(roots λ, coefficients α, covariance of α) of the joint linear prediction (module docstring, 4)."""
    rows, rhs = [], []
    for u in signals:
        n = u.size - order
        rows.append(np.column_stack([u[j:j + n] for j in range(order)]))
        rhs.append(-u[order:])
    a, b = np.vstack(rows), np.concatenate(rhs)
    if b.size <= 2 * order:
        raise RingDownError(f"{b.size} values to fit a linear prediction of order {order}")
    alpha = np.linalg.lstsq(a, b, rcond=None)[0]
    residual = b - a @ alpha
    variance = float(np.vdot(residual, residual).real) / (b.size - order)
    covariance = variance * np.linalg.inv(a.conj().T @ a)
    return np.roots(np.concatenate([[1.0], alpha[::-1]])), alpha, covariance


def _energies(signals: list[NDArray], roots: NDArray) -> NDArray[np.float64]:
    """Energy of each pole's share of the signals (module docstring, 4)."""
    out = np.zeros(roots.size)
    for u in signals:
        powers = roots[None, :] ** np.arange(u.size)[:, None]
        c = np.linalg.lstsq(powers, u, rcond=None)[0]
        out += np.abs(c) ** 2 * np.sum(np.abs(powers) ** 2, axis=0)
    return out


@dataclass(frozen=True)
class _Decay:
    """A record made ready for the fits: baseband signals, envelopes and usable spans per channel."""

    t: NDArray
    fs: float
    band: tuple[float, float]
    baseband: list[NDArray]
    envelopes: list[NDArray]
    ends: list[tuple[int, int]]
    names: tuple[str, ...]

    @property
    def centre(self) -> float:
        return 0.5 * (self.band[0] + self.band[1])


def _decay(time_s: NDArray, responses: dict[str, NDArray], band_hz: tuple[float, float] | None,
           force: NDArray | None, snr: float, source: str) -> _Decay:
    """Module docstring, steps 1–2: each channel after the blow, band-passed to baseband, with
    the span (first, last index) where it is clear of the filter's ends and of the noise."""
    t = np.asarray(time_s, dtype=float).ravel()
    fs = _uniform_rate(t, source)
    names = list(responses)
    if not names:
        raise RingDownError(f"{source}: no response channel beside time_s (and the force)")
    xs = []
    for name in names:
        x = np.asarray(responses[name], dtype=float).ravel()
        if x.shape != t.shape or not np.all(np.isfinite(x)):
            raise RingDownError(f"{source}: channel {name!r} must hold one finite value per time ({t.size})")
        xs.append(x - x.mean())
    if force is not None:
        f = np.abs(np.asarray(force, dtype=float).ravel())
        loud = np.flatnonzero(f > FORCE_END * f.max())
        start = int(loud[-1]) + 1 if loud.size else 0
    else:  # an impact record starts before the blow: fit from the largest response on
        start = int(np.argmax(np.abs(xs[0])))
    t, xs = t[start:], [x[start:] for x in xs]
    low, high = default_band(xs[0], fs) if band_hz is None else (float(band_hz[0]), float(band_hz[1]))
    if not 0 < low < high < fs / 2:
        raise RingDownError(f"{source}: band {low:g}–{high:g} Hz: expected 0 < low < high < the Nyquist frequency "
                            f"{fs / 2:g} Hz")
    centre, bandwidth, index = 0.5 * (low + high), high - low, np.arange(t.size)
    baseband, envelopes, ends = [], [], []
    for name, x in zip(names, xs):
        z, sos = analytic_band_pass(t, x, (low, high), fs)
        baseband.append(z * np.exp(-2j * np.pi * centre * (t - t[0])))
        envelopes.append(np.abs(z))
        residual = x - z.real
        noise = float(1.4826 * np.median(np.abs(residual - np.median(residual)))
                      * np.sqrt(bandwidth / max(fs / 2 - bandwidth, bandwidth)))
        head, tail = _trims(_filter_tail(sos, t.size), envelopes[-1])
        usable = (index >= head) & (index < t.size - tail) & (envelopes[-1] >= snr * noise)
        if not usable.any():
            raise RingDownError(f"{source}: channel {name!r}: nothing of the decay is left after trimming the filter's "
                                f"ends and dropping the envelope below {snr:g} × the noise ({noise:.3g}): give the "
                                f"band, a longer record, or leave the channel out (--channel)")
        ends.append((head, int(np.flatnonzero(usable)[-1])))
    return _Decay(t, fs, (low, high), baseband, envelopes, ends, tuple(names))


def _fit_window(decay: _Decay, first: int, last: int, order: int, shape: float | None, per_bandwidth: float,
                source: str) -> LinearLimit:
    """The pole of the mode over ``first`` … ``last`` (indices) of the first channel, the
    others joining as far as their own spans allow (module docstring, steps 4–5), values
    1/(``per_bandwidth`` × bandwidth) apart."""
    low, high = decay.band
    step = max(int(round(decay.fs / (per_bandwidth * (high - low)))), 1)
    parts = [u[max(first, h):min(last, e) + 1:step] for u, (h, e) in zip(decay.baseband, decay.ends)]
    parts = [part for part in parts if part.size >= 4 * order]
    t = decay.t
    if not parts:
        raise RingDownError(f"{source}: the part of the decay fitted ({t[first]:.4g}–{t[last]:.4g} s) holds fewer than "
                            f"{4 * order} values a 1/bandwidth apart: give a wider band, a larger span or a lower "
                            f"order")
    roots, alpha, covariance = _lsce(parts, order)
    delta = step / decay.fs
    poles = np.log(roots.astype(complex)) / delta + 2j * np.pi * decay.centre
    decaying = poles.real < 0
    if not decaying.any():
        raise RingDownError(f"{source}: no decaying pole in {low:g}–{high:g} Hz (order {order})")
    k = int(np.argmax(np.where(decaying, _energies(parts, roots), -np.inf)))
    s, lam = poles[k], roots[k]
    derivative = np.polyval(np.polyder(np.concatenate([[1.0], alpha[::-1]])), lam)
    gradient = -(lam ** np.arange(order)) / derivative  # dλ/dα_j
    var_lambda = float(np.real(gradient @ covariance @ gradient.conj()))
    omega = abs(s)
    std_s = np.sqrt(var_lambda / 2) / abs(lam) / delta  # of Re s and of Im s (ds = dλ/(λΔ))
    phi = 1.0 if shape is None else abs(float(shape))
    part = decay.envelopes[0][first:last + 1] / phi
    return LinearLimit(omega / (2 * np.pi), float(-s.real / omega), float(std_s / (2 * np.pi)), float(std_s / omega),
                       float(np.sum(part**3) / np.sum(part**2)), (float(part.min()), float(part.max())),
                       (float(t[first]), float(t[last])), (low, high), decay.names, order, source, phi)


def fit_linear_limit(time_s: NDArray, responses: dict[str, NDArray], band_hz: tuple[float, float] | None = None,
                     shape: float | None = None, force: NDArray | None = None, order: int = 1, span: float = 3.0,
                     snr: float = 20.0, source: str = "<impact>") -> LinearLimit:
    """The linear limit of the mode in ``band_hz`` (module docstring) from response channels
    (name → values at ``time_s``, s, uniform; any unit), optionally the hammer's ``force``;
    ``shape`` |φ| (1/√kg) at the first channel makes the amplitude modal. The fitted part
    is the first channel's quietest (module docstring, 3); the other channels join it there
    as far as their own noise and the filter's ends allow."""
    decay = _decay(time_s, responses, band_hz, force, snr, source)
    (head, last), envelope = decay.ends[0], decay.envelopes[0]
    index = np.arange(envelope.size)
    first = int(np.flatnonzero((index >= head) & (index <= last) & (envelope <= span * envelope[last]))[0])
    return _fit_window(decay, first, last, order, shape, 1.0, source)


def decay_segments(time_s: NDArray, responses: dict[str, NDArray], band_hz: tuple[float, float] | None = None,
                   shape: float | None = None, span: float = 1.5, snr: float = 20.0,
                   source: str = "<ring-down>") -> list[LinearLimit]:
    """A ring-down as successive linear fits: the usable decay of the first channel cut into
    parts over each of which its envelope falls by ``span``, each fitted as the quiet part
    is (order 1, values 1/(4 × bandwidth) apart: a part holds few independent values) and
    placed at its amplitude weighted by the squared envelope. Noise-robust where
    differentiating the envelope is not (docs/ring-down.md, "Noisy ring-downs")."""
    decay = _decay(time_s, responses, band_hz, None, snr, source)
    (head, last), envelope = decay.ends[0], decay.envelopes[0]
    out, first = [], head
    while first < last:
        below = np.flatnonzero(envelope[first:last + 1] <= envelope[first] / span)
        if below.size == 0:
            break
        end = first + int(below[0])
        try:
            out.append(_fit_window(decay, first, end, 1, shape, 4.0, source))
        except RingDownError:
            pass  # too short a part (a fast stretch of the decay): the next one starts after it
        first = end
    if not out:
        raise RingDownError(f"{source}: no part of the decay falls by a factor {span:g} clear of the noise and the "
                            f"filter's ends")
    return out


def split_force(columns: dict[str, NDArray], channel: str | None) -> tuple[NDArray, dict[str, NDArray], NDArray | None]:
    """(time_s, the response channels to fit, the force or None) of a record's columns
    (:func:`~nlupdate.core.identification.ring_down.read_channels`): ``channel`` alone when
    given, else every response channel."""
    if "time_s" not in columns:
        raise RingDownError("no 'time_s' column/variable; an impact record holds time_s (s), the response channels and "
                            "optionally the force")
    force_names = [n for n in columns if n in FORCE_CHANNELS]
    responses = {n: v for n, v in columns.items() if n != "time_s" and n not in FORCE_CHANNELS}
    if channel is not None:
        if channel not in responses:
            raise RingDownError(f"no channel {channel!r}; the record holds {list(responses)}")
        responses = {channel: responses[channel]}
    return columns["time_s"], responses, (columns[force_names[0]] if force_names else None)
