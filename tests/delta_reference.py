"""The nonlinearity matrix Δ written out element by element (docs/methods.md §1): the
reference the solvers' vectorised assembly is checked against."""
from __future__ import annotations

from typing import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nlupdate.core.model.elements import NonlinearElement, nonlinear_dofs


def assemble_delta(
    elements: Sequence[NonlinearElement], displacement: ArrayLike, omega: float, dofs: Sequence[int] | None = None
) -> NDArray[np.complex128]:
    """Nonlinearity matrix Δ (docs/methods.md §1) at complex amplitudes ``displacement``.

    ``displacement`` holds the complex amplitudes at ``dofs`` (default: the element
    coordinates :func:`nonlinear_dofs`); Δ is returned on the same coordinates.
    """
    dofs = tuple(dofs) if dofs is not None else nonlinear_dofs(elements)
    x = np.asarray(displacement, dtype=complex)
    position = {d: i for i, d in enumerate(dofs)}
    delta = np.zeros((len(dofs), len(dofs)), dtype=complex)
    for element in elements:
        r = position[element.dofs[0]]
        relative = x[r] - (x[position[element.dofs[1]]] if len(element.dofs) == 2 else 0.0)
        nu = complex(element.describing_function(abs(relative), omega))
        delta[r, r] += nu
        if len(element.dofs) == 2:
            j = position[element.dofs[1]]
            delta[j, j] += nu
            delta[r, j] -= nu
            delta[j, r] -= nu
    return delta
