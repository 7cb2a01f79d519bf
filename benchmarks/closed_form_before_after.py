"""The DF closed form before and after a change, counted as frf_speed.py Part 3a counts:
``python benchmarks/closed_form_before_after.py [--commit REV] [--repeats N]``.

The "before" code is ``src/nlupdate/core/response/closed_form.py`` and ``sweep.py`` at ``--commit``
(default b86565c, the last before the closed form was sped up), read with ``git show`` and
loaded beside the working tree's in one process. Both ``frequency_sweep`` up + down on the
10,000-point Duffing grid, the vectorised trigonometric solve of the cubic and batched
companion eigenvalues at the same frequencies are timed interleaved; printed: CPU time
(process and children) per frequency, medians, wall beside, the ratios, the load average,
the largest relative difference between the two codes' responses, and the goal (issue 39: the
working tree's ``frequency_sweep`` ≤ 2× the trigonometric limit per frequency) met or not, on
CPU time. ``--write-docs``: the output becomes its block of docs/performance.md
(benchmarks/docs_block.py).
"""
from __future__ import annotations

import argparse
import datetime
import subprocess
import sys
import types
from pathlib import Path

if __package__ in (None, ""):  # run as a script: make the repository root importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np  # noqa: E402

from benchmarks import docs_block  # noqa: E402
from benchmarks.frf.common import BAND, FORCE, duffing, interleaved, load_average, timed  # noqa: E402
from benchmarks.frf.cubic_reference import companion_roots, trigonometric_roots  # noqa: E402
from benchmarks.frf.grid import DF_LIMIT_GOAL, GRID_POINTS, cubic_coefficients  # noqa: E402
from nlupdate.core.model.system import CondensedProblem  # noqa: E402
from nlupdate.core.response.sweep import frequency_sweep  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


# Before 16a321a the package was not under src/ and had no core/ layer: the old code's own
# path and its imports of the modules that still exist, moved.
MOVED = (("src/nlupdate/core/", "nlupdate/"),)
MOVED_IMPORTS = (("nlupdate.model.", "nlupdate.core.model."), ("nlupdate.response.", "nlupdate.core.response."))


def old_source(commit: str, path: str) -> tuple[str, str]:
    """(path as of ``commit``, its text): ``path`` or, for a commit before the move, its old path."""
    candidates = [path] + [path.replace(new, old, 1) for new, old in MOVED if path.startswith(new)]
    for candidate in candidates:
        shown = subprocess.run(["git", "show", f"{commit}:{candidate}"], cwd=ROOT, capture_output=True, text=True)
        if shown.returncode == 0:
            return candidate, shown.stdout
    raise FileNotFoundError(f"--commit {commit}: none of {', '.join(candidates)} exists there")


def old_module(name: str, commit: str, path: str, replace: tuple[str, str] | None = None) -> types.ModuleType:
    """The module at ``path`` as of ``commit``, loaded under ``name`` (``replace``: one text substitution;
    then its imports of moved modules follow them)."""
    path, source = old_source(commit, path)
    if replace:
        replace = (replace[0].replace("nlupdate.core.", "nlupdate.") if replace[0] not in source else replace[0],
                   replace[1])
        if source.count(replace[0]) != 1:
            raise ValueError(f"{commit}:{path}: expected one {replace[0]!r}")
        source = source.replace(*replace)
    for before, after in MOVED_IMPORTS:
        source = source.replace(f"from {before}", f"from {after}").replace(f"from {before[:-1]} import",
                                                                           f"from {after[:-1]} import")
    module = types.ModuleType(name)
    module.__file__ = f"{commit}:{path}"
    sys.modules[name] = module  # dataclasses look their module up
    exec(compile(source, module.__file__, "exec"), module.__dict__)
    return module


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--commit", default="b86565c")
    parser.add_argument("--repeats", type=int, default=41)
    docs_block.add_option(parser)
    args = parser.parse_args(argv)
    with docs_block.writing_docs(args.write_docs, "closed_form_before_after.py", argv):
        measure(args.commit, args.repeats)


def measure(commit: str, repeats: int) -> None:
    """Time the code of ``commit`` against the working tree's and print the table."""
    old_module("closed_form_before", commit, "src/nlupdate/core/response/closed_form.py")
    sweep_before = old_module("sweep_before", commit, "src/nlupdate/core/response/sweep.py",
                              ("from nlupdate.core.response import closed_form\n", "import closed_form_before as closed_form\n"))
    grid = np.linspace(*BAND, GRID_POINTS)
    system, forcing = duffing(), {0: FORCE}
    coefficients = cubic_coefficients(CondensedProblem(system, forcing), grid)
    tasks = {
        f"before ({commit}): frequency_sweep up + down": timed(
            lambda: [sweep_before.frequency_sweep(system, forcing, grid, d) for d in ("up", "down")]),
        "after (working tree): frequency_sweep up + down": timed(
            lambda: [frequency_sweep(system, forcing, grid, d) for d in ("up", "down")]),
        "trigonometric limit, one solve": timed(lambda: trigonometric_roots(*coefficients)),
        "companion eigenvalues, one solve": timed(lambda: companion_roots(*coefficients)),
    }
    results = {name: task()[1] for name, task in tasks.items()}  # warm-up
    before, after = list(results.values())[:2]
    difference = max(float(np.max(np.abs(a.x_nonlinear - b.x_nonlinear) / np.abs(b.x_nonlinear)))
                     for a, b in zip(after, before))
    print(f"closed_form_before_after.py — {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC; "
          f"load average {load_average()}; {GRID_POINTS} frequencies, medians of {repeats} interleaved repeats\n"
          f"largest relative difference of the responses, after against before: {difference:.1e}")
    timing = interleaved(tasks, repeats)
    limit = timing["trigonometric limit, one solve"].cpu_median
    companion = timing["companion eigenvalues, one solve"].cpu_median
    for name, t in timing.items():
        print(f"  {name:52s} CPU {1e6 * t.cpu_median / GRID_POINTS:6.3f} µs per frequency (wall {1e6 * t.median / GRID_POINTS:6.3f});"
              f" {t.cpu_median / limit:5.2f}× the trigonometric limit, {t.cpu_median / companion:5.2f}× companion")
    after_ratio = timing["after (working tree): frequency_sweep up + down"].cpu_median / limit
    print(f"goal: frequency_sweep up + down ≤ {DF_LIMIT_GOAL:g}× the trigonometric limit per frequency (CPU): "
          f"{after_ratio:.2f}× — {'met' if after_ratio <= DF_LIMIT_GOAL else 'NOT met'}")
    print(f"load average at the end {load_average()}")


if __name__ == "__main__":
    main()
