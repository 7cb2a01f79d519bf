"""PRD for several nonlinear coordinates: the ``aa`` partition (METHODS §4, thesis eq. 2.52).

With local nonlinear elements on the coordinates ``a``, ``[Δ_aa] = [H^NL_aa]⁻¹ − [H^L_aa]⁻¹``
and, between a high level i and the low level 1 at one excitation frequency,

    [D_i] = [H^NL_aa]_i⁻¹ − [H^NL_aa]_1⁻¹ = [Δ_HF]_i − [Δ_f]_1.

Δ is assembled from the element DFs (METHODS §1): ``Δ_rr = ν_r + Σ_j ν_rj`` and
``Δ_rj = −ν_rj``. So each element's PRD points follow from D: an element between r and
ground has ``y = Σ_j D_rj`` (row sum), an element between r and j has
``y = −(D_rj + D_jr)/2``; its amplitude is ``|X_r|`` or ``|X_r − X_j|`` with
``X = [H^NL_aa]_i[:, p]·F_i`` the response to the force at the driven coordinate p.
Each element's points are fitted like the scalar PRD (source estimator,
:func:`nlupdate.identification.prd.fit_y_points`), and the linear FRF matrix over the
low-force sweep is ``[H^L_aa] = ([H^NL_aa]_1⁻¹ − [Δ_f1])⁻¹``.

Caveat (not addressed by the source): the inversion needs the whole matrix
``[H^NL_aa]`` *at one response state*. A test with a single shaker measures only the
column of the driven coordinate at that state; columns measured by moving the shaker
belong to other states. The simulated data of the tests are built consistently
(``H^NL = (Z + Δ(X))⁻¹`` at the state X of the driven test).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from nlupdate.identification.data import FRFLevels
from nlupdate.identification.prd import IdentificationError, Model, PRDResult, PRDSetup, fit_y_points


@dataclass(frozen=True, eq=False)
class MatrixPRDResult:
    """Per-element PRD results on the ``a`` coordinates and the linear-FRF extraction."""

    dofs: tuple[str, ...]
    drive_dof: str
    connections: tuple[tuple[str, ...], ...]
    elements: tuple[PRDResult, ...]

    def delta_f1(self) -> NDArray[np.complex128]:
        """``[Δ_f1]`` on ``dofs`` (N/m) assembled from each element's Δ_f1."""
        return _assemble(self.dofs, self.connections, [r.delta_f1 for r in self.elements])

    def extract_linear_frf(self, h_low: NDArray) -> NDArray[np.complex128]:
        """``[H^L_aa] = ([H_1]⁻¹ − [Δ_f1])⁻¹`` for low-force matrices of shape (n_f, n_a, n_a)."""
        return np.linalg.inv(np.linalg.inv(h_low) - self.delta_f1()[None])


def _assemble(dofs: Sequence[str], connections: Sequence[tuple[str, ...]], values: Sequence[complex]) -> NDArray:
    index = {d: i for i, d in enumerate(dofs)}
    delta = np.zeros((len(dofs), len(dofs)), dtype=complex)
    for connection, nu in zip(connections, values):
        r = index[connection[0]]
        delta[r, r] += nu
        if len(connection) == 2:
            j = index[connection[1]]
            delta[j, j] += nu
            delta[r, j] -= nu
            delta[j, r] -= nu
    return delta


def frf_matrices(
    table: pd.DataFrame, dofs: Sequence[str], force_n: float, frequency_hz: Sequence[float] | None = None
) -> tuple[NDArray[np.float64], NDArray[np.complex128]]:
    """``[H_aa]`` at one force level: (frequencies in Hz, array (n_f, n_a, n_a)) on the
    frequencies measured for every (response, input) pair of ``dofs``."""
    curves = {}
    for r in dofs:
        for q in dofs:
            curves[(r, q)] = FRFLevels.from_table(table, r, q)
    common = None
    for data in curves.values():
        f = data.curve(force_n)[0]
        common = f if common is None else common[np.isin(np.round(common, 9), np.round(f, 9))]
    if frequency_hz is not None:
        wanted = np.atleast_1d(np.asarray(frequency_hz, dtype=float))
        missing = wanted[~np.isin(np.round(wanted, 9), np.round(common, 9))]
        if missing.size:
            raise IdentificationError(
                f"frequency {missing[0]:g} Hz is not measured for every pair of coordinates {list(dofs)} at "
                f"{force_n:g} N"
            )
        common = wanted
    h = np.empty((common.size, len(dofs), len(dofs)), dtype=complex)
    for (r, q), data in curves.items():
        h[:, list(dofs).index(r), list(dofs).index(q)] = data.values(force_n, common)
    return common, h


def identify_prd_matrix(
    table: pd.DataFrame,
    dofs: Sequence[str],
    drive_dof: str,
    frequency_hz: float,
    connections: Sequence[tuple[str, ...]],
    models: Sequence[Model],
    low_force: float | None = None,
    high_forces: Sequence[float] | None = None,
) -> MatrixPRDResult:
    """Identify one element per connection (``("r",)`` to ground or ``("r", "j")``)."""
    dofs = tuple(str(d) for d in dofs)
    drive = str(drive_dof)
    if drive not in dofs:
        raise IdentificationError(f"drive dof {drive!r} must be one of the nonlinear coordinates {list(dofs)}")
    connections = tuple(tuple(str(d) for d in c) for c in connections)
    if len(models) != len(connections):
        raise IdentificationError(f"{len(connections)} connections but {len(models)} models")
    for connection in connections:
        if not 1 <= len(connection) <= 2 or any(d not in dofs for d in connection):
            raise IdentificationError(f"connection {connection} must name one or two of {list(dofs)}")
    levels = FRFLevels.from_table(table, drive, drive).levels
    if levels.size < 2:
        raise IdentificationError(f"the aa-PRD needs two or more force levels, found {list(levels)} N")
    low = float(levels[0]) if low_force is None else float(low_force)
    highs = [float(f) for f in levels if f > low] if high_forces is None else [float(f) for f in high_forces]
    matrices = {level: frf_matrices(table, dofs, level, [frequency_hz])[1][0] for level in [low] + highs}
    inverse_low = np.linalg.inv(matrices[low])
    p_index = dofs.index(drive)
    x_low = matrices[low][:, p_index] * low
    results = []
    setup = PRDSetup(float(frequency_hz), low, tuple(highs))
    omega = 2 * np.pi * float(frequency_hz)
    for connection, model in zip(connections, models):
        r = dofs.index(connection[0])
        j = dofs.index(connection[1]) if len(connection) == 2 else None
        amplitude, y = [], []
        for level in highs:
            d = np.linalg.inv(matrices[level]) - inverse_low
            x = matrices[level][:, p_index] * level
            if j is None:
                y.append(d[r].sum())
                amplitude.append(abs(x[r]))
            else:
                y.append(-(d[r, j] + d[j, r]) / 2)
                amplitude.append(abs(x[r] - x[j]))
        a_low = abs(x_low[r]) if j is None else abs(x_low[r] - x_low[j])
        amplitude, y = np.array(amplitude), np.array(y)
        p, _ = fit_y_points(model, amplitude, y, a_low, omega)
        results.append(PRDResult("prd-aa", "naive", model, p, setup, amplitude, y,
                                 np.full(amplitude.size, float(frequency_hz)), a_low))
    return MatrixPRDResult(dofs, drive, connections, tuple(results))
