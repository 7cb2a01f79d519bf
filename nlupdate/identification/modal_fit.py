"""Modal fit of a (noisy) receptance: a smooth linear model of an extracted linear FRF.

The extracted linear FRF inherits the noise of the low-force sweep, amplified near the
linear resonance where ``|1/H^L|`` is small. Regenerating a hardening response on those
samples is fragile: the upper branch ends wherever one noisy sample lets it. A modal
model fitted to the whole band averages that noise out:

    H(ω) = Σ_r A_r / (ω_r² − ω² + i η_r ω_r²) + R,

with complex modal constants A_r (m/N·rad²/s², complex to absorb non-proportional
damping and measurement phase), natural frequencies ω_r, loss factors η_r and a complex
residual R for the modes outside the band. ω_r and η_r are found by nonlinear least
squares (variable projection: A_r and R by linear least squares inside), starting from
:func:`nlupdate.correlation.metrics.natural_frequencies` and a loss factor from
the peak height; residuals are relative, ``(H_model − H)/|H|`` (METHODS §8 noise).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.optimize
from numpy.typing import ArrayLike, NDArray

from nlupdate.correlation.metrics import natural_frequencies


@dataclass(frozen=True)
class ModalFit:
    """Fitted modal parameters: natural frequencies (Hz), loss factors, modal constants and
    residual; :meth:`receptance` evaluates the model (m/N)."""

    natural_frequencies_hz: NDArray[np.float64]
    loss_factors: NDArray[np.float64]
    modal_constants: NDArray[np.complex128]
    residual: complex
    relative_rms_error: float

    def receptance(self, frequency_hz: ArrayLike) -> NDArray[np.complex128]:
        w = 2 * np.pi * np.asarray(frequency_hz, dtype=float)[:, None]
        wr = 2 * np.pi * self.natural_frequencies_hz[None, :]
        return (self.modal_constants / (wr**2 - w**2 + 1j * self.loss_factors * wr**2)).sum(axis=1) + self.residual


def _basis(omega: NDArray, wr: NDArray, eta: NDArray, residual: bool) -> NDArray:
    columns = 1.0 / (wr[None, :] ** 2 - omega[:, None] ** 2 + 1j * eta[None, :] * wr[None, :] ** 2)
    if residual:
        columns = np.concatenate([columns, np.ones((omega.size, 1))], axis=1)
    return columns


def fit_modal_model(
    frequency_hz: ArrayLike,
    h: ArrayLike,
    n_modes: int | None = None,
    residual: bool = True,
    inverse_noise: ArrayLike | None = None,
) -> ModalFit:
    """Fit ``n_modes`` modes (default: the peaks found in the band) and a residual.

    ``inverse_noise``: standard deviation (any common scale) of the noise of ``1/H`` at
    each point, when known. For a PRD-extracted FRF ``1/H^L = 1/H̃_1 − Δ_f1`` the noise of
    ``1/H^L`` is that of ``1/H̃_1``, i.e. ∝ ``|1/H̃_1|`` — *not* ∝ ``|1/H^L|``: near the
    linear resonance it is much larger than ``|1/H^L|``, and a fit with relative
    residuals would be biased (on §3.1 with 5 % noise the loss factor comes out ~30 %
    high). With ``inverse_noise`` the residuals are ``(1/H_model − 1/H)/inverse_noise``.
    """
    f = np.asarray(frequency_hz, dtype=float)
    hh = np.asarray(h, dtype=complex)
    keep = np.isfinite(hh)
    noise = None if inverse_noise is None else np.broadcast_to(np.asarray(inverse_noise, dtype=float), hh.shape)[keep]
    f, hh = f[keep], hh[keep]
    peaks = natural_frequencies(f, hh, n_modes=n_modes)
    if peaks.size == 0:
        raise ValueError("modal fit: no resonance peak in the band")
    omega = 2 * np.pi * f
    weights = 1.0 / np.abs(hh)
    eta0 = []
    for fr in peaks:  # loss factor from the peak height of an SDOF with the line-fit stiffness
        k = np.argmin(np.abs(f - fr))
        eta0.append(float(np.clip(np.abs((1.0 / hh[k]).imag) / max(abs((1.0 / hh[max(k - 5, 0)]).real), 1e-300),
                                  1e-4, 0.3)))
    x0 = np.concatenate([np.log(2 * np.pi * peaks), np.log(eta0)])
    n = peaks.size

    def solve_linear(x):
        wr, eta = np.exp(x[:n]), np.exp(x[n:])
        basis = _basis(omega, wr, eta, residual)
        coefficients = np.linalg.lstsq(basis * weights[:, None], hh * weights, rcond=None)[0]
        return basis, coefficients

    def objective(x):
        basis, coefficients = solve_linear(x)
        model = basis @ coefficients
        if noise is None:
            r = (model - hh) * weights
        else:
            r = (1.0 / model - 1.0 / hh) / noise
        return np.concatenate([r.real, r.imag])

    # a few starts around the peak estimates: a noisy peak can sit beside the resonance
    # natural frequencies stay in the measured band, loss factors in [1e-5, 1]
    lower = np.concatenate([np.full(n, np.log(omega.min())), np.full(n, np.log(1e-5))])
    upper = np.concatenate([np.full(n, np.log(omega.max())), np.zeros(n)])
    starts = (np.clip(x0 + np.concatenate([np.full(n, df), np.full(n, de)]), lower + 1e-9, upper - 1e-9)
              for df in (0.0, -0.005, 0.005) for de in (0.0, np.log(2.0)))
    with np.errstate(all="ignore"):
        solution = min(
            (scipy.optimize.least_squares(objective, start, bounds=(lower, upper), method="trf") for start in starts),
            key=lambda candidate: candidate.cost,
        )
    if noise is not None:  # refine the modal constants with the inverse-domain residual too
        def full(z):
            wr, eta = np.exp(z[:n]), np.exp(z[n : 2 * n])
            c = z[2 * n :: 2] + 1j * z[2 * n + 1 :: 2]
            r = (1.0 / (_basis(omega, wr, eta, residual) @ c) - 1.0 / hh) / noise
            return np.concatenate([r.real, r.imag])

        _, c0 = solve_linear(solution.x)
        z0 = np.concatenate([solution.x, np.column_stack([c0.real, c0.imag]).ravel()])
        scale = np.maximum(np.abs(z0), 1e-12 * np.max(np.abs(z0[2 * n :])))
        with np.errstate(all="ignore"):
            refined = scipy.optimize.least_squares(lambda q: full(q * scale), z0 / scale, method="lm")
        z = refined.x * scale
        start_fun = full(z0)
        # keep the refinement only if it stayed finite, improved the fit and kept the
        # natural frequencies in the measured band (a noisy sweep can make it run away)
        in_band = np.all((np.exp(z[:n]) >= omega.min()) & (np.exp(z[:n]) <= omega.max()))
        if not (np.all(np.isfinite(refined.fun)) and in_band and refined.cost <= 0.5 * np.sum(start_fun**2)):
            z, refined_fun = z0, start_fun
        else:
            refined_fun = refined.fun
        solution_x, coefficients = z[: 2 * n], z[2 * n :: 2] + 1j * z[2 * n + 1 :: 2]
        fun = refined_fun
    else:
        solution_x, fun = solution.x, solution.fun
        _, coefficients = solve_linear(solution_x)
    order = np.argsort(solution_x[:n])
    rms = float(np.sqrt(np.mean(fun**2) * 2))
    return ModalFit(
        natural_frequencies_hz=np.exp(solution_x[:n])[order] / (2 * np.pi),
        loss_factors=np.exp(solution_x[n:])[order],
        modal_constants=coefficients[:n][order],
        residual=complex(coefficients[n]) if residual else 0j,
        relative_rms_error=rms,
    )
