"""The physical bounds of an amplitude-dependent modal model's linear limit (f₀, ζ₀) and the
warnings of a fit that ends on them (:mod:`nlupdate.core.identification.amplitude_modal_fit`'s
module docstring: a joint only softens the mode and only adds damping as it slips)."""
from __future__ import annotations

from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.model.amplitude_modal import AmplitudeModalModel


class ModalSamples(Protocol):
    """What the bounds read of :class:`~nlupdate.core.identification.modal_samples.ModalSamples`."""

    amplitude: NDArray
    frequency_hz: NDArray
    damping_ratio: NDArray


#: a linear damping ratio below this is the fit's bound ζ₀ ≥ 0 reached, not a value (the transmitter
#: beam's polynomial fit ended at 1.377e-22, printed "1.377e-20 %")
ZETA_FLOOR = 1e-9
#: the words of the warning that f₀ is on (at or above) its upper physical bound; the reports
#: print such an f₀ as a one-sided "≥" (:mod:`nlupdate.reporting.model_numbers`)
F0_AT_UPPER_BOUND = "sits at or above its physical bound"


def zeta_text(zeta: float, digits: int = 4) -> str:
    """A damping ratio (fraction) as printed, in percent; at or below :data:`ZETA_FLOOR` it is its
    bound 0, which the samples do not determine, not a number."""
    if zeta <= ZETA_FLOOR:
        return "0 (at its bound ζ₀ ≥ 0: the samples do not determine it)"
    return f"{100 * zeta:.{digits}g} %"


def linear_limit_warnings(model: AmplitudeModalModel, samples: ModalSamples, frequency_std: float,
                          fitted_zeta: float | None = None, damping_std: float | NDArray = 0.05) -> tuple[str, ...]:
    """What is unphysical or undetermined about a fitted model's linear limit (module
    docstring): f₀ outside :func:`linear_limit_range` (an Iwan fit's bound: on it), ζ₀ ≤ 0,
    below 1 % of the damping ratio of the lowest-amplitude sample or at or above
    :func:`damping_cap`."""
    stiff = stiffening_warning(model, samples, frequency_std)  # said first
    out = list(stiff) + list(extrapolation_warning(model, samples, frequency_std, damping_std))
    low, high = (w / (2 * np.pi) for w in linear_limit_range(samples, frequency_std))
    f0 = model.natural_frequency_hz
    f_ref = float(samples.frequency_hz[np.argmin(samples.amplitude)])
    if f0 >= high - 1e-3 * (high - low):
        out.append(f"the linear limit {f0:.5g} Hz {F0_AT_UPPER_BOUND} {high:.5g} Hz (the lowest-amplitude "
                   f"sample's {f_ref:.5g} Hz plus the softening measured over all samples): the samples do not show "
                   f"the joint stuck at the lowest level, so they do not determine the linear limit; measure lower "
                   f"levels")
    elif f0 < low - 1e-3 * (high - low) and not stiff:
        out.append(f"the linear limit {f0:.5g} Hz lies below the highest sample's frequency "
                   f"{float(samples.frequency_hz.max()):.5g} Hz: the backbone stiffens, which a joint does not do")
    zeta = model.damping_ratio if fitted_zeta is None else fitted_zeta
    z_ref = float(samples.damping_ratio[np.argmin(samples.amplitude)])
    if zeta < 0.01 * z_ref:
        out.append(f"the linear damping ratio ζ₀ = {zeta_text(max(zeta, 0.0), 3)} is below 1 % of the damping measured "
                   f"at the lowest level ({100 * z_ref:.3g} %): the fit gives the joint all of the damping, and the data "
                   f"do not determine the linear damping" + (" (kept at 0)" if zeta < 0 else ""))
    elif zeta >= 0.999 * damping_cap(samples, damping_std):
        out.append(f"the linear damping ratio ζ₀ = {zeta_text(zeta, 3)} is at or above the damping measured at the lowest "
                   f"level ({100 * z_ref:.3g} %, its bound): the damping curve falls with amplitude from the linear "
                   f"limit, which a joint (it only adds damping as it slips) does not do; the samples do not determine "
                   f"ζ₀")
    return tuple(out)


#: the samples' frequency trend is a measured stiffening beyond this many of its standard errors
STIFFENING_LIMIT = 2.0

#: a backbone "rises" over the samples only by more than this fraction of its frequency: a
#: flat backbone's ends differ by the fit's round-off (42.8 Hz → 42.8 + 5e-14 Hz on one CPU's
#: BLAS kernels, 5e-14 lower on another's), which no measurement resolves
RISE_RESOLUTION = 1e-9


def frequency_trend(samples: ModalSamples, frequency_std: float | NDArray) -> tuple[float, float]:
    """(slope, standard error) of the samples' natural frequency (Hz) against their modal
    amplitude a (Hz per m·√kg), a straight line by least squares. The standard error is the
    larger of the residuals' own (n − 2 degrees of freedom, from 3 samples) and the one the
    relative noise ``frequency_std`` per sample gives: a trend is measured only beyond both the
    samples' scatter and the noise the fit assumes."""
    a, f = np.asarray(samples.amplitude, float), np.asarray(samples.frequency_hz, float)
    if a.size < 2 or np.ptp(a) <= 0:
        return 0.0, float("inf")
    sxx = float(np.sum((a - a.mean()) ** 2))
    slope = float(np.sum((a - a.mean()) * (f - f.mean())) / sxx)
    assumed = float(np.median(np.asarray(frequency_std, float) * f)) / np.sqrt(sxx)
    if a.size < 3:
        return slope, assumed
    residual = f - f.mean() - slope * (a - a.mean())
    return slope, max(assumed, float(np.sqrt(np.sum(residual ** 2) / (a.size - 2) / sxx)))


def stiffening_warning(model: AmplitudeModalModel, samples: ModalSamples,
                       frequency_std: float | NDArray) -> tuple[str, ...]:
    """A warning (empty when none) that the model's backbone rises over the measured amplitudes,
    which a joint in microslip does not do (it only softens). Judged by the samples' own trend
    (:func:`frequency_trend`), not a fixed fraction: a slope more than :data:`STIFFENING_LIMIT`
    standard errors above 0 is a measured stiffening (a hardening contact or geometric
    nonlinearity, or the test's repeatability drifting with the levels — not a joint's
    microslip); a model that rises over the samples while their slope is within its error (the
    BRB's four force levels: 80.26, 80.04, 80.26, 80.33 Hz, slope +0.048 ± 0.067 Hz per
    10⁻⁴ m·√kg, and the polynomial's 80.15 → 80.31 Hz) shows no softening: its rise is the form
    following the scatter, or a hardening the samples cannot tell from it. A softening model
    says nothing."""
    a = np.asarray(samples.amplitude, float)
    if a.size < 2:
        return ()
    ends = np.array([a.min(), a.max()])
    f_low, f_high = (float(v) for v in model.frequency_hz(ends))
    slope, std = frequency_trend(samples, frequency_std)
    t = slope / std
    trend = (f"the samples' straight line changes their frequency by {slope * np.ptp(a):+.3g} Hz over their "
             f"amplitudes {ends[0]:.3g}–{ends[1]:.3g} ({t:+.2g} standard errors of its slope)")
    if t > STIFFENING_LIMIT:
        return (f"the backbone stiffens over the measured amplitudes, beyond the samples' noise: {trend}, the model "
                f"{f_low:.6g} → {f_high:.6g} Hz; a joint in microslip only softens, so this is a hardening contact "
                f"(or geometric stiffening) or the test's repeatability drifting with the levels, not the joint's "
                f"microslip: the model's joint parameters and linear limit do not describe a friction joint",)
    if f_high - f_low > RISE_RESOLUTION * f_low and t > -STIFFENING_LIMIT:
        return (f"the model's backbone rises over the measured amplitudes, {f_low:.6g} → {f_high:.6g} Hz, which a joint "
                f"in microslip does not do (it only softens), while {trend}: not beyond their scatter, so the rise is "
                f"the backbone form following the test's repeatability, or a hardening contact these samples cannot "
                f"tell from it — not the joint's microslip; the samples show no softening beyond their scatter",)
    return ()


#: the linear limit is reported as extrapolated beyond this many standard errors of the
#: lowest-amplitude sample from the model's value there
EXTRAPOLATION_LIMIT = 3.0


def extrapolation_warning(model: AmplitudeModalModel, samples: ModalSamples,
                          frequency_std: float | NDArray, damping_std: float | NDArray = 0.05) -> tuple[str, ...]:
    """Warnings (empty when none) that the model's linear limit f₀ (a → 0) — or its linear
    damping ratio ζ₀ — lies more than :data:`EXTRAPOLATION_LIMIT` standard errors of the
    lowest-amplitude sample away from the model's own value at that sample's amplitude: it is
    then the backbone form's (the damping curve's) extrapolation below every sample, not a
    measurement. The damping curve is checked alike (``damping_std`` relative): on the
    transmitter beam (docs/validation.md) the frequency moved 0.09 % over the levels, within
    the default 0.1 % per sample, while the damping curve through 0.035–0.068 % reached
    ζ₀ = 0.001 % at a → 0, 19 standard errors below its value at the lowest level, unstated. A joint in microslip keeps softening down to a → 0
    (an Iwan joint: by a^(1+χ)), so an impact or low-level pole at a nonzero amplitude is not
    the linear limit either (the Iwan SDOF of tests/test_ring_down.py, χ = −0.5: 10.4720 Hz at 1 %
    of its slip amplitude, 10.4881 Hz at a → 0, 0.15 % apart; tests/test_amplitude_extrapolation.py);
    a stuck joint does not.

    The polynomial backbone only: a modal joint's (``iwan``, ``jenkins``) f₀ is its stuck limit,
    extrapolated by the joint's own law and held physical by :func:`linear_limit_range` (a
    Jenkins SDOF slipping at every level: the Iwan fit's f₀ 81.88 Hz, 0.56 Hz above its lowest
    level, against the stuck truth's 81.98 Hz; tests/test_validate.py)."""
    if model.joint is not None:
        return ()
    lowest = int(np.argmin(samples.amplitude))
    a_low = float(samples.amplitude[lowest])
    std = float(np.broadcast_to(np.asarray(frequency_std, float), samples.amplitude.shape)[lowest])
    z_std = float(np.broadcast_to(np.asarray(damping_std, float), samples.amplitude.shape)[lowest])
    f_low = float(model.frequency_hz(np.array([a_low]))[0])
    z_low = float(model.damping(np.array([a_low]))[0])
    f0, z0 = model.natural_frequency_hz, model.damping_ratio
    gap = (f0 - f_low) / (std * f_low)
    z_gap = (z0 - z_low) / (z_std * z_low) if z_low > 0 else 0.0
    out = []
    if abs(gap) > EXTRAPOLATION_LIMIT:
        out.append(f"the linear limit {f0:.6g} Hz is the backbone's extrapolation below every sample: {f0 - f_low:+.3g} "
                   f"Hz ({gap:+.3g} standard errors of the lowest-amplitude sample, "
                   f"{float(samples.frequency_hz[lowest]):.6g} Hz at {a_low:.3g} m·√kg) from the model there; the data "
                   f"do not show the mode linear (a joint in microslip keeps softening towards a → 0, a stuck one does "
                   f"not): quote the model at that amplitude, or measure lower")
    if abs(z_gap) > EXTRAPOLATION_LIMIT:
        out.append(f"the linear damping ratio ζ₀ = {zeta_text(z0)} is the damping curve's extrapolation below every "
                   f"sample: {100 * (z0 - z_low):+.3g} % ({z_gap:+.3g} standard errors of the lowest-amplitude sample, "
                   f"{100 * float(samples.damping_ratio[lowest]):.4g} % at {a_low:.3g} m·√kg) from the model there; "
                   f"the data do not determine the linear damping: quote the model at that amplitude, or measure lower")
    return tuple(out)


def damping_cap(samples: ModalSamples, damping_std: float | NDArray = 0.05) -> float:
    """The highest physical linear damping ratio ζ₀: the lowest-amplitude sample's damping
    ratio plus three of its relative standard deviations (a joint only adds damping)."""
    z_ref = float(samples.damping_ratio[np.argmin(samples.amplitude)])
    return z_ref * (1 + 3 * float(np.median(damping_std)))


#: with ``form_extrapolates``, the highest linear limit is this factor above the highest sample's
#: frequency: a joint stuck at most as stiff as the rest of the mode (K_T ≤ ω∞², a guard only)
FORM_REACH = float(np.sqrt(2.0))


def linear_limit_range(samples: ModalSamples, frequency_std: float,
                       form_extrapolates: bool = False) -> tuple[float, float]:
    """(lowest, highest) linear limit ω₀ (rad/s) that is physical for these samples (module
    docstring): at or above every sample, and above the lowest-amplitude one by no more than
    the softening measured over all of them.

    ``form_extrapolates`` (the ``jenkins`` backbone): no softening cap — the form carries the
    stuck frequency below the samples itself. Its softening below the lowest sample at u × the
    slip amplitude is K_T(1 − r(u)), r = Re ν/K_T, over the samples only K_T(r(u) − r(u_max)):
    2.7 × less with samples from 3 to 15 × (r(3) = 0.29, r(15) = 0.03), and less still the
    further they lie into macroslip, so the cap excluded the truth of a ring-down whose samples
    start at 3 × and its fit missed the damping by 13–20 % (docs/ring-down.md); the highest
    ω₀ is then :data:`FORM_REACH` × the highest sample's."""
    f = samples.frequency_hz
    f_ref = float(f[np.argmin(samples.amplitude)])
    typical = float(np.median(frequency_std))  # one value, or the median of each sample's
    margin = max((float(f.max()) - float(f.min())) / f_ref, 3 * typical)
    low = 2 * np.pi * float(f.max()) * (1 - 3 * typical)
    if form_extrapolates:
        return low, 2 * np.pi * float(f.max()) * FORM_REACH
    return low, 2 * np.pi * f_ref * (1 + margin)
