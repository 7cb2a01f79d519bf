"""Places (where an element acts) as the model names them, for messages, reports and plots.

A place is one coordinate (an element to ground) or two (an element between them, acting on
``x₁ − x₂``), held as model coordinate indices; a person reads the model's ``dof_names``.
"""
from __future__ import annotations

from typing import Sequence


def place_name(dofs: Sequence[int], names: Sequence[str] = ()) -> str:
    """A place as the model names it: ``"m2–m3"`` (an element between two coordinates),
    ``"m1 (to ground)"``; ``"dofs [1, 2]"`` when the model names its coordinates only by
    index (``dof_names`` left out, so they are ``"0"``, ``"1"``, …) or ``names`` is empty."""
    dofs = [int(d) for d in dofs]
    if not names or tuple(names) == tuple(str(i) for i in range(len(names))):
        return f"dofs {dofs}"
    labels = [str(names[d]) for d in dofs]
    return f"{labels[0]} (to ground)" if len(labels) == 1 else "–".join(labels)
