"""Reproduce the source's simulated identification case studies (thesis ch. 3, docs/methods.md §8).

    python benchmarks/reproduce_source.py [--seeds 100] [--quick] [--jobs 2] [--json FILE]

Cases (data: describing-function responses by continuation + upward stepped sine on a
1 Hz grid, like the source's harmonic-balance data; noise 5 % of |H| per docs/methods.md §8):

1. §3.1 SDOF, cubic + Jenkins, PRD at 710 Hz, 0.01 N + 11 levels 100…400 N (Table 3.1).
2. §3.2 2-DOF, PRD at 725 Hz (Table 3.2) and the excitation-frequency table
   725 / 730 / 745 Hz (Table 3 of the 2-DOF paper).
3. §3.5 SDOF cubic only: DDF with force pairs 100/350, 150/450, 100/450 N over the bands
   600–850, 650–900, 700–950 Hz (Tables 3.6–3.8) and PRD at 710 Hz with 12 levels
   50…400 N (Table 3.9).
4. Linear-FRF extraction (FRAC against the true linear FRF, raw and through a modal fit;
   natural-frequency and loss-factor errors of the fit) and regeneration of a high-level
   FRF on the modal fit (FRAC, peak frequency and amplitude errors).
5. Coverage of the Monte-Carlo 95 % intervals of the improved estimator.

Columns: the source's value, this project noise-free, and mean ± std over the noise seeds
for the source's naive least squares and for the improved estimator (PRD: joint
output-error ML over ±1 % of the excitation frequency; DDF: noise-weighted rows).
Models: "poly2" = the source's 2nd-order polynomial PRD fit (k3 = 4/3·c2, kf = −c0);
"elements" = cubic + Jenkins (or cubic) fitted as physical elements.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from source_cases import case_data  # noqa: E402

from nlupdate.core.correlation.metrics import frac, peak_errors  # noqa: E402
from nlupdate.core.identification.ddf import identify_ddf  # noqa: E402
from nlupdate.core.identification.dfmodels import PhysicalModel, PolynomialModel  # noqa: E402
from nlupdate.core.identification.modal_fit import fit_modal_model  # noqa: E402
from nlupdate.core.identification.prd import identify_prd  # noqa: E402
from nlupdate.core.identification.regenerate import regenerate_frf  # noqa: E402
from nlupdate.core.identification.uncertainty import monte_carlo  # noqa: E402

NOISE = 0.05
POLY2 = PolynomialModel.of_order(2)
FRICTION = PhysicalModel(("cubic", "jenkins"))
CUBIC = PhysicalModel(("cubic",))
DDF_PAIRS = ((100.0, 350.0), (150.0, 450.0), (100.0, 450.0))
DDF_BANDS = ((600.0, 850.0), (650.0, 900.0), (700.0, 950.0))
# source values (thesis Tables 3.1, 3.2, 3.6–3.9 and Table 3 of the 2-DOF paper)
SOURCE = {
    ("sdof", "k3"): "9.9e9 / 9.9e9 (5 %)", ("sdof", "kf"): "3e5 / 3.1e5 (5 %)",
    ("2dof@725", "k3"): "9.9e9 (5 %)", ("2dof@725", "kf"): "8.03e4 (5 %)",
    ("2dof@730", "k3"): "9.9e9 (5 %)", ("2dof@730", "kf"): "7.67e4 (5 %)",
    ("2dof@745", "k3"): "9.9e9 (5 %)", ("2dof@745", "kf"): "16.3e4 (5 %)",
    ("ddf", (100.0, 350.0)): ["9.389e9", "9.389e9", "9.374e9"],
    ("ddf", (150.0, 450.0)): ["9.828e9", "9.827e9", "9.823e9"],
    ("ddf", (100.0, 450.0)): ["1.026e10", "1.026e10", "1.027e10"],
    ("cubic-prd", "k3"): "9.99e9 (5 %)",
}


# ----------------------------------------------------------------------------- one data set
def _prd(data, frequency, model, estimator, **kwargs):
    return identify_prd(data, frequency, model, estimator=estimator, **kwargs)


def _parameters(result, names):
    values = result.parameters()
    return {name: values[name] for name in names}


def _correlation(case, data, result, regen_force):
    """The extracted linear FRF against the true one (raw and via a modal fit, whose
    natural frequency and loss factor are compared with the exact modal values), and the
    FRF regenerated at ``regen_force`` on the modal fit against the noise-free measured one."""
    _, clean = case_data(case.name)
    f, h_low = data.curve(0.01)
    true_linear = case.linear_frf(f)
    extracted = result.extract_linear_frf(f, h_low)
    modal = fit_modal_model(f, extracted, n_modes=1, inverse_noise=np.abs(1.0 / h_low))
    exact = fit_modal_model(f, true_linear, n_modes=1)
    regenerated = regenerate_frf(f, modal.receptance(f), result.df_for_force(regen_force), regen_force)
    _, measured = clean.curve(regen_force)
    errors = peak_errors(f, measured, regenerated)
    return {
        "linear FRAC (raw)": frac(true_linear, extracted),
        "linear FRAC (modal fit)": frac(true_linear, modal.receptance(f)),
        "natural frequency error %": 100 * (modal.natural_frequencies_hz[0] / exact.natural_frequencies_hz[0] - 1),
        "loss factor error %": 100 * (modal.loss_factors[0] / exact.loss_factors[0] - 1),
        f"regenerated {regen_force:g} N FRAC": frac(measured, regenerated),
        f"regenerated {regen_force:g} N peak frequency error Hz": errors.frequency_error_hz,
        f"regenerated {regen_force:g} N peak amplitude error %": errors.amplitude_error_percent,
    }


def evaluate(seed: int | None) -> dict:
    """Every estimate for one noise seed (None = noise-free)."""
    out: dict = {}
    rng = None if seed is None else np.random.default_rng(seed)

    def noisy(name):
        case, data = case_data(name)
        return case, (data if rng is None else data.with_noise(NOISE, rng))

    # §3.1 SDOF with friction
    case, data = noisy("sdof_friction")
    for model_name, model, names in (("poly2", POLY2, ("k3", "kf")), ("elements", FRICTION, ("k3", "kf", "slip_force"))):
        for estimator in ("naive", "improved"):
            result = _prd(data, 710.0, model, estimator)
            out[("sdof", model_name, estimator)] = _parameters(result, names)
            out[("sdof-corr", model_name, estimator)] = _correlation(case, data, result, 280.0)
    # §3.2 2-DOF, three excitation frequencies
    case, data = noisy("two_dof_friction")
    for frequency in (725.0, 730.0, 745.0):
        for model_name, model in (("poly2", POLY2), ("elements", FRICTION)):
            for estimator in ("naive", "improved"):
                result = _prd(data, frequency, model, estimator)
                out[(f"2dof@{frequency:g}", model_name, estimator)] = _parameters(result, ("k3", "kf"))
                if frequency == 725.0:
                    out[("2dof-corr", model_name, estimator)] = _correlation(case, data, result, 100.0)
    # §3.5 SDOF cubic only: DDF and PRD
    case, data = noisy("sdof_cubic")
    for pair in DDF_PAIRS:
        for band in DDF_BANDS:
            for estimator in ("naive", "weighted"):  # "weighted" is reported, not the default (see report)
                result = identify_ddf(data, pair, band, order=2, estimator=estimator)
                out[("ddf", pair, band, estimator)] = result.parameters()["k3"]
    prd_levels = tuple(float(f) for f in np.linspace(50.0, 400.0, 12))
    for model_name, model in (("poly2", POLY2), ("elements", CUBIC)):
        for estimator in ("naive", "improved"):
            result = _prd(data, 710.0, model, estimator, low_force=50.0, high_forces=prd_levels[1:])
            out[("cubic-prd", model_name, estimator)] = _parameters(result, ("k3",))
    return out


def coverage(seed: int, n_samples: int) -> dict:
    """Is the true value inside the Monte-Carlo 95 % interval (improved estimator, §3.1)?"""
    case, clean = case_data("sdof_friction")
    data = clean.with_noise(NOISE, np.random.default_rng(10_000 + seed))
    out = {}
    for model_name, model in (("poly2", POLY2), ("elements", FRICTION)):
        estimate = _Estimate(model)
        point = estimate(data).parameters()
        stats = monte_carlo(estimate, data, point, NOISE, n_samples=n_samples, seed=seed)
        for name in ("k3", "kf"):
            low, high = stats.parameters[name].ci95
            out[(model_name, name)] = (low <= case.true[name] <= high, stats.parameters[name].std)
    return out


class _Estimate:
    """Picklable improved PRD estimator at 710 Hz."""

    def __init__(self, model):
        self.model = model

    def __call__(self, data):
        return identify_prd(data, 710.0, self.model, estimator="improved")


# ----------------------------------------------------------------------------- formatting
def _fmt(value: float) -> str:
    return f"{value:.4g}" if np.isfinite(value) else "nan"


def _stat(values: list[float], truth: float | None = None) -> str:
    v = np.array(values, dtype=float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return "n/a"
    text = f"{v.mean():.4g} ± {v.std(ddof=1) if v.size > 1 else 0.0:.2g}"
    if truth:
        text += f" ({100 * (v.mean() / truth - 1):+.1f} %)"
    return text


def _err(value: float, truth: float) -> str:
    return f"{value:.5g} ({100 * (value / truth - 1):+.2f} %)"


def _table(title: str, header: list[str], rows: list[list[str]]) -> str:
    widths = [max(len(str(r[i])) for r in [header] + rows) for i in range(len(header))]
    line = lambda r: "| " + " | ".join(str(c).ljust(w) for c, w in zip(r, widths)) + " |"  # noqa: E731
    rule = "|" + "|".join("-" * (w + 2) for w in widths) + "|"
    return "\n".join([f"\n### {title}", line(header), rule] + [line(r) for r in rows])


def report(free: dict, seeds: list[dict], cover: list[dict] | None) -> tuple[str, list[str]]:
    """Markdown tables and the list of noise-free results off by more than 1 %."""
    truths = {"sdof": {"k3": 1e10, "kf": 3e5, "slip_force": 1.0}, "2dof": {"k3": 1e10, "kf": 8e4}, "cubic": {"k3": 1e10}}
    problems = []
    text = []
    n = len(seeds)
    header = ["case", "parameter", "model", "source", "noise-free", f"naive LS (n={n})", f"improved (n={n})"]
    for title, keys, truth, source_key in (
        ("§3.1 SDOF cubic + Jenkins, PRD at 710 Hz (Table 3.1)", ["sdof"], truths["sdof"], "sdof"),
        ("§3.2 2-DOF, PRD at 725 Hz (Table 3.2) and excitation frequency (Table 3)",
         ["2dof@725", "2dof@730", "2dof@745"], truths["2dof"], None),
        ("§3.5 SDOF cubic only, PRD at 710 Hz, 12 levels 50…400 N (Table 3.9)", ["cubic-prd"], truths["cubic"], None),
    ):
        rows = []
        for key in keys:
            for model in ("poly2", "elements"):
                for name in free[(key, model, "naive")]:
                    t = truth.get(name)
                    value = free[(key, model, "naive")][name]
                    if t and name != "slip_force" and abs(value / t - 1) > 0.01:
                        problems.append(f"{key} {model} {name}: noise-free {value:.5g} vs {t:.5g}")
                    source = SOURCE.get((key, name), "—") if (model == "poly2" and name != "slip_force") else "—"
                    rows.append([
                        key, name, model, source, _err(value, t) if t else _fmt(value),
                        _stat([s[(key, model, "naive")][name] for s in seeds], t),
                        _stat([s[(key, model, "improved")][name] for s in seeds], t),
                    ])
        text.append(_table(title, header, rows))
    rows = []
    for pair in DDF_PAIRS:
        for band, source in zip(DDF_BANDS, SOURCE[("ddf", pair)]):
            value = free[("ddf", pair, band, "naive")]
            if abs(value / 1e10 - 1) > 0.01:
                problems.append(f"DDF {pair} {band}: noise-free {value:.5g}")
            rows.append([
                f"{pair[0]:g}/{pair[1]:g} N", f"{band[0]:g}–{band[1]:g} Hz", f"{source} ({100 * (float(source) / 1e10 - 1):+.2f} %)",
                _err(value, 1e10),
                _stat([s[("ddf", pair, band, "naive")] for s in seeds], 1e10),
                _stat([s[("ddf", pair, band, "weighted")] for s in seeds], 1e10),
            ])
    text.append(_table("§3.5 DDF, k3 for three force pairs and bands (Tables 3.6–3.8)",
                       ["force pair", "band", "source (5 %)", "noise-free", f"naive LS (n={n})", f"weighted (n={n})"],
                       rows))
    rows = []
    for key, label in (("sdof-corr", "§3.1 SDOF @710 Hz"), ("2dof-corr", "§3.2 2-DOF @725 Hz")):
        for model in ("poly2", "elements"):
            for metric in free[(key, model, "naive")]:
                rows.append([
                    label, model, metric, _fmt(free[(key, model, "naive")][metric]),
                    _stat([s[(key, model, "naive")][metric] for s in seeds]),
                    _stat([s[(key, model, "improved")][metric] for s in seeds]),
                ])
    text.append(_table("Linear-FRF extraction (vs the true linear FRF) and regeneration (vs the noise-free measured FRF)",
                       ["case", "model", "metric", "noise-free", f"naive (n={n})", f"improved (n={n})"], rows))
    if cover:
        rows = []
        for model in ("poly2", "elements"):
            for name in ("k3", "kf"):
                inside = np.mean([c[(model, name)][0] for c in cover])
                mc_std = np.mean([c[(model, name)][1] for c in cover])
                spread = np.std([s[("sdof", model, "improved")][name] for s in seeds], ddof=1)
                rows.append([model, name, f"{100 * inside:.0f} %", _fmt(mc_std), _fmt(spread)])
        text.append(_table(f"Monte-Carlo 95 % intervals, improved estimator, §3.1 ({len(cover)} data sets)",
                           ["model", "parameter", "truth inside ci95", "mean MC std", "std over seeds"], rows))
    return "\n".join(text), problems


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=100, help="noise seeds (default 100)")
    parser.add_argument("--quick", action="store_true", help="20 seeds, 10 coverage data sets of 30 samples")
    parser.add_argument("--coverage-sets", type=int, default=40, help="data sets for the ci95 coverage (default 40)")
    parser.add_argument("--coverage-samples", type=int, default=50, help="MC samples per coverage data set (default 50)")
    parser.add_argument("--jobs", type=int, default=2, help="worker processes (default 2)")
    parser.add_argument("--json", help="also write the raw numbers to this JSON file")
    args = parser.parse_args(argv)
    seeds, sets, samples = args.seeds, args.coverage_sets, args.coverage_samples
    if args.quick:
        seeds, sets, samples = 20, 10, 30
    started = time.perf_counter()
    free = evaluate(None)
    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        noisy = list(pool.map(evaluate, range(seeds), chunksize=max(1, seeds // (4 * args.jobs))))
        cover = list(pool.map(coverage, range(sets), [samples] * sets)) if sets else None
    text, problems = report(free, noisy, cover)
    print(f"# Source case studies reproduced ({seeds} noise seeds, noise {100 * NOISE:g} % of |H|)")
    print(text)
    print(f"\nnoise-free results within 1 % of the true values: {'yes' if not problems else 'NO'}")
    for problem in problems:
        print("  " + problem)
    print(f"run time {time.perf_counter() - started:.0f} s with {args.jobs} worker(s)")
    if args.json:
        def key(k):
            return " | ".join(map(str, k)) if isinstance(k, tuple) else str(k)
        raw = {"noise_free": {key(k): v for k, v in free.items()},
               "seeds": [{key(k): v for k, v in s.items()} for s in noisy]}
        with open(args.json, "w") as handle:
            json.dump(raw, handle, indent=1, default=float)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
