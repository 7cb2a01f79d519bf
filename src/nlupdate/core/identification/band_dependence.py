"""Whether the band a user chose changes the stepped sine's backbone samples.

``nlupdate amplitude --band`` (a study's ``[amplitude] band_hz``) leaves out the measured
lines outside the band before any step, and each force level's sample (its resonance
frequency, amplitude and damping ratio:
:func:`~nlupdate.core.identification.modal_samples.samples_from_frfs`) is read from
what is left. A band cut into the resonance changes that reading: the other modes' share and
the modal constant (the shape φ_f when it is not given) are read from the lines near each
level's top (:mod:`~nlupdate.core.identification.level_residual`), which the band may cut, and
a level whose peak lies outside the band is read at the band's edge. On the Brake–Reuss beam
(tests/data/brb, 41 lines over 79.2–81.2 Hz) ``--band 80.1:80.5`` moves the four damping
ratios by −10, +6, +27 and +35 % and ``--band 80:80.6`` by −2.1, −2.3, +0.8 and +3.3 %
(measured; the latter −25, −17, −4 and −8 % while the share came from a one-mode fit of the
lowest level), with no sign of it in the output before this check (docs/ring-down.md, "A band
cut into the resonance").

:func:`band_changes` reads the samples again on the lines the file gives without the band
(``whole``: the file's excited band, as the command reads it without ``--band``) and compares,
level by level, the band's damping ratio ζ_band with the whole band's at the same response
amplitude x (the resonance amplitude at the excited coordinate, which no shape estimate
scales): the whole band's samples interpolated linearly in (log x, log ζ), extended by the
end samples' slope. A sample that only moves along the damping curve is then not a change.
A change is reported when it exceeds both :data:`NOISE_SCORE` standard deviations of what
the measurement's noise alone changes it by — the same comparison repeated on
:data:`NOISE_DRAWS` copies of the whole band with complex noise at each level's estimated
relative noise (:func:`~nlupdate.core.measurement.noise.estimate_noise_fraction`; 0 when a
level has too few lines to estimate it) — and :data:`MIN_CHANGE`, the accuracy a damping
sample is asked for (:data:`~nlupdate.core.identification.amplitude_joint.POOR_FIT`): the
BRB's noise is 0.2–0.5 %, and a cut band changes its damping by more than that noise's own
effect (``NOISE_SCORE`` standard deviations: 0.17–0.52 %), −2.9 … +3.0 % for 79.2–80.6 Hz (none
named). The whole band itself is never
compared (nothing left out, nothing changed).

Each noisy copy's share (:func:`~nlupdate.core.identification.level_residual.frf_residual`) is
fitted from one start, the end the clean reading of the same lines reached, not from the
:data:`~nlupdate.core.identification.level_residual.STARTS`: the draws measure how far the noise
alone moves the damping about the minimum the clean data reach. The four starts exist to find the
smallest of the clean data's separate minima (the BRB cut to 80–80.6 Hz has them:
tests/test_level_residual.py); a noisy copy that jumped to another minimum would mix the band's
ill-determination — which :attr:`~nlupdate.core.identification.level_residual.LevelResidual.at_bound`
and :func:`~nlupdate.core.identification.level_residual.bound_warning` already report — into the
noise's spread. On the BRB ``--band 80.1:80.5`` (the slope S on its bound) that spread fell from
±4.3, 5.3, 17 and 18 % to ±1.4, 2.3, 5.1 and 4.6 % (the same four levels named), with 76 fits of the
share instead of 256; for 79.2–80.6 Hz (one minimum) the spreads above are the same to the digits shown.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.level_residual import frf_residual
from nlupdate.core.identification.modal_samples import ModalSamples, samples_from_frfs
from nlupdate.core.measurement.band import in_band
from nlupdate.core.measurement.noise import estimate_noise_fraction
from nlupdate.core.model.amplitude_modal import AmplitudeModelError
from nlupdate.core.run_cache import one_run

#: relative change of a damping ratio below which a band's effect is not reported: the damping
#: accuracy asked of a sample (amplitude_joint.POOR_FIT, 5 %)
MIN_CHANGE = 0.05
#: a change is reported beyond this many standard deviations of what the noise alone changes
NOISE_SCORE = 2.0
#: noisy copies of the whole band the noise's effect is measured on
NOISE_DRAWS = 30


@dataclass(frozen=True)
class BandChange:
    """One force level's damping ratio read on the band and on the whole band.

    level: the force level (the reference unit); frequency_hz: the band's resonance (Hz);
    band_damping: ζ of the band's sample; whole_damping: ζ of the whole band's samples at
    the same response amplitude; change: ``band_damping/whole_damping − 1``; noise: the
    standard deviation of that change from the measurement's noise alone."""

    level: float
    frequency_hz: float
    band_damping: float
    whole_damping: float
    change: float
    noise: float

    @property
    def significant(self) -> bool:
        return abs(self.change) > max(NOISE_SCORE * self.noise, MIN_CHANGE)


def _whole_at(whole: ModalSamples, amplitude: np.ndarray) -> np.ndarray:
    """The whole band's damping ratios at the response ``amplitude``s: linear in (log x,
    log ζ) between its samples, extended by the end samples' slope."""
    x, z = np.log(whole.response_amplitude), np.log(whole.damping_ratio)
    order = np.argsort(x)
    x, z = x[order], z[order]
    t = np.log(amplitude)
    inside = np.interp(t, x, z)
    if x.size < 2 or x[-1] == x[0]:
        return np.exp(inside)
    low = z[0] + (t - x[0]) * (z[1] - z[0]) / (x[1] - x[0])
    high = z[-1] + (t - x[-1]) * (z[-1] - z[-2]) / (x[-1] - x[-2])
    return np.exp(np.where(t < x[0], low, np.where(t > x[-1], high, inside)))


def _relative_changes(whole: ModalSamples, band: ModalSamples, levels: np.ndarray) -> np.ndarray:
    """``ζ_band/ζ_whole(x_band) − 1`` at each of ``levels`` (NaN where the band has no sample)."""
    out = np.full(levels.size, np.nan)
    for i, level in enumerate(levels):
        at = np.flatnonzero(np.isclose(band.level, level, rtol=1e-9))
        if at.size:
            k = at[0]
            out[i] = band.damping_ratio[k] / _whole_at(whole, band.response_amplitude[k:k + 1])[0] - 1
    return out


def _noise_levels(data: FRFLevels) -> np.ndarray:
    """Each level's relative noise (0 where the curve is too short to estimate it)."""
    out = []
    for f, h in zip(data.frequencies, data.receptances):
        try:
            out.append(estimate_noise_fraction(f, h))
        except ValueError:
            out.append(0.0)
    return np.array(out)


def band_changes(whole: FRFLevels, band: FRFLevels, band_hz: tuple[float, float], input_shape: float | None = None,
                 seed: int = 0) -> list[BandChange]:
    """The damping ratio of each level of ``band`` (the FRFs the band keeps) against
    ``whole`` (the lines the file gives without the band) at the same response amplitude,
    with the noise's own effect (module docstring); ``input_shape`` as the samples are read
    (None: from the modal constant of every level at once,
    :func:`~nlupdate.core.identification.level_residual.frf_residual`); each noisy copy's share
    fitted from the clean reading's end (module docstring). Empty when the band leaves out none of
    ``whole``'s lines or either reading has no samples."""
    if all(in_band(f, band_hz).all() for f in whole.frequencies):
        return []
    try:
        with one_run():  # the clean shares the samples were read with, fitted once
            reference = samples_from_frfs(whole, input_shape)
            cut = samples_from_frfs(band, input_shape)
            whole_share, band_share = frf_residual(whole)[1], frf_residual(band)[1]
    except (AmplitudeModelError, ValueError):
        return []
    levels = cut.level
    observed = _relative_changes(reference, cut, levels)
    rng = np.random.default_rng(seed)
    sigma = _noise_levels(whole)
    draws = []
    for _ in range(NOISE_DRAWS):
        noisy = dataclasses.replace(whole, receptances=tuple(
            h * (1 + s * (rng.standard_normal(h.size) + 1j * rng.standard_normal(h.size)) / np.sqrt(2))
            for h, s in zip(whole.receptances, sigma)))
        try:
            draws.append(_relative_changes(samples_from_frfs(noisy, input_shape, start=whole_share),
                                           samples_from_frfs(noisy.within(band_hz), input_shape, start=band_share),
                                           levels))
        except (AmplitudeModelError, ValueError):
            continue
    spread = np.nanstd(np.array(draws), axis=0) if len(draws) > 1 else np.zeros(levels.size)
    changes = []
    for i, level in enumerate(levels):
        if np.isfinite(observed[i]):
            changes.append(BandChange(float(level), float(cut.frequency_hz[i]), float(cut.damping_ratio[i]),
                                      float(cut.damping_ratio[i] / (1 + observed[i])), float(observed[i]),
                                      float(spread[i]) if np.isfinite(spread[i]) else 0.0))
    return changes


def band_warning(changes: list[BandChange], band_hz: tuple[float, float], whole_hz: tuple[float, float],
                 unit: str = "N") -> str | None:
    """One warning naming the levels whose damping the band changes beyond the noise and
    :data:`MIN_CHANGE` (None when none does)."""
    found = [c for c in changes if c.significant]
    if not found:
        return None
    each = "; ".join(f"{c.level:g} {unit}: {100 * c.band_damping:.4g} % against {100 * c.whole_damping:.4g} % "
                     f"({100 * c.change:+.3g} %, noise alone ±{100 * NOISE_SCORE * c.noise:.2g} %)" for c in found)
    return (f"the band {band_hz[0]:g}–{band_hz[1]:g} Hz changes the stepped sine's damping ratios from what the "
            f"file's {whole_hz[0]:g}–{whole_hz[1]:g} Hz gives at the same response amplitude — {each}: the samples "
            f"depend on where the band ends (the other modes' share and the shape read from the levels' "
            f"tops, or a level's peak, are read differently); widen the band, or leave --band (band_hz) out")
