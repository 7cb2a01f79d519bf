"""One look per updating run, the same in every plot.

A study's runs come in families: the eigensensitivity runs of one parameter set (one
per difference formula) and each optimisation candidate. Each family gets a colour and
each run within it a line style (bars: a hatch), so a person matches a run across the
convergence, frequency-error and FRF plots, the formulas of one parameter set read as one
group, and no two runs look alike however many there are. The initial model is grey and
dashed (:data:`nlupdate.reporting.figures.INITIAL_STYLE`).
"""
from __future__ import annotations

import itertools
from typing import Iterable, Sequence

from nlupdate.reporting.figures import INITIAL_STYLE

#: Family colours (matplotlib's tab10 without its grey, kept for the initial model).
COLOURS = ("C0", "C1", "C2", "C3", "C4", "C5", "C6", "C8", "C9")
LINE_STYLES = ("-", "--", ":", "-.")
MARKERS = ("", "o", "s", "^", "v", "D")
#: The bar hatches standing in for each line style and marker.
HATCHES = {"-": "", "--": "//", ":": "..", "-.": "xx"}
MARKER_HATCHES = {"": "", "o": "o", "s": "O", "^": "*", "v": "+", "D": "|"}


def run_family(method: str, parameter_set: Sequence[str], name: str) -> tuple:
    """The family of a run: eigensensitivity runs of one parameter set share one; every
    other run (an optimisation candidate) is its own."""
    if method == "eigensensitivity":
        return (method, tuple(parameter_set))
    return (method, name)


def run_styles(runs: Iterable) -> dict[str, dict]:
    """Name → matplotlib line keywords (``color``, ``ls``, ``marker``) for ``initial`` and
    every run (:class:`~nlupdate.core.updating.eigensensitivity.UpdatingResult`), all distinct."""
    families: dict[tuple, list[str]] = {}
    for run in runs:  # in run order: within a family, the formulas in the order the study lists them
        families.setdefault(run_family(run.method, tuple(run.parameters), run.name), []).append(run.name)
    combinations = list(itertools.product(COLOURS, LINE_STYLES, MARKERS))
    used = {(INITIAL_STYLE["color"], INITIAL_STYLE["ls"], "")}
    styles = {"initial": {**INITIAL_STYLE, "marker": ""}}
    for k, names in enumerate(families.values()):
        for j, name in enumerate(names):
            wanted = (COLOURS[k % len(COLOURS)], LINE_STYLES[j % len(LINE_STYLES)],
                      MARKERS[(k // len(COLOURS) + j // len(LINE_STYLES)) % len(MARKERS)])
            choice = wanted if wanted not in used else next(c for c in combinations if c not in used)
            used.add(choice)
            styles[name] = {"color": choice[0], "ls": choice[1], "marker": choice[2]}
    return styles


def bar_style(style: dict) -> dict:
    """Bar keywords (face colour, hatch, edge) for a :func:`run_styles` entry."""
    hatch = HATCHES.get(style["ls"], "") + MARKER_HATCHES.get(style.get("marker", ""), "")
    return {"color": style["color"], "hatch": hatch or None, "edgecolor": "white" if hatch else style["color"]}
