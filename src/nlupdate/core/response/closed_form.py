"""Every root of the single-harmonic balance at once, where the elements allow it.

With one nonlinear coordinate and only cubic springs on it (to ground), the condensed
balance ``X = X_lin − h ν(|X|) X`` (``h = H_aa(ω)``, ``X_lin = H_af(ω) F``, ν = c·A² with
``c = ¾ Σ k₃``, docs/methods.md §2–3) gives ``X = X_lin / (1 + h c u)`` with u = |X|², and
taking the modulus squared, a cubic in u at every frequency::

    c²|h|² u³ + 2c Re(h) u² + u − |X_lin|² = 0.

Its positive real roots are all the solutions at that frequency — every branch, also the
unstable one — whatever the linear model (any receptance ``h``). They come from Viète's
trigonometric form (three real roots) or Cardano's formula in its cancellation-free form (one
real root) for all frequencies at once, without masks, polished by a Newton step on the
cubic itself, and a second where the first moved a root by more than 1e-7 (the shift back from
the depressed cubic cancels for a root much smaller than ``b/3a``; near a fold two roots
meet). Per frequency this costs less than the textbook trigonometric solve alone
(``benchmarks/frf/cubic_reference.py``; docs/performance.md).

Stability is the continuation's criterion, the sign of ``det ∂R/∂y``, and that determinant
is the cubic's slope at the root. With ``g(u) = 1 + h c u`` the residual (times the positive
scale) is ``X g(|X|²) − X_lin``, a map of X and X̄ whose real Jacobian determinant is
``|∂R/∂X|² − |∂R/∂X̄|² = |g + u g'|² − u²|g'|² = |g|² + 2u Re(ḡ g') = d/du (u |g|²)``, and
``u |g|² − |X_lin|²`` is the cubic above: ``det ∂R/∂y = 3c²|h|²u² + 4c Re(h) u + 1``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.model.system import CondensedProblem


def applies(problem: CondensedProblem) -> bool:
    """True when every element is a cubic spring on the one nonlinear coordinate."""
    return problem.n == 1 and bool(problem.element_index) and all(
        element.cubic_coefficient is not None for element, _, _ in problem.element_index
    )


@dataclass(frozen=True, eq=False)
class Roots:
    """The solutions at P frequencies: ``u = |x|²`` (P, 3) (m²) sorted ascending, NaN where
    fewer than three roots are positive; ``stable`` by the sign of det ∂R/∂y; ``count`` of
    positive roots (1 or 3); ``x_lin`` (P,) (m) and ``gain = c h`` (P,) (1/m²) give the
    complex amplitudes at the nonlinear coordinate, ``x = x_lin / (1 + gain u)``."""

    omega: NDArray[np.float64]
    u: NDArray[np.float64]
    stable: NDArray[np.bool_]
    count: NDArray[np.int64]
    x_lin: NDArray[np.complex128]
    gain: NDArray[np.complex128]

    @property
    def x(self) -> NDArray[np.complex128]:
        """Complex amplitudes (P, 3) (m) of all roots, NaN where ``u`` is."""
        with np.errstate(invalid="ignore"):
            return self.x_lin[:, None] / (1 + self.gain[:, None] * self.u)

    def response(self, index: NDArray) -> NDArray[np.complex128]:
        """Complex amplitude (P,) (m) of root ``index[i]`` at frequency i."""
        u = np.take_along_axis(self.u, np.asarray(index)[:, None], axis=1)[:, 0]
        with np.errstate(invalid="ignore"):
            return self.x_lin / (1 + self.gain * u)


_BLOCK = 4096  # frequencies solved together: their temporaries stay in cache and on pages already mapped


def cubic_roots(problem: CondensedProblem, omega: NDArray) -> Roots:
    """All solutions of the single-harmonic balance at every ω (rad/s) of ``omega``;
    needs :func:`applies`.

    Solved in blocks of ``_BLOCK`` frequencies: the few dozen temporaries of a whole grid
    of 10,000 would be fresh pages at every call once the allocator returns them to the
    system (half the time of the solve, measured), those of a block are reused.
    """
    omega = np.asarray(omega, dtype=float)
    linear = problem.linear_batch(omega, derivative=False)
    c = 0.75 * sum(element.cubic_coefficient for element, _, _ in problem.element_index)
    u = np.empty((omega.size, 3))
    stable = np.empty((omega.size, 3), bool)
    for start in range(0, omega.size, _BLOCK):
        block = slice(start, start + _BLOCK)
        h, x_lin = linear.h_aa[block, 0, 0], linear.x_lin[block, 0]
        lead, quadratic = c**2 * (h.real**2 + h.imag**2), 2 * c * h.real
        u[block] = roots = _positive_cubic_roots(lead, quadratic, np.ones_like(lead), -(x_lin.real**2 + x_lin.imag**2))
        lead, quadratic = 3 * lead, 2 * quadratic
        with np.errstate(invalid="ignore"):  # NaN roots are not stable
            for k in range(3):  # det ∂R/∂y, the cubic's slope (module docstring)
                stable[block, k] = (lead * roots[:, k] + quadratic) * roots[:, k] + 1 > 0
    count = (u[:, 0] == u[:, 0]).astype(np.int64) + (u[:, 1] == u[:, 1]) + (u[:, 2] == u[:, 2])
    return Roots(omega, u, stable, count, linear.x_lin[:, 0], c * linear.h_aa[:, 0, 0])


_SQRT3 = float(np.sqrt(3.0))


def _positive_cubic_roots(a: NDArray, b: NDArray, c: NDArray, d: NDArray) -> NDArray:
    """Positive real roots of ``a u³ + b u² + c u + d`` (a > 0) per row, sorted, NaN-padded to 3.

    The depressed cubic ``t³ + p t + q`` (``u = t + s``, ``s = −b/3a``, ``q`` the monic
    cubic's value at ``s``) has three real roots where ``(q/2)² + (p/3)³ < 0``:
    ``t = 2r cos(θ − 2πk/3)``, ``r = √(−p/3)``, ``cos 3θ = −q/(2r³)``, θ ∈ [0, π/3], taken as
    ``2r cos θ`` and ``r(−cos θ ± √3 sin θ)`` (ascending: −, +, then the first). Else one:
    ``t = A − p/(3A)``, ``A = −sign(q) ∛(|q|/2 + √((q/2)² + (p/3)³))`` (no cancellation).
    Both are evaluated on every row (NaN where they do not apply) and chosen by the sign.
    """
    b, c, d = b / a, c / a, d / a
    s = b / -3.0
    p = c - 3.0 * s * s
    q = (c - 2.0 * s * s) * s + d
    discriminant = 0.25 * q * q + p * p * p / 27.0
    three = discriminant < 0
    with np.errstate(invalid="ignore", divide="ignore"):  # each formula is NaN where the other applies
        r = np.sqrt(p / -3.0)
        theta = np.arccos(np.clip(q / (-2.0 * r * r * r), -1.0, 1.0)) / 3.0
        r_cos, r_sin = r * np.cos(theta), _SQRT3 * r * np.sin(theta)
        big = np.copysign(np.cbrt(0.5 * np.abs(q) + np.sqrt(discriminant)), -q)
        one = np.where(big != 0, big - p / (3.0 * big), 0.0)  # big = 0: p = q = 0, the triple root t = 0
    columns = [np.where(three, -r_cos - r_sin, one) + s,
               np.where(three, r_sin - r_cos, np.nan) + s,
               np.where(three, 2.0 * r_cos, np.nan) + s]
    for k, root in enumerate(columns):
        polished = _newton_step(root, b, c, d)
        # a second step where the first corrected more than 1e-7 (relative): a root much
        # smaller than the shift s, or close to a double root (a fold)
        again = np.flatnonzero(np.abs(polished - root) > 1e-7 * np.abs(polished))
        if again.size:
            polished[again] = _newton_step(polished[again], b[again], c[again], d[again])
        polished[~(polished > 0)] = np.inf  # not positive, or no real root: last, then NaN
        columns[k] = polished
    low, mid, high = columns  # ascending: a sorting network on the three columns
    low, mid = np.minimum(low, mid), np.maximum(low, mid)
    mid, high = np.minimum(mid, high), np.maximum(mid, high)
    low, mid = np.minimum(low, mid), np.maximum(low, mid)
    roots = np.stack([low, mid, high], axis=1)
    roots[roots == np.inf] = np.nan
    return roots


def _newton_step(root: NDArray, b: NDArray, c: NDArray, d: NDArray) -> NDArray:
    """One Newton step on the monic cubic ``u³ + b u² + c u + d`` (no step where its slope is 0)."""
    value = ((root + b) * root + c) * root + d
    slope = (3.0 * root + 2.0 * b) * root + c
    with np.errstate(invalid="ignore", divide="ignore"):
        return root - np.where(slope != 0, value / slope, 0.0)


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
