"""What the solvers need from a harmonic-balance problem, written down once.

Two problems implement it: the single-harmonic (describing-function) balance
:class:`~nlupdate.core.model.system.CondensedProblem` and the multi-harmonic one
:class:`~nlupdate.core.response.harmonic_balance.HarmonicBalanceProblem`. Both are condensed to
the nonlinear coordinates ``a`` in receptance form,
``R(y, ω) = X − X_lin(ω) + H(ω) G(X, ω)`` over real scaled unknowns
``y = [real parts of X] / x_scale`` (docs/methods.md §3, docs/harmonic-balance.md). The
continuation (:func:`~nlupdate.core.response.continuation.trace_curve`), the batched Newton
(:func:`~nlupdate.core.model.system.newton_batch`) and the stepped-sine reading
(:func:`~nlupdate.core.response.stepped_sine.stepped_sine`) use nothing else.

Batched evaluation: the linear part at P frequencies is computed once
(:meth:`BalanceProblem.linear_batch`, a :class:`~nlupdate.core.model.system.LinearTerms`) and
reused while Newton iterates at those frequencies (:meth:`BalanceProblem.residual_batch`).
"""
from __future__ import annotations

from typing import Protocol, Sequence, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nlupdate.core.model.linear import LinearModel
from nlupdate.core.model.system import LinearTerms


@runtime_checkable
class BalanceProblem(Protocol):
    """A condensed harmonic balance at one force vector (the attributes are read, not set,
    by the solvers, except ``x_scale`` which the tracer chooses before it starts)."""

    model: LinearModel
    a: tuple[int, ...]
    """The nonlinear coordinates."""
    n: int
    """len(a)."""
    forced: tuple[int, ...]
    force: NDArray[np.complex128]
    """Force amplitudes (N) at the forced coordinates."""
    x_scale: float
    """Amplitude scale (m) of the unknowns y."""
    element_index: list
    """(element, r, j) per element, r and j positions in ``a`` (j = −1: to ground)."""

    @property
    def size(self) -> int:
        """Number of real unknowns."""
        ...

    def initial_guesses(self, omega: float) -> tuple[NDArray, ...]: ...

    def to_complex(self, y: NDArray) -> NDArray[np.complex128]:
        """States (…, state shape) in m from scaled unknowns (…, size)."""
        ...

    def to_real(self, state: NDArray) -> NDArray[np.float64]:
        """Scaled unknowns (…, size) from states."""
        ...

    def linear_batch(self, omega: ArrayLike, derivative: bool = True) -> LinearTerms: ...

    def residual_batch(self, y: NDArray, linear: LinearTerms, jacobian: bool = True):
        """Residuals (P, size); with ``jacobian`` also ∂R/∂y (P, size, size) and ∂R/∂ω (P, size)."""
        ...

    def residual(self, y: NDArray, omega: float) -> NDArray[np.float64]: ...

    def residual_and_jacobians(self, y: NDArray, omega: float) -> tuple[NDArray, NDArray, NDArray]: ...

    def linear_response(self, omega: ArrayLike, dofs: Sequence[int]) -> NDArray[np.complex128]:
        """First harmonic of the underlying linear system (m), (n_omega, len(dofs))."""
        ...

    def response_at(self, omega: ArrayLike, states: NDArray, dofs: Sequence[int]) -> NDArray[np.complex128]:
        """First-harmonic amplitudes (m) at any coordinates, (n_omega, len(dofs))."""
        ...


@runtime_checkable
class MultiHarmonicProblem(BalanceProblem, Protocol):
    """A balance of several harmonics: states (…, H+1, n_a) hold X₀ … X_H."""

    harmonics: int

    def harmonics_at(self, omega: ArrayLike, states: NDArray, dofs: Sequence[int]) -> NDArray[np.complex128]:
        """Harmonics X₀ … X_H (m) at any coordinates, (n_omega, H+1, len(dofs))."""
        ...
