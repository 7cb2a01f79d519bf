"""Multi-harmonic balance, condensed to the nonlinear coordinates, with Hill stability.

The periodic response ``x(t) = X₀ + Σ_{k=1}^{H} Re(X_k e^{ikωt})`` of the linear model with
local elements balances every harmonic k = 0 … H. Condensed to the nonlinear coordinates
``a`` as in :mod:`nlupdate.core.model.system` (receptance form)::

    R_k = X_{a,k} − δ_{k1} H_af(ω) F + H_aa^{(k)}(ω) G_k(X_a, ω) = 0,   k = 0 … H,

where ``H^{(k)}`` is the receptance at the k-th harmonic
(:meth:`~nlupdate.core.model.linear.LumpedModel.harmonic_receptance`; ``H^{(0)} = K⁻¹``) and
``G_k`` the k-th harmonic of the element forces by the alternating frequency–time scheme
(:mod:`nlupdate.core.response.aft`), with analytic Jacobians through the same transform. The
unknowns are ``n_a·(2H+1)`` real numbers whatever the size of the linear model; any other
coordinate follows from ``X_{b,k} = δ_{k1} H_bf F − H_ba^{(k)} G_k``. With H = 1 and no
constant term in the response (symmetric elements) this is the describing-function
balance of :mod:`nlupdate.core.model.system`.

The curve is traced by the same pseudo-arclength continuation
(:func:`nlupdate.core.response.continuation.trace_curve`); stability comes from Floquet
multipliers by Hill's method (:mod:`nlupdate.core.response.hill`), which also flags branch
points, period doublings and Neimark–Sacker points; a large dense model is reduced to its
joint coordinates and retained modes first (:mod:`nlupdate.core.response.hill_reduction`).

Truncation check. The share of a harmonic is ``‖X_k‖ / (Σ_{j≥1} ‖X_j‖²)^{1/2}`` over the
nonlinear coordinates; :attr:`FrequencyResponse.harmonic_share` is the largest share of the
two highest harmonics over the curve (two, because symmetric elements leave every even
harmonic at zero). A warning says when it exceeds ``share_limit``, and when the element
forces change by more than ``share_limit`` with 8× the samples per period (aliasing).
``harmonics="auto"`` raises H until the share is below the limit.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nlupdate.core.model.linear import ReceptancePlan
from nlupdate.core.model.system import LinearTerms, NonlinearSystem, forcing_vector
from nlupdate.core.response.aft import Fourier, aliasing_change, period_forces_batch
from nlupdate.core.response.continuation import (
    Bifurcation,
    FrequencyResponse,
    check_band,
    default_x_scale,
    trace_curve,
)
from nlupdate.core.response.hill import classify, floquet_batch
from nlupdate.core.response.hill_reduction import hill_model

DEFAULT_SHARE_LIMIT = 1e-3
AUTO_HARMONICS = (3, 5, 7, 9, 11, 15, 19, 25, 31)
DEFAULT_FILL = 4
"""The continuation takes steps up to 4 × ``max_step`` and the points between are corrected
all at once (:mod:`nlupdate.core.response.curve_fill`): every residual evaluation of this balance
costs numpy's fixed overhead, which a batch shares."""


class HarmonicTruncationWarning(RuntimeWarning):
    """The highest harmonics or the aliasing check exceed the stated share."""


def default_samples(harmonics: int) -> int:
    """Samples per period: a power of two ≥ max(64, 8·(H+1)) (exact low harmonics for laws
    up to 7th power; non-smooth laws are checked by :func:`aliasing_change`)."""
    return int(2 ** np.ceil(np.log2(max(64, 8 * (harmonics + 1)))))


class HarmonicBalanceProblem:
    """Residual and Jacobians of the condensed multi-harmonic balance at one force vector
    (a :class:`~nlupdate.core.response.balance.MultiHarmonicProblem`).

    Unknowns ``y`` (scaled by ``x_scale``, m): the coefficients ``[X₀, Re X₁, Im X₁, …]`` of
    every nonlinear coordinate, stored coefficient-major, ``y[c·n_a + i]``.
    The state of a point is the complex array ``(H+1, n_a)`` of ``X₀ … X_H`` (m).
    """

    def __init__(
        self,
        system: NonlinearSystem,
        forcing: Mapping[int | str, complex],
        harmonics: int,
        samples: int | None = None,
        x_scale: float = 1.0,
    ) -> None:
        self.system = system
        self.model = system.model
        if not hasattr(self.model, "harmonic_receptance"):
            raise ValueError(
                f"harmonic balance with several harmonics needs a model with matrices or modes (LumpedModel, "
                f"ModalModel); {type(self.model).__name__} has receptances at measured frequencies only — "
                "use the describing-function method"
            )
        self.a = system.nonlinear_dofs
        self.n = len(self.a)
        self.forced, self.force = forcing_vector(system, forcing)
        self.fourier = Fourier(harmonics, samples or default_samples(harmonics))
        self.harmonics = self.fourier.harmonics
        self.x_scale = float(x_scale)
        self.size = self.n * self.fourier.size
        position = {dof: i for i, dof in enumerate(self.a)}
        self.element_index = [
            (element, position[element.dofs[0]], position[element.dofs[1]] if len(element.dofs) == 2 else -1)
            for element in system.elements
        ]
        self._cols = list(self.a) + list(self.forced)
        self._orders = np.arange(1, self.harmonics + 1)
        self._zero_orders = np.zeros((1, self.harmonics))
        self._plan = ReceptancePlan(self.model, self.a, self._cols)
        # flat positions in the size × size matrix of the blocks [[Re h, −Im h], [Im h, Re h]]
        # of harmonics 1 … H, in the order (harmonic, block, row, col) that _real_block_receptance fills
        n, k = self.n, np.arange(self.harmonics)[:, None, None, None]
        row0 = n + 2 * n * k + np.array([0, 0, n, n])[None, :, None, None]
        col0 = n + 2 * n * k + np.array([0, n, 0, n])[None, :, None, None]
        rows = row0 + np.arange(n)[None, None, :, None]
        cols = col0 + np.arange(n)[None, None, None, :]
        self._block_index = (rows * self.size + cols).reshape(-1)
        self._diagonal = np.arange(self.size)
        try:
            static = self.model.harmonic_receptance(0.0, 0, self.a, self.a)[0]
        except (np.linalg.LinAlgError, RuntimeError):
            static = np.full((self.n, self.n), np.nan)
        if not np.all(np.isfinite(static)):
            raise ValueError("the constant term needs a grounded model: the static receptance K⁻¹ is not finite")
        self._static = static.real

    # -- linear part -------------------------------------------------------------------
    def linear_batch(self, omega: ArrayLike, derivative: bool = True) -> LinearTerms:
        """The linear part at every ω of ``omega`` (rad/s): the real block-diagonal receptance
        (P, size, size) as ``h_aa``, ``X_lin`` (P, size) and their ω-derivatives."""
        omega = np.atleast_1d(np.asarray(omega, dtype=float))
        n, count, points = self.n, self.harmonics, omega.size
        fundamental = (omega[:, None] + self._zero_orders).reshape(-1)
        orders = (self._zero_orders[0] + self._orders + np.zeros((points, 1))).reshape(-1)
        result = self._plan.harmonic(fundamental, orders, derivative)
        # H and dH/dω together: (1 or 2, P, H, n, n + forced)
        both = np.stack(result) if derivative else result[None]
        both = both.reshape(both.shape[0], points, count, n, -1)
        blocks = self._real_block_receptance(both[..., :n].reshape((-1, count, n, n)))
        blocks = blocks.reshape(both.shape[0], points, self.size, self.size)
        blocks[0, :, :n, :n] = self._static
        lin = both[:, :, 0, :, n:] @ self.force  # (1 or 2, P, n)
        x = np.zeros((both.shape[0], points, self.size))
        x[:, :, n : 2 * n], x[:, :, 2 * n : 3 * n] = lin.real, lin.imag
        if derivative:
            return LinearTerms(omega, blocks[0], x[0], blocks[1], x[1])
        return LinearTerms(omega, blocks[0], x[0])

    def _real_block_receptance(self, h: NDArray) -> NDArray:
        """Block-diagonal real forms (P, size, size) of receptances h (P, H, n, n):
        ``[[Re h, −Im h], [Im h, Re h]]`` per harmonic, zero for X₀."""
        points = h.shape[0]
        h_aa = np.zeros((points, self.size * self.size))
        real, imag = h.real, h.imag
        parts = np.concatenate([real, -imag, imag, real], axis=2)  # (P, H, 4n, n): the blocks in _block_index order
        h_aa[:, self._block_index] = parts.reshape(points, -1)
        return h_aa.reshape(points, self.size, self.size)

    def linear_response(self, omega: ArrayLike, dofs: Sequence[int]) -> NDArray[np.complex128]:
        """First harmonic of the underlying linear system (m) at ``dofs``, (n_omega, len(dofs))."""
        h = self.model.receptance(np.atleast_1d(omega), list(dofs), list(self.forced))
        return h @ self.force

    # -- nonlinear forces ---------------------------------------------------------------
    def forces_batch(self, coefficients: NDArray, omega: NDArray, jacobian: bool = False):
        """Element force coefficients G (P, 2H+1, n_a) (N) for motion coefficients (P, 2H+1, n_a)
        (m) at ω (P,) (rad/s); with ``jacobian=True`` G, ∂G/∂X and ∂G/∂ω flattened like ``y``:
        (P, size), (P, size, size), (P, size)."""
        coefficients = np.asarray(coefficients, dtype=float)
        points, (n, m) = coefficients.shape[0], (self.n, self.fourier.size)
        g = np.zeros((points, m, n))
        dg = np.zeros((points, m, n, m, n)) if jacobian else None
        dg_dw = np.zeros((points, m, n)) if jacobian else None
        for element, r, j in self.element_index:
            u = coefficients[:, :, r] - (coefficients[:, :, j] if j >= 0 else 0.0)
            period = period_forces_batch(element, u, omega, self.fourier)
            pairs = ((r, 1.0), (j, -1.0)) if j >= 0 else ((r, 1.0),)
            for row, row_sign in pairs:
                g[:, :, row] += row_sign * period.g
                if jacobian:
                    dg_dw[:, :, row] += row_sign * period.dg_domega
                    for col, col_sign in pairs:
                        dg[:, :, row, :, col] += row_sign * col_sign * period.dg_dc
        if jacobian:
            return g.reshape(points, -1), dg.reshape(points, self.size, self.size), dg_dw.reshape(points, -1)
        return g

    def forces(self, coefficients: NDArray, omega: float, jacobian: bool = False):
        """:meth:`forces_batch` at one point: G (2H+1, n_a), or with ``jacobian`` G, ∂G/∂X and
        ∂G/∂ω flattened like ``y``."""
        result = self.forces_batch(np.asarray(coefficients, dtype=float)[None], np.array([omega], dtype=float), jacobian)
        return tuple(part[0] for part in result) if jacobian else result[0]

    # -- residual -----------------------------------------------------------------------
    def initial_guesses(self, omega: float) -> tuple[NDArray, NDArray]:
        """Starting guesses at ω: the linear response in the first harmonic, then zero."""
        x_lin = self.linear_batch(omega, derivative=False).x_lin[0]
        return x_lin / self.x_scale, np.zeros(self.size)

    def to_complex(self, y: NDArray) -> NDArray[np.complex128]:
        """States ``(…, H+1, n_a)`` complex (m) from scaled unknowns (…, size)."""
        y = np.asarray(y)
        c = y.reshape(y.shape[:-1] + (self.fourier.size, self.n)) * self.x_scale
        state = np.empty(y.shape[:-1] + (self.harmonics + 1, self.n), complex)
        state[..., 0, :] = c[..., 0, :]
        state[..., 1:, :] = c[..., 1::2, :] + 1j * c[..., 2::2, :]
        return state

    def to_real(self, state: NDArray) -> NDArray[np.float64]:
        """Scaled unknowns (…, size) of states (…, H+1, n_a) (m)."""
        c = self.coefficients(state)
        return c.reshape(c.shape[:-2] + (self.size,)) / self.x_scale

    def coefficients(self, state: NDArray) -> NDArray[np.float64]:
        """Real coefficient arrays (…, 2H+1, n_a) (m) of states (…, H+1, n_a)."""
        state = np.asarray(state, complex)
        c = np.empty(state.shape[:-2] + (self.fourier.size, self.n))
        c[..., 0, :] = state[..., 0, :].real
        c[..., 1::2, :], c[..., 2::2, :] = state[..., 1:, :].real, state[..., 1:, :].imag
        return c

    def residual_batch(self, y: NDArray, linear: LinearTerms, jacobian: bool = True):
        """Scaled residuals (P, size) at states ``y`` (P, size) and the frequencies of ``linear``;
        with ``jacobian`` also ``∂R/∂y`` (P, size, size) and ``∂R/∂ω`` (P, size; None when
        ``linear`` has no derivatives)."""
        x = np.asarray(y, dtype=float) * self.x_scale
        coefficients = x.reshape(x.shape[0], self.fourier.size, self.n)
        if not jacobian:
            g = self.forces_batch(coefficients, linear.omega).reshape(x.shape[0], -1)
            return (x - linear.x_lin + (linear.h_aa @ g[..., None])[..., 0]) / self.x_scale
        g, dg, dg_dw = self.forces_batch(coefficients, linear.omega, jacobian=True)
        r = (x - linear.x_lin + (linear.h_aa @ g[..., None])[..., 0]) / self.x_scale
        jac = linear.h_aa @ dg
        jac[:, self._diagonal, self._diagonal] += 1.0
        jac_w = None
        if linear.dh_aa is not None:
            jac_w = (-linear.dx_lin + (linear.dh_aa @ g[..., None] + linear.h_aa @ dg_dw[..., None])[..., 0]) / self.x_scale
        return r, jac, jac_w

    def residual(self, y: NDArray, omega: float) -> NDArray[np.float64]:
        return self.residual_batch(np.asarray(y, dtype=float)[None], self.linear_batch(omega, False), jacobian=False)[0]

    def residual_and_jacobians(self, y: NDArray, omega: float):
        """Scaled residual, ``∂R/∂y`` and ``∂R/∂ω`` (per rad/s) at one point."""
        r, jac, jac_w = self.residual_batch(np.asarray(y, dtype=float)[None], self.linear_batch(omega))
        return r[0], jac[0], jac_w[0]

    # -- response anywhere --------------------------------------------------------------
    def harmonics_at(self, omega: ArrayLike, states: NDArray, dofs: Sequence[int]) -> NDArray[np.complex128]:
        """Harmonics X₀ … X_H (m) at any ``dofs`` for states (n_omega, H+1, n_a): (n_omega, H+1, len(dofs))."""
        omega = np.atleast_1d(np.asarray(omega, dtype=float))
        states = np.asarray(states).reshape(omega.size, self.harmonics + 1, self.n)
        dofs = list(dofs)
        out = np.zeros((omega.size, self.harmonics + 1, len(dofs)), complex)
        out[:, 1] = self.model.receptance(omega, dofs, list(self.forced)) @ self.force
        if not self.n:
            return out
        g = self.forces_batch(self.coefficients(states), omega)  # (n_ω, 2H+1, n_a)
        g_complex = np.concatenate([g[:, :1] + 0j, g[:, 1::2] + 1j * g[:, 2::2]], axis=1)
        for k in range(self.harmonics + 1):
            h_ba = self.model.harmonic_receptance(omega if k else np.zeros(1), k, dofs, list(self.a))
            h_ba = h_ba.real if k == 0 else h_ba
            out[:, k] -= np.einsum("wbk,wk->wb", np.broadcast_to(h_ba, (omega.size,) + h_ba.shape[1:]), g_complex[:, k])
        return out

    def response_at(self, omega: ArrayLike, states: NDArray, dofs: Sequence[int]) -> NDArray[np.complex128]:
        """First-harmonic amplitudes (m) at ``dofs``, (n_omega, len(dofs))."""
        return self.harmonics_at(omega, states, dofs)[:, 1]


def harmonic_shares(states: NDArray) -> NDArray[np.float64]:
    """Share of each harmonic 1 … H per point, (n_points, H), over the nonlinear coordinates."""
    norms = np.linalg.norm(np.asarray(states)[:, 1:], axis=2)
    total = np.sqrt(np.sum(norms**2, axis=1, keepdims=True))
    return np.divide(norms, total, out=np.zeros_like(norms), where=total > 0)


def _stability(problem: HarmonicBalanceProblem, omega, states, turning):
    hill = hill_model(problem.model, problem.a, problem.element_index, float(np.max(omega)), problem.harmonics)
    coefficients = problem.coefficients(states)
    _, force_jacobians, _ = problem.forces_batch(coefficients, omega, jacobian=True)
    _, multipliers = floquet_batch(hill, problem.element_index, coefficients, omega, problem.fourier, force_jacobians)
    stable = np.max(np.abs(multipliers), axis=1) < 1.0 + 1e-7
    bifurcations = []
    points = np.flatnonzero(~turning)
    for p, q in zip(points[:-1], points[1:]):
        if stable[p] == stable[q] or np.any(turning[p + 1 : q]):
            continue
        unstable = q if stable[p] else p
        mu = multipliers[unstable][np.argmax(np.abs(multipliers[unstable]))]
        grow_p, grow_q = (np.log(np.max(np.abs(multipliers[i]))) for i in (p, q))
        weight = grow_p / (grow_p - grow_q) if grow_p != grow_q else 0.5
        where = float(omega[p] + np.clip(weight, 0, 1) * (omega[q] - omega[p]))
        bifurcations.append(Bifurcation(classify(complex(mu)), where, int(unstable), complex(mu)))
    stable[turning] = False
    return stable, multipliers, tuple(bifurcations)


def _check_truncation(problem, curve_states, omega, share_limit: float) -> float:
    shares = harmonic_shares(curve_states)
    top = shares[:, -2:].max(axis=1) if problem.harmonics > 1 else np.zeros(len(omega))
    share = float(top.max()) if top.size else 0.0
    if share > share_limit:
        at = omega[int(np.argmax(top))] / (2 * np.pi)
        warnings.warn(
            f"harmonic balance with H = {problem.harmonics}: the highest harmonics carry {100 * share:.2g} % of the "
            f"response at {at:.6g} Hz (limit {100 * share_limit:.2g} %); raise the number of harmonics",
            HarmonicTruncationWarning,
            stacklevel=3,
        )
    amplitude = np.linalg.norm(curve_states[:, 1:].reshape(len(omega), -1), axis=1)
    peak = int(np.argmax(amplitude))
    coefficients = problem.coefficients(curve_states[peak])
    worst = 0.0
    for element, r, j in problem.element_index:
        u = coefficients[:, r] - (coefficients[:, j] if j >= 0 else 0.0)
        worst = max(worst, aliasing_change(element, u, omega[peak], problem.fourier))
    if worst > share_limit:
        warnings.warn(
            f"harmonic balance with N = {problem.fourier.samples} samples per period: the element forces change by "
            f"{100 * worst:.2g} % with 8× the samples at {omega[peak] / (2 * np.pi):.6g} Hz; raise the samples",
            HarmonicTruncationWarning,
            stacklevel=3,
        )
    return share


@dataclass(frozen=True)
class HarmonicSettings:
    """How many harmonics, samples per period and whether to compute Floquet stability."""

    harmonics: int | str = 3
    samples: int | None = None
    stability: bool = True
    share_limit: float = DEFAULT_SHARE_LIMIT


def trace_harmonic_balance(
    system: NonlinearSystem,
    forcing: Mapping[int | str, complex],
    omega_start: float,
    omega_end: float,
    *,
    harmonics: int | str = 3,
    samples: int | None = None,
    stability: bool = True,
    share_limit: float = DEFAULT_SHARE_LIMIT,
    x_scale: float | None = None,
    **options,
) -> FrequencyResponse:
    """Trace the multi-harmonic frequency response over ``[omega_start, omega_end]`` (rad/s).

    ``harmonics``: H ≥ 1, or ``"auto"`` (the first of 3, 5, 7, 9, 11, 15, … up to 31 whose
    highest harmonics carry at most ``share_limit`` of the response); ``samples``: N per
    period (default :func:`default_samples`); ``stability``: Floquet multipliers by Hill's
    method at every point for H ≥ 2 (otherwise, and always for H = 1 — a single-harmonic
    orbit is too coarse for Hill's method, whose odd perturbations then stop at their first
    copy — the determinant sign of the describing-function solver, saddle-node only); ``options``
    those of :func:`~nlupdate.core.response.continuation.trace_curve` (``fill`` defaults to
    :data:`DEFAULT_FILL`). The returned curve's
    ``x_nonlinear`` holds the states (n_points, H+1, n_a).
    """
    check_band(omega_start, omega_end)
    if not (np.isfinite(share_limit) and 0 < share_limit < 1):
        raise ValueError(f"share_limit: expected a fraction in (0, 1), got {share_limit}")
    if harmonics == "auto":
        for count in AUTO_HARMONICS:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", HarmonicTruncationWarning)
                curve = trace_harmonic_balance(
                    system, forcing, omega_start, omega_end, harmonics=count, samples=samples, stability=False,
                    share_limit=share_limit, x_scale=x_scale, **options,
                )
            if curve.harmonic_share <= share_limit:
                break
        harmonics = count
    if isinstance(harmonics, str) or int(harmonics) != harmonics or harmonics < 1:
        raise ValueError(f"harmonics: expected an integer ≥ 1 or 'auto', got {harmonics!r}")
    problem = HarmonicBalanceProblem(system, forcing, int(harmonics), samples)
    if problem.n == 0:
        raise ValueError("harmonic balance needs at least one nonlinear element; the linear response is H(ω)·F")
    problem.x_scale = x_scale or default_x_scale(problem, omega_start, omega_end)
    curve = trace_curve(problem, omega_start, omega_end, **{"fill": DEFAULT_FILL, **options})
    states = problem.to_complex(curve.y)
    if stability and problem.harmonics > 1:
        stable, multipliers, bifurcations = _stability(problem, curve.omega, states, curve.turning_point)
    else:
        stable = curve.jacobian_determinant > 0
        stable[curve.turning_point] = False
        multipliers, bifurcations = None, ()
    share = _check_truncation(problem, states, curve.omega, share_limit)
    return FrequencyResponse(
        problem, curve.omega, states, stable, curve.turning_point, multipliers, bifurcations, share
    )
