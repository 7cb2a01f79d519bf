"""Coverage of the 95 % bands when the model is the wrong form (issue 34, "honest bands").

    python benchmarks/band_coverage.py [--seeds 20] [--samples 10] [--processes 2] [--write-docs] [--rows CSV]

Two cases, each a 1 kg SDOF at 80 Hz whose joint the fitted model cannot describe:

* ``iwan→jenkins`` — a four-parameter Iwan joint (microslip, then macroslip) fitted with a
  Jenkins element;
* ``gap→cubic`` — a symmetric clearance (contact spring beyond ±g) fitted with a cubic spring.

Each seed draws the joint's parameters, the damping and the five force levels from ranges
(below), so that the model-form error differs from seed to seed, and the measurement noise
(1 % of |H|, docs/methods.md §8). The measured FRFs come from the multi-harmonic balance
of the *true* joint (5 harmonics, 256 samples per period: :func:`simulate`), not from the
describing function the estimator fits, and the noise is added to that table.

Per seed and case it checks whether the 95 % bands hold the truth:

* **parameters** (``nlupdate identify``, PRD, ``--samples`` Monte-Carlo samples): the truth of
  a parameter of a model that is the wrong form is the one the model takes where it is
  fitted without noise. ``same levels``: the noise-free fit at the five measured levels;
  ``dense levels``: the noise-free fit at nine levels over the same range — the value a
  test of the same structure over the same range converges to, which the band's
  model-form part (the leave-one-level-out spread) is for;
* **predictions** (``nlupdate validate --model prd:ELEMENTS``, an interior and the top
  level held out): resonance frequency, damping ratio (circle fit) and peak |H| of the
  held-out level against those of its noise-free curve. A curve whose resonance spans
  fewer than 5 lines at 0.4 max|H| has no circle-fit damping ratio (NaN, the top levels
  of some Jenkins fits): that row has no band, is left out of the coverage and counted.

Prints one table (coverage = the share of seeds whose band holds the truth, the median
band half-width and error relative to the value) and, with ``--write-docs``, writes it into
docs/validation.md between the ``band-coverage`` markers.
"""
from __future__ import annotations

import argparse
import multiprocessing
import os
import re
import sys
import time
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs" / "validation.md"
NOISE = 0.01
TRUTH_NOISE = 0.5
STIFFNESS = (2 * np.pi * 80.0) ** 2  # N/m, 1 kg at 80 Hz
FREQUENCY_HZ = np.linspace(76.0, 84.0, 81)
MARKERS = ("<!-- band-coverage: begin (python benchmarks/band_coverage.py --write-docs) -->",
           "<!-- band-coverage: end -->")


@dataclass(frozen=True)
class Design:
    """One seed's structure: the true system, the measured levels (N), the dense levels of
    the ``dense levels`` truth, the fitted elements and the validate model."""

    system: Any
    levels: tuple[float, ...]
    dense: tuple[float, ...]
    elements: tuple[str, ...]
    model: str


def _levels(rng: np.random.Generator, lowest: float, ratio: float) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """Five levels geometric from ``lowest`` (jittered ±20 %) over ``ratio`` (each inner
    level moved up to a quarter step), and nine geometric over the same range."""
    low = lowest * rng.uniform(0.8, 1.25)
    steps = np.linspace(0.0, 1.0, 5)
    steps[1:-1] += rng.uniform(-0.06, 0.06, 3)
    levels = tuple(float(np.round(low * ratio**s, 6)) for s in steps)
    dense = tuple(float(np.round(v, 6)) for v in np.geomspace(levels[0], levels[-1], 9))
    return levels, dense


def iwan_design(rng: np.random.Generator) -> Design:
    """Iwan joint: F_S 0.014–0.028 N, K_T 3.5–7 % of k, χ −0.7…−0.3, β 0.2–1; loss factor
    0.0016–0.0025; levels 0.004–0.0063 N up to 16× that (stuck-ish to macroslip)."""
    from nlupdate.core.model.elements import IwanJoint
    from nlupdate.core.model.linear import LumpedModel
    from nlupdate.core.model.system import NonlinearSystem

    joint = IwanJoint((0,), 0.02 * rng.uniform(0.7, 1.4), 0.05 * STIFFNESS * rng.uniform(0.7, 1.4),
                      rng.uniform(-0.7, -0.3), rng.uniform(0.2, 1.0))
    eta = 0.002 * rng.uniform(0.8, 1.25)
    levels, dense = _levels(rng, 0.005, 16.0)
    return Design(NonlinearSystem(LumpedModel.with_loss_factor([[1.0]], [[STIFFNESS]], eta), (joint,)),
                  levels, dense, ("jenkins",), "prd:jenkins")


def gap_design(rng: np.random.Generator) -> Design:
    """Clearance g 8–12.5 µm, contact kc 0.7–1.4 % of k; loss factor 0.01; levels from
    0.016–0.025 N up to 5× that (the lowest at the clearance, the top at about 4 g)."""
    from nlupdate.core.model.elements import SymmetricGap
    from nlupdate.core.model.linear import LumpedModel
    from nlupdate.core.model.system import NonlinearSystem

    gap = SymmetricGap((0,), 1e-5 * rng.uniform(0.8, 1.25), 0.01 * STIFFNESS * rng.uniform(0.7, 1.4))
    levels, dense = _levels(rng, 0.02, 5.0)
    return Design(NonlinearSystem(LumpedModel.with_loss_factor([[1.0]], [[STIFFNESS]], 0.01), (gap,)),
                  levels, dense, ("cubic",), "prd:cubic")


CASES: dict[str, Callable[[np.random.Generator], Design]] = {"iwan→jenkins": iwan_design, "gap→cubic": gap_design}


def simulate(system: Any, levels: tuple[float, ...]):
    """The measured-FRF table of ``system`` at ``levels`` over :data:`FREQUENCY_HZ`: the
    first harmonic of the multi-harmonic balance (an independent path from the describing
    function the estimators fit)."""
    from nlupdate.core.response.harmonic_balance import HarmonicSettings
    from nlupdate.core.response.simulate import simulate_frf_table

    settings = HarmonicSettings(harmonics=5, samples=256, stability=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # truncation notes of the reference itself
        table, report = simulate_frf_table(system, 0, FREQUENCY_HZ, levels, method="hb", harmonic_balance=settings)
    if any(report.dropped_points.values()):
        raise RuntimeError(f"the reference lost points: {report.dropped_points}")
    return table


def noise_free_fit(data, elements: tuple[str, ...]):
    """The identification of noise-free ``data``; only its point estimates are used, so its
    noise level is given as :data:`TRUTH_NOISE` (above the fit's residual: no
    leave-one-level-out refits, two Monte-Carlo samples)."""
    from nlupdate.core.identification.pipeline import IdentificationSettings, identify

    return identify(data, IdentificationSettings("0", "0", elements=elements, samples=2, noise_fraction=TRUTH_NOISE))


def one_seed(case: str, seed: int, samples: int, hold: str = "interior,top") -> list[dict[str, Any]]:
    """Every band of one seed of ``case``, with its truth: rows of ``kind`` (parameter |
    prediction), ``quantity``, ``truth_kind``, ``value``, ``low``, ``high``, ``truth``,
    ``covered``; ``residual_ratio`` of the fit."""
    from nlupdate.core.identification.data import FRFLevels
    from nlupdate.core.identification.pipeline import IdentificationSettings, identify
    from nlupdate.core.measurement.noise import add_table_noise
    from nlupdate.core.validation.held_out import QUANTITIES, validate
    from nlupdate.core.validation.resonance import resonance

    rng = np.random.default_rng([seed, list(CASES).index(case)])
    design = CASES[case](rng)
    clean_table = simulate(design.system, design.levels)
    clean = FRFLevels.from_table(clean_table, "0", "0")
    data = FRFLevels.from_table(add_table_noise(clean_table, NOISE, int(rng.integers(2**31))), "0", "0")
    rows: list[dict[str, Any]] = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fitted = identify(data, IdentificationSettings("0", "0", elements=design.elements, samples=samples, seed=seed))
        truths = {"same levels": noise_free_fit(clean, design.elements),
                  "dense levels": noise_free_fit(FRFLevels.from_table(simulate(design.system, design.dense), "0", "0"),
                                                 design.elements)}
    ratio = fitted.uncertainty.residual_ratio
    for name, stats in fitted.uncertainty.parameters.items():
        for truth_kind, truth in truths.items():
            if name not in truth.uncertainty.parameters:
                continue
            value = truth.uncertainty.parameters[name].value
            rows.append({"case": case, "seed": seed, "kind": "parameter", "quantity": name, "truth_kind": truth_kind,
                         "value": stats.value, "low": stats.ci95[0], "high": stats.ci95[1], "truth": value,
                         "residual_ratio": ratio, "bound": stats.bound is not None})
    picks = {"interior": design.levels[2], "top": design.levels[-1]}
    held = [picks[h] for h in hold.split(",")]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = validate(data, held, [design.model])
    for r in result.held_out:
        shown = resonance(*clean.curve(r.level))
        truth = {"resonance_hz": shown.resonance_hz, "damping_ratio": shown.damping_ratio, "peak_abs": shown.peak_abs}
        where = "top" if r.level == design.levels[-1] else "interior"
        for q in QUANTITIES:
            c = r.compared[q]
            rows.append({"case": case, "seed": seed, "kind": "prediction", "quantity": q, "truth_kind": f"{where} level",
                         "value": c.predicted, "low": c.low, "high": c.high, "truth": truth[q],
                         "residual_ratio": r.residual_to_noise, "bound": False, "informative": c.informative})
    for row in rows:
        row["has_band"] = not (np.isnan(row["low"]) or np.isnan(row["high"]))
        row["covered"] = bool(row["low"] <= row["truth"] <= row["high"])
        row["contains_value"] = bool(row["low"] <= row["value"] <= row["high"])
    return rows


def _run(args: tuple[str, int, int]) -> list[dict[str, Any]]:
    return one_seed(*args)


def coverage_table(rows: list[dict[str, Any]]) -> str:
    """Markdown: one row per case, kind, quantity and truth; coverage, seeds, median
    half-width and median |error| relative to |truth|; then the pooled coverage per case
    and kind."""
    import pandas as pd

    frame = pd.DataFrame(rows)
    unbanded = int((~frame["has_band"]).sum())
    frame = frame[frame["has_band"]].copy()
    frame["half"] = (frame["high"] - frame["low"]) / 2 / frame["truth"].abs()
    frame["error"] = (frame["value"] - frame["truth"]).abs() / frame["truth"].abs()
    lines = ["| case | kind | quantity | truth | coverage | seeds | median half-width / truth | median error / truth |",
             "|---|---|---|---|---|---|---|---|"]
    for (case, kind, quantity, truth), g in frame.groupby(["case", "kind", "quantity", "truth_kind"], sort=False):
        lines.append(f"| {case} | {kind} | {quantity} | {truth} | {100 * g['covered'].mean():.0f} % | {len(g)} | "
                     f"{g['half'].median():.3g} | {g['error'].median():.3g} |")
    lines += ["", "| case | kind | truth | pooled coverage | bands | of the covering bands, uninformative |",
              "|---|---|---|---|---|---|"]
    for (case, kind, truth), g in frame.groupby(["case", "kind", "truth_kind"], sort=False):
        idle = "—" if kind == "parameter" else str(int((g["covered"] & (g["informative"] == False)).sum()))  # noqa: E712
        lines.append(f"| {case} | {kind} | {truth} | {100 * g['covered'].mean():.1f} % | {len(g)} | {idle} |")
    outside = int((~frame["contains_value"]).sum())
    lines += ["", f"estimates outside their own band: {outside} of {len(frame)}; without a band (no circle-fit "
                  f"damping ratio: fewer than 5 lines at 0.4 max|H|): {unbanded}; residual over noise of the "
                  f"parameter fits: median {frame.loc[frame.kind == 'parameter', 'residual_ratio'].median():.3g}"]
    return "\n".join(lines)


def write_docs(text: str) -> None:
    """Replace the text between :data:`MARKERS` in docs/validation.md."""
    doc = DOCS.read_text()
    begin, end = MARKERS
    if begin not in doc or end not in doc:
        raise SystemExit(f"{DOCS}: the markers {begin!r} and {end!r} are missing")
    pattern = re.compile(re.escape(begin) + ".*?" + re.escape(end), re.S)
    DOCS.write_text(pattern.sub(lambda _: f"{begin}\n{text}\n{end}", doc))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--samples", type=int, default=10, help="Monte-Carlo samples per identification")
    parser.add_argument("--processes", type=int, default=2)
    parser.add_argument("--write-docs", action="store_true", help="write the table into docs/validation.md")
    parser.add_argument("--rows", type=Path, help="also write every band with its truth to this CSV file")
    args = parser.parse_args(argv)
    jobs = [(case, seed, args.samples) for seed in range(args.seeds) for case in CASES]
    started, cpu = time.perf_counter(), time.process_time()
    header = (f"{args.seeds} seeds per case, {args.samples} Monte-Carlo samples, noise {100 * NOISE:g} %; load "
              f"{os.getloadavg()[0]:.1f} (1 min) on {os.cpu_count()} cores; {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}")
    if args.processes > 1:
        with multiprocessing.get_context("spawn").Pool(args.processes) as pool:
            parts = pool.map(_run, jobs)
    else:
        parts = [_run(job) for job in jobs]
    rows = [row for part in parts for row in part]
    if args.rows:
        import pandas as pd

        pd.DataFrame(rows).to_csv(args.rows, index=False)
    table = coverage_table(rows)
    footer = (f"{time.perf_counter() - started:.0f} s wall, {time.process_time() - cpu:.0f} s CPU in the "
              f"main process (the work runs in {args.processes} processes)")
    text = f"`python benchmarks/band_coverage.py --seeds {args.seeds} --samples {args.samples}` ({header}):\n\n{table}\n\n{footer}"
    print(text)
    if args.write_docs:
        write_docs(text)
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    sys.exit(main())
