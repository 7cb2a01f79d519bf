"""The floors a closed-form describing-function sweep is measured against (Part 3a): the real
roots of one cubic ``a u³ + b u² + c u + d`` per frequency, for all frequencies at once, from
precomputed coefficients, written here independently of the project's solver.

* :func:`trigonometric_roots` — the textbook vectorised solve: the depressed cubic
  ``t³ + p t + q`` (``u = t − b/3a``), Viète's trigonometric form where it has three real
  roots (discriminant ``(q/2)² + (p/3)³ < 0``) and Cardano's formula where it has one.
* :func:`companion_roots` — numpy's general route: the eigenvalues of a stack of 3×3
  companion matrices (``numpy.linalg.eigvals``, LAPACK ``geev`` per matrix).

Neither polishes its roots nor evaluates anything else (no stability, no response, no sweep):
they are what any solver of the same cubic must at least do.
"""
from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def trigonometric_roots(a: NDArray, b: NDArray, c: NDArray, d: NDArray) -> NDArray[np.float64]:
    """Real roots (P, 3) of ``a u³ + b u² + c u + d`` (a ≠ 0) per row; where there is one real
    root it is in column 0 and the others are NaN."""
    b, c, d = b / a, c / a, d / a  # monic
    p = c - b * b / 3
    q = 2 * b**3 / 27 - b * c / 3 + d
    discriminant = (q / 2) ** 2 + (p / 3) ** 3
    roots = np.full(a.shape + (3,), np.nan)
    three = discriminant < 0
    m = 2 * np.sqrt(-p[three] / 3)
    theta = np.arccos(np.clip(3 * q[three] / (p[three] * m), -1.0, 1.0)) / 3
    roots[three] = m[:, None] * np.cos(theta[:, None] - 2 * np.pi / 3 * np.arange(3)) - b[three, None] / 3
    one = ~three
    s = np.sqrt(discriminant[one])
    roots[one, 0] = np.cbrt(-q[one] / 2 + s) + np.cbrt(-q[one] / 2 - s) - b[one] / 3
    return roots


def companion_roots(a: NDArray, b: NDArray, c: NDArray, d: NDArray) -> NDArray[np.complex128]:
    """All roots (P, 3) of ``a u³ + b u² + c u + d`` (a ≠ 0) per row, complex: the eigenvalues
    of the companion matrices ``[[−b/a, −c/a, −d/a], [1, 0, 0], [0, 1, 0]]``."""
    companion = np.zeros(a.shape + (3, 3))
    companion[:, 0, 0], companion[:, 0, 1], companion[:, 0, 2] = -b / a, -c / a, -d / a
    companion[:, 1, 0] = companion[:, 2, 1] = 1.0
    return np.linalg.eigvals(companion)
