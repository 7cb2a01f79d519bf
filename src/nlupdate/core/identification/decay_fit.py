"""A ring-down read as one averaged decay: the slow flow fitted to the band-passed record.

Differentiating a noisy envelope (:mod:`~nlupdate.core.identification.ring_down`) or fitting
short parts of it (:func:`~nlupdate.core.identification.impact.decay_segments`) gives samples
each from a few independent values: with white noise of 2 % of the initial amplitude the
segments over a factor 1.5 of decay scatter by 1–18 % in damping (their stated standard
errors, which match that scatter), so the largest over a record and over seeds is 12–33 %
(docs/ring-down.md, "Noisy ring-downs"). This fits the averaged equations of the decay
(first-order averaging, docs/ring-down.md "What it is checked against") to the whole usable
record at once::

    da/dt = −σ(a)·a,      dθ/dt = ω_d(a),      x(t) ≈ a(t) cos θ(t),

with the decay rate σ = ζω and the damped frequency ω_d = ω√(1 − ζ²) (rad/s) smooth
functions of the amplitude a, so every value of the record informs the curve, and each
amplitude's estimate averages over the whole decay rather than over one window.

Form. ``σ(a)·r² = Σ_k c_k r^{k+2}`` and ``(ω_d(a) − ω_c)·r² = Σ_k b_k r^{k+2}``, the powers
k taken in the order 0, −1, −2, 1 (:data:`POWERS`), r = a/a_ref (a_ref the geometric mean
of the fitted envelope's ends, ω_c the band's centre): the power the mode loses, ``2σa²``,
is a polynomial in the amplitude — viscous damping loses ∝ a², a Jenkins slider in
macroslip ∝ a − a_slip (``W = 4F_s(A − F_s/k_t)`` per cycle), an Iwan joint in microslip
∝ a^(χ+3). Least-squares fits of the form to the truth's σ and ω_d over the amplitudes the
truth records of tests/test_decay_fit.py cover (measured): with all four terms the damping
ratio within 0.40 % and the frequency within 5.5e-4 (Jenkins SDOF from 1.38 × its slip
amplitude up; 0.11 % / 2.2e-4 on the 2-DOF), 0.40 % / 1.2e-4 (Iwan SDOF, microslip over a
factor 9); three terms hold the Jenkins records within 0.65 % and 0.17 % but the Iwan SDOF
only within 5 %. Terms are added while the F-test of the fit without the new one (two
parameters fewer, :func:`~nlupdate.core.identification.amplitude_modal_fit.microslip_test`,
the values counted as one per correlation time) has p < :data:`SIGNIFICANCE` (0.2): a term
missing biases the curve, a term too many only widens its standard errors, which the
sample rule below accounts for.

Fit (output error, as :mod:`~nlupdate.core.identification.impact` step 5). The record is
band-passed and made analytic by the ring-down's filter, trimmed by its rule (the filter's
ends; the envelope down to ``snr`` × the in-band noise, both docs/ring-down.md) and taken
at baseband every 1/(4B) s (B the bandwidth); the model ``a(t)e^{i(θ(t) − ω_c t)}``,
integrated by RK4 on those instants from ``(a(t₀), θ(t₀))``, is fitted to it by
Levenberg–Marquardt over ``ln a(t₀)``, ``θ(t₀)``, c and b, started from the segments'
samples fitted by the same form (or, when that ends in a worse minimum, from the fit with one
term fewer). The noise is in the residual only, so the fit is not biased by it. Standard
errors: the residual's variance times ``(JᵀJ)⁻¹`` (J the Jacobian), times the values'
correlation factor (:func:`noise_correlation`: Σ_k ρ(k·Δ) of the filter's own impulse
response, 4.42 for values 1/(4B) apart — it was taken as 4), carried to ω = √(σ² + ω_d²) and
ζ = σ/ω at each amplitude by their gradients; and, where the F-test stopped before the last
term, the term it left out: the fit *with* that term is the alternative the test could not
tell apart at p ≥ 0.2, and its curve's difference from the chosen one is added in quadrature
(the choice of form is part of the uncertainty; without it the damping errors of the samples
of fits that stopped before the last term were 1.2–1.5 of their stated errors in deviation,
1.0–1.3 with it).
Over 40 seeds of the four truth records (2 % noise, ``benchmarks/ring_down_noise.py``) the
damping errors of the samples were 1.18–1.25 of their stated errors in deviation (1.27–1.40
before both), with a mean of +1.0 on the SDOF records, whose noise-free records read 1–3 %
above the periodic truth (a free decay through hysteresis dissipates more: docs/ring-down.md).

Samples (:meth:`DecayFit.samples`): the fitted curves at amplitudes a factor 1.5 apart
(as dense as the segments), from half a step inside the fitted range's top, kept where the
damping ratio's standard error is at most :data:`PRECISION` (1.5 %) of it — the curve's
ends, which the record holds least, are left out by that rule, not by a tuned margin.
They are points of one curve, not independent; the source's stated noise — one value for all
its samples, as every source has in a joint fit — is their *largest* standard error, so no
sample is weighted beyond what the fit states for it. The median did that to the samples at
the record's low end, the least known and, on a Jenkins joint, the nearest its slip amplitude:
over 24 seeds of the four truth records (2 % noise, tests/test_test_type_truth.py) the samples'
errors were 2.2 and 2.0 × the median in rms frequency (3.4–3.7 × below 5 a_s on the Jenkins
SDOF) and 1.3–1.7 × in damping, against 0.82–1.08 × and 0.88–1.28 × the largest; with the
median the Jenkins SDOF's held-out fits placed the slip amplitude 1.7 × further from it than
without the ring-down at all (docs/ring-down.md, "Efficient at the kink").
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.optimize
import scipy.signal
from numpy.typing import NDArray

from nlupdate.core.identification.amplitude_modal_fit import microslip_test
from nlupdate.core.identification.impact import _decay, decay_segments
from nlupdate.core.identification.modal_samples import ModalSamples
from nlupdate.core.identification.ring_down import RingDownError, analytic_band_pass

#: powers of r in σ(a) and ω_d(a) − ω_c, in the order they are added (module docstring)
POWERS = (0, -1, -2, 1)
#: at most this many of them
TERMS = len(POWERS)
#: a term is added while the F-test rejects the fit without it at this level
SIGNIFICANCE = 0.2
#: samples are taken this factor of amplitude apart
SAMPLE_SPACING = 1.5
#: values fitted per reciprocal bandwidth
PER_BANDWIDTH = 4.0
#: samples are reported where the damping ratio's standard error is at most this fraction of it
PRECISION = 0.015


def _basis(r: NDArray, terms: int) -> NDArray:
    """The first ``terms`` of r⁰, r⁻¹, r⁻², r¹ (:data:`POWERS`), one column each (module docstring)."""
    return np.asarray(r, dtype=float)[..., None] ** np.array(POWERS[:terms], dtype=float)


@dataclass(frozen=True, eq=False)
class DecayFit:
    """The fitted slow flow of one ring-down (module docstring): ``rate`` c and ``frequency``
    b (rad/s), their joint covariance ``covariance`` (2·terms square, c first), ``reference``
    a_ref and ``amplitude_range`` (response units), ``centre_rad_s`` ω_c, ``window_s`` the
    fitted times, ``band_hz``, ``shape`` |φ| (1/√kg; 1 when not given), ``rms`` the residual's
    standard deviation relative to a_ref; ``alternative`` (c, b) of the fit with the term the
    F-test left out (None when every term was taken), whose difference the standard errors
    carry."""

    rate: NDArray[np.float64]
    frequency: NDArray[np.float64]
    covariance: NDArray[np.float64]
    reference: float
    amplitude_range: tuple[float, float]
    centre_rad_s: float
    window_s: tuple[float, float]
    band_hz: tuple[float, float]
    shape: float
    rms: float
    source: str = "<ring-down>"
    alternative: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None

    def curves(self, amplitude) -> tuple[NDArray, NDArray, NDArray, NDArray]:
        """(natural frequency Hz, damping ratio, their standard errors) at modal amplitudes
        (m·√kg; response units when no shape was given)."""
        r = np.asarray(amplitude, dtype=float) * self.shape / self.reference
        g = _basis(r, self.rate.size)
        sigma, omega_d = g @ self.rate, self.centre_rad_s + g @ self.frequency
        omega = np.hypot(sigma, omega_d)
        zeta = sigma / omega
        # gradients of ω and ζ with respect to (c, b): through σ and ω_d
        d_omega = np.concatenate([g * (sigma / omega)[..., None], g * (omega_d / omega)[..., None]], axis=-1)
        d_zeta = (np.concatenate([g / omega[..., None], np.zeros_like(g)], axis=-1)
                  - (sigma / omega**2)[..., None] * d_omega)
        var_omega = np.einsum("...i,ij,...j->...", d_omega, self.covariance, d_omega)
        var_zeta = np.einsum("...i,ij,...j->...", d_zeta, self.covariance, d_zeta)
        if self.alternative is not None:
            g2 = _basis(r, self.alternative[0].size)
            s2, w2 = g2 @ self.alternative[0], self.centre_rad_s + g2 @ self.alternative[1]
            o2 = np.hypot(s2, w2)
            var_omega = var_omega + (o2 - omega) ** 2
            var_zeta = var_zeta + (s2 / o2 - zeta) ** 2
        return omega / (2 * np.pi), zeta, np.sqrt(var_omega) / (2 * np.pi), np.sqrt(var_zeta)

    def sample_amplitudes(self, precision: float = PRECISION) -> NDArray[np.float64]:
        """Modal amplitudes a factor :data:`SAMPLE_SPACING` apart, half a step inside the fitted
        range, where the damping ratio's standard error is at most ``precision`` of it."""
        low, high = (a / self.shape for a in self.amplitude_range)
        count = int(np.floor(np.log(high / low) / np.log(SAMPLE_SPACING)))
        a = (high / np.sqrt(SAMPLE_SPACING) * SAMPLE_SPACING ** -np.arange(count, dtype=float) if count >= 1
             else np.array([np.sqrt(high * low)]))
        _, zeta, _, zeta_std = self.curves(a)
        return a[zeta_std <= precision * zeta]

    def samples(self, precision: float = PRECISION) -> ModalSamples:
        """The fitted curves at :meth:`sample_amplitudes` as backbone samples (no force)."""
        a = self.sample_amplitudes(precision)
        if a.size == 0:
            raise RingDownError(f"{self.source}: the decay fit determines the damping ratio to {100 * precision:g} % "
                                f"nowhere over {self.amplitude_range[0]:.3g}–{self.amplitude_range[1]:.3g} (response "
                                f"units): record a longer or less noisy decay")
        f, zeta, _, _ = self.curves(a)
        return ModalSamples(a, f, zeta, np.zeros(a.size), self.shape)

    def stated_noise(self, precision: float = PRECISION) -> tuple[float, float]:
        """The largest relative standard errors (frequency, damping) of the samples: the source's
        noise (module docstring: not their median)."""
        f, zeta, f_std, zeta_std = self.curves(self.samples(precision).amplitude)
        return float(np.max(f_std / f)), float(np.max(zeta_std / zeta))


def noise_correlation(band_hz: tuple[float, float], sample_rate_hz: float, step: int) -> float:
    """Variance of a mean of the baseband values ``step`` samples apart, times their count,
    over one value's variance, for white noise through the ring-down's forward–backward
    band-pass (:func:`~nlupdate.core.identification.ring_down.analytic_band_pass`):
    ``Σ_k ρ(k·step)``, ρ the filter's normalised impulse-response autocorrelation — the
    factor by which correlated values understate a least-squares variance (4.42 for values
    1/(4B) apart; 1 for independent values)."""
    low, high = band_hz
    length = 8 * int(np.ceil(sample_rate_hz / (high - low))) + 1  # the filter's response is gone by then
    sos = analytic_band_pass(np.arange(length) / sample_rate_hz, np.zeros(length), band_hz, sample_rate_hz)[1]
    impulse = np.zeros(2 * length + 1)
    impulse[length] = 1.0
    h = scipy.signal.sosfiltfilt(sos, impulse)
    rho = scipy.signal.fftconvolve(h, h[::-1])
    middle = rho.size // 2
    lags = middle + step * np.arange(-(middle // step), middle // step + 1)
    return float(rho[lags].sum() / rho[middle])


def _flow(params: NDArray, step: float, count: int, centre: float, terms: int) -> NDArray[np.complex128]:
    """Baseband model ``(a/a_ref)·e^{i(θ − ω_c t)}`` at ``count`` instants ``step`` apart, for
    each parameter set (rows: ln r₀, θ₀, c, b): RK4 of ``d ln r/dt = −σ``, ``dφ/dt = ω_d − ω_c``.
    The rates depend on ln r alone, so the loop steps ln r only and keeps its stages; φ's RK4
    increments, ``ω_d − ω_c`` at those stages, are then evaluated at once and summed in order
    (the same operations as stepping both together)."""
    p = np.atleast_2d(params)
    c, b = p[:, 2:2 + terms], p[:, 2 + terms:2 + 2 * terms]
    v = p[:, 0].copy()
    log_r = np.empty((count, p.shape[0]))  # ln r at the instants
    stages = np.empty((count - 1, 4, p.shape[0]))  # ln r at each step's four RK4 stages
    log_r[0] = v
    for n in range(1, count):
        stages[n - 1, 0] = v
        k1 = -np.einsum("pk,pk->p", _basis(np.exp(v), terms), c)
        stages[n - 1, 1] = v + step / 2 * k1
        k2 = -np.einsum("pk,pk->p", _basis(np.exp(stages[n - 1, 1]), terms), c)
        stages[n - 1, 2] = v + step / 2 * k2
        k3 = -np.einsum("pk,pk->p", _basis(np.exp(stages[n - 1, 2]), terms), c)
        stages[n - 1, 3] = v + step * k3
        k4 = -np.einsum("pk,pk->p", _basis(np.exp(stages[n - 1, 3]), terms), c)
        v = v + step / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        log_r[n] = v
    w = np.einsum("nspk,pk->nsp", _basis(np.exp(stages), terms), b)
    increments = step / 6 * (w[:, 0] + 2 * w[:, 1] + 2 * w[:, 2] + w[:, 3])
    phase = np.cumsum(np.concatenate([p[None, :, 1], increments]), axis=0)
    return np.exp(log_r + 1j * phase).T


def _fit_terms(measured: NDArray, step: float, centre: float, terms: int,
               start: NDArray) -> scipy.optimize.OptimizeResult:
    """Levenberg–Marquardt fit of the flow with ``terms`` terms to the baseband values (module docstring)."""
    def residual(p):
        with np.errstate(all="ignore"):
            r = _flow(p, step, measured.size, centre, terms)[0] - measured
        r = np.concatenate([r.real, r.imag])
        return np.where(np.isfinite(r), r, 1e3)  # a flow that blows up (LM's trial step) fits nothing

    def jacobian(p):
        h = 1e-7 * np.maximum(np.abs(p), 1.0)
        with np.errstate(all="ignore"):
            flows = _flow(np.vstack([p, p + np.diag(h)]), step, measured.size, centre, terms)
        d = (flows[1:] - flows[0]) / h[:, None]
        return np.nan_to_num(np.concatenate([d.real, d.imag], axis=1).T)

    return scipy.optimize.least_squares(residual, start, jac=jacobian, method="lm", x_scale="jac", xtol=1e-12,
                                        ftol=1e-12, max_nfev=400)


def fit_decay(time_s: NDArray, response: NDArray, band_hz: tuple[float, float] | None = None,
              shape: float | None = None, snr: float = 20.0, source: str = "<ring-down>") -> DecayFit:
    """The slow flow fitted to one channel's free decay (module docstring): ``time_s`` (s,
    uniform) and ``response`` (any unit); ``band_hz`` the mode's band (default: around the
    largest peak); ``shape`` |φ| (1/√kg) at the sensor makes amplitudes modal; ``snr`` the
    envelope-to-noise ratio where the fitted part ends."""
    decay = _decay(time_s, {"response": response}, band_hz, None, snr, source)
    (head, last), envelope = decay.ends[0], decay.envelopes[0]
    low, high = decay.band
    step = max(int(round(decay.fs / (PER_BANDWIDTH * (high - low)))), 1)
    index = np.arange(head, last + 1, step)
    if index.size < 8 * TERMS:
        raise RingDownError(f"{source}: {index.size} values 1/(4 × bandwidth) apart are left of the decay after "
                            f"trimming; a decay fit needs {8 * TERMS}: record a longer decay or give a wider band")
    reference = float(np.sqrt(envelope[head] * envelope[last]))
    measured, centre, dt = decay.baseband[0][index] / reference, 2 * np.pi * decay.centre, step / decay.fs
    # start: the segments' samples (rate σ = ζω, damped frequency) fitted by the same form
    parts = decay_segments(time_s, {"response": response}, band_hz, snr=snr, source=source)
    amplitude = np.array([part.amplitude for part in parts]) / reference
    omega = 2 * np.pi * np.array([part.frequency_hz for part in parts])
    zeta = np.array([part.damping_ratio for part in parts])
    fit, chosen, alternative = None, 0, None
    for terms in range(1, TERMS + 1):
        g = _basis(amplitude, min(terms, amplitude.size))
        pad = (0, terms - g.shape[1])
        start = np.concatenate([[np.log(abs(measured[0])), np.angle(measured[0])],
                                np.pad(np.linalg.lstsq(g, zeta * omega, rcond=None)[0], pad),
                                np.pad(np.linalg.lstsq(g, omega * np.sqrt(1 - zeta**2) - centre, rcond=None)[0], pad)])
        more = _fit_terms(measured, dt, centre, terms, start)
        if fit is not None and more.cost > fit.cost:  # a worse minimum: from the fit with one term fewer instead
            fewer_start = np.insert(np.insert(fit.x, 2 + 2 * chosen, 0.0), 2 + chosen, 0.0)
            more = _fit_terms(measured, dt, centre, terms, fewer_start)
        if fit is not None:
            # F-test of two parameters more, the values PER_BANDWIDTH to a correlation time
            dof = (more.fun.size - more.x.size) / PER_BANDWIDTH
            chi2, fewer = float(more.fun @ more.fun) / PER_BANDWIDTH, float(fit.fun @ fit.fun) / PER_BANDWIDTH
            if microslip_test(chi2, fewer, int(dof)) >= SIGNIFICANCE:
                alternative = (more.x[2:2 + terms], more.x[2 + terms:])
                break
        fit, chosen = more, terms
    dof = max(fit.fun.size - fit.x.size, 1)
    variance = float(fit.fun @ fit.fun) / dof
    covariance = (noise_correlation((low, high), decay.fs, step) * variance
                  * np.linalg.pinv(fit.jac.T @ fit.jac)[2:, 2:])
    phi = 1.0 if shape is None else abs(float(shape))
    ends = reference * np.abs(_flow(fit.x, dt, index.size, centre, chosen)[0, [-1, 0]])
    return DecayFit(fit.x[2:2 + chosen], fit.x[2 + chosen:], covariance, reference, (float(ends[0]), float(ends[1])),
                    centre, (float(decay.t[head]), float(decay.t[last])), (low, high), phi,
                    float(np.sqrt(variance / 2)), source, alternative)
