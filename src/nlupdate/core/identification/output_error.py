"""PRD's improved estimator, its model of the data: the measured points of a frequency
window and the output-error residual over them, with its Jacobian.

:class:`Window` holds every low-force and high-force point with
``|f − f_e| ≤ half_window·f_e``; :class:`OutputError` maps θ = (Re z, Im z, p) — the
window's complex quadratic ``Z_L`` and the DF parameters — to the residuals
``(X_model − X̃)/|X̃|``, each point's amplitude solved by the scalar harmonic balance
(:mod:`nlupdate.core.identification.scalar_balance`), and gives ∂r/∂θ from the solved
amplitudes. The estimator that fits it is :func:`nlupdate.core.identification.prd.prd_improved`.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.dfmodels import Model, PolynomialModel
from nlupdate.core.identification.scalar_balance import RootSensitivity, nearest_amplitude


def window_design(x: NDArray, degree: int) -> NDArray:
    """Columns 1, x, x², … (up to ``degree``) of the window's quadratic ``Z_L(x)``."""
    return x[:, None] ** np.arange(degree + 1)[None, :]


@dataclass(frozen=True, eq=False)
class Window:
    """The measured points of the improved estimator's window ``|f − f_e| ≤ half_window·f_e``.

    Low level: frequencies ``f_low`` (Hz), receptances ``h_low`` (m/N), forces ``force_low``
    (N, achieved at each line). High levels: points f-major (each frequency of ``f_high``
    repeated for every level): forces ``force_high``, measured complex amplitudes
    ``x_high`` (m), the low level's force at their frequency ``low_force_high``.
    ``degree``: of the quadratic ``Z_L`` (less with fewer low-force lines).
    """

    frequency_hz: float
    degree: int
    levels: NDArray[np.float64]
    f_low: NDArray[np.float64]
    h_low: NDArray[np.complex128]
    force_low: NDArray[np.float64]
    f_high: NDArray[np.float64]
    force_high: NDArray[np.float64]
    x_high: NDArray[np.complex128]
    low_force_high: NDArray[np.float64]
    low_force_e: float

    @property
    def x_low(self) -> NDArray[np.complex128]:
        """Measured complex amplitudes (m) of the low level."""
        return self.h_low * self.force_low

    @property
    def omega_low(self) -> NDArray[np.float64]:
        return 2 * np.pi * self.f_low

    @property
    def omega_high(self) -> NDArray[np.float64]:
        return 2 * np.pi * np.repeat(self.f_high, self.levels.size)

    def design(self, which: str) -> NDArray[np.float64]:
        """``Z_L``'s design matrix at the ``"low"`` or ``"high"`` points (``x = (f − f_e)/f_e``)."""
        f = self.f_low if which == "low" else np.repeat(self.f_high, self.levels.size)
        return window_design((f - self.frequency_hz) / self.frequency_hz, self.degree)


def window_points(data: FRFLevels, frequency_hz: float, low_force: float, high_forces: Sequence[float],
                  half_window: float) -> Window:
    """The points of :class:`Window` from the measured curves: the window around the
    excitation frequency ``frequency_hz`` (Hz) of the ``low_force`` and ``high_forces`` (N)
    levels."""
    fe = frequency_hz
    f_low_all, h_low_all = data.curve(low_force)
    inside = np.abs(f_low_all - fe) <= half_window * fe + 1e-9 * fe
    f_low, h_low = f_low_all[inside], h_low_all[inside]
    levels = np.array(high_forces)
    common = data.common_frequencies(levels)
    f_high = common[np.abs(common - fe) <= half_window * fe + 1e-9 * fe]
    # Z_L(ω) is a quadratic in the window, fixed mostly by the low-force sweep; with a
    # single low-force frequency it is a constant and only ω_e can be used at high force
    degree = int(min(2, max(f_low.size - 1, 0)))
    if degree == 0:
        f_high = f_high[np.isclose(f_high, fe, rtol=1e-9, atol=0.0)]
    h_high = np.array([data.values(level, f_high) for level in levels])          # (n_levels, n_f)
    achieved = np.array([data.force_at(level, f_high) for level in levels])      # the force at each line
    return Window(
        frequency_hz=fe, degree=degree, levels=levels, f_low=f_low, h_low=h_low,
        force_low=data.force_at(low_force, f_low), f_high=f_high, force_high=achieved.T.ravel(),
        x_high=(h_high * achieved).T.ravel(),
        low_force_high=data.force_at(low_force, np.repeat(f_high, levels.size)),
        low_force_e=float(data.force_at(low_force, fe)),
    )


class OutputError:
    """Residuals ``(X_model − X̃)/|X̃|`` of every window point for θ = (Re z, Im z, p)
    (module docstring), and their Jacobian. Each point's amplitude root is followed from
    call to call (warm start at the previous root; the measured amplitude when that branch
    is lost)."""

    def __init__(self, window: Window, model: Model, a_low_e: float) -> None:
        self.window, self.model, self.a_low_e = window, model, a_low_e
        self.n_z = window.degree + 1
        self.design_low, self.design_high = window.design("low"), window.design("high")
        self.previous = {"low": np.abs(window.x_low), "high": np.abs(window.x_high)}
        self._last: tuple[bytes, list[SolvedPoints]] | None = None

    def split(self, theta: NDArray) -> tuple[NDArray[np.complex128], NDArray[np.float64]]:
        """(z: ``Z_L``'s complex coefficients, p: the DF parameters)."""
        return theta[: self.n_z] + 1j * theta[self.n_z : 2 * self.n_z], theta[2 * self.n_z :]

    def low_force_df(self, p: NDArray) -> Callable:
        """ν at the low level. A polynomial model has no low-force DF of its own: Δ_f1 at
        f_e, varying like the high-force DF with the low-force amplitude across the window."""
        if not isinstance(self.model, PolynomialModel):
            return self.model.function(p, "low")
        nu_high = self.model.function(p, "high")
        delta = self.model.delta_f1(p)
        reference = nu_high(np.array([self.a_low_e]), 2 * np.pi * self.window.frequency_hz)[0]
        return lambda a, omega: delta + nu_high(a, omega) - reference

    def _dfs(self, p: NDArray) -> tuple[Callable, Callable]:
        return self.low_force_df(p), self.model.function(p, "high")

    def _amplitudes(self, z_l: NDArray, nu: Callable, force: NDArray, omega: NDArray,
                    which: str) -> tuple[NDArray, NDArray]:
        measured = np.abs(self.window.x_low if which == "low" else self.window.x_high)
        a, ok = nearest_amplitude(z_l, nu, force, omega, self.previous[which])
        if not np.all(ok):
            a, ok = nearest_amplitude(z_l, nu, force, omega, measured)
        self.previous[which] = a
        return a, ok

    def _solve(self, theta: NDArray) -> list[SolvedPoints]:
        """The low and the high points solved at θ (the last θ is kept: the Jacobian is asked
        for where the residual was just evaluated)."""
        key = np.asarray(theta, dtype=float).tobytes()
        if self._last is not None and self._last[0] == key:
            return self._last[1]
        w = self.window
        z, p = self.split(theta)
        nu_low, nu_high = self._dfs(p)
        solved = []
        for which, design, nu, force, omega in (("low", self.design_low, nu_low, w.force_low, w.omega_low),
                                                ("high", self.design_high, nu_high, w.force_high, w.omega_high)):
            z_l = design @ z
            a, ok = self._amplitudes(z_l, nu, force, omega, which)
            solved.append(SolvedPoints(design, z_l, nu, force, omega, a, ok))
        self._last = (key, solved)
        return solved

    def responses(self, theta: NDArray) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
        """Model amplitudes ``X = F/(Z_L(ω) + ν(A))`` (m) at the low and the high points."""
        low, high = self._solve(theta)
        return low.response(), high.response()

    def __call__(self, theta: NDArray) -> NDArray[np.float64]:
        x_low, x_high = self.responses(theta)
        w = self.window
        r = np.concatenate([(x_low - w.x_low) / np.abs(w.x_low), (x_high - w.x_high) / np.abs(w.x_high)])
        return np.concatenate([r.real, r.imag])

    def jacobian(self, theta: NDArray) -> NDArray[np.float64]:
        """∂r/∂θ from the solved amplitudes (no solve per parameter): a change ∂s of
        ``s = Z_L + ν(A, p)`` at fixed A (``design·dz`` for z, a forward difference of the DF
        for p) moves the root as :class:`~nlupdate.core.identification.scalar_balance.RootSensitivity`
        says, and ``dX = −F/s² ds``."""
        w = self.window
        z, p = self.split(theta)
        steps = 1e-7 * np.where(p != 0, np.abs(p), 1.0)
        stepped = [self._dfs(p + step * unit) for step, unit in zip(steps, np.eye(p.size))]
        blocks = []
        for k, (part, measured) in enumerate(zip(self._solve(theta), (w.x_low, w.x_high))):
            changes = [part.design[:, j] + 0j for j in range(self.n_z)]
            changes += [1j * part.design[:, j] for j in range(self.n_z)]
            changes += [(functions[k](part.amplitude, part.omega) - part.value) / step
                        for functions, step in zip(stepped, steps)]
            blocks.append(part.d_responses(changes) / np.abs(measured)[:, None])
        d_r = np.concatenate(blocks)
        return np.concatenate([d_r.real, d_r.imag])


@dataclass(frozen=True, eq=False)
class SolvedPoints:
    """The low or the high points of the window solved at one θ: design, ``Z_L``, ν, the
    force (N), ω (rad/s), the amplitude A (m) and whether each point has a root."""

    design: NDArray[np.float64]
    z_l: NDArray[np.complex128]
    nu: Callable
    force: NDArray[np.float64]
    omega: NDArray[np.float64]
    amplitude: NDArray[np.float64]
    solved: NDArray[np.bool_]

    @property
    def value(self) -> NDArray[np.complex128]:
        return self.nu(self.amplitude, self.omega)

    def response(self) -> NDArray[np.complex128]:
        return self.force / (self.z_l + self.value)

    def d_responses(self, changes: list[NDArray[np.complex128]]) -> NDArray[np.complex128]:
        """dX (points, changes) for each change of s at fixed amplitude (see :meth:`OutputError.jacobian`)."""
        root = RootSensitivity.at(self.z_l, self.nu, self.amplitude, self.omega, self.solved)
        return np.stack([-self.force / root.s**2 * root.d_s(change) for change in changes], axis=1)
