"""The linear limit of one mode from an impact or a low-level free decay: a least-squares
complex exponential (LSCE) fit refined by an output-error fit.

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
   its peak for good; the fit ends where the envelope falls below ``snr`` (5) times the
   in-band noise (estimated as for a ring-down);
3. **the linear limit**: a joint makes the decay amplitude-dependent, so only the quietest
   part of the record is fitted — where the envelope of the first channel is at most
   ``span`` (3) times its value at the fit's end, widened by factors of 1.5 until the damping
   ratio's standard error is at most ``precision`` (1 %) of it (the smaller of the error from
   the noise estimate alone and the one from the residual, step 6) — and the
   sample is placed at the amplitude the fit belongs to: the envelope averaged with the
   kernel by which a least-squares slope of ln a (each value weighted by a², as the fit of
   step 5 weighs it) averages the local decay rates, ``K_j = Σ_{i≥j} a_i²(t_i − t̄)``. A truly
   linear record gives the same pole from any part;
4. the baseband signals are taken every Δ = 1/B (B the bandwidth: the band-passed noise is
   then about independent from one value to the next) and fitted jointly (one set of poles
   for all channels) by linear prediction of order p (default 1: the band-passed analytic
   signal holds the one mode; a higher order takes noise or a second mode in the band, but on
   a decay whose frequency drifts, as a joint's does, it splits the drift between two poles),
   ``u_{n+p} + Σ_{j<p} α_j u_{n+j} = 0`` in least squares; the roots λ of
   ``λ^p + Σ α_j λ^j`` are ``e^{(s − 2πi f_c)Δ}``;
5. the linear prediction is biased by the noise in its regressors (errors in variables:
   three-channel records with white noise of 2 % of each channel's peak gave ζ 0.4–8.6 %
   high over 8 seeds), so its roots only start an **output-error** fit, ``u_n ≈ Σ_r c_r λ_r^n``
   per channel (λ shared, c per channel) in least squares over the values themselves
   (Levenberg–Marquardt): the noise is then in the residual only, and the estimate is
   unbiased (16 seeds: ζ within 2.0 % at 2 % noise, 1.0 % at 0.5 %; tests/test_impact.py).
   The mode's pole is the decaying one that carries most of the fitted signal (energy
   ``Σ|c_r|²|λ_r|^{2n}``): the extra poles take noise and whatever else is in the band;
   ``ω = |s|``, ``ζ = −Re s/|s|``;
6. standard errors: the residual's variance times ``(JᵀJ)⁻¹`` of the output-error fit (J its
   Jacobian), carried from λ to s by ``ds = dλ/(λΔ)`` and on to f and ζ; values closer than
   1/B count as 1/(BΔ) times correlated. Over 16 seeds the error was within 2.7 of them.

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
import scipy.optimize
from numpy.typing import NDArray

from nlupdate.core.identification.modal_samples import ModalSamples
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


def _lsce(signals: list[NDArray], order: int) -> NDArray:
    """Roots λ of the joint linear prediction (module docstring, 4)."""
    rows, rhs = [], []
    for u in signals:
        n = u.size - order
        rows.append(np.column_stack([u[j:j + n] for j in range(order)]))
        rhs.append(-u[order:])
    a, b = np.vstack(rows), np.concatenate(rhs)
    if b.size <= 2 * order:
        raise RingDownError(f"{b.size} values to fit a linear prediction of order {order}")
    alpha = np.linalg.lstsq(a, b, rcond=None)[0]
    return np.roots(np.concatenate([[1.0], alpha[::-1]])).astype(complex)


def _energies(signals: list[NDArray], roots: NDArray) -> NDArray[np.float64]:
    """Energy of each pole's share of the signals (module docstring, 5)."""
    out = np.zeros(roots.size)
    for u in signals:
        powers = roots[None, :] ** np.arange(u.size)[:, None]
        c = np.linalg.lstsq(powers, u, rcond=None)[0]
        out += np.abs(c) ** 2 * np.sum(np.abs(powers) ** 2, axis=0)
    return out


def _output_error(signals: list[NDArray], roots: NDArray) -> tuple[NDArray, NDArray, float]:
    """(roots λ, (JᵀJ)⁻¹ of their real and imaginary parts (2p × 2p), the residual's variance
    per real value) of the output-error fit ``u_n ≈ Σ_r c_r λ_r^n`` (module docstring, 5),
    started from the linear prediction's roots."""
    order = roots.size
    steps = [np.arange(u.size) for u in signals]

    def amplitudes(lam: NDArray) -> list[NDArray]:
        return [np.linalg.lstsq(lam[None, :] ** n[:, None], u, rcond=None)[0] for u, n in zip(signals, steps)]

    def residual(p: NDArray) -> NDArray:  # p: Re λ, Im λ, then each channel's Re c, Im c
        lam = p[:order] + 1j * p[order:2 * order]
        c = p[2 * order:].reshape(len(signals), 2, order)
        r = np.concatenate([(lam[None, :] ** n[:, None]) @ (ci[0] + 1j * ci[1]) - u
                            for u, n, ci in zip(signals, steps, c)])
        return np.concatenate([r.real, r.imag])

    start = np.concatenate([roots.real, roots.imag] + [np.concatenate([c.real, c.imag]) for c in amplitudes(roots)])
    fit = scipy.optimize.least_squares(residual, start, method="lm", x_scale="jac", xtol=1e-12, ftol=1e-12)
    lam = fit.x[:order] + 1j * fit.x[order:2 * order]
    dof = max(fit.fun.size - fit.x.size, 1)
    return lam, np.linalg.pinv(fit.jac.T @ fit.jac)[:2 * order, :2 * order], float(fit.fun @ fit.fun) / dof


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
    noise: float  # the first channel's in-band noise (standard deviation, the response's units)

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
    baseband, envelopes, ends, noises = [], [], [], []
    for name, x in zip(names, xs):
        z, sos = analytic_band_pass(t, x, (low, high), fs)
        baseband.append(z * np.exp(-2j * np.pi * centre * (t - t[0])))
        envelopes.append(np.abs(z))
        residual = x - z.real
        noise = float(1.4826 * np.median(np.abs(residual - np.median(residual)))
                      * np.sqrt(bandwidth / max(fs / 2 - bandwidth, bandwidth)))
        noises.append(noise)
        head, tail = _trims(_filter_tail(sos, t.size), envelopes[-1])
        usable = (index >= head) & (index < t.size - tail) & (envelopes[-1] >= snr * noise)
        if not usable.any():
            raise RingDownError(f"{source}: channel {name!r}: nothing of the decay is left after trimming the filter's "
                                f"ends and dropping the envelope below {snr:g} × the noise ({noise:.3g}): give the "
                                f"band, a longer record, or leave the channel out (--channel)")
        ends.append((head, int(np.flatnonzero(usable)[-1])))
    return _Decay(t, fs, (low, high), baseband, envelopes, ends, tuple(names), noises[0])


def _placement(envelope: NDArray) -> float:
    """The amplitude an exponential fitted over ``envelope`` (values equally spaced in time)
    belongs to: the envelope averaged with the kernel by which a least-squares slope of the
    logarithm, each value weighted by its squared envelope, averages the local slopes,
    ``K_j = Σ_{i≥j} w_i(t_i − t̄)``, ``w = a²`` (module docstring, 3)."""
    w = envelope**2
    n = np.arange(envelope.size, dtype=float)
    kernel = np.cumsum((w * (n - np.sum(w * n) / np.sum(w)))[::-1])[::-1]
    return float(np.sum(kernel * envelope) / np.sum(kernel))


def _fit_window(decay: _Decay, first: int, last: int, order: int, shape: float | None, per_bandwidth: float,
                source: str) -> tuple[LinearLimit, float]:
    """The pole of the mode over ``first`` … ``last`` (indices) of the first channel, the
    others joining as far as their own spans allow (module docstring, steps 4–6), values
    1/(``per_bandwidth`` × bandwidth) apart; and the damping ratio's standard error that the
    first channel's noise alone would give (the stated one is from the residual, which also
    holds a nonlinear decay's misfit)."""
    low, high = decay.band
    step = max(int(round(decay.fs / (per_bandwidth * (high - low)))), 1)
    parts = [u[max(first, h):min(last, e) + 1:step] for u, (h, e) in zip(decay.baseband, decay.ends)]
    parts = [part for part in parts if part.size >= 4 * order]
    t = decay.t
    if not parts:
        raise RingDownError(f"{source}: the part of the decay fitted ({t[first]:.4g}–{t[last]:.4g} s) holds fewer than "
                            f"{4 * order} values a 1/bandwidth apart: give a wider band, a larger span or a lower "
                            f"order")
    roots, jtj_inv, variance = _output_error(parts, _lsce(parts, order))
    delta = step / decay.fs
    poles = np.log(roots) / delta + 2j * np.pi * decay.centre
    decaying = poles.real < 0
    if not decaying.any():
        raise RingDownError(f"{source}: no decaying pole in {low:g}–{high:g} Hz (order {order})")
    k = int(np.argmax(np.where(decaying, _energies(parts, roots), -np.inf)))
    s, lam = poles[k], roots[k]
    omega = abs(s)
    # ds = dλ/(λΔ): (Re s, Im s) from (Re λ, Im λ); values 1/(per_bandwidth·B) apart are that
    # many times correlated, so the information is per_bandwidth times less than counted
    rotate = np.array([[lam.real, lam.imag], [-lam.imag, lam.real]]) / (abs(lam) ** 2 * delta)
    cov_s = per_bandwidth * rotate @ jtj_inv[np.ix_([k, order + k], [k, order + k])] @ rotate.T
    unit = np.array([s.real, s.imag]) / omega  # d|s|
    gradient = -np.array([1.0, 0.0]) / omega - s.real / omega**2 * unit  # d(−Re s/|s|)
    phi = 1.0 if shape is None else abs(float(shape))
    part = decay.envelopes[0][first:last + 1:step] / phi
    std_f = float(np.sqrt(variance * unit @ cov_s @ unit)) / (2 * np.pi)
    fit = LinearLimit(omega / (2 * np.pi), float(-s.real / omega), std_f,
                      float(np.sqrt(variance * gradient @ cov_s @ gradient)), _placement(part),
                      (float(part.min()), float(part.max())), (float(t[first]), float(t[last])), (low, high),
                      decay.names, order, source, phi)
    return fit, float(decay.noise * np.sqrt(gradient @ cov_s @ gradient))


def fit_linear_limit(time_s: NDArray, responses: dict[str, NDArray], band_hz: tuple[float, float] | None = None,
                     shape: float | None = None, force: NDArray | None = None, order: int = 1, span: float = 3.0,
                     snr: float = 5.0, precision: float = 0.01, source: str = "<impact>") -> LinearLimit:
    """The linear limit of the mode in ``band_hz`` (module docstring) from response channels
    (name → values at ``time_s``, s, uniform; any unit), optionally the hammer's ``force``;
    ``shape`` |φ| (1/√kg) at the first channel makes the amplitude modal. The fitted part
    is the first channel's quietest (module docstring, 3): the envelope within ``span`` of its
    end, widened by factors of 1.5 until the damping ratio's standard error is at most
    ``precision`` of it (or the whole usable decay is fitted) — the smaller of the error from
    the noise estimate alone (which out-of-band content can inflate) and the stated one (from
    the residual, which a nonlinear decay's misfit inflates); the other channels join it there
    as far as their own noise and the filter's ends allow."""
    decay = _decay(time_s, responses, band_hz, force, snr, source)
    (head, last), envelope = decay.ends[0], decay.envelopes[0]
    index = np.arange(envelope.size)
    while True:
        first = int(np.flatnonzero((index >= head) & (index <= last) & (envelope <= span * envelope[last]))[0])
        fit, noise_std = _fit_window(decay, first, last, order, shape, 1.0, source)
        if min(noise_std, fit.damping_std) <= precision * fit.damping_ratio or first == head:
            return fit
        span *= 1.5


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
            out.append(_fit_window(decay, first, end, 1, shape, 4.0, source)[0])
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
