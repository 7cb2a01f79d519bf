"""Modal fit of a (noisy) receptance: a smooth linear model of an extracted linear FRF.

The extracted linear FRF inherits the noise of the low-force sweep, amplified near the
linear resonance where ``|1/H^L|`` is small. Regenerating a hardening response on those
samples is fragile: the upper branch ends wherever one noisy sample lets it. A modal
model fitted to the whole band averages that noise out:

    H(ω) = Σ_r A_r / (ω_r² − ω² + i η_r ω_r²) + R − R_m/ω² + S ω²,

with complex modal constants A_r (m/N·rad²/s², complex to absorb non-proportional
damping and measurement phase), natural frequencies ω_r, loss factors η_r, a complex
residual R for the modes above the band and, optionally (``lower_residual``), a residual
mass term R_m/ω² for the modes below it and (``residual_slope``) the next term S ω² of
the modes above, A/(ω_a² − ω²) ≈ (A/ω_a²)(1 + ω²/ω_a²): a mode just above the band
bends the residual over it. On the demo's T-beam, one-mode fits of the exact receptance
over ±10 % put the 185.19 Hz mode 0.022 Hz high with R alone (modes at 215 and 219 Hz,
16 % above) and 0.001 Hz high with S ω². ω_r and η_r are found by nonlinear least
squares (variable projection: A_r and the residuals by linear least squares inside),
starting from :func:`nlupdate.core.correlation.metrics.natural_frequencies` (or given
frequencies) and a loss factor from the peak height; residuals are relative,
``(H_model − H)/|H|`` (docs/methods.md §8 noise).

A PRD-extracted linear FRF ``1/H^L = 1/H̃_1 − Δ_f1`` is noisiest exactly at its own
resonance, where ``|1/H^L|`` is small while the noise of ``1/H̃_1`` is not: with friction
stuck at low force (Δ_f1 = kf, often several times the structure's own stiffness there)
the peak can be buried in noise. Away from the peak, ``Re(1/H^L) ≈ k_r(1 − ω²/ω_r²)`` is
still well determined, and that is what locates the mode: :func:`resonance_crossings`
finds where a moving average of ``Re(1/H)`` falls through zero, and :func:`fit_mode_near`
fits one mode with both residual terms over a band around the crossing, weighting each point
by the noise of ``1/H`` (``inverse_noise``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.optimize
from numpy.typing import ArrayLike, NDArray

from nlupdate.core.correlation.metrics import natural_frequencies
from nlupdate.core.run_cache import remembered_in_run


@dataclass(frozen=True)
class ModalFit:
    """Fitted modal parameters: natural frequencies (Hz), loss factors, modal constants,
    upper residual R (m/N) and residual mass term R_m (m/N·rad²/s²);
    :meth:`receptance` evaluates the model (m/N)."""

    natural_frequencies_hz: NDArray[np.float64]
    loss_factors: NDArray[np.float64]
    modal_constants: NDArray[np.complex128]
    residual: complex
    relative_rms_error: float
    lower_residual: complex = 0j
    residual_slope: complex = 0j

    def receptance(self, frequency_hz: ArrayLike) -> NDArray[np.complex128]:
        w = 2 * np.pi * np.asarray(frequency_hz, dtype=float)[:, None]
        wr = 2 * np.pi * self.natural_frequencies_hz[None, :]
        modes = (self.modal_constants / (wr**2 - w**2 + 1j * self.loss_factors * wr**2)).sum(axis=1)
        return modes + self.residual_receptance(frequency_hz)

    def residual_receptance(self, frequency_hz: ArrayLike) -> NDArray[np.complex128]:
        """The share of the modes outside the fit (m/N): R − R_m/ω² + S ω². Over a narrow
        band its three terms are nearly collinear and only their sum is determined."""
        w = 2 * np.pi * np.asarray(frequency_hz, dtype=float)
        return self.residual - self.lower_residual / w**2 + self.residual_slope * w**2


def _basis(omega: NDArray, wr: NDArray, eta: NDArray, residual: bool, lower_residual: bool = False,
           residual_slope: bool = False) -> NDArray:
    """Columns: one per mode, then R, R_m and S as requested (S's column scaled by the
    band's top frequency, so that its coefficient is of the size of R's)."""
    columns = [1.0 / (wr[None, :] ** 2 - omega[:, None] ** 2 + 1j * eta[None, :] * wr[None, :] ** 2)]
    if residual:
        columns.append(np.ones((omega.size, 1)))
    if lower_residual:
        columns.append(-1.0 / omega[:, None] ** 2)
    if residual_slope:
        columns.append((omega[:, None] / omega.max()) ** 2)
    return np.concatenate(columns, axis=1)


def fit_modal_model(
    frequency_hz: ArrayLike,
    h: ArrayLike,
    n_modes: int | None = None,
    residual: bool = True,
    inverse_noise: ArrayLike | None = None,
    initial_hz: ArrayLike | None = None,
    lower_residual: bool = False,
    residual_slope: bool = False,
) -> ModalFit:
    """Fit ``n_modes`` modes (default: the peaks found in the band) and a residual.

    ``initial_hz``: start values of the natural frequencies (Hz) instead of the peaks of
    |H| (which a noisy FRF may put beside the resonance). ``lower_residual`` and
    ``residual_slope`` add the residual-mass and S ω² terms of the module docstring.

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
    peaks = natural_frequencies(f, hh, n_modes=n_modes) if initial_hz is None else np.atleast_1d(np.asarray(initial_hz, float))
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
        basis = _basis(omega, wr, eta, residual, lower_residual, residual_slope)
        matrix = basis * weights[:, None]
        norms = np.linalg.norm(matrix, axis=0)  # columns of unit norm: their scales differ by 1e8
        coefficients = np.linalg.lstsq(matrix / norms, hh * weights, rcond=None)[0] / norms
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
    # (given start frequencies are trusted: only the loss factor start varies)
    shifts = (0.0,) if initial_hz is not None else (0.0, -0.005, 0.005)
    starts = (np.clip(x0 + np.concatenate([np.full(n, df), np.full(n, de)]), lower + 1e-9, upper - 1e-9)
              for df in shifts for de in (0.0, np.log(2.0)))
    with np.errstate(all="ignore"):
        solution = min(
            (scipy.optimize.least_squares(objective, start, bounds=(lower, upper), method="trf") for start in starts),
            key=lambda candidate: candidate.cost,
        )
    if noise is not None:  # refine the modal constants with the inverse-domain residual too
        def full(z):
            wr, eta = np.exp(z[:n]), np.exp(z[n : 2 * n])
            c = z[2 * n :: 2] + 1j * z[2 * n + 1 :: 2]
            r = (1.0 / (_basis(omega, wr, eta, residual, lower_residual, residual_slope) @ c) - 1.0 / hh) / noise
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
        lower_residual=complex(coefficients[n + int(residual)]) if lower_residual else 0j,
        residual_slope=complex(coefficients[-1]) / omega.max() ** 2 if residual_slope else 0j,
    )


def resonance_crossings(frequency_hz: ArrayLike, h: ArrayLike, window: int | None = None) -> NDArray[np.float64]:
    """Frequencies (Hz, ascending) where ``Re(1/H)``, averaged over ``window`` neighbouring
    points, passes through zero: the resonances of a receptance. Near a mode
    ``1/H ≈ (k_r/A_r)(1 − ω²/ω_r²)``: it falls through zero for a positive modal constant
    (a point FRF) and rises through zero for a negative one (a transfer FRF across a
    node), so both directions count. ``Re(1/H)`` also changes sign at an antiresonance,
    through infinity (H → 0), which is no resonance. Two marks tell them apart, and a
    crossing with either is kept:

    * the valley: at a resonance ``|1/H|`` is at a minimum, at an antiresonance at a
      maximum — a crossing whose averaged ``|1/H|`` does not exceed its values a window
      away on both sides;
    * the damping's sign: ``Im(1/H) ≈ (k_r/A_r) η_r`` has the sign of the modal constant, so
      a resonance falls through zero where the averaged ``Im(1/H)`` is positive and rises
      where it is negative; an antiresonance goes the other way (a point FRF rises through
      its antiresonances, where ``Im(1/H) > 0``).

    Either alone loses modes of a noisy extracted FRF (the demo's T-beam at 5 % noise:
    near a broad mode the noise can lift ``|1/H|`` at the crossing above its sides, or
    flip the averaged damping), both together lose none of them there, and neither
    mark is carried by an antiresonance.

    ``window`` (odd; default about 1 % of the points, at least 5) averages out the noise
    of an extracted FRF; crossings closer than 3 % of their frequency are merged (noise
    makes one resonance cross several times). Each crossing is interpolated linearly.
    """
    f = np.asarray(frequency_hz, dtype=float)
    inverse = 1.0 / np.asarray(h, dtype=complex)
    z = inverse.real
    if window is None:
        window = max(5, (f.size // 100) | 1)
    if window < 1 or window % 2 == 0:
        raise ValueError(f"resonance_crossings: window must be an odd number of points, got {window}")
    if f.size < window + 2:
        raise ValueError(f"resonance_crossings: need more than {window + 1} frequencies, got {f.size}")
    smooth = np.convolve(z, np.ones(window) / window, mode="valid")
    centres = f[window // 2 : f.size - window // 2]
    changes = np.flatnonzero(((smooth[:-1] > 0) & (smooth[1:] <= 0)) | ((smooth[:-1] < 0) & (smooth[1:] >= 0)))
    magnitude = np.convolve(np.abs(inverse), np.ones(window) / window, mode="valid")
    sides = np.maximum(magnitude[np.maximum(changes - window, 0)], magnitude[np.minimum(changes + 1 + window, magnitude.size - 1)])
    valley = np.maximum(magnitude[changes], magnitude[changes + 1]) <= sides
    damping = np.convolve(inverse.imag, np.ones(window) / window, mode="valid")
    damped = (smooth[changes] > smooth[changes + 1]) == (damping[changes] + damping[changes + 1] > 0)
    zeros = changes[valley | damped]
    crossings = centres[zeros] + (centres[zeros + 1] - centres[zeros]) * smooth[zeros] / (
        smooth[zeros] - smooth[zeros + 1])
    merged: list[list[float]] = []
    for value in crossings:
        if merged and value - merged[-1][-1] <= 0.03 * value:
            merged[-1].append(float(value))
        else:
            merged.append([float(value)])
    return np.array([np.mean(group) for group in merged])


@remembered_in_run  # a validation fits the same lowest level for every set of kept levels that holds it
def fit_mode_near(
    frequency_hz: ArrayLike,
    h: ArrayLike,
    near_hz: float,
    inverse_noise: ArrayLike | None = None,
    band_fraction: float = 0.2,
    residual_slope: bool = False,
    lower_residual: bool = True,
) -> ModalFit:
    """One mode (with the residuals R and, with ``lower_residual``, R_m/ω², and S ω² with
    ``residual_slope``) fitted over ``near_hz·(1 ± band_fraction)``. S ω² pays where the band is wide and a mode lies
    just above it (module docstring); over a few per cent its column is nearly that of R
    and R_m/ω², and the modal constant loses its definition (examples/bolted_beam's input shape
    came out 4.9 for 2.8).

    The mode is started at the resonance crossing (:func:`resonance_crossings`) nearest
    to ``near_hz``, or at ``near_hz`` if the band has none. ``inverse_noise`` as for
    :func:`fit_modal_model` (the noise of ``1/H`` at each point; for an extracted FRF,
    ``|1/H̃_1|``). Raises ValueError when the band holds fewer than 8 points or the
    fitted natural frequency runs into the outer quarter of the band (no clear resonance:
    a noise-dominated fit).
    """
    if not 0 < band_fraction < 1:
        raise ValueError(f"band_fraction must be in (0, 1), got {band_fraction}")
    f = np.asarray(frequency_hz, dtype=float)
    hh = np.asarray(h, dtype=complex)
    band = np.abs(f - near_hz) <= band_fraction * near_hz
    if band.sum() < 8:
        raise ValueError(
            f"modal fit near {near_hz:.4g} Hz: only {int(band.sum())} measured point(s) within ±{100 * band_fraction:g} %; "
            f"need at least 8"
        )
    try:
        crossings = resonance_crossings(f[band], hh[band])
    except ValueError:
        crossings = np.array([])
    start = float(crossings[np.argmin(np.abs(crossings - near_hz))]) if crossings.size else float(near_hz)
    noise = None if inverse_noise is None else np.broadcast_to(np.asarray(inverse_noise, dtype=float), hh.shape)[band]
    fit = fit_modal_model(f[band], hh[band], n_modes=1, inverse_noise=noise, initial_hz=[start],
                          lower_residual=lower_residual, residual_slope=residual_slope)
    natural = float(fit.natural_frequencies_hz[0])
    if abs(natural - near_hz) > 0.75 * band_fraction * near_hz:
        raise ValueError(f"modal fit near {near_hz:.4g} Hz ran to the edge of its band ({natural:.4g} Hz): no clear "
                         f"resonance there")
    return fit


def fit_mode_over_band(frequency_hz: ArrayLike, h: ArrayLike, lower_residual: bool = True) -> ModalFit:
    """One mode fitted over a curve's whole measured band (:func:`fit_mode_near` about its
    largest |H|, the band as wide as the data on the wider side, at most ±90 %): the one-mode
    description of a stepped-sine curve or a response-controlled run."""
    f, hh = np.asarray(frequency_hz, dtype=float), np.asarray(h, dtype=complex)
    near = float(f[int(np.nanargmax(np.abs(hh)))])
    fraction = min(0.9, max(near - f.min(), f.max() - near) / near * 1.0001)
    return fit_mode_near(f, hh, near, band_fraction=fraction, lower_residual=lower_residual)
