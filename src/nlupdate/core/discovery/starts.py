"""Starting values for a fit of several effects at one place: variable projection on DF samples.

Every library DF is ``c·b_s(A, ω)`` (:mod:`nlupdate.core.discovery.effects`), so for fixed shapes
``s_1 … s_k`` the sum of k effects is linear in the scales ``c``. For each combination of
shapes from the effects' shape grids the scales follow from a weighted linear least-squares
fit to the apparent DF samples ``ν̃`` (weights ``1/std²``); combinations whose scales have
a wrong sign are dropped. The best few combinations (smallest weighted misfit) are the
starts of the output-error fit, each also with the first effect's scale reduced tenfold in
case the equation-error scale overshoots into a region without a response (grids are thinned
to at most 600 combinations). This finds the
joint optimum of two same-type effects (two friction sliders) that fitting one at a time
from the other's fixed values misses.
"""
from __future__ import annotations

from itertools import product
from typing import Sequence

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.discovery.effects import SIGNED, DFSamples, Effect

_MAX_COMBINATIONS = 600


def _scales(basis: NDArray, samples: DFSamples) -> NDArray[np.float64]:
    """Real scales minimising ``Σ |B c − ν̃|² / std²``."""
    weighted = basis / samples.std[:, None]
    target = samples.nu / samples.std
    design = np.vstack([weighted.real, weighted.imag])
    return np.linalg.lstsq(design, np.concatenate([target.real, target.imag]), rcond=None)[0]


def joint_starts(effects: Sequence[Effect], samples: DFSamples, count: int = 2) -> list[list[NDArray[np.float64]]]:
    """Start values (one array per effect) for a joint fit of ``effects`` to ``samples``."""
    grids = [list(effect.shapes(samples.amplitude)) for effect in effects]
    while np.prod([len(g) for g in grids]) > _MAX_COMBINATIONS:  # thin the largest grid
        largest = max(range(len(grids)), key=lambda k: len(grids[k]))
        grids[largest] = grids[largest][::2]
    scored = []
    for shapes in product(*grids):
        basis = np.column_stack([
            np.broadcast_to(e.basis(s, samples.amplitude, samples.omega), samples.nu.shape) for e, s in zip(effects, shapes)
        ])
        scales = _scales(basis, samples)
        if any(e.scale_sign != SIGNED and e.scale_sign * c <= 0 for e, c in zip(effects, scales)):
            continue
        misfit = float(np.sum(np.abs(basis @ scales - samples.nu) ** 2 / samples.std**2))
        scored.append((misfit, shapes, scales))
    if not scored:
        typical = float(np.sqrt(np.mean(np.abs(samples.nu) ** 2)))
        fallback = []
        for effect, grid in zip(effects, grids):
            shape = grid[len(grid) // 2]
            size = typical / max(float(np.sqrt(np.mean(np.abs(effect.basis(shape, samples.amplitude, samples.omega)) ** 2))), 1e-300)
            fallback.append(effect.values((effect.scale_sign or 1) * 1e-2 * size, shape))
        return [fallback]
    scored.sort(key=lambda item: item[0])
    starts = []
    for _, shapes, scales in scored[:count]:
        values = [e.values(c, s) for e, c, s in zip(effects, scales, shapes)]
        reduced = [effects[0].values(0.1 * scales[0], shapes[0])] + values[1:]
        starts += [values, reduced]
    return starts
