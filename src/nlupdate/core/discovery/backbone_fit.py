"""Amplitude-dependent natural frequency and damping of one mode, and candidate fits to them.

Single-mode describing-function model. With the mass-normalised mode r of the linear model
(φ its shape, ω_r, ζ_r, η_r) and elements acting on ``ψ_e q`` (``ψ_e = φ_{r_e} − φ_{j_e}``,
q the modal amplitude), the harmonic balance of the mode driven at coordinate f is

    (ω_r² − ω² + i(2ζ_r ω_r ω + η_r ω_r²) + Σ_e ψ_e² ν_e(|ψ_e| Q, ω)) q = φ_f F,   Q = |q|.

At phase resonance (the force in quadrature with the response, as a phase-resonance test
sets it and as a modal fit of a random test reads it) the real part vanishes and

    ω_eq² = ω_r² + Σ ψ_e² Re ν_e,   D(Q) = 2ζ_r ω_r ω_eq + η_r ω_r² + Σ ψ_e² Im ν_e,
    Q·D(Q) = |φ_f| F,   ζ_eq = D / (2 ω_eq²),

solved for the smallest Q (the state reached by raising the force from zero): a log-grid
scan of ``Q·D(Q) − |φ_f|F``, then the Illinois (modified regula falsi) method,
with ω_eq by fixed-point iteration at each Q.
For a random test the table's force is an RMS value; it is used as the amplitude F, so
amplitude-dependent parameters (slip forces) are in those units.

Fit. Residuals ``(f_eq − f̃)/(σ_f f̃)`` and ``(ζ_eq − ζ̃)/(σ_ζ ζ̃)`` (relative uncertainties
σ_f, σ_ζ), so ``Σ r² = χ²``. Everything acts on the one modal coordinate, so all elements —
wherever they are — are solved together; a modal table cannot tell places apart beyond
how much the mode moves there (|ψ|).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.discovery.candidates import CandidateFit, FoundEffect
from nlupdate.core.discovery.effects import DFSamples, Effect
from nlupdate.core.discovery.fitting import fit_at_place
from nlupdate.core.discovery.localisation import Localisation, summarise
from nlupdate.core.model.linear import ModalModel

_GRID = np.geomspace(1e-5, 1e2, 71)
_FREQUENCY_ITERATIONS = 20
_ITERATIONS = 60

Term = tuple[NDArray[np.float64], Callable[[NDArray, NDArray], NDArray]]


def _participation(modal: ModalModel, mode: NDArray, dofs: Sequence[int]) -> NDArray[np.float64]:
    """``ψ = φ_r − φ_j`` of each point's mode at a place."""
    phi = modal.mode_shapes
    return phi[dofs[0], mode] - (phi[dofs[1], mode] if len(dofs) == 2 else 0.0)


def phase_resonance(
    modal: ModalModel, mode: NDArray, input_dof: int, force: NDArray, terms: Sequence[Term]
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """``(ω_eq in rad/s, ζ_eq, Q)`` per point for the DF terms ``(ψ per point, ν(A, ω))``."""
    wr = modal.omega_r[mode][:, None]
    zeta = modal.damping_ratios[mode][:, None]
    eta = modal.loss_factors[mode][:, None]
    drive = (np.abs(modal.mode_shapes[input_dof, mode]) * force)[:, None]

    def state(q: NDArray) -> tuple[NDArray, NDArray, NDArray]:
        floor = 1e-12 * wr**2
        w2 = np.broadcast_to(wr**2, q.shape)
        for _ in range(_FREQUENCY_ITERATIONS):
            w = np.sqrt(np.maximum(w2, floor))
            nu = sum(psi[:, None] ** 2 * df(np.abs(psi[:, None]) * q, w) for psi, df in terms)
            new = wr**2 + np.real(nu)
            settled = np.max(np.abs(new - w2)) <= 1e-13 * np.max(wr**2)
            w2 = new
            if settled:
                break
        w = np.sqrt(np.maximum(w2, floor))
        damping = 2 * zeta * wr * w + eta * wr**2 + np.imag(nu)
        return w, damping, np.where(w2 > 0, q * damping - drive, np.inf)

    q_linear = drive[:, 0] / np.maximum(2 * zeta * wr**2 + eta * wr**2, 1e-4 * wr**2)[:, 0]
    grid = q_linear[:, None] * _GRID[None, :]
    rows = np.arange(grid.shape[0])
    with np.errstate(all="ignore"):
        balance = state(grid)[2]
        above = ~(balance <= 0)  # NaN counts as above: no balance there
        first = np.argmax(above, axis=1)
        bracketed = above.any(axis=1) & (first > 0)
        k = np.clip(first, 1, grid.shape[1] - 1)
        low, high = grid[rows, k - 1], grid[rows, k]
        g_low, g_high = balance[rows, k - 1], balance[rows, k]
        replaced_low = np.zeros(low.shape, bool)  # Illinois: which end the last step replaced
        replaced_high = np.zeros(low.shape, bool)
        for _ in range(_ITERATIONS):  # Illinois in Q; bisection where the upper side has no balance
            secant = np.isfinite(g_high) & np.isfinite(g_low) & (g_high != g_low)
            middle = np.where(secant, low - g_low * (high - low) / np.where(secant, g_high - g_low, 1.0), 0.5 * (low + high))
            g = state(middle[:, None])[2][:, 0]
            below = g <= 0
            g_high = np.where(below & replaced_low, 0.5 * g_high, g_high)
            g_low = np.where(~below & replaced_high, 0.5 * g_low, g_low)
            low, g_low = np.where(below, middle, low), np.where(below, g, g_low)
            high, g_high = np.where(below, high, middle), np.where(below, g_high, g)
            replaced_low, replaced_high = below, ~below
            if np.all(~bracketed | (np.abs(g) <= 1e-12 * drive[:, 0]) | (high - low <= 1e-14 * high)):
                break
        q = np.where(bracketed, middle, np.where(first == 0, grid[:, 0], grid[:, -1]))
        w, damping, _ = state(q[:, None])
    return w[:, 0], damping[:, 0] / (2 * w[:, 0] ** 2), q


@dataclass(frozen=True, eq=False)
class ModalContext:
    """Everything needed to fit candidates at one place against a modal table.

    modal: the background linear model as modes; background: DF terms of the elements not
    at the place (fixed); psi: the tested modes' ψ at the place, per point; fixed: the
    user's elements at the place; companions: effects found earlier there.
    """

    dofs: tuple[int, ...]
    modal: ModalModel
    mode: NDArray[np.int64]
    input_dof: int
    force: NDArray[np.float64]
    frequency_hz: NDArray[np.float64]
    damping_ratio: NDArray[np.float64]
    background: tuple[Term, ...]
    psi: NDArray[np.float64]
    fixed: tuple
    companions: tuple[FoundEffect, ...]
    frequency_uncertainty: float
    damping_uncertainty: float
    penalty: float
    samples: DFSamples
    localisation: Localisation

    @property
    def n_data(self) -> int:
        return 2 * self.force.size

    def predict(self, effects: Sequence[Effect] = (), values: Sequence[NDArray] = ()) -> tuple[NDArray, NDArray]:
        """Natural frequency (Hz) and damping ratio per point with these effects at the place."""
        terms = list(self.background) + [(self.psi, e.describing_function) for e in self.fixed]
        terms += [(self.psi, lambda a, w, e=e, v=v: e.nu(v, a, w)) for e, v in zip(effects, values)]
        w, zeta, _ = phase_resonance(self.modal, self.mode, self.input_dof, self.force, terms)
        return w / (2 * np.pi), zeta

    def residual(self, effects: Sequence[Effect], values: Sequence[NDArray]) -> NDArray[np.float64]:
        return modal_residual(self, *self.predict(effects, values))

    def fit(self, effect: Effect) -> CandidateFit:
        return fit_at_place(self, effect)


def modal_residual(table, frequency_hz: NDArray, damping_ratio: NDArray) -> NDArray[np.float64]:
    """The misfits of a model's natural frequencies (Hz) and damping ratios at a modal table's
    points, each relative to the measured value over its uncertainty (the module docstring's
    residual, ``Σ r² = χ²``): frequencies first. ``table``: the measured ``frequency_hz``,
    ``damping_ratio`` and their relative ``frequency_uncertainty``, ``damping_uncertainty``
    (a :class:`ModalContext`, or the joint problem's
    :class:`~nlupdate.core.discovery.joint.ModalJoint`)."""
    return np.concatenate([
        (frequency_hz - table.frequency_hz) / (table.frequency_uncertainty * table.frequency_hz),
        (damping_ratio - table.damping_ratio) / (table.damping_uncertainty * table.damping_ratio),
    ])


def element_terms(modal: ModalModel, mode: NDArray, elements: Sequence) -> list[Term]:
    """DF terms ``(ψ, ν)`` of model elements for the tested modes."""
    return [(_participation(modal, mode, e.dofs), e.describing_function) for e in elements]


def modal_context(
    modal: ModalModel,
    background_elements: Sequence,
    fixed: tuple,
    companions: tuple[FoundEffect, ...],
    dofs: tuple[int, ...],
    input_dof: int,
    force: NDArray,
    mode: NDArray,
    frequency_hz: NDArray,
    damping_ratio: NDArray,
    level_index: NDArray,
    frequency_uncertainty: float,
    damping_uncertainty: float,
    penalty: float,
) -> ModalContext:
    """Context of one place with the apparent DF samples from the measured frequency and
    damping: ``ψ²ν̃ = ω̃² − ω_r² − Σψ_e² Re ν_e + i(2ζ̃ω̃² − 2ζ_r ω_r ω̃ − η_r ω_r² − Σψ_e² Im ν_e)``
    at ``A = |ψ| Q̃``, ``Q̃ = |φ_f| F / (2ζ̃ ω̃²)`` (the background evaluated there)."""
    background = tuple(element_terms(modal, mode, background_elements))
    psi = _participation(modal, mode, dofs)
    w = 2 * np.pi * frequency_hz
    q = np.abs(modal.mode_shapes[input_dof, mode]) * force / (2 * damping_ratio * w**2)
    wr, zr, er = modal.omega_r[mode], modal.damping_ratios[mode], modal.loss_factors[mode]
    known = sum((p**2 * nu(np.abs(p) * q, w) for p, nu in background), np.zeros_like(w, dtype=complex))
    scaled = (w**2 - wr**2 - known.real) + 1j * (2 * damping_ratio * w**2 - 2 * zr * wr * w - er * wr**2 - known.imag)
    nu = scaled / psi**2
    amplitude = np.abs(psi) * q
    std = np.hypot(2 * w**2 * frequency_uncertainty, 2 * damping_ratio * w**2 * damping_uncertainty) / psi**2
    taken = sum((e.describing_function(amplitude, w) for e in fixed), np.zeros_like(w, dtype=complex))
    samples = DFSamples(amplitude, w, nu - taken, std)
    localisation = summarise(dofs, 1.0, level_index, DFSamples(amplitude, w, nu, std))
    return ModalContext(
        dofs, modal, mode, input_dof, force, frequency_hz, damping_ratio, background, psi, tuple(fixed),
        tuple(companions), frequency_uncertainty, damping_uncertainty, penalty, samples, localisation,
    )
