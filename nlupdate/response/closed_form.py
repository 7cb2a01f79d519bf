"""Every root of the single-harmonic balance at once, where the elements allow it.

With one nonlinear coordinate and only cubic springs on it (to ground), the condensed
balance ``X = X_lin − h ν(|X|) X`` (``h = H_aa(ω)``, ``X_lin = H_af(ω) F``, ν = c·A² with
``c = ¾ Σ k₃``, docs/methods.md §2–3) gives ``X = X_lin / (1 + h c u)`` with u = |X|², and
taking the modulus squared, a cubic in u at every frequency::

    c²|h|² u³ + 2c Re(h) u² + u − |X_lin|² = 0.

Its positive real roots are all the solutions at that frequency — every branch, also the
unstable one — whatever the linear model (any receptance ``h``). They come from the
trigonometric or Cardano formula for all frequencies at once, polished by two Newton steps
on the cubic. Stability is the continuation's criterion, the sign of ``det ∂R/∂y``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from nlupdate.model.elements import CubicStiffness
from nlupdate.model.system import CondensedProblem


def applies(problem: CondensedProblem) -> bool:
    """True when every element is a cubic spring on the one nonlinear coordinate."""
    return problem.n == 1 and bool(problem.element_index) and all(
        type(element) is CubicStiffness for element, _, _ in problem.element_index
    )


@dataclass(frozen=True, eq=False)
class Roots:
    """The solutions at P frequencies: ``x`` (P, 3) complex amplitudes at the nonlinear
    coordinate (m), NaN where fewer than three roots are positive; ``u = |x|²`` sorted
    ascending; ``stable`` by the sign of det ∂R/∂y; ``count`` of positive roots (1 or 3)."""

    omega: NDArray[np.float64]
    x: NDArray[np.complex128]
    u: NDArray[np.float64]
    stable: NDArray[np.bool_]
    count: NDArray[np.int64]


def cubic_roots(problem: CondensedProblem, omega: NDArray) -> Roots:
    """All solutions of the single-harmonic balance at every ω (rad/s) of ``omega``;
    needs :func:`applies`."""
    omega = np.asarray(omega, dtype=float)
    linear = problem.linear_batch(omega, derivative=False)
    h = linear.h_aa[:, 0, 0]
    x_lin = linear.x_lin[:, 0]
    c = 0.75 * sum(element.k3 for element, _, _ in problem.element_index)
    lead = c**2 * np.abs(h) ** 2
    u = _positive_cubic_roots(lead, 2 * c * h.real, np.ones_like(lead), -np.abs(x_lin) ** 2)
    with np.errstate(invalid="ignore"):  # NaN roots stay NaN
        x = x_lin[:, None] / (1 + h[:, None] * c * u)
    valid = np.isfinite(u)
    count = valid.sum(axis=1)
    stable = np.zeros(u.shape, bool)
    rows, cols = np.nonzero(valid)
    if rows.size:
        _, jac, _ = problem.residual_batch(problem.to_real(x[rows, cols][:, None]), linear.take(rows))
        stable[rows, cols] = np.linalg.det(jac) > 0
    return Roots(omega, x, u, stable, count)


def _positive_cubic_roots(a: NDArray, b: NDArray, c: NDArray, d: NDArray) -> NDArray:
    """Positive real roots of ``a u³ + b u² + c u + d`` (a > 0) per row, sorted, NaN-padded to 3."""
    p = (3 * a * c - b**2) / (3 * a**2)  # depressed cubic t³ + p t + q, u = t − b/(3a)
    q = (2 * b**3 - 9 * a * b * c + 27 * a**2 * d) / (27 * a**3)
    shift = -b / (3 * a)
    discriminant = (q / 2) ** 2 + (p / 3) ** 3
    roots = np.full(a.shape + (3,), np.nan)
    three = discriminant < 0  # three distinct real roots: the trigonometric form
    if three.any():
        radius = 2 * np.sqrt(-p[three] / 3)
        angle = np.arccos(np.clip(3 * q[three] / (p[three] * radius), -1.0, 1.0)) / 3
        k = np.arange(3)
        roots[three] = radius[:, None] * np.cos(angle[:, None] - 2 * np.pi * k / 3) + shift[three, None]
    one = ~three
    if one.any():
        root = np.sqrt(np.maximum(discriminant[one], 0.0))
        roots[one, 0] = np.cbrt(-q[one] / 2 + root) + np.cbrt(-q[one] / 2 - root) + shift[one]
    for _ in range(2):  # Newton on the cubic itself: full precision whatever the formula lost
        value = ((a[:, None] * roots + b[:, None]) * roots + c[:, None]) * roots + d[:, None]
        slope = (3 * a[:, None] * roots + 2 * b[:, None]) * roots + c[:, None]
        roots = roots - np.divide(value, slope, out=np.zeros_like(roots), where=np.abs(slope) > 0)
    roots = np.where(roots > 0, roots, np.nan)
    return np.sort(roots, axis=1)  # NaN last


def sweep_roots(roots: Roots, direction: str) -> tuple[NDArray, NDArray] | None:
    """A stepped-sine sweep over the roots (frequencies ascending): the root index each point
    stays on, and where it jumped; None when the roots do not follow the pattern this reads
    (one stable root, or stable–unstable–stable) or the sweep starts among three roots.

    Within a run of frequencies with the same number of roots the branches keep their order,
    so the sweep keeps its rank; where the count changes, the two roots that are born or
    meet at the fold are the closer pair, and the sweep stays on the third root when it is
    on it (no fold between), else it jumps to it.
    """
    count, stable = roots.count, roots.stable
    one = (count == 1) & stable[:, 0]
    three = (count == 3) & stable[:, 0] & ~stable[:, 1] & stable[:, 2]
    if not np.all(one | three):
        return None
    order = np.arange(count.size) if direction == "up" else np.arange(count.size)[::-1]
    many = three[order]
    if many[0]:
        return None
    gap_low = roots.u[order, 1] - roots.u[order, 0]
    gap_high = roots.u[order, 2] - roots.u[order, 1]
    other_end = np.where(gap_high < gap_low, 0, 2)  # the root not in the closer pair
    index = np.zeros(count.size, np.int64)
    jumped = np.zeros(count.size, bool)
    edges = np.flatnonzero(np.diff(many.astype(np.int8))) + 1
    for start, end in zip(edges[::2], np.append(edges[1::2], count.size)):
        rank = other_end[start]  # entering three roots: stay on the branch that goes on
        index[start:end] = rank
        if end < count.size and other_end[end - 1] != rank:  # leaving: the branch ends in a fold
            jumped[end] = True
    position = np.empty_like(order)
    position[order] = np.arange(order.size)
    return index[position], jumped[position]
