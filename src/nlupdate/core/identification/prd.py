"""PRD method (Pseudo Receptance Difference, docs/methods.md §4) for a nonlinearity at one coordinate.

Length: the result type, the setup and the two estimators share the PRD conventions
stated below; the improved estimator's window is a third of it.

Data: the driving-point (or any) receptance of the nonlinear coordinate measured at one
excitation frequency ω_e at a low force F_1 (friction stuck) and at high forces F_i.
Because the linear part does not depend on the force,

    y_i = 1/H_i − 1/H_1 = ν_high(|X_i|) − ν_low(|X_1|),     |X_i| = |H_i|·F_i,

and once the describing functions are known the linear FRF follows over the whole
low-force sweep: ``1/H^L(ω) = 1/H_1(ω) − ν_low(|H_1(ω)|·F_1)`` (``= 1/H_1 − Δ_f1``).
The DF models are in :mod:`nlupdate.core.identification.dfmodels`.

Two estimators
--------------
``"naive"`` — the source: the points ``(|X_i|, y_i)`` at ω_e only, fitted by unweighted
least squares (polynomial: linear LS of real and imaginary parts; physical elements:
nonlinear LS of ``y_i − ν(A_i) + ν(A_1)``). Its weaknesses under noise: (1) the noise
of the single low-force value ``1/H_1(ω_e)`` goes straight into ``Δ_f1`` (kf);
(2) the abscissa ``|X_i|`` is as noisy as the ordinate (errors in variables), which
biases the slope (k3) low; (3) only n−1 points carry the fit.

``"improved"`` — joint output-error maximum likelihood over a frequency window
``|f − f_e| ≤ half_window·f_e`` (default 1 %): the unknowns are the DF parameters and a
local quadratic ``Z_L(ω) = z_0 + z_1 x + z_2 x²`` (``x = (f − f_e)/f_e``, complex) of the
linear dynamic stiffness; the data are every low-force point and every high-force point
in the window. For each point the model response is the scalar harmonic balance
``X = F/(Z_L(ω) + ν(A))`` with A the root of ``A|Z_L + ν(A)| = F`` nearest to the
measured amplitude (:mod:`nlupdate.core.identification.scalar_balance`), and the residual is
``(X_model − X̃)/|X̃|`` — the docs/methods.md §8 noise model (std ∝ |H|), so the fit is the
maximum-likelihood estimate (Levenberg–Marquardt, its Jacobian from the solved amplitudes
by the implicit function theorem: one amplitude solve per step, not one per unknown; the
window and this residual: :mod:`nlupdate.core.identification.output_error`). This removes all
three weaknesses: the force is exact so there are no errors in variables, ``Z_L`` is shared by all levels so the low-force noise
averages over the window, and neighbouring frequencies add points. With a single
measured frequency it still removes (2). For a polynomial model the low-force points of
the window are modelled with ``Δ_f1 + ν_high(A) − ν_high(A_1(ω_e))``: the constant Δ_f1
while the friction is stuck (ν_high hardly changes over the tiny low-force amplitudes),
and the right amplitude dependence when the "low" level is itself in the smooth
nonlinear regime (the source's §3.5 uses 50 N as its low level).

How much this gains under noise (100 seeds, ``benchmarks/identification_study.py``):
docs/methods.md §9.

The returned :class:`PRDResult` carries the parameters, the PRD points for plotting,
the DFs and the linear-FRF extraction.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.optimize
from numpy.typing import ArrayLike, NDArray

from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.output_error import OutputError, Window, window_points
from nlupdate.core.measurement.noise import smooth_inverse_receptance
from nlupdate.core.identification.dfmodels import (Model, PhysicalModel, PolynomialModel, polynomial_approximation,
                                              with_clipped_damping)

ESTIMATORS = ("improved", "naive")

#: Relative half-width of the improved estimator's frequency window around f_e (1 %).
DEFAULT_HALF_WINDOW = 0.01
#: The bounded (naive, equation-error) fits keep each log-parameter within this factor of its
#: start; the improved fit, unbounded, has diverged where it carries one further (:func:`diverged`).
SEARCH_FACTOR = 1e6


class IdentificationError(ValueError):
    """The data cannot support the requested identification (message says why)."""


@dataclass(frozen=True)
class PRDSetup:
    """Which levels and frequency a PRD identification uses."""

    frequency_hz: float
    low_force: float
    high_forces: tuple[float, ...]


def prd_setup(
    data: FRFLevels, frequency_hz: float, low_force: float | None = None, high_forces: ArrayLike | None = None
) -> PRDSetup:
    """Validate the choice of levels and excitation frequency (defaults: lowest level is low,
    all others high)."""
    if data.levels.size < 2:
        raise IdentificationError(
            f"PRD needs a low force level and at least one high level; response {data.response_dof!r} / input "
            f"{data.input_dof!r} has only {data.levels.size} force level "
            f"({float(data.levels[0]):g} {data.reference_unit})"
        )
    low = float(data.levels[0]) if low_force is None else float(data.levels[data.level_index(low_force)])
    if high_forces is None:
        highs = tuple(float(level) for level in data.levels if level > low)
    else:
        highs = tuple(sorted(float(data.levels[data.level_index(level)]) for level in np.atleast_1d(high_forces)))
    if not highs:
        unit = data.reference_unit
        raise IdentificationError(f"no high force level above the low level {low:g} {unit}; levels "
                                  f"{list(data.levels)} {unit}")
    if low in highs:
        raise IdentificationError(f"the low level {low:g} {data.reference_unit} is also listed as a high level")
    for level in (low,) + highs:
        if not data.has_frequency(level, frequency_hz):
            f, _ = data.curve(level)
            raise IdentificationError(
                f"excitation frequency {float(frequency_hz):g} Hz is not in the data at {level:g} {data.reference_unit} "
                f"(measured {f.min():g}–{f.max():g} Hz, {f.size} points); pick a measured frequency"
            )
    return PRDSetup(float(frequency_hz), low, highs)


@dataclass(frozen=True, eq=False)
class PRDResult:
    """An identified nonlinearity at one coordinate (PRD or DDF) and its linear-FRF extraction.

    p: fitted model vector; parameters(): SI parameters by name. amplitude / y /
    point_frequency_hz: the PRD points (m, N/m, Hz) as fitted (y relative to the fitted
    low-force dynamic stiffness for the improved estimator). amplitude_low: |X_1| at
    the excitation frequency. covariance: linearised covariance of p (improved only).
    noise_fraction: relative noise level implied by the fit residuals (improved only).
    residual_noise_fraction: the same for every estimator — the RMS of the fit's
    residuals normalised like the docs/methods.md §8 noise (std / |H|) and corrected for the
    fitted degrees of freedom; it matches the noise fraction when the model fits (None
    when there are no spare degrees of freedom). amplitude_low_max: the largest
    low-force amplitude the fit used (m; a Jenkins slider slipping there would show).
    at_bound: parameters that ended on the bounds of a bounded fit (naive physical fits
    keep log-parameters within a factor :data:`SEARCH_FACTOR` of their start). diverged:
    (name, start value) of each log-parameter the unbounded improved fit carried further than
    that factor from where it started — beyond the box of the bounded fits: the fit ran off,
    the value is no estimate (:func:`diverged`). point_force_n: the high force level (N)
    each PRD point was measured at.
    """

    method: str
    estimator: str
    model: Model
    p: NDArray[np.float64]
    setup: PRDSetup
    amplitude: NDArray[np.float64]
    y: NDArray[np.complex128]
    point_frequency_hz: NDArray[np.float64]
    amplitude_low: float
    covariance: NDArray[np.float64] | None = None
    noise_fraction: float | None = None
    z_coefficients: NDArray[np.complex128] | None = None
    extras: dict = field(default_factory=dict)
    residual_noise_fraction: float | None = None
    amplitude_low_max: float | None = None
    at_bound: tuple[str, ...] = ()
    point_force_n: NDArray[np.float64] | None = None
    diverged: tuple[tuple[str, float], ...] = ()

    @property
    def omega(self) -> float:
        return 2 * np.pi * self.setup.frequency_hz

    def parameters(self) -> dict[str, float]:
        return self.model.parameters(self.p)

    def nu_high(self, amplitude: ArrayLike, omega: ArrayLike | None = None) -> NDArray[np.complex128]:
        """High-force DF (N/m) at amplitudes A (m), ω in rad/s (default: excitation frequency)."""
        return self.model.nu_high(self.p, np.asarray(amplitude, dtype=float), self.omega if omega is None else omega)

    def nu_low(self, amplitude: ArrayLike, omega: ArrayLike | None = None) -> NDArray[np.complex128]:
        """Low-force DF (N/m); constant Δ_f1 for a polynomial model."""
        return self.model.nu_low(self.p, np.asarray(amplitude, dtype=float), self.omega if omega is None else omega)

    def df_for_force(self, force_n: float):
        """The DF to regenerate a response at ``force_n``: low-force DF at or below the low
        level, high-force DF above (the same function for physical elements).

        A polynomial is only known over the fitted amplitude range. Its real part (the
        stiffness, ¾k*A² for a cubic spring) is extrapolated, but its imaginary part is
        evaluated at the amplitude clipped to the fitted range: friction damping behaves
        like 4Fs/(πA), which a polynomial extrapolates wildly (on §3.1 the regenerated
        280 N FRF has FRAC 0.71 with the extrapolated damping and 1.000 when clipped)."""
        if float(force_n) <= self.setup.low_force:
            return self.nu_low
        if isinstance(self.model, PhysicalModel):
            return self.nu_high
        return with_clipped_damping(self.nu_high, *self.amplitude_range)

    @property
    def delta_f1(self) -> complex:
        """Δ_f1: the DF at the low-force amplitude at the excitation frequency (N/m)."""
        return complex(self.nu_low(np.array([self.amplitude_low]))[0])

    def fitted_y(self, amplitude: ArrayLike) -> NDArray[np.complex128]:
        """The fitted PRD curve ``ν_high(A) − Δ_f1``."""
        return self.nu_high(amplitude) - self.delta_f1

    @property
    def amplitude_range(self) -> tuple[float, float]:
        return float(self.amplitude.min()), float(self.amplitude.max())

    def describing_function(self, order: int = 3) -> tuple[list[float], list[float]]:
        """High-force DF as (real, imag) polynomial coefficients, highest order first (SI).

        Exact for a polynomial model; a least-squares polynomial of ``order`` over the
        fitted amplitude range for physical elements.
        """
        if isinstance(self.model, PolynomialModel):
            return self.model.describing_function(self.p)
        low, high = self.amplitude_range
        return polynomial_approximation(self.nu_high, (0.5 * low, high), order)

    def prd_polynomial(self, order: int = 3) -> tuple[list[float], list[float]]:
        """PRD curve ``y(A)`` as polynomial coefficients (constant term = −Δ_f1)."""
        if isinstance(self.model, PolynomialModel):
            return self.model.prd_polynomial(self.p)
        low, high = self.amplitude_range
        return polynomial_approximation(self.fitted_y, (0.5 * low, high), order)

    def elements(self, dofs: tuple[int, ...] = (0,)) -> list:
        """Elements for a forward model (physical elements, or the high-force PolynomialDF)."""
        return self.model.elements(self.p, dofs)

    def extract_linear_frf(
        self,
        frequency_hz: ArrayLike,
        h_low: ArrayLike,
        low_force: ArrayLike | None = None,
        *,
        amplitude_dependent: bool = False,
        smoothing_window: int = 0,
    ) -> NDArray[np.complex128]:
        """Linear receptance (m/N) from a low-force sweep: ``1/H^L = 1/H_1 − Δ_f1``.

        By default Δ_f1 is the constant identified at the excitation frequency (the
        source's eq. 2.55; exact while the friction stays stuck over the sweep). With
        ``amplitude_dependent`` it is ``ν_low(|H_1(ω)|·F_1, ω)`` at every frequency — right
        when the low force makes the slider slip near the low-force resonance, but only if
        the slip force is well identified (under noise it often is not, and a too small
        slip force then puts a spurious peak into H^L). ``smoothing_window`` > 0 first
        smooths ``1/H_1`` (:func:`~nlupdate.core.identification.data.smooth_inverse_receptance`).
        ``low_force``: the force of the sweep, one value or the force achieved at each
        frequency (default: the low level).
        """
        force = self.setup.low_force if low_force is None else np.asarray(low_force, dtype=float)
        f = np.asarray(frequency_hz, dtype=float)
        h = np.asarray(h_low, dtype=complex)
        inverse = smooth_inverse_receptance(f, h, smoothing_window) if smoothing_window else 1.0 / h
        if amplitude_dependent:
            delta = self.model.nu_low(self.p, force / np.abs(inverse), 2 * np.pi * f)
        else:
            delta = self.delta_f1
        return 1.0 / (inverse - delta)


# ------------------------------------------------------------------------------ fitting helpers
def _check_points(n_points: int, model: Model) -> None:
    if isinstance(model, PolynomialModel):
        need = max(len(model.real_powers), len(model.imag_powers))
        if n_points < need:
            raise IdentificationError(
                f"PRD fit: {n_points} high-force point(s) but the polynomial has {need} coefficients per part; "
                f"use a lower order or more force levels"
            )
    elif 2 * n_points < model.n_params:
        raise IdentificationError(
            f"PRD fit: {n_points} high-force point(s) (2 equations each) for {model.n_params} element parameters; "
            f"use fewer elements or more force levels"
        )


def _linear_fit(design: NDArray, target: NDArray, weights: NDArray, what: str) -> NDArray:
    matrix = design * weights[:, None]
    scale = np.max(np.abs(matrix), axis=0)
    scale[scale == 0] = 1.0
    rank = np.linalg.matrix_rank(matrix / scale)
    if rank < design.shape[1]:
        raise IdentificationError(
            f"singular PRD fit ({what}): the regression matrix has rank {rank} < {design.shape[1]} "
            f"coefficients (amplitudes too close together); use a lower order or more distinct force levels"
        )
    return np.linalg.lstsq(matrix / scale, target * weights, rcond=None)[0] / scale


def fit_y_points(
    model: Model,
    amplitude: NDArray,
    y: NDArray,
    amplitude_low: NDArray | float,
    omega: NDArray | float,
    weights: NDArray | None = None,
) -> tuple[NDArray[np.float64], tuple[str, ...]]:
    """Equation-error fit of ``y = ν_high(A) − ν_low(A_1)`` (weights multiply residuals).

    Returns the parameters and the names of those that ended on the bounds of the fit
    (physical models only: log-parameters stay within a factor 1e6 of their start)."""
    amplitude = np.asarray(amplitude, dtype=float)
    y = np.asarray(y, dtype=complex)
    weights = np.ones(amplitude.size) if weights is None else np.asarray(weights, dtype=float)
    _check_points(amplitude.size, model)
    if isinstance(model, PolynomialModel):
        vr, vi = model.design(amplitude)
        return np.concatenate([
            _linear_fit(vr, y.real, weights, "real part"),
            _linear_fit(vi, y.imag, weights, "imaginary part"),
        ]), ()
    a_low = np.broadcast_to(np.asarray(amplitude_low, dtype=float), amplitude.shape)
    om = np.broadcast_to(np.asarray(omega, dtype=float), amplitude.shape)

    def residual(p: NDArray) -> NDArray:
        r = (y - model.nu(p, amplitude, om) + model.nu(p, a_low, om)) * weights
        return np.concatenate([r.real, r.imag])

    best = None
    positive = np.array(["k3" not in name for name in model.names])  # log-parameters
    for start in model.initial_guesses(amplitude, y, float(np.median(a_low)), float(np.median(om))):
        scale = np.maximum(np.abs(start), 1.0)
        # log-parameters stay within a factor SEARCH_FACTOR of the start (keeps an unidentifiable
        # parameter, e.g. a slip force never reached, from running off to overflow)
        span = np.where(positive, np.log(SEARCH_FACTOR), np.inf)
        try:
            solution = scipy.optimize.least_squares(
                lambda q: residual(q * scale), start / scale, method="trf",
                bounds=((start - span) / scale, (start + span) / scale),
            )
        except ValueError as error:
            raise IdentificationError(f"PRD fit of {model.description()} failed: {error}") from error
        if best is None or solution.cost < best[0]:
            best = (solution.cost, solution.x * scale, np.asarray(solution.active_mask) != 0)
    return best[1], tuple(name for name, on_bound in zip(model.names, best[2]) if on_bound)


def diverged(model: Model, start: NDArray, p: NDArray) -> tuple[tuple[str, float], ...]:
    """(name, start value) of each log-parameter (a positive one of a physical model) that
    ``p`` puts further than :data:`SEARCH_FACTOR` from its ``start`` (both fitted vectors):
    beyond the box the bounded fits keep, where no fit of the same data moves a parameter it
    determines (on the BRB its Jenkins kf moves 0.55× from its start; with the sensor's sign
    reversed 1e41×, to 9e47 N/m)."""
    if not isinstance(model, PhysicalModel):
        return ()
    positive = np.array([pos for _, _, pos in model._slots])
    moved = positive & (np.abs(np.asarray(p, float) - np.asarray(start, float)) > np.log(SEARCH_FACTOR))
    return tuple((name, float(value)) for name, value, far in zip(model.names, model.values(start), moved) if far)


def residual_noise_fraction(residual: NDArray, noise_scale: NDArray, n_parameters: int) -> float | None:
    """Relative noise level implied by complex equation residuals whose noise std is
    ``fraction·noise_scale``: ``sqrt(2 Σ|r/s|² / (2n − n_parameters))`` (None without
    spare degrees of freedom)."""
    dof = 2 * np.size(residual) - int(n_parameters)
    if dof <= 0:
        return None
    return float(np.sqrt(2 * np.sum(np.abs(np.asarray(residual) / np.asarray(noise_scale)) ** 2) / dof))


def _equation_error_start(window: Window, model: Model) -> tuple[NDArray, NDArray, float, NDArray]:
    """Start of the output-error fit: ``Z_L`` from the low-force sweep (weighted by |H|:
    the noise of 1/H is relative), then the DF from the pooled PRD points against it.
    Returns (θ₀, the smooth low-force ``1/H`` coefficients, the low-force amplitude at f_e,
    their design at the low points)."""
    design_low = window.design("low")
    weights = np.abs(window.h_low)
    smooth = np.linalg.lstsq(design_low * weights[:, None], (1 / window.h_low) * weights, rcond=None)[0]
    z_high_smooth = window.design("high") @ smooth
    y_pooled = 1.0 / (window.x_high / window.force_high) - z_high_smooth
    a_low_high = np.abs(1.0 / z_high_smooth) * window.low_force_high
    p0, _ = fit_y_points(model, np.abs(window.x_high), y_pooled, a_low_high, window.omega_high,
                         weights=np.abs(window.x_high / window.force_high))
    a_low_e = float(abs(1.0 / smooth[0]) * window.low_force_e)
    z0 = smooth.copy()
    z0[0] -= complex(model.nu_low(p0, np.array([a_low_e]), 2 * np.pi * window.frequency_hz)[0])
    return np.concatenate([z0.real, z0.imag, p0]), smooth, a_low_e, design_low



# ------------------------------------------------------------------------------ estimators
def prd_naive(data: FRFLevels, setup: PRDSetup, model: Model) -> PRDResult:
    """The source's estimator: unweighted fit of the PRD points at the excitation frequency."""
    f = setup.frequency_hz
    h_low = complex(data.values(setup.low_force, f)[0])
    forces = np.array(setup.high_forces)
    h_high = np.array([complex(data.values(level, f)[0]) for level in forces])
    amplitude = np.abs(h_high) * np.array([data.force_at(level, f) for level in forces])
    y = 1.0 / h_high - 1.0 / h_low
    a_low = abs(h_low) * float(data.force_at(setup.low_force, f))
    omega = 2 * np.pi * f
    p, at_bound = fit_y_points(model, amplitude, y, a_low, omega)
    # noise of y_i = 1/H_i − 1/H_1: fraction·|1/H| on each term (docs/methods.md §8)
    misfit = y - model.nu_high(p, amplitude, omega) + model.nu_low(p, np.array([a_low]), omega)
    residual = residual_noise_fraction(misfit, np.sqrt(np.abs(1 / h_high) ** 2 + abs(1 / h_low) ** 2), model.n_params)
    return PRDResult("prd", "naive", model, p, setup, amplitude, y, np.full(amplitude.size, f), a_low,
                     residual_noise_fraction=residual, amplitude_low_max=a_low, at_bound=at_bound,
                     point_force_n=forces.astype(float))


def prd_improved(data: FRFLevels, setup: PRDSetup, model: Model, half_window: float = DEFAULT_HALF_WINDOW) -> PRDResult:
    """Joint output-error maximum-likelihood PRD over a frequency window (module docstring)."""
    if not 0 <= half_window < 0.5:
        raise IdentificationError(f"half_window must be a relative width in [0, 0.5), got {half_window}")
    window = window_points(data, setup.frequency_hz, setup.low_force, setup.high_forces, half_window)
    _check_points(window.x_high.size, model)
    theta0, smooth, a_low_e, design_low = _equation_error_start(window, model)
    residual = OutputError(window, model, a_low_e)
    n_z = residual.n_z

    scale = np.abs(theta0)
    scale = np.where(scale > 0, scale, 1.0)
    scale[: 2 * n_z] = np.maximum(scale[: 2 * n_z], 1e-6 * np.max(np.abs(theta0[: 2 * n_z])))
    if isinstance(model, PhysicalModel):
        scale[2 * n_z :] = np.maximum(scale[2 * n_z :], 1.0)
    solution = scipy.optimize.least_squares(lambda q: residual(q * scale), theta0 / scale, method="lm",
                                            jac=lambda q: residual.jacobian(q * scale) * scale[None, :])
    started = theta0
    # Safeguard against a poor start (seen once in 100 noisy §3.1 data sets at 760 Hz, where
    # the fit ran to kf → 1e12 with a residual noise level of 33 %): if the residuals are
    # far above the noise level of the low-force points about their smooth fit, restart
    # from the single-frequency naive estimate and keep the better fit.
    fits_low_noise = window.f_low.size > n_z
    low_noise = np.sqrt(np.mean(np.abs(design_low @ smooth * window.h_low - 1) ** 2)) if fits_low_noise else 0.0
    if np.sqrt(2 * solution.cost / solution.fun.size) > 3 * max(low_noise / np.sqrt(2), 1e-6):
        try:
            alternative = prd_naive(data, setup, model).p
        except IdentificationError:
            alternative = None
        if alternative is not None:
            start = np.concatenate([theta0[: 2 * n_z], alternative])
            retry = scipy.optimize.least_squares(lambda q: residual(q * scale), start / scale, method="lm",
                                                 jac=lambda q: residual.jacobian(q * scale) * scale[None, :])
            if retry.cost < solution.cost:
                solution, started = retry, start
    theta = solution.x * scale
    n_res, n_par = solution.fun.size, theta.size
    sigma2 = 2 * solution.cost / max(n_res - n_par, 1)
    try:  # linearised covariance of theta (unscaled)
        jac = solution.jac / scale[None, :]
        covariance = sigma2 * np.linalg.inv(jac.T @ jac)
    except np.linalg.LinAlgError:
        covariance = None
    low_response, _ = residual.responses(theta)  # the fitted low-force amplitudes over the window
    z, p = residual.split(theta)
    # PRD points relative to the fitted low-force dynamic stiffness, for plots and reports
    omega_high = window.omega_high
    z_high = residual.design_high @ z
    a_low_points = np.abs(1.0 / (z_high + model.nu_low(p, np.full(z_high.shape, a_low_e), omega_high))) \
        * window.low_force_high
    y_points = window.force_high / window.x_high - (z_high + model.nu_low(p, a_low_points, omega_high))
    fe = window.frequency_hz
    a_low_fit = float(abs(window.low_force_e / (z[0] + model.nu_low(p, np.array([a_low_e]), 2 * np.pi * fe)[0])))
    return PRDResult(
        "prd", "improved", model, p, setup, np.abs(window.x_high), y_points,
        np.repeat(window.f_high, window.levels.size), a_low_fit,
        covariance=None if covariance is None else covariance[2 * n_z :, 2 * n_z :],
        noise_fraction=float(np.sqrt(2 * sigma2)), z_coefficients=z,
        residual_noise_fraction=float(np.sqrt(2 * sigma2)) if n_res > n_par else None,
        amplitude_low_max=float(np.max(np.abs(low_response))), point_force_n=np.tile(window.levels.astype(float), window.f_high.size),
        diverged=diverged(model, started[2 * n_z :], p),
        extras={"half_window": half_window, "window_hz": (float(fe * (1 - half_window)), float(fe * (1 + half_window))),
                "n_low_points": int(window.f_low.size), "n_high_points": int(window.x_high.size),
                "z_degree": window.degree},
    )


def identify_prd(
    data: FRFLevels,
    frequency_hz: float,
    model: Model,
    *,
    low_force: float | None = None,
    high_forces: ArrayLike | None = None,
    estimator: str = "improved",
    half_window: float = DEFAULT_HALF_WINDOW,
) -> PRDResult:
    """PRD identification at ``frequency_hz`` (Hz) with the chosen estimator."""
    setup = prd_setup(data, frequency_hz, low_force, high_forces)
    if estimator == "naive":
        return prd_naive(data, setup, model)
    if estimator == "improved":
        return prd_improved(data, setup, model, half_window)
    raise IdentificationError(f"unknown estimator {estimator!r}; choose one of {ESTIMATORS}")

