"""The baseline a physics model must beat (docs/methods.md §10): interpolation in log-amplitude.

Each kept level is described by what its curve shows — its resonance frequency and
damping ratio (:mod:`nlupdate.core.validation.resonance`, the estimator every
comparison uses) and its peak, which give the modal constant of the one-mode curve
through them, ``|A| = max|H|·2ζω_n²√(1 − ζ²)`` (its phase from a one-mode fit,
:func:`nlupdate.core.identification.modal_fit.fit_mode_over_band`) — and by its amplitude, the
response amplitude at resonance ``a = max|H|·F`` (m for a receptance). A level not kept
takes ω, ζ and A interpolated linearly in ``log a`` between the two kept levels around it,
or extrapolated linearly from the two nearest for an end level (ζ kept above a tenth of the
smallest kept one); its own amplitude is unknown beforehand and solves
``a = F·max_Ω|H(Ω; a)|`` (bisection in log a). Its FRF is the one-mode curve
``A/(ω_n² − Ω² + 2iζω_nΩ)``: a linear FRF at each level, with no model of the joint at
all and no other modes (the residual terms of a one-mode fit to a distorted nonlinear
curve moved its peak by 0.07 Hz on a Jenkins SDOF). At a kept level it gives back that
level's resonance, damping and peak.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable, Sequence

import numpy as np
import scipy.optimize
from numpy.typing import ArrayLike, NDArray

from nlupdate.core.identification.modal_fit import ModalFit, fit_mode_over_band
from nlupdate.core.validation.resonance import resonance

if TYPE_CHECKING:
    from nlupdate.core.identification.data import FRFLevels

@dataclass(frozen=True)
class LevelFit:
    """One kept level: its level (reference unit), resonance amplitude (m), resonance (Hz),
    damping ratio, peak |H| and its one-mode fit (phase and residual terms)."""

    level: float
    amplitude: float
    resonance_hz: float
    damping_ratio: float
    peak_abs: float
    fit: ModalFit

    def values(self) -> dict[str, complex]:
        return {"resonance_hz": complex(self.resonance_hz), "damping_ratio": complex(self.damping_ratio),
                "constant": complex(self.constant)}

    @property
    def constant(self) -> complex:
        """The modal constant (m/N·rad²/s²) whose one-mode curve at this level's resonance
        and damping has its peak: ``|A| = max|H|·2ζω_n²√(1 − ζ²)``, the fit's phase."""
        zeta = self.damping_ratio
        natural = 2 * np.pi * self.resonance_hz / np.sqrt(max(1 - 2 * zeta**2, 1e-6))
        return self.peak_abs * 2 * zeta * natural**2 * np.sqrt(1 - zeta**2) * \
            np.exp(1j * np.angle(complex(self.fit.modal_constants[0])))


def fit_level(level: float, frequency_hz: ArrayLike, h: ArrayLike, force: ArrayLike | float | None = None) -> LevelFit:
    """What the baseline keeps of one measured curve (``force``: the force per line,
    default ``level``). Where the estimator gives none (too few lines, a jump, the peak at
    the band's edge), the damping ratio is the one-mode fit's (half its loss factor)."""
    f = np.asarray(frequency_hz, dtype=float)
    hh = np.asarray(h, dtype=complex)
    k = int(np.nanargmax(np.abs(hh)))
    fit = fit_mode_over_band(f, hh)
    shown = resonance(f, hh)
    zeta = shown.damping_ratio if np.isfinite(shown.damping_ratio) else float(fit.loss_factors[0]) / 2
    forces = np.broadcast_to(float(level) if force is None else np.asarray(force, dtype=float), f.shape)
    return LevelFit(float(level), float(np.abs(hh[k]) * forces[k]), shown.resonance_hz, zeta, shown.peak_abs, fit)


def baseline_fits(data: "FRFLevels", levels: Sequence[float]) -> list[LevelFit]:
    """The baseline's description of each of ``levels`` of ``data`` (:func:`fit_level`, the
    force achieved at each line)."""
    return [fit_level(v, *data.curve(v), data.force_at(v, data.curve(v)[0])) for v in levels]


def _interpolated(fits: list[LevelFit], log_a: float) -> Callable[[NDArray], NDArray[np.complex128]]:
    """The one-mode receptance (of frequency in Hz) with every quantity interpolated
    (extrapolated) in log a."""
    x = np.log([fit.amplitude for fit in fits])
    order = np.argsort(x)
    x = x[order]
    rows = [fits[i].values() for i in order]
    if log_a <= x[0]:
        pick = [0, 1]
    elif log_a >= x[-1]:
        pick = [x.size - 2, x.size - 1]
    else:
        upper = int(np.searchsorted(x, log_a))
        pick = [upper - 1, upper]
    x0, x1 = x[pick[0]], x[pick[1]]
    t = 0.0 if x1 == x0 else (log_a - x0) / (x1 - x0)
    v = {name: rows[pick[0]][name] + t * (rows[pick[1]][name] - rows[pick[0]][name]) for name in rows[0]}
    floor = 0.1 * min(fit.damping_ratio for fit in fits)  # an extrapolation may not reach 0
    zeta = max(v["damping_ratio"].real, floor)
    natural = 2 * np.pi * v["resonance_hz"].real / np.sqrt(max(1 - 2 * zeta**2, 1e-6))
    constant = v["constant"]

    def receptance(frequency_hz: NDArray) -> NDArray[np.complex128]:
        w = 2 * np.pi * np.asarray(frequency_hz, dtype=float)
        return constant / (natural**2 - w**2 + 2j * zeta * natural * w)

    return receptance


def baseline_frf(fits: list[LevelFit], level: float, frequency_hz: ArrayLike) -> NDArray[np.complex128]:
    """The baseline's receptance at ``level`` (module docstring) over ``frequency_hz``;
    needs two or more kept levels."""
    if len(fits) < 2:
        raise ValueError(f"the log-amplitude baseline needs two or more kept levels, got {len(fits)}")
    f = np.asarray(frequency_hz, dtype=float)
    fine = np.linspace(f.min(), f.max(), max(4 * f.size, 400))

    def mismatch(log_a: float) -> float:
        return log_a - np.log(float(level) * np.max(np.abs(_interpolated(fits, log_a)(fine))))

    amplitudes = np.log([fit.amplitude for fit in fits])
    low, high = amplitudes.min() - 5.0, amplitudes.max() + 5.0
    if mismatch(low) * mismatch(high) < 0:
        log_a = scipy.optimize.brentq(mismatch, low, high, xtol=1e-10)
    else:  # no self-consistent amplitude: scale the nearest level's amplitude by the force
        nearest = min(fits, key=lambda fit: abs(np.log(fit.level / float(level))))
        log_a = float(np.log(nearest.amplitude * float(level) / nearest.level))
    return _interpolated(fits, log_a)(f)


def baseline_at_response(fits: list[LevelFit], amplitude_m: float, frequency_hz: ArrayLike) -> NDArray[np.complex128]:
    """The baseline's receptance of a run that holds the response amplitude at
    ``amplitude_m`` (m, every line): the one-mode curve interpolated at that amplitude
    (module docstring; no self-consistency to solve)."""
    if len(fits) < 2:
        raise ValueError(f"the log-amplitude baseline needs two or more levels, got {len(fits)}")
    return _interpolated(fits, float(np.log(amplitude_m)))(np.asarray(frequency_hz, dtype=float))
