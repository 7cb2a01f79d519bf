"""Amplitude-dependent modal model of one nonlinear mode (single-nonlinear-mode theory).

Near a well-separated resonance a structure with joints behaves like one mode whose natural
frequency and damping ratio depend on how far it vibrates. With the mode mass-normalised
(shape φ in 1/√kg at each coordinate, modal coordinate q in m·√kg), a harmonic force
``Re(F e^{iΩt})`` (N) at coordinate f and the modal amplitude ``a = |q|``::

    D(a, Ω) q = φ_f F,        X_j = φ_j q   (m),

ω in rad/s, D the mode's dynamic stiffness (below). ``ω(0)`` and ``ζ(0)`` are the linear limit (the joint stuck): the natural
frequency an FE model with tied contact should have, and an updating target.

Backbones (ω(a), ζ(a)):

* ``iwan`` — a modal Iwan joint (:class:`~nlupdate.core.model.elements.IwanJoint`, parameters in
  modal units: K_T in rad²/s², i.e. N/m per kg of modal mass; F_S in N/√kg; φ_max in
  m·√kg; a physical joint whose relative displacement is ψ·q gives ψ²K_T and ψF_S)::

      ω(a)² = ω₀² − K_T + Re ν(a),      ζ(a) = ζ_lin(a) + Im ν(a) / (2ω(a)²),

  ν the joint's describing function, so ω(0) = ω₀; the joint softens the mode and adds
  damping that grows as a^(χ+1) in microslip and falls as 1/a in macroslip. The rest of
  the structure's damping ``ζ_lin`` is ``linear_damping = "viscous"`` (a constant modal
  damping coefficient 2ζ₀ω₀: ζ_lin = ζ₀ω₀/ω(a)) or ``"structural"`` (a loss factor on the
  stiffness: ζ_lin = ζ₀ω₀²/ω(a)²), both ζ₀ at a → 0;
* ``polynomial`` — ``f(a) = f₀(1 + Σ_k c_k u^k)`` in ``u = (a/a_ref)^p`` and
  ``ζ(a) = ζ₀ + Σ_k d_k v^k`` in ``v = (a/a_ref)^q``, k = 1 … n, a_ref the largest amplitude
  it was fitted to, p and q the ``frequency_exponent`` and ``damping_exponent`` (1: a
  polynomial in a; ½ follows a joint's ``a^(χ+1)`` softening in microslip over decades of
  amplitude); beyond a_ref the curves are held at their values there (``beyond_reference =
  "hold"``, the default: a polynomial extrapolated turns back on itself and draws a second,
  spurious resonance branch) or continued as fitted up to where they would turn back and
  held from there (``"continued"``: monotone, for predicting a level above the fitted
  ones), and ζ is kept ≥ 0.

Forced response. The mode's dynamic stiffness and receptance are those of
:mod:`nlupdate.core.model.single_mode`: ``D(a, Ω) = ω(a)² − Ω² + 2i[ζ(a)ω(a)² + ζ_v(a)ω(a)(Ω − ω(a))]``,
the damping hysteretic (a friction joint's: its dissipation per cycle does not depend on Ω)
but for the viscous share ζ_v (:meth:`AmplitudeModalModel.viscous_damping`: the rest of the
structure's damping of an ``iwan`` backbone with ``linear_damping = "viscous"``, ζ₀ω₀/ω(a);
zero otherwise, a ``polynomial`` backbone's ζ(a) all hysteretic); at resonance the imaginary
part is 2ζω² either way. For a given a the excitation frequencies with ``|q| = a`` are ::

    Ω² = ω² ± √(P² − 4ζ²ω⁴),     P = |φ_f F| / a,

(without a viscous share; with one, iterated: :func:`~nlupdate.core.model.single_mode.excitation_frequencies`)
real up to the peak amplitude, where the two meet. :meth:`AmplitudeModalModel.frf` traces
this curve over a from the smallest amplitude up to the first peak — the branch continuous
with the linear response; where the discriminant turns real again at larger a the curve is
not followed there — (the branch below resonance up to the peak, the one above back down) and
reads it like a stepped-sine test: each frequency in sweep order takes the first crossing
on a part of the curve that runs in the sweep direction, at or after the current position
(passing a fold is a jump), and solves ``a·|D(a, Ω)| = |φ_f F|`` within that segment.
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from nlupdate.files import atomic_file
from nlupdate.input_files import read_input_text
from nlupdate.core.measurement.frf_table import frf_table
from nlupdate.core.model.elements import IwanJoint
from nlupdate.core.model import single_mode

BACKBONES = ("iwan", "polynomial")
LINEAR_DAMPING = ("viscous", "structural")
#: A polynomial backbone beyond the largest amplitude it was fitted to: held at its value
#: there, or continued as fitted up to where it would turn back and held from there
#: (monotone, so no second resonance branch; what ``nlupdate validate`` needs to predict a
#: level above the fitted ones).
BEYOND_REFERENCE = ("hold", "continued")
#: The Iwan joint's parameters a fit in microslip only bounds from below (fixed β = 0 and φ_max
#: at the largest amplitude: a larger joint fits as well); a model's ``lower_bounds`` names them.
LOWER_BOUNDED = ("kt", "slip_force")
_CURVE_POINTS = 1500


class AmplitudeModelError(ValueError):
    """An amplitude-dependent modal model that cannot be used (the message says why)."""


def joint_omega_zeta(omega0: ArrayLike, damping_ratio: ArrayLike, kt: ArrayLike, nu: NDArray,
                     linear_damping: str) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """ω(a) (rad/s) and ζ(a) of an ``iwan`` backbone from its joint's describing function ν(a)
    (N/m in modal units, rad²/s²): ``ω² = ω₀² − K_T + Re ν``, ``ζ = ζ₀ω₀/ω`` (viscous) or
    ``ζ₀ω₀²/ω²`` (structural) ``+ Im ν/(2ω²)``; the parameters may be arrays that broadcast
    with ν (many models at once)."""
    omega = np.sqrt(np.maximum(omega0**2 - kt + nu.real, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        linear = damping_ratio * omega0 / omega if linear_damping == "viscous" else damping_ratio * omega0**2 / omega**2
        zeta = linear + nu.imag / (2 * omega**2)
    return omega, zeta


@dataclass(frozen=True)
class AmplitudeModalModel:
    """One nonlinear mode: natural frequency and damping ratio against modal amplitude.

    natural_frequency_hz, damping_ratio: the linear limit f₀ (Hz) and ζ₀ (fraction).
    shapes: the mass-normalised mode shape (1/√kg) at named coordinates, as pairs.
    joint: the modal Iwan joint of the ``iwan`` backbone (modal units, module docstring);
    or frequency_coefficients c_k, damping_coefficients d_k (k = 1 …), reference_amplitude
    a_ref (m·√kg) and the exponents p, q of their variables (module docstring) of the
    ``polynomial`` backbone.
    mode: the mode's number (1 = lowest); note: how it was obtained (free text); warnings:
    what the fit could not establish (one sentence each, e.g. a linear limit at its bound);
    reference_unit: "N", or "V" for a model of FRFs per volt (forces, the joint's F_S and the
    shapes' N then per volt: V where N would stand).
    lower_bounds: the joint's parameters the fit determines only from below (:data:`LOWER_BOUNDED`
    names them): ``("kt", "slip_force")`` where it fixed β = 0 and φ_max at the largest amplitude
    because no sample reaches macroslip; empty otherwise.
    """

    natural_frequency_hz: float
    damping_ratio: float
    shapes: tuple[tuple[str, float], ...]
    joint: IwanJoint | None = None
    frequency_coefficients: tuple[float, ...] = ()
    damping_coefficients: tuple[float, ...] = ()
    reference_amplitude: float = 1.0
    mode: int = 1
    frequency_exponent: float = 1.0
    damping_exponent: float = 1.0
    beyond_reference: str = "hold"
    linear_damping: str = "viscous"
    note: str = field(default="", compare=False)
    warnings: tuple[str, ...] = field(default=(), compare=False)
    reference_unit: str = "N"
    lower_bounds: tuple[str, ...] = field(default=(), compare=False)

    def __post_init__(self) -> None:
        f0, zeta = float(self.natural_frequency_hz), float(self.damping_ratio)
        if not (np.isfinite(f0) and f0 > 0):
            raise AmplitudeModelError(f"natural_frequency_hz must be a frequency > 0 Hz, got {self.natural_frequency_hz}")
        if not (np.isfinite(zeta) and 0 <= zeta < 1):
            raise AmplitudeModelError(f"damping_ratio must be a fraction 0 ≤ ζ < 1, got {self.damping_ratio}")
        shapes = tuple((str(name), float(value)) for name, value in self.shapes)
        if not shapes or any(not np.isfinite(v) for _, v in shapes):
            raise AmplitudeModelError("shapes: give the mass-normalised mode shape (1/√kg) at one coordinate or more")
        if self.joint is not None:
            if self.frequency_coefficients or self.damping_coefficients:
                raise AmplitudeModelError("give either an Iwan joint or polynomial coefficients, not both")
            if self.joint.kt >= (2 * np.pi * f0) ** 2:
                raise AmplitudeModelError(
                    f"joint kt = {self.joint.kt:.4g} rad²/s² must be below ω₀² = {(2 * np.pi * f0) ** 2:.4g} (the mode "
                    "without the joint would have no stiffness)")
        if not set(self.lower_bounds) <= set(LOWER_BOUNDED) or (self.lower_bounds and self.joint is None):
            raise AmplitudeModelError(f"lower_bounds: names of the Iwan joint's parameters {list(LOWER_BOUNDED)} (with a "
                                      f"joint), got {list(self.lower_bounds)}")
        if self.reference_unit not in ("N", "V"):
            raise AmplitudeModelError(f"reference_unit must be 'N' or 'V', got {self.reference_unit!r}")
        if self.linear_damping not in LINEAR_DAMPING:
            raise AmplitudeModelError(f"linear_damping must be one of {list(LINEAR_DAMPING)}, got {self.linear_damping!r}")
        if self.beyond_reference not in BEYOND_REFERENCE:
            raise AmplitudeModelError(f"beyond_reference must be one of {list(BEYOND_REFERENCE)}, "
                                      f"got {self.beyond_reference!r}")
        for name in ("frequency_exponent", "damping_exponent"):
            if not (np.isfinite(getattr(self, name)) and getattr(self, name) > 0):
                raise AmplitudeModelError(f"{name} must be > 0, got {getattr(self, name)}")
        if not (np.isfinite(self.reference_amplitude) and self.reference_amplitude > 0):
            raise AmplitudeModelError(f"reference_amplitude must be > 0 (m·√kg), got {self.reference_amplitude}")
        object.__setattr__(self, "natural_frequency_hz", f0)
        object.__setattr__(self, "damping_ratio", zeta)
        object.__setattr__(self, "shapes", shapes)
        object.__setattr__(self, "frequency_coefficients", tuple(float(c) for c in self.frequency_coefficients))
        object.__setattr__(self, "damping_coefficients", tuple(float(c) for c in self.damping_coefficients))
        object.__setattr__(self, "reference_amplitude", float(self.reference_amplitude))

    @property
    def backbone(self) -> str:
        return "iwan" if self.joint is not None else "polynomial"

    @property
    def omega0(self) -> float:
        return 2 * np.pi * self.natural_frequency_hz

    def shape(self, coordinate: str | int) -> float:
        """φ (1/√kg) at a coordinate (name, or position in ``shapes``)."""
        if isinstance(coordinate, (int, np.integer)) and not isinstance(coordinate, bool):
            return self.shapes[int(coordinate)][1]
        for name, value in self.shapes:
            if name == str(coordinate):
                return value
        raise AmplitudeModelError(f"coordinate {coordinate!r}: the model's shape is given at "
                                  f"{[name for name, _ in self.shapes]}")

    # -- backbone and damping curve -------------------------------------------------------
    def omega_zeta(self, amplitude: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """ω(a) (rad/s) and ζ(a) at modal amplitudes a (m·√kg)."""
        a = np.asarray(amplitude, dtype=float)
        w0, z0 = self.omega0, self.damping_ratio
        if self.joint is not None:
            return self.joint_curves(self.joint.describing_function(a))
        x = a / self.reference_amplitude
        omega = w0 * (1 + _series(self.frequency_coefficients, x, self.frequency_exponent, self.beyond_reference))
        zeta = np.maximum(z0 + _series(self.damping_coefficients, x, self.damping_exponent, self.beyond_reference), 0.0)
        return np.asarray(omega + 0 * x, dtype=float), np.asarray(zeta + 0 * x, dtype=float)

    def joint_curves(self, describing_function: NDArray) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """ω (rad/s) and ζ of a joint's backbone from its describing function ν (N/m per modal
        unit) at the amplitudes ν was evaluated at (:func:`joint_omega_zeta`): what
        :meth:`omega_zeta` returns there, for a caller that has ν already (the Iwan fit keeps it
        for its Jacobian)."""
        return joint_omega_zeta(self.omega0, self.damping_ratio, self.joint.kt, describing_function,
                                self.linear_damping)

    def frequency_hz(self, amplitude: ArrayLike) -> NDArray[np.float64]:
        """Natural frequency (Hz) at modal amplitudes a (m·√kg): the backbone."""
        return self.omega_zeta(amplitude)[0] / (2 * np.pi)

    def damping(self, amplitude: ArrayLike) -> NDArray[np.float64]:
        """Damping ratio at modal amplitudes a (m·√kg): the damping curve."""
        return self.omega_zeta(amplitude)[1]

    def viscous_damping(self, amplitude: ArrayLike) -> NDArray[np.float64]:
        """The viscous share ζ_v(a) of ζ(a) at modal amplitudes a (m·√kg): ζ₀ω₀/ω(a) for an
        ``iwan`` backbone with ``linear_damping = "viscous"``, else 0 (module docstring)."""
        a = np.asarray(amplitude, dtype=float)
        if self.joint is None or self.linear_damping != "viscous":
            return np.zeros(a.shape)
        with np.errstate(divide="ignore", invalid="ignore"):
            return self.damping_ratio * self.omega0 / self.omega_zeta(a)[0]

    def dynamic_stiffness(self, amplitude: ArrayLike, omega: ArrayLike) -> NDArray[np.complex128]:
        """The mode's ``D(a, Ω)`` (rad²/s²) at modal amplitudes a (m·√kg) and excitation Ω
        (rad/s): :func:`~nlupdate.core.model.single_mode.dynamic_stiffness`."""
        w, zeta = self.omega_zeta(amplitude)
        return single_mode.dynamic_stiffness(omega, w, zeta, self.viscous_damping(amplitude))

    # -- forced response ------------------------------------------------------------------
    def _curve(self, modal_force: float, lowest: float) -> tuple[NDArray, NDArray]:
        """(Ω rad/s, a) along the response curve: below resonance up to the peak, then back."""
        peak_guess = modal_force / (2 * max(self.damping_ratio, 1e-6) * self.omega0**2)
        a = np.geomspace(lowest, 10 * peak_guess, _CURVE_POINTS)

        def discriminant_of(amplitude):
            return single_mode.resonance_discriminant(modal_force, amplitude, *self.omega_zeta(amplitude))

        discriminant = discriminant_of(a)
        real = (discriminant >= 0) & np.isfinite(discriminant)
        # the branch continuous from the smallest amplitude: up to the first peak only
        top = int(np.argmin(real)) - 1 if not real.all() else a.size - 1
        real[top + 1:] = False
        if 0 <= top < a.size - 1:  # the peak, where the two branches meet, by bisection
            lo, hi = a[top], a[top + 1]
            for _ in range(60):
                mid = np.sqrt(lo * hi)
                lo, hi = (mid, hi) if discriminant_of(mid) >= 0 else (lo, mid)
            a = np.insert(a, top + 1, lo)
            real = np.insert(real, top + 1, True)
        w_a, zeta = self.omega_zeta(a)
        below, above = single_mode.excitation_frequencies(modal_force, a, w_a, np.where(real, zeta, np.nan),
                                                          self.viscous_damping(a))
        keep_below, keep_above = np.isfinite(below), np.isfinite(above)
        w = np.concatenate([below[keep_below], above[keep_above][::-1]])
        amp = np.concatenate([a[keep_below], a[keep_above][::-1]])
        return w, amp

    def modal_amplitude(self, omega: ArrayLike, force_n: float, input_dof: str | int, sweep: str = "up") -> NDArray:
        """Modal amplitude a (m·√kg) at the excitation frequencies Ω (rad/s) for a force of
        amplitude ``force_n`` (N) at ``input_dof``, read as a stepped-sine test (module docstring)."""
        if sweep not in ("up", "down"):
            raise AmplitudeModelError(f"sweep must be 'up' or 'down', got {sweep!r}")
        omega = np.asarray(omega, dtype=float)
        modal_force = abs(self.shape(input_dof) * float(force_n))
        if modal_force == 0:
            return np.zeros(omega.shape)
        w_max = float(np.max(omega))
        lowest = modal_force / (4 * (self.omega0**2 + w_max**2))  # |q| well below any |φ_f F/D|
        w, a = self._curve(modal_force, lowest)
        order = np.argsort(omega) if sweep == "up" else np.argsort(omega)[::-1]
        if sweep == "down":
            w, a = w[::-1], a[::-1]
        sign = 1.0 if sweep == "up" else -1.0
        low = np.full(omega.shape, np.nan)
        high = np.full(omega.shape, np.nan)
        position = 0
        for index in order:
            target = omega[index]
            lo, hi = w[position:-1], w[position + 1:]
            forward = sign * (hi - lo) > 0
            crossing = forward & ((lo - target) * (hi - target) <= 0)
            hits = np.flatnonzero(crossing)
            if hits.size == 0:
                if sign * (target - w[position]) < 0:  # before the traced curve: far from resonance
                    low[index] = high[index] = a[0]
                continue
            k = position + int(hits[0])
            low[index], high[index] = a[k], a[k + 1]
            position = k
        return self._polish(omega, modal_force, low, high)

    def _polish(self, omega: NDArray, modal_force: float, low: NDArray, high: NDArray) -> NDArray:
        """The root of ``a·|D(a, Ω)| = |φ_f F|`` between the amplitudes of the curve segment
        each Ω crosses (bisection in log a; the segment end nearer the root where the
        bracket does not change sign)."""
        def mismatch(a):
            return np.log(a * np.abs(self.dynamic_stiffness(a, omega)) / modal_force)

        valid = np.isfinite(low) & np.isfinite(high)
        lo, hi = np.where(valid, np.minimum(low, high), 1.0), np.where(valid, np.maximum(low, high), 1.0)
        g_lo = mismatch(lo)
        bracket = valid & (np.sign(g_lo) != np.sign(mismatch(hi)))
        for _ in range(60):
            mid = np.sqrt(lo * hi)
            g_mid = mismatch(mid)
            same = np.sign(g_mid) == np.sign(g_lo)
            lo, g_lo = np.where(same, mid, lo), np.where(same, g_mid, g_lo)
            hi = np.where(same, hi, mid)
        nearest = np.where(np.abs(mismatch(np.where(valid, low, 1.0))) <= np.abs(mismatch(np.where(valid, high, 1.0))),
                           low, high)
        return np.where(bracket, np.sqrt(lo * hi), np.where(valid, nearest, np.nan))

    def frf(self, frequency_hz: ArrayLike, force_n: float, response_dof: str | int, input_dof: str | int,
            sweep: str = "up") -> NDArray[np.complex128]:
        """Receptance H = X_response/F (m/N) at the frequencies (Hz) for a force amplitude
        ``force_n`` (N) at ``input_dof``, by single-nonlinear-mode theory (module docstring)."""
        omega = 2 * np.pi * np.asarray(frequency_hz, dtype=float)
        return self.receptance(self.modal_amplitude(omega, force_n, input_dof, sweep), omega, response_dof, input_dof)

    def receptance(self, amplitude: ArrayLike, omega: ArrayLike, response_dof: str | int,
                   input_dof: str | int) -> NDArray[np.complex128]:
        """The mode's receptance ``φ_rφ_f/D(a, Ω)`` (m/N) at modal amplitudes a (m·√kg) and
        excitation Ω (rad/s): :func:`~nlupdate.core.model.single_mode.receptance`."""
        w, zeta = self.omega_zeta(amplitude)
        return single_mode.receptance(omega, w, zeta, self.shape(response_dof), self.shape(input_dof),
                                      viscous=self.viscous_damping(amplitude))

    # -- the other test types ----------------------------------------------------------
    def phase_resonance_point(self, force_n: ArrayLike, input_dof: str | int) -> tuple[NDArray, NDArray]:
        """(natural frequency Hz, modal amplitude a m·√kg) a phase-resonance test holds at
        force amplitudes ``force_n`` (N) at ``input_dof``: at quadrature Ω = ω(a) and
        ``2ζ(a)ω(a)²a = |φ_f|F`` (docs/ring-down.md, "Phase resonance"), solved for a by
        bisection in log a over 1e-12 … 1e3 m·√kg (the lowest a if several)."""
        modal_force = np.abs(self.shape(input_dof) * np.asarray(force_n, dtype=float))

        def excess(a):
            omega, zeta = self.omega_zeta(a)
            return np.log(2 * zeta * omega**2 * a / modal_force)

        lo, hi = np.full(modal_force.shape, 1e-12), np.full(modal_force.shape, 1e3)
        grid = np.geomspace(1e-12, 1e3, 301)
        values = np.array([excess(np.full(modal_force.shape, a)) for a in grid])
        crossing = np.argmax(values >= 0, axis=0)  # the first grid amplitude at or past the balance
        found = np.take_along_axis(values >= 0, crossing[None], axis=0)[0] & (crossing > 0)
        lo = np.where(found, grid[np.maximum(crossing - 1, 0)], np.nan)
        hi = np.where(found, grid[crossing], np.nan)
        for _ in range(60):
            mid = np.sqrt(lo * hi)
            above = excess(mid) >= 0
            lo, hi = np.where(above, lo, mid), np.where(above, mid, hi)
        a = np.sqrt(lo * hi)
        return self.frequency_hz(a), a

    def ring_down_envelope(self, time_s: ArrayLike, start_amplitude: float) -> NDArray[np.float64]:
        """Modal amplitude a(t) (m·√kg) of a free decay from ``start_amplitude`` at ``time_s[0]``:
        the slow flow ``da/dt = −ζ(a)ω(a)a`` of first-order averaging (docs/ring-down.md, "What it
        is checked against"), integrated in ln a by scipy's DOP853 (rtol 1e-9)."""
        import scipy.integrate

        t = np.asarray(time_s, dtype=float)

        def rate(_, y):
            omega, zeta = self.omega_zeta(np.exp(y))
            return -zeta * omega

        solution = scipy.integrate.solve_ivp(rate, (t[0], t[-1]), [np.log(float(start_amplitude))], method="DOP853",
                                             t_eval=t, rtol=1e-9, atol=1e-12)
        return np.exp(solution.y[0])

    def held_frf(self, frequency_hz: ArrayLike, held_m: float, response_dof: str | int,
                 input_dof: str | int) -> NDArray[np.complex128]:
        """Receptance (m/N) of a response-controlled sweep holding the displacement amplitude
        ``held_m`` (m) at ``response_dof``: at a = held/|φ_r| the mode is linear,
        ``H = φ_rφ_f/D(a, Ω)`` (:meth:`receptance`)."""
        omega = 2 * np.pi * np.asarray(frequency_hz, dtype=float)
        amplitude = np.full(omega.shape, abs(float(held_m)) / abs(self.shape(response_dof)))
        return self.receptance(amplitude, omega, response_dof, input_dof)

    def frf_table(self, frequency_hz: ArrayLike, force_levels_n: Sequence[float], input_dof: str,
                  sweep: str = "up") -> pd.DataFrame:
        """Predicted measured-FRF table (every coordinate of ``shapes``) at each force level."""
        f = np.asarray(frequency_hz, dtype=float)
        names = [name for name, _ in self.shapes]
        tables = []
        for level in force_levels_n:
            h = np.column_stack([self.frf(f, level, name, input_dof, sweep) for name in names])
            tables.append(frf_table(f[:, None], float(level), np.array(names, dtype=object)[None, :], str(input_dof), h))
        return pd.concat(tables, ignore_index=True)

    # -- files ----------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "kind": "amplitude_dependent_mode", "mode": self.mode, "backbone": self.backbone,
            "natural_frequency_hz": self.natural_frequency_hz, "damping_ratio": self.damping_ratio,
            "shapes": {name: value for name, value in self.shapes},
            "units": ("modal amplitude a in m*sqrt(kg) (mass-normalised mode), shapes in 1/sqrt(kg), frequencies in Hz"
                      if self.reference_unit == "N" else
                      "modal amplitude a in m*sqrt(kg*V/N) (mass-normalised mode of FRFs per volt), shapes in "
                      "1/sqrt(kg*V/N), frequencies in Hz; per volt: the levels are in V and every N of the forces and "
                      "of the joint's slip_force is V"),
            "reference_unit": self.reference_unit,
        }
        if self.joint is not None:
            j = self.joint
            out["joint"] = {"slip_force": j.slip_force, "kt": j.kt, "chi": j.chi, "beta": j.beta,
                            "units": f"modal: slip_force {self.reference_unit}/sqrt(kg), kt rad^2/s^2"}
            out["linear_damping"] = self.linear_damping
        else:
            out["polynomial"] = {"frequency_coefficients": list(self.frequency_coefficients),
                                 "damping_coefficients": list(self.damping_coefficients),
                                 "reference_amplitude": self.reference_amplitude,
                                 "frequency_exponent": self.frequency_exponent,
                                 "damping_exponent": self.damping_exponent,
                                 "beyond_reference": self.beyond_reference}
        if self.note:
            out["note"] = self.note
        if self.warnings:
            out["warnings"] = list(self.warnings)
        if self.lower_bounds:
            out["lower_bounds"] = list(self.lower_bounds)
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], source: str = "<amplitude model>") -> "AmplitudeModalModel":
        try:
            shapes = tuple(dict(data["shapes"]).items())
            common = dict(natural_frequency_hz=float(data["natural_frequency_hz"]),
                          damping_ratio=float(data["damping_ratio"]), shapes=shapes, mode=int(data.get("mode", 1)),
                          note=str(data.get("note", "")), warnings=tuple(str(w) for w in data.get("warnings", ())),
                          reference_unit=str(data.get("reference_unit", "N")),
                          lower_bounds=tuple(str(name) for name in data.get("lower_bounds", ())))
            if data.get("backbone") == "iwan":
                j = data["joint"]
                joint = IwanJoint((0,), slip_force=j["slip_force"], kt=j["kt"], chi=j["chi"], beta=j["beta"])
                return cls(joint=joint, linear_damping=str(data.get("linear_damping", "viscous")), **common)
            if data.get("backbone") == "polynomial":
                p = data["polynomial"]
                return cls(frequency_coefficients=tuple(p["frequency_coefficients"]),
                           damping_coefficients=tuple(p["damping_coefficients"]),
                           reference_amplitude=float(p["reference_amplitude"]),
                           frequency_exponent=float(p.get("frequency_exponent", 1.0)),
                           damping_exponent=float(p.get("damping_exponent", 1.0)),
                           beyond_reference=str(p.get("beyond_reference", "hold")), **common)
        except (KeyError, TypeError, ValueError) as error:
            raise AmplitudeModelError(f"{source}: not an amplitude-dependent modal model ({error})") from None
        raise AmplitudeModelError(f"{source}: 'backbone' must be one of {list(BACKBONES)}, got {data.get('backbone')!r}")


def write_amplitude_model(model: AmplitudeModalModel, path: str | os.PathLike) -> Path:
    """Write the model as JSON (atomically); returns the path."""
    path = Path(path)
    with atomic_file(path) as temporary:
        Path(temporary).write_text(json.dumps(model.to_dict(), indent=2) + "\n")
    return path


def read_amplitude_model(path: str | os.PathLike) -> AmplitudeModalModel:
    """Read a model written by :func:`write_amplitude_model`."""
    try:
        data = json.loads(read_input_text(Path(path), "amplitude-dependent modal model"))
    except json.JSONDecodeError as error:
        raise AmplitudeModelError(f"{path}: not valid JSON ({error})") from None
    if not isinstance(data, dict):
        raise AmplitudeModelError(f"{path}: expected a JSON object")
    return AmplitudeModalModel.from_dict(data, str(path))


def _series(coefficients: Sequence[float], x: NDArray, exponent: float, beyond: str) -> NDArray:
    """``Σ_k c_k u^k`` (k = 1 …) in ``u = x^exponent``; beyond x = 1 held at its value there,
    or continued as it is up to where it would turn back (its first stationary point past
    u = 1) and held from there (:data:`BEYOND_REFERENCE`)."""
    u = np.asarray(x, dtype=float) ** exponent
    stop = 1.0
    if beyond == "continued" and len(coefficients):
        slope = np.polynomial.Polynomial([0.0, *coefficients]).deriv()
        turns = [r.real for r in slope.roots() if abs(r.imag) < 1e-12 and r.real > 1.0]
        stop = min(turns, default=np.inf)
    u = np.minimum(u, stop)
    return sum(c * u ** (k + 1) for k, c in enumerate(coefficients)) + 0.0 * u
