"""Correlation metrics between measured and computed FRFs and modes (docs/methods.md §7).

Shared by identification (regenerated vs measured FRFs) and updating (model vs test).
Frequencies are in Hz, receptances in m/N; every function works on plain arrays.

* :func:`frac` — Frequency Response Assurance Criterion of two FRFs on one grid.
* :func:`mac_matrix` — Modal Assurance Criterion between two sets of mode shapes.
* :func:`natural_frequency_error` — relative error in %.
* :func:`peak` / :func:`peak_errors` — peak frequency and amplitude of |H|, interpolated.
* :func:`natural_frequencies` — natural frequencies of an FRF by the line-fit
  (Dobson) method, peaks located on a smoothed copy: near each peak of |H|, ``Re(1/H)`` is a straight line in ω² for a
  lightly damped mode, ``Re(1/H) ≈ k_r(1 − ω²/ω_r²)``; its zero crossing is ω_r. This
  is exact for an isolated mode with structural or viscous damping and averages the
  noise over the fitted points, unlike the raw peak location.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nlupdate.core.measurement.noise import smooth_inverse_receptance


#: What FRAC is, for a reader who meets the word.
FRAC_MEANING = "frequency response assurance criterion (1 = identical curve shapes)"


def frac(h_measured: ArrayLike, h_model: ArrayLike) -> float:
    """FRAC ``|H_Xᴴ H_A|² / ((H_Xᴴ H_X)(H_Aᴴ H_A))`` (0..1) of two FRFs on the same grid.

    NaN points (e.g. frequencies a regeneration could not solve) are excluded from both.
    """
    x = np.asarray(h_measured, dtype=complex).ravel()
    a = np.asarray(h_model, dtype=complex).ravel()
    if x.shape != a.shape:
        raise ValueError(f"FRAC: the FRFs have {x.size} and {a.size} points; they must share one grid")
    keep = np.isfinite(x) & np.isfinite(a)
    x, a = x[keep], a[keep]
    denominator = np.vdot(x, x).real * np.vdot(a, a).real
    return float(abs(np.vdot(x, a)) ** 2 / denominator) if denominator > 0 else 0.0


def mac_matrix(phi_a: ArrayLike, phi_b: ArrayLike) -> NDArray[np.float64]:
    """MAC between every column of ``phi_a`` (n × p) and of ``phi_b`` (n × q): shape (p, q).

    ``MAC = |φ_aᴴ φ_b|² / ((φ_aᴴ φ_a)(φ_bᴴ φ_b))``, 0..1; a zero vector gives 0.
    """
    a = np.asarray(phi_a)
    b = np.asarray(phi_b)
    a = a[:, None] if a.ndim == 1 else a
    b = b[:, None] if b.ndim == 1 else b
    if a.shape[0] != b.shape[0]:
        raise ValueError(f"MAC: mode shapes have {a.shape[0]} and {b.shape[0]} coordinates")
    cross = np.abs(a.conj().T @ b) ** 2
    norms = np.outer(np.sum(np.abs(a) ** 2, axis=0), np.sum(np.abs(b) ** 2, axis=0))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(norms > 0, cross / np.where(norms > 0, norms, 1.0), 0.0)


def natural_frequency_error(reference_hz: ArrayLike, model_hz: ArrayLike) -> NDArray[np.float64]:
    """``100·(f_model − f_reference)/f_reference`` (%), element-wise."""
    reference = np.asarray(reference_hz, dtype=float)
    model = np.asarray(model_hz, dtype=float)
    if np.any(reference <= 0):
        raise ValueError("natural_frequency_error: reference frequencies must be > 0 Hz")
    return 100.0 * (model - reference) / reference


def _check_frf(frequency_hz: ArrayLike, h: ArrayLike) -> tuple[NDArray, NDArray]:
    f = np.asarray(frequency_hz, dtype=float)
    hh = np.asarray(h, dtype=complex)
    if f.ndim != 1 or f.shape != hh.shape:
        raise ValueError(f"FRF: frequency has shape {f.shape} and H has shape {hh.shape}; expected equal 1-D")
    if f.size < 3 or np.any(np.diff(f) <= 0):
        raise ValueError("FRF: need at least 3 strictly increasing frequencies")
    return f, hh


def peak(frequency_hz: ArrayLike, h: ArrayLike) -> tuple[float, float]:
    """Frequency (Hz) and amplitude (m/N) of the largest |H|, by a parabola through the
    three samples around the maximum of |H| (ignores NaN samples)."""
    f, hh = _check_frf(frequency_hz, h)
    magnitude = np.where(np.isfinite(hh), np.abs(hh), -np.inf)
    k = int(np.argmax(magnitude))
    if 0 < k < f.size - 1 and np.all(np.isfinite(magnitude[k - 1 : k + 2])):
        coefficients = np.polyfit(f[k - 1 : k + 2] - f[k], magnitude[k - 1 : k + 2], 2)
        if coefficients[0] < 0:
            shift = -coefficients[1] / (2 * coefficients[0])
            if abs(shift) <= max(f[k + 1] - f[k], f[k] - f[k - 1]):
                return float(f[k] + shift), float(np.polyval(coefficients, shift))
    return float(f[k]), float(magnitude[k])


@dataclass(frozen=True)
class PeakErrors:
    """Peak of the model FRF relative to the reference: frequency error (Hz and %) and
    amplitude error (%)."""

    reference_hz: float
    model_hz: float
    frequency_error_hz: float
    frequency_error_percent: float
    reference_amplitude: float
    model_amplitude: float
    amplitude_error_percent: float


def peak_errors(frequency_hz: ArrayLike, h_reference: ArrayLike, h_model: ArrayLike) -> PeakErrors:
    """Peak frequency and amplitude errors of ``h_model`` against ``h_reference`` (one grid)."""
    f_ref, a_ref = peak(frequency_hz, h_reference)
    f_mod, a_mod = peak(frequency_hz, h_model)
    return PeakErrors(
        f_ref, f_mod, f_mod - f_ref, 100.0 * (f_mod - f_ref) / f_ref,
        a_ref, a_mod, 100.0 * (a_mod - a_ref) / a_ref,
    )


def natural_frequencies(
    frequency_hz: ArrayLike,
    h: ArrayLike,
    n_modes: int | None = None,
    half_width: float = 0.01,
    prominence: float = 1.5,
    smoothing_window: int = 9,
) -> NDArray[np.float64]:
    """Natural frequencies (Hz, ascending) of the peaks of a receptance FRF.

    Peaks are located on a smoothed copy of the FRF (local quadratic fits of ``1/H`` over
    ``smoothing_window`` points, see :func:`nlupdate.core.identification.data.smooth_inverse_receptance`;
    0 or fewer points than the window: no smoothing) so that noise spikes are not taken for
    modes, as the local maxima of |H| standing out by a factor ``prominence`` from the
    surrounding minima (``scipy.signal.find_peaks`` prominence on log|H|); the ``n_modes``
    largest if given. For each, ``Re(1/H)`` of the *unsmoothed* data is fitted by a
    straight line in ω² over ±``half_width`` (relative) around the peak and its zero is
    returned (line-fit method, see module docstring); if the line has no zero in that
    band the interpolated peak frequency is returned.
    """
    f, hh = _check_frf(frequency_hz, h)
    finite = np.isfinite(hh)
    f, hh = f[finite], hh[finite]
    located = hh
    if smoothing_window and f.size >= smoothing_window:
        located = 1.0 / smooth_inverse_receptance(f, hh, smoothing_window)
    log_magnitude = np.log(np.maximum(np.abs(located), 1e-300))
    import scipy.signal  # here: importing it costs 0.3 s (it imports scipy.stats)

    peaks, _ = scipy.signal.find_peaks(log_magnitude, prominence=np.log(prominence))
    peaks = sorted(peaks, key=lambda k: -log_magnitude[k])
    if n_modes is not None:
        peaks = peaks[:n_modes]
    result = []
    for k in peaks:
        value = peak(f[k - 1 : k + 2], located[k - 1 : k + 2])[0]
        window = np.abs(f - value) <= half_width * value
        if window.sum() >= 3:
            slope, intercept = np.polyfit((2 * np.pi * f[window]) ** 2, (1.0 / hh[window]).real, 1)
            if slope < 0 < intercept:
                root = float(np.sqrt(-intercept / slope) / (2 * np.pi))
                if abs(root - value) <= half_width * value:
                    value = root
        result.append(value)
    return np.sort(np.array(result, dtype=float))
