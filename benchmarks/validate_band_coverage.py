"""Coverage of ``nlupdate validate``'s 95 % bands for the single-mode models (issue 34).

    python benchmarks/validate_band_coverage.py [--seeds 20] [--first-seed 0] [--models lines-background]
        [--processes 2] [--write-docs]

Each seed: a 1 kg SDOF at 80 Hz with a four-parameter Iwan joint (χ, β, its slip force and
stiffness drawn per seed), measured like the Brake–Reuss beam — four force levels spanning a
factor 7.5 from the joint stuck into microslip, 41 lines over ±1.25 % of the resonance,
0.5 % noise (docs/methods.md §8) — and with a test repeatability the BRB shows: every level
measured on a structure whose stiffness is drawn anew (resonance scatter σ_f =
``--sigma-f`` Hz, 1σ) and whose linear loss factor is drawn anew (σ 10 % of it). The curves
come from the describing-function continuation of the *true* joint
(:func:`~nlupdate.core.response.simulate.simulate_frf_table`), the polynomial models fitted
to them are the wrong form. ``validate --hold-out each`` holds out every level in turn; the
band must hold the *measured* held-out value (the criterion the BRB is judged by).

Prints per model and quantity: coverage (share of held-out levels, every seed, whose band
holds the measured value), the misses, the median of |error| and of band half-width relative
to |error|. ``--first-seed``: seeds first-seed … first-seed + seeds − 1 (a second set to check a
change chosen on the first). ``--write-docs``: the output becomes the script's block of
docs/validation.md (benchmarks/docs_block.py).
"""
from __future__ import annotations

import argparse
import multiprocessing
import sys
import time
import warnings
from pathlib import Path

import numpy as np

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks import docs_block  # noqa: E402

DOCS = Path(__file__).resolve().parents[1] / "docs" / "validation.md"
LEVELS = (0.2, 0.5, 1.0, 1.5)


def simulated_test(seed: int, sigma_f: float = 0.1):
    """The four curves of one seed (module docstring) as FRFLevels."""
    import pandas as pd

    from nlupdate.core.identification.data import FRFLevels
    from nlupdate.core.model.elements.iwan import IwanJoint
    from nlupdate.core.model.linear import LumpedModel
    from nlupdate.core.model.system import NonlinearSystem
    from nlupdate.core.response.simulate import simulate_frf_table

    rng = np.random.default_rng(seed)
    k = (2 * np.pi * 80.0) ** 2
    eta = rng.uniform(0.002, 0.003)
    kt = rng.uniform(0.03, 0.08) * k
    chi, beta = rng.uniform(-0.6, -0.2), rng.uniform(0.3, 2.0)
    # slip force: the top level's stuck response amplitude is 0.5–1.5 φ_max-equivalents (microslip)
    top_stuck = LEVELS[-1] / (eta * (k + kt))
    slip = rng.uniform(0.3, 0.8) * kt * top_stuck
    f = 80.0 * np.sqrt(1 + kt / k) * (1 + np.linspace(-0.0125, 0.0125, 41))
    tables = []
    for level in LEVELS:
        k_level = k * (1 + 2 * rng.normal(0.0, sigma_f / 80.0))
        eta_level = eta * (1 + 0.1 * rng.normal())
        system = NonlinearSystem(LumpedModel.with_loss_factor([[1.0]], [[k_level]], eta_level),
                                 (IwanJoint((0,), slip_force=slip, kt=kt, chi=chi, beta=beta),))
        table, _ = simulate_frf_table(system, 0, f, [level], noise=0.005, seed=int(rng.integers(1 << 31)))
        tables.append(table)
    return FRFLevels.from_table(pd.concat(tables, ignore_index=True), "0", "0")


def one_seed(args: tuple[int, tuple[str, ...], float]) -> list[dict]:
    from nlupdate.core.validation.held_out import validate

    seed, models, sigma_f = args
    data = simulated_test(seed, sigma_f)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = validate(data, "each", list(models))
    rows = []
    for r in result.held_out:
        for name, c in r.compared.items():
            if name == "damping_ratio" and r.half_power_lines < 5:
                continue
            scale = 1.0 if name == "resonance_hz" else c.measured
            rows.append({"seed": seed, "model": r.model, "level": r.level, "quantity": name, "inside": c.inside,
                         "error": abs(c.predicted - c.measured) / scale,
                         "half_width": 0.5 * (c.high - c.low) / scale})
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--models", default="lines-background")
    parser.add_argument("--sigma-f", type=float, default=0.1)
    parser.add_argument("--processes", type=int, default=2)
    docs_block.add_option(parser)
    args = parser.parse_args(argv)
    with docs_block.writing_docs(args.write_docs, "validate_band_coverage.py", argv, DOCS):
        run(args)
    return 0


def run(args: argparse.Namespace) -> None:
    """Print the coverage table of the seeds and models ``args`` names (module docstring)."""
    import pandas as pd

    models = tuple(m.strip() for m in args.models.split(",") if m.strip())
    started, cpu = time.perf_counter(), docs_block.cpu_seconds()
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    jobs = [(seed, models, args.sigma_f) for seed in seeds]
    with multiprocessing.Pool(args.processes) as pool:
        rows = [row for part in pool.map(one_seed, jobs) for row in part]
    table = pd.DataFrame(rows)
    print(f"seeds {seeds.start}–{seeds.stop - 1} × {len(LEVELS)} held-out levels, σ_f = {args.sigma_f} Hz, "
          "0.5 % noise")
    print("| model | quantity | coverage | misses | held-out levels | median error | median half-width / error |")
    print("|---|---|---|---|---|---|---|")
    for (model, quantity), group in table.groupby(["model", "quantity"], sort=False):
        known = group[group["inside"].notna()]
        ratio = (known["half_width"] / known["error"].clip(lower=1e-12)).median()
        unit = "Hz" if quantity == "resonance_hz" else ""
        error = known["error"].median() if unit else 100 * known["error"].median()
        inside = known["inside"].astype(bool)
        print(f"| {model} | {quantity} | {100 * inside.mean():.1f} % | {int((~inside).sum())} | {len(known)} of "
              f"{len(group)} | {error:.3g}{' Hz' if unit else ' %'} | {ratio:.2f} |")
    print(f"\n{time.perf_counter() - started:.1f} s wall, {docs_block.cpu_seconds() - cpu:.1f} s CPU "
          f"(this process and its {args.processes} workers)")


if __name__ == "__main__":
    sys.exit(main())
