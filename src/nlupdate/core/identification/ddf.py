"""DDF method (Direct nonlinearity by Describing Functions, docs/methods.md §5), for comparison.

Two force levels F1 < F2 measured over a frequency band. At every frequency ω_n,

    Δ(x_2) − Δ(x_1) = 1/H_2 − 1/H_1,      x_j = |H_j(ω_n)|·F_j,

with ``Δ(x) = Σ_{k=1..order} c_k x^k`` (complex c_k; no constant term — it cancels in the
difference, which is why the DDF method cannot see a stuck-friction stiffness). Stacking
the rows ``[x_2^k − x_1^k]`` over the band gives a linear least-squares problem for the
real and imaginary parts of c. Named physical elements can be fitted instead
(nonlinear LS of the same equation). The linear FRF then follows from either level:
``H^L = 1/(1/H_j − Δ(x_j))`` at every frequency level j was measured.

Estimators: ``"naive"`` (the source, unweighted; the default) and ``"weighted"`` — each
row divided by the standard deviation of its right-hand side under the docs/methods.md §8 noise
model, ``∝ sqrt(|1/H_1|² + |1/H_2|²)``. Weighting is not a consistent win
(``benchmarks/reproduce_source.py``, 5 % noise, 100 seeds: k3 bias −8.5 % → −4.6 % for
100/350 N at 700–950 Hz, but −11.9 % → −32.7 % for 150/450 N): the dominant error is
the noise in the amplitudes x_j (errors in variables), which row weights cannot fix,
and weighting favours the rows near resonance where that noise matters most.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.dfmodels import PhysicalModel, polynomial_approximation, with_clipped_damping
from nlupdate.core.identification.prd import IdentificationError, fit_y_points, residual_noise_fraction

DDF_ESTIMATORS = ("naive", "weighted")


@dataclass(frozen=True)
class DDFSetup:
    """Force pair (N), band (Hz) and polynomial order of a DDF identification."""

    force_pair: tuple[float, float]
    band_hz: tuple[float, float]
    order: int
    linear_level: float


def ddf_setup(
    data: FRFLevels,
    force_pair: tuple[float, float] | None = None,
    band_hz: tuple[float, float] | None = None,
    order: int = 2,
    linear_level: float | None = None,
) -> DDFSetup:
    """Validate the choice (defaults: lowest and highest level, their whole common band,
    linear FRF from the lower level of the pair)."""
    if data.levels.size < 2:
        raise IdentificationError(
            f"DDF needs two force levels; response {data.response_dof!r} / input {data.input_dof!r} has only "
            f"{data.levels.size} ({float(data.levels[0]):g} {data.reference_unit})"
        )
    if force_pair is None:
        pair = (float(data.levels[0]), float(data.levels[-1]))
    else:
        pair = tuple(sorted(float(data.levels[data.level_index(level)]) for level in force_pair))
        if len(pair) != 2 or pair[0] == pair[1]:
            raise IdentificationError(f"DDF force pair must be two different measured levels, got {force_pair}")
    common = data.common_frequencies(pair)
    if common.size == 0:
        raise IdentificationError(f"levels {pair[0]:g} and {pair[1]:g} {data.reference_unit} share no frequency")
    band = (float(common.min()), float(common.max())) if band_hz is None else (float(min(band_hz)), float(max(band_hz)))
    if int(order) < 1:
        raise IdentificationError(f"DDF polynomial order must be ≥ 1, got {order}")
    level = pair[0] if linear_level is None else float(data.levels[data.level_index(linear_level)])
    return DDFSetup(pair, band, int(order), level)


@dataclass(frozen=True, eq=False)
class DDFResult:
    """Identified DF ``Δ(x)`` from a DDF fit and the linear-FRF extraction.

    amplitude / y: the DF values implied by the data at the higher level,
    ``y_n = 1/H_2 − 1/H_1 + Δ_fit(x_1)`` at amplitude ``x_2`` (for plots), and
    point_frequency_hz their frequencies. residual_noise_fraction: the relative noise
    level implied by the fit's residuals (each row normalised by its docs/methods.md §8 noise
    scale ``sqrt(|1/H_1|² + |1/H_2|²)``; None without spare degrees of freedom).
    at_bound: parameters of a physical fit that ended on its bounds.
    """

    method: str
    estimator: str
    setup: DDFSetup
    coefficients: NDArray[np.complex128] | None
    physical: PhysicalModel | None
    p: NDArray[np.float64] | None
    amplitude: NDArray[np.float64]
    y: NDArray[np.complex128]
    point_frequency_hz: NDArray[np.float64]
    extras: dict = field(default_factory=dict)
    residual_noise_fraction: float | None = None
    at_bound: tuple[str, ...] = ()

    def nu_high(self, amplitude: ArrayLike, omega: ArrayLike | None = None) -> NDArray[np.complex128]:
        """Identified DF Δ (N/m) at amplitudes A (m); ω (rad/s) defaults to the band centre."""
        a = np.asarray(amplitude, dtype=float)
        if omega is None:
            omega = np.pi * (self.setup.band_hz[0] + self.setup.band_hz[1])
        if self.physical is not None:
            return self.physical.nu(self.p, a, omega)
        return sum(c * a ** (k + 1) for k, c in enumerate(self.coefficients)) + 0j * a

    nu_low = nu_high
    fitted_y = nu_high

    def df_for_force(self, force_n: float):
        """The DF used to regenerate a response at any force (a single DF); a polynomial's
        imaginary part is held at its values at the ends of the fitted amplitude range
        (see :meth:`nlupdate.core.identification.prd.PRDResult.df_for_force`)."""
        if self.physical is not None:
            return self.nu_high
        return with_clipped_damping(self.nu_high, *self.amplitude_range)

    @property
    def amplitude_range(self) -> tuple[float, float]:
        return float(self.amplitude.min()), float(self.amplitude.max())

    def parameters(self) -> dict[str, float]:
        """``k3 = (4/3)·Re c_2`` (order ≥ 2) and the raw coefficients, or the element parameters."""
        if self.physical is not None:
            return self.physical.parameters(self.p)
        out: dict[str, float] = {}
        if self.coefficients.size >= 2:
            out["k3"] = float(4.0 / 3.0 * self.coefficients[1].real)
        for k, c in enumerate(self.coefficients, start=1):
            out[f"re_c{k}"] = float(c.real)
            out[f"im_c{k}"] = float(c.imag)
        return out

    def describing_function(self, order: int = 3) -> tuple[list[float], list[float]]:
        """(real, imag) coefficients of Δ(x), highest order first, constant 0 (SI)."""
        if self.physical is not None:
            low, high = self.amplitude_range
            return polynomial_approximation(self.nu_high, (0.5 * low, high), order)
        c = np.concatenate([self.coefficients[::-1], [0.0]])
        return [float(v) for v in c.real], [float(v) for v in c.imag]

    def elements(self, dofs: tuple[int, ...] = (0,)) -> list:
        from nlupdate.core.model.elements import PolynomialDF

        if self.physical is not None:
            return self.physical.elements(self.p, dofs)
        real, imag = self.describing_function()
        return [PolynomialDF(tuple(dofs), real=tuple(real), imag=tuple(imag))]

    def extract_linear_frf(self, frequency_hz: ArrayLike, h: ArrayLike, force: ArrayLike | None = None) -> NDArray[np.complex128]:
        """``H^L = 1/(1/H_j − Δ(|H_j|F_j))`` from a curve measured at force F_j (m/N): one
        value, or the force achieved at each frequency (default: the level)."""
        level = self.setup.linear_level if force is None else np.asarray(force, dtype=float)
        h = np.asarray(h, dtype=complex)
        omega = 2 * np.pi * np.asarray(frequency_hz, dtype=float)
        return 1.0 / (1.0 / h - self.nu_high(np.abs(h) * level, omega))


def identify_ddf(
    data: FRFLevels,
    force_pair: tuple[float, float] | None = None,
    band_hz: tuple[float, float] | None = None,
    order: int = 2,
    *,
    physical: PhysicalModel | None = None,
    estimator: str = "naive",
    linear_level: float | None = None,
) -> DDFResult:
    """DDF identification (module docstring)."""
    if estimator not in DDF_ESTIMATORS:
        raise IdentificationError(f"unknown DDF estimator {estimator!r}; choose one of {DDF_ESTIMATORS}")
    setup = ddf_setup(data, force_pair, band_hz, order, linear_level)
    f1, f2 = setup.force_pair
    common = data.common_frequencies(setup.force_pair)
    band = common[(common >= setup.band_hz[0] - 1e-9) & (common <= setup.band_hz[1] + 1e-9)]
    n_coefficients = setup.order if physical is None else physical.n_params
    if band.size < n_coefficients:
        raise IdentificationError(
            f"DDF fit: {band.size} frequencies in {setup.band_hz[0]:g}–{setup.band_hz[1]:g} Hz for "
            f"{n_coefficients} coefficients; widen the band or lower the order"
        )
    h1, h2 = data.values(f1, band), data.values(f2, band)
    x1, x2 = np.abs(h1) * data.force_at(f1, band), np.abs(h2) * data.force_at(f2, band)
    rhs = 1.0 / h2 - 1.0 / h1
    weights = np.ones(band.size)
    if estimator == "weighted":
        weights = 1.0 / np.sqrt(np.abs(1.0 / h1) ** 2 + np.abs(1.0 / h2) ** 2)
    omega = 2 * np.pi * band
    noise_scale = np.sqrt(np.abs(1.0 / h1) ** 2 + np.abs(1.0 / h2) ** 2)
    if physical is not None:
        p, at_bound = fit_y_points(physical, x2, rhs, x1, omega, weights=weights)
        implied = rhs + physical.nu(p, x1, omega)
        residual = residual_noise_fraction(implied - physical.nu(p, x2, omega), noise_scale, physical.n_params)
        return DDFResult("ddf", estimator, setup, None, physical, p, x2, implied, band,
                         residual_noise_fraction=residual, at_bound=at_bound)
    powers = np.arange(1, setup.order + 1)
    design = (x2[:, None] ** powers - x1[:, None] ** powers) * weights[:, None]
    scale = np.max(np.abs(design), axis=0)
    scale[scale == 0] = 1.0
    rank = np.linalg.matrix_rank(design / scale)
    if rank < powers.size:
        raise IdentificationError(
            f"singular DDF fit: the regression matrix has rank {rank} < {powers.size} (the two levels give the "
            f"same amplitudes); use levels further apart or a lower order"
        )
    solution = np.linalg.lstsq(design / scale, np.stack([rhs.real, rhs.imag], axis=1) * weights[:, None], rcond=None)[0]
    coefficients = (solution[:, 0] + 1j * solution[:, 1]) / scale
    implied = rhs + sum(c * x1 ** (k + 1) for k, c in enumerate(coefficients))
    misfit = implied - sum(c * x2 ** (k + 1) for k, c in enumerate(coefficients))
    return DDFResult("ddf", estimator, setup, coefficients, None, None, x2, implied, band,
                     residual_noise_fraction=residual_noise_fraction(misfit, noise_scale, 2 * coefficients.size))
