"""Linear models of the underlying (linear) structure and their receptances.

Conventions (docs/methods.md §1): SI units, harmonic motion ``x(t) = Re(X e^{iωt})``,
dynamic stiffness ``Z(ω) = K − ω²M + iωC + iD`` and receptance ``H = Z⁻¹`` (m/N).
Angular frequency ω is in rad/s everywhere in this module.

Two model kinds share one interface (:class:`LinearModel`):

* :class:`LumpedModel` — mass, viscous damping, structural damping and stiffness
  matrices (dense or scipy.sparse); receptance by modal superposition over all modes where
  that is exact (dense, proportional damping: one eigenproblem per model), else by solves
  for the needed columns only (never a full inverse).
* :class:`ModalModel` — natural frequencies, mass-normalised mode shapes at named
  coordinates and modal damping; receptance by modal superposition.

Both return receptance blocks ``H[rows, cols]`` for an array of frequencies with shape
``(n_omega, len(rows), len(cols))`` and the derivative ``dH/dω`` needed by Newton and
continuation solvers; :class:`ReceptancePlan` evaluates one block at many frequencies.

(Over 400 lines: the two model kinds and the receptance routes they share — modal sum,
column solves, sparse factorisation — belong together.)
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol, Sequence

import numpy as np
import scipy.linalg
import scipy.sparse
import scipy.sparse.linalg
from numpy.typing import ArrayLike, NDArray

from nlupdate.fingerprints import fingerprint

ComplexArray = NDArray[np.complex128]
FloatArray = NDArray[np.float64]

PROPORTIONAL_TOLERANCE = 1e-10
"""Largest off-diagonal of ΦᵀCΦ and ΦᵀDΦ, relative to their diagonal, for which a dense
lumped model's damping counts as proportional and its receptance is the modal superposition
of all its modes (the undamped modes then diagonalise Z(ω) exactly, up to rounding)."""


class LinearModel(Protocol):
    """What the nonlinear solvers need from a linear model."""

    @property
    def n_dof(self) -> int: ...

    @property
    def dof_names(self) -> tuple[str, ...]: ...

    def receptance(
        self, omega: ArrayLike, rows: Sequence[int], cols: Sequence[int], derivative: bool = False
    ) -> ComplexArray | tuple[ComplexArray, ComplexArray]: ...

    def fingerprint(self) -> str: ...


def _as_matrix(name: str, value: ArrayLike, n: int | None) -> np.ndarray | scipy.sparse.csr_matrix:
    if scipy.sparse.issparse(value):
        matrix = scipy.sparse.csr_matrix(value, dtype=float)
    else:
        matrix = np.atleast_2d(np.asarray(value, dtype=float))
    if matrix.ndim != 2 or matrix.shape[0] != matrix.shape[1]:
        raise ValueError(f"{name} must be a square matrix, got shape {matrix.shape}")
    if n is not None and matrix.shape[0] != n:
        raise ValueError(f"{name} must be {n}×{n} like the mass matrix, got {matrix.shape}")
    data = matrix.data if scipy.sparse.issparse(matrix) else matrix
    if not np.all(np.isfinite(data)):
        raise ValueError(f"{name} contains NaN or infinite entries")
    return matrix


def _default_names(n: int) -> tuple[str, ...]:
    return tuple(str(i) for i in range(n))


@dataclass(frozen=True, eq=False)
class LumpedModel:
    """Lumped linear model ``M ẍ + C ẋ + K x (+ i D x) = f``.

    Parameters
    ----------
    mass, stiffness:
        Mass (kg) and stiffness (N/m) matrices, dense or scipy.sparse.
    damping:
        Viscous damping matrix C (N·s/m); zero if omitted.
    structural_damping:
        Structural (hysteretic) damping matrix D (N/m) entering as ``iD``; zero if omitted.
        :meth:`with_loss_factor` builds ``D = γ K``.
    dof_names:
        Names of the coordinates (default ``"0", "1", …``).
    """

    mass: np.ndarray | scipy.sparse.csr_matrix
    stiffness: np.ndarray | scipy.sparse.csr_matrix
    damping: np.ndarray | scipy.sparse.csr_matrix | None = None
    structural_damping: np.ndarray | scipy.sparse.csr_matrix | None = None
    dof_names: tuple[str, ...] = field(default=())

    def __post_init__(self) -> None:
        mass = _as_matrix("mass", self.mass, None)
        n = mass.shape[0]
        object.__setattr__(self, "mass", mass)
        object.__setattr__(self, "stiffness", _as_matrix("stiffness", self.stiffness, n))
        for name in ("damping", "structural_damping"):
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, _as_matrix(name, value, n))
        names = tuple(self.dof_names) or _default_names(n)
        if len(names) != n:
            raise ValueError(f"dof_names has {len(names)} entries for a model of {n} dofs")
        object.__setattr__(self, "dof_names", names)
        if not self.is_sparse:  # dense copies once, so receptance() is cheap per call
            object.__setattr__(
                self, "_dense_mkcd", tuple(self._dense(m) for m in (self.mass, self.stiffness, self.damping, self.structural_damping))
            )

    @classmethod
    def with_loss_factor(
        cls,
        mass: ArrayLike,
        stiffness: ArrayLike,
        loss_factor: float,
        damping: ArrayLike | None = None,
        dof_names: Sequence[str] = (),
    ) -> "LumpedModel":
        """Model with structural damping ``D = loss_factor · K``."""
        stiffness_matrix = _as_matrix("stiffness", stiffness, None)
        return cls(mass, stiffness_matrix, damping, loss_factor * stiffness_matrix, tuple(dof_names))

    @property
    def n_dof(self) -> int:
        return self.mass.shape[0]

    @property
    def is_sparse(self) -> bool:
        return scipy.sparse.issparse(self.mass)

    def fingerprint(self) -> str:
        """Stable content hash (for caching)."""
        return fingerprint(
            "lumped", self.mass, self.stiffness, self.damping, self.structural_damping, self.dof_names, length=16
        )

    def _dense(self, matrix: object) -> np.ndarray:
        if matrix is None:
            return np.zeros((self.n_dof, self.n_dof))
        return matrix.toarray() if scipy.sparse.issparse(matrix) else matrix

    def dynamic_stiffness(self, omega: float) -> np.ndarray:
        """``Z(ω) = K − ω²M + iωC + iD`` as a dense complex matrix."""
        z = self._dense(self.stiffness) - omega**2 * self._dense(self.mass) + 0j
        z = z + 1j * omega * self._dense(self.damping) + 1j * self._dense(self.structural_damping)
        return z

    def receptance(
        self, omega: ArrayLike, rows: Sequence[int], cols: Sequence[int], derivative: bool = False
    ) -> ComplexArray | tuple[ComplexArray, ComplexArray]:
        """Receptance block ``H[rows, cols]`` (m/N) at each ω (rad/s) (see the module docstring).

        With ``derivative=True`` also returns ``dH/dω = −H (dZ/dω) H`` with
        ``dZ/dω = −2ωM + iC``. Shapes ``(n_omega, len(rows), len(cols))``.
        """
        return self._receptance(omega, rows, cols, derivative, 1.0)

    def harmonic_receptance(
        self, omega: ArrayLike, harmonic: ArrayLike, rows: Sequence[int], cols: Sequence[int], derivative: bool = False
    ) -> ComplexArray | tuple[ComplexArray, ComplexArray]:
        """Receptance at the ``harmonic``-th multiple of the fundamental ω (rad/s).

        ``Z_h = K − (hω)²M + i(hω C + h D)``: the structural damping acts as the viscous
        damping ``D/ω`` equivalent at the fundamental, the form a time integration can
        realise (:mod:`nlupdate.core.response.time_integration`). ``h = 1`` is :meth:`receptance`;
        ``h = 0`` is the static receptance ``K⁻¹``. The derivative is with respect to the
        fundamental ω: ``h·dH/dω(hω)``. ``omega`` and ``harmonic`` broadcast (several
        frequencies at one harmonic, or several harmonics of one frequency).
        """
        return _harmonic_receptance(self, omega, harmonic, rows, cols, derivative)

    def _receptance(self, omega, rows, cols, derivative: bool, d_scale: float):
        """Dense models: modal superposition when it is exact (:meth:`_proportional_modes`),
        else a solve for the needed columns (and rows) only, a few frequencies at a time."""
        omega = np.atleast_1d(np.asarray(omega, dtype=float))
        rows, cols = list(rows), list(cols)
        if self.is_sparse:
            return self._receptance_sparse(omega, rows, cols, derivative, d_scale)
        d_scale = np.broadcast_to(np.asarray(d_scale, dtype=float), omega.shape)
        modes = self._proportional_modes()
        if modes is not None:
            omega_sq, phi, c_r, d_r = modes
            return _modal_block(omega_sq, c_r, d_r, phi[rows], phi[cols].T, omega, d_scale, derivative)
        return self._receptance_columns(omega, rows, cols, derivative, d_scale)

    def _proportional_modes(self):
        """(ω_r², Φ, diag ΦᵀCΦ, diag ΦᵀDΦ) of the undamped modes (ΦᵀMΦ = I) when they also
        diagonalise C and D — proportional damping such as D = γK — so that modal
        superposition over all modes is the exact receptance; else None. Computed once per
        model (one symmetric eigenproblem, O(N³))."""
        cached = self.__dict__.get("_modes_cache")
        if cached is None:
            cached = (self._modal_decomposition(),)
            object.__setattr__(self, "_modes_cache", cached)
        return cached[0]

    def _modal_decomposition(self):
        m, k, c, d = self._dense_mkcd
        if not (np.allclose(m, m.T, rtol=0, atol=1e-14 * np.abs(m).max())
                and np.allclose(k, k.T, rtol=0, atol=1e-14 * max(np.abs(k).max(), 1e-300))):
            return None
        try:
            omega_sq, phi = scipy.linalg.eigh(k, m, check_finite=False)
        except (np.linalg.LinAlgError, ValueError):
            return None
        diagonals = []
        for matrix in (c, d):
            projected = phi.T @ matrix @ phi
            diagonal = np.diag(projected).copy()
            off = projected - np.diag(diagonal)
            scale = max(np.abs(diagonal).max(), 1e-300)
            if np.abs(off).max() > PROPORTIONAL_TOLERANCE * scale:
                return None
            diagonals.append(diagonal)
        return omega_sq, phi, diagonals[0], diagonals[1]

    def _receptance_columns(self, omega, rows, cols, derivative: bool, d_scale: NDArray):
        """``H[rows, cols]`` by LU solves for the columns (and, for the derivative, the rows) only."""
        m, k, c, d = self._dense_mkcd
        n = self.n_dof
        unit = np.eye(n)
        h = np.empty((omega.size, len(rows), len(cols)), dtype=complex)
        dh = np.empty_like(h) if derivative else None
        chunk = max(1, int(2**22 // (n * n)))  # ≤ 64 MB of complex matrices at a time
        for start in range(0, omega.size, chunk):
            w = omega[start : start + chunk, None, None]
            z = k[None] - w**2 * m[None] + 1j * (w * c[None] + d_scale[start : start + chunk, None, None] * d[None])
            columns = np.linalg.solve(z, np.broadcast_to(unit[:, cols], (z.shape[0], n, len(cols))))
            h[start : start + chunk] = columns[:, rows]
            if derivative:
                # H[rows, :] = (Z⁻ᵀ e_rows)ᵀ; dH/dω = −H[rows, :] (dZ/dω) H[:, cols]
                row_block = np.linalg.solve(np.swapaxes(z, 1, 2), np.broadcast_to(unit[:, rows], (z.shape[0], n, len(rows))))
                dz = -2.0 * w * m[None] + 1j * c[None]
                dh[start : start + chunk] = -np.swapaxes(row_block, 1, 2) @ (dz @ columns)
        return (h, dh) if derivative else h

    def _receptance_sparse(
        self, omega: np.ndarray, rows: list[int], cols: list[int], derivative: bool, d_scale: float
    ) -> ComplexArray | tuple[ComplexArray, ComplexArray]:
        n = self.n_dof
        zero = scipy.sparse.csr_matrix((n, n))
        m, k = self.mass, self.stiffness
        c = self.damping if self.damping is not None else zero
        d = self.structural_damping if self.structural_damping is not None else zero
        rhs = np.zeros((n, len(cols)), dtype=complex)
        rhs[cols, np.arange(len(cols))] = 1.0
        rhs_rows = np.zeros((n, len(rows)), dtype=complex)
        rhs_rows[rows, np.arange(len(rows))] = 1.0
        h = np.empty((omega.size, len(rows), len(cols)), dtype=complex)
        dh = np.empty_like(h)
        d_scale = np.broadcast_to(np.asarray(d_scale, dtype=float), omega.shape)
        for i, w in enumerate(omega):
            z = (k - w**2 * m + 1j * (w * c + d_scale[i] * d)).tocsc()
            lu = scipy.sparse.linalg.splu(z)
            cols_sol = lu.solve(rhs)
            h[i] = cols_sol[rows]
            if derivative:
                # Z is complex symmetric, so H[rows, :] = (Z⁻¹ e_rows)ᵀ.
                rows_sol = lu.solve(rhs_rows)
                dz = -2.0 * w * m + 1j * c
                dh[i] = -rows_sol.T @ (dz @ cols_sol)
        return (h, dh) if derivative else h

    def modes(self, n_modes: int | None = None) -> tuple[FloatArray, FloatArray]:
        """Undamped natural frequencies (rad/s) and mass-normalised mode shapes.

        Dense models use ``scipy.linalg.eigh``; sparse ones the shift-invert Lanczos
        solver ``eigsh`` about zero for the lowest ``n_modes``.
        """
        if self.is_sparse:
            count = n_modes or min(self.n_dof - 1, 20)
            values, vectors = scipy.sparse.linalg.eigsh(  # fixed start vector: reproducible modes
                self.stiffness.tocsc(), k=count, M=self.mass.tocsc(), sigma=0.0, which="LM",
                v0=np.random.default_rng(0).standard_normal(self.n_dof),
            )
        else:
            values, vectors = scipy.linalg.eigh(self._dense(self.stiffness), self._dense(self.mass))
            if n_modes is not None:
                values, vectors = values[:n_modes], vectors[:, :n_modes]
        order = np.argsort(values)
        values, vectors = values[order], vectors[:, order]
        if np.any(values < -1e-9 * max(1.0, abs(values).max())):
            raise ValueError("stiffness matrix is not positive semi-definite (negative eigenvalue)")
        return np.sqrt(np.clip(values, 0.0, None)), vectors

    def to_modal(self, n_modes: int | None = None, coordinates: Sequence[int] | None = None) -> "ModalModel":
        """Modal model of the lowest ``n_modes`` modes at the given coordinates.

        Modal damping is taken from the diagonal of ``ΦᵀCΦ`` (viscous, ζ_r) and ``ΦᵀDΦ``
        (loss factor η_r); exact for proportional damping such as ``D = γK``.
        """
        omega_r, phi = self.modes(n_modes)
        coords = list(range(self.n_dof)) if coordinates is None else list(coordinates)
        zeta = np.zeros_like(omega_r)
        eta = np.zeros_like(omega_r)
        safe = np.where(omega_r > 0, omega_r, 1.0)
        if self.damping is not None:
            zeta = np.einsum("ir,ir->r", phi, self.damping @ phi) / (2.0 * safe)
        if self.structural_damping is not None:
            eta = np.einsum("ir,ir->r", phi, self.structural_damping @ phi) / safe**2
        return ModalModel(
            natural_frequencies_hz=omega_r / (2 * np.pi),
            mode_shapes=phi[coords],
            damping_ratios=zeta,
            loss_factors=eta,
            dof_names=tuple(self.dof_names[i] for i in coords),
        )


@dataclass(frozen=True, eq=False)
class ModalModel:
    """Modal model: ``H_jk(ω) = Σ_r φ_jr φ_kr / (ω_r² − ω² + 2iζ_r ω_r ω + iη_r ω_r²)``.

    Parameters
    ----------
    natural_frequencies_hz:
        Undamped natural frequencies f_r (Hz).
    mode_shapes:
        Mass-normalised mode shapes at the model's coordinates, shape (n_coords, n_modes),
        units 1/√kg.
    damping_ratios:
        Viscous modal damping ratios ζ_r (default 0).
    loss_factors:
        Structural modal loss factors η_r (default 0).
    dof_names:
        Names of the coordinates (rows of ``mode_shapes``).
    """

    natural_frequencies_hz: np.ndarray
    mode_shapes: np.ndarray
    damping_ratios: np.ndarray | float = 0.0
    loss_factors: np.ndarray | float = 0.0
    dof_names: tuple[str, ...] = field(default=())

    def __post_init__(self) -> None:
        f = np.atleast_1d(np.asarray(self.natural_frequencies_hz, dtype=float))
        phi = np.asarray(self.mode_shapes, dtype=float)
        if phi.ndim == 1:
            phi = phi[:, None] if f.size == 1 else phi[None, :]
        if phi.shape[1] != f.size:
            raise ValueError(
                f"mode_shapes has {phi.shape[1]} columns but there are {f.size} natural frequencies"
            )
        if np.any(f < 0) or not np.all(np.isfinite(f)):
            raise ValueError("natural frequencies must be finite and non-negative (Hz)")
        zeta = np.broadcast_to(np.asarray(self.damping_ratios, dtype=float), f.shape).copy()
        eta = np.broadcast_to(np.asarray(self.loss_factors, dtype=float), f.shape).copy()
        object.__setattr__(self, "natural_frequencies_hz", f)
        object.__setattr__(self, "mode_shapes", phi)
        object.__setattr__(self, "damping_ratios", zeta)
        object.__setattr__(self, "loss_factors", eta)
        names = tuple(self.dof_names) or _default_names(phi.shape[0])
        if len(names) != phi.shape[0]:
            raise ValueError(f"dof_names has {len(names)} entries for {phi.shape[0]} coordinates")
        object.__setattr__(self, "dof_names", names)

    @property
    def n_dof(self) -> int:
        return self.mode_shapes.shape[0]

    @property
    def omega_r(self) -> FloatArray:
        return 2 * np.pi * self.natural_frequencies_hz

    def fingerprint(self) -> str:
        return fingerprint(
            "modal",
            self.natural_frequencies_hz,
            self.mode_shapes,
            self.damping_ratios,
            self.loss_factors,
            self.dof_names,
            length=16,
        )

    def receptance(
        self, omega: ArrayLike, rows: Sequence[int], cols: Sequence[int], derivative: bool = False
    ) -> ComplexArray | tuple[ComplexArray, ComplexArray]:
        """Receptance block by modal superposition; see :meth:`LumpedModel.receptance`."""
        return self._receptance(omega, rows, cols, derivative, 1.0)

    def harmonic_receptance(
        self, omega: ArrayLike, harmonic: ArrayLike, rows: Sequence[int], cols: Sequence[int], derivative: bool = False
    ) -> ComplexArray | tuple[ComplexArray, ComplexArray]:
        """Receptance at the ``harmonic``-th multiple of ω; see :meth:`LumpedModel.harmonic_receptance`
        (the loss factor acts as ``h·η_r ω_r²`` at harmonic h)."""
        return _harmonic_receptance(self, omega, harmonic, rows, cols, derivative)

    def _receptance(self, omega, rows, cols, derivative: bool, eta_scale: float):
        omega = np.atleast_1d(np.asarray(omega, dtype=float))
        eta_scale = np.broadcast_to(np.asarray(eta_scale, dtype=float), omega.shape)
        omega_sq, c_r, d_r = self.modal_damping()
        return _modal_block(omega_sq, c_r, d_r, self.mode_shapes[list(rows)], self.mode_shapes[list(cols)].T, omega,
                            eta_scale, derivative)

    def modal_damping(self) -> tuple[FloatArray, FloatArray, FloatArray]:
        """(ω_r², c_r = 2ζ_r ω_r, d_r = η_r ω_r²): the receptance is
        ``Σ_r φ_r φ_rᵀ / (ω_r² − ω² + i(ω c_r + d_r))``."""
        wr = self.omega_r
        return wr**2, 2 * self.damping_ratios * wr, self.loss_factors * wr**2


def _modal_block(omega_sq, c_r, d_r, phi_rows, phi_cols_t, omega, d_scale, derivative: bool):
    """``Σ_r φ_jr φ_kr / (ω_r² − ω² + i(ω c_r + s d_r))`` (P, rows, cols) at ω (P,) rad/s with the
    structural-damping factor s (P,) (1 at the fundamental, h at harmonic h), and its
    ω-derivative."""
    w = omega[:, None]
    inverse = 1.0 / (omega_sq - w**2 + 1j * (w * c_r + d_scale[:, None] * d_r))
    if not derivative:
        return (phi_rows[None] * inverse[:, None, :]) @ phi_cols_t
    # H and dH/dω as one stack: one product with the mode shapes for both
    weights = np.stack([inverse, (2 * w - 1j * c_r) * inverse**2])  # (2, P, modes)
    both = (phi_rows * weights[:, :, None, :]) @ phi_cols_t
    return both[0], both[1]


class ReceptancePlan:
    """Receptance blocks ``H[rows, cols]`` of one model at many frequencies, the rows and
    columns fixed: with exact modal data (a :class:`ModalModel`, or a dense
    :class:`LumpedModel` with proportional damping) the mode-shape rows are sliced once and
    every call is the modal sum; otherwise it is the model's own receptance."""

    def __init__(self, model: LinearModel, rows: Sequence[int], cols: Sequence[int]) -> None:
        self.model, self.rows, self.cols = model, list(rows), list(cols)
        self._modal = None
        if isinstance(model, ModalModel):
            omega_sq, c_r, d_r = model.modal_damping()
            phi = model.mode_shapes
        elif isinstance(model, LumpedModel) and not model.is_sparse and model._proportional_modes() is not None:
            omega_sq, phi, c_r, d_r = model._proportional_modes()
        else:
            return
        self._modal = (omega_sq, c_r, d_r, phi[self.rows], phi[self.cols].T)

    def harmonic(self, omega: NDArray, harmonic: NDArray, derivative: bool = False):
        """``H`` at the harmonics ``harmonic`` (P,) of the fundamentals ``omega`` (P,) rad/s, and its
        derivative with respect to the fundamental (as :meth:`LumpedModel.harmonic_receptance`)."""
        omega = np.asarray(omega, dtype=float)
        harmonic = np.asarray(harmonic, dtype=float)
        if self._modal is None:
            return self.model.harmonic_receptance(omega, harmonic, self.rows, self.cols, derivative)
        result = _modal_block(*self._modal, harmonic * omega, harmonic, derivative)
        return (result[0], harmonic[:, None, None] * result[1]) if derivative else result

    def __call__(self, omega: NDArray, derivative: bool = False):
        """``H`` at the frequencies ``omega`` (P,) rad/s (and dH/dω)."""
        omega = np.atleast_1d(np.asarray(omega, dtype=float))
        if self._modal is None:
            return self.model.receptance(omega, self.rows, self.cols, derivative)
        return _modal_block(*self._modal, omega, np.ones(omega.shape), derivative)


def _harmonic_receptance(model, omega, harmonic, rows, cols, derivative):
    omega, harmonic = np.broadcast_arrays(np.atleast_1d(np.asarray(omega, dtype=float)), np.atleast_1d(harmonic))
    harmonic = harmonic.astype(float)
    result = model._receptance(harmonic * omega, rows, cols, derivative, harmonic)
    return (result[0], harmonic[:, None, None] * result[1]) if derivative else result


def dof_index(model: LinearModel, dof: int | str) -> int:
    """Index of a coordinate given by index or by name, with a clear error."""
    names = model.dof_names
    if isinstance(dof, (int, np.integer)) and not isinstance(dof, bool):
        if 0 <= dof < model.n_dof:
            return int(dof)
    elif str(dof) in names:
        return names.index(str(dof))
    raise ValueError(f"unknown dof {dof!r}: the model has dofs 0..{model.n_dof - 1} named {list(names)[:10]}")
