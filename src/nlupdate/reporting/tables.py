"""A study's results as tidy tables (written as ``tables/<name>.parquet`` in an archive).

===================  ==========================================================================
measured             the measured-FRF table (frequency_hz, force_level_n, response_dof, …)
identification       per identified parameter: value, Monte-Carlo mean, std, ci95 (SI)
linear_frf           the extracted linear FRF (force_level_n = 0 marks "linear")
linear_modes         per mode of the extracted FRF: natural frequency and loss factor ± std
targets              per target mode: label, frequency (Hz), std (Hz), weight
runs                 per updating run: method, formula, parameter set, convergence and why it
                     stopped (``stop``, ``reason``), FE runs (new / cached), updated values
                     ``p:<name>`` and their std ``std:<name>`` (NaN for a run that did not converge)
histories            per iteration of every run (column ``run``)
comparison           run × mode: target, frequency, error %, MAC, FRAC vs the linear FRF
ranking              runs scored for the user's mode weights (``converged``: converged runs rank first)
failures             updating runs that failed, with the error
predictions          predicted FRFs of every predicted model (column ``model``)
correlation          per model and force level: FRAC, normalised error, peak errors
fe_modes             ``[fe_validation]``: each elastic FE mode of the initial and the updated model,
                     with the test's frequency where paired (``frequency_hz_measured``)
validation           ``[validation]``: held-out levels; ``[fe_validation]``: one row per forced run
                     and model, measured and predicted resonance, damping ratio and peak
amplitude_backbone   ``[amplitude]``: the fitted backbone (amplitude/backbone.csv: modal_amplitude,
                     natural_frequency_hz, damping_ratio and their 95 % ``*_low``/``*_high``)
===================  ==========================================================================
"""
from __future__ import annotations

from typing import Sequence

import pandas as pd

from nlupdate.core.updating.eigensensitivity import UpdatingResult
from nlupdate.core.updating.sensitivity import FORMULA_LABELS


def runs_table(results: Sequence[UpdatingResult]) -> pd.DataFrame:
    """One row per candidate: method, formula, parameters (``p:<name>``), convergence, cost."""
    rows = []
    for result in results:
        row: dict[str, object] = {
            "candidate": result.name,
            "method": result.method,
            "formula": FORMULA_LABELS[result.history["formula"].iloc[0]] if len(result.history) else "",
            "parameter_set": ",".join(result.parameters),
        }
        row.update({f"p:{k}": v for k, v in result.parameters.items()})
        row.update({
            "converged": result.converged,
            "stop": result.stop,
            "reason": result.reason,
            "iterations": result.iterations,
            "new_evaluations": result.counts["new"],
            "cached_evaluations": result.counts["cached"],
            "wall_time_s": result.wall_time_s,
        })
        rows.append(row)
    return pd.DataFrame(rows)


def study_tables(result) -> dict[str, pd.DataFrame]:
    """Every table a :class:`~nlupdate.study.chain.StudyResult` holds, by name."""
    tables: dict[str, pd.DataFrame] = {}
    if result.measured is not None:
        tables["measured"] = result.measured
    ident = result.identification
    if ident is not None:
        stats = ident.uncertainty.parameters
        tables["identification"] = pd.DataFrame([
            {"parameter": name, "value": s.value, "mean": s.mean, "std": s.std, "ci95_low": s.ci95[0], "ci95_high": s.ci95[1]}
            for name, s in stats.items() if name in ident.parameters()
        ])
        tables["linear_frf"] = ident.linear_frf_table()
        tables["linear_modes"] = pd.DataFrame([
            {"mode": i + 1, "natural_frequency_hz": stats[f"linear_f{i + 1}_hz"].value,
             "natural_frequency_std_hz": stats[f"linear_f{i + 1}_hz"].std, "loss_factor": stats[f"linear_eta{i + 1}"].value,
             "loss_factor_std": stats[f"linear_eta{i + 1}"].std}
            for i in range(len(ident.modes))
        ], columns=["mode", "natural_frequency_hz", "natural_frequency_std_hz", "loss_factor", "loss_factor_std"])
    if result.targets is not None:
        t = result.targets.targets
        std = result.targets.std_hz
        tables["targets"] = pd.DataFrame({"mode": list(t.labels), "frequency_hz": t.frequencies_hz,
                                          "std_hz": std if std is not None else float("nan"), "weight": t.weights})
    if result.runs:
        runs = runs_table(result.runs)
        for name in sorted({n for r in result.runs for n in r.parameters}):
            runs[f"std:{name}"] = [
                result.uncertainties[r.name].std.get(name, float("nan")) if r.name in result.uncertainties else float("nan")
                for r in result.runs
            ]
        tables["runs"] = runs
        history = pd.concat([r.history.assign(run=r.name) for r in result.runs], ignore_index=True)
        tables["histories"] = history[["run"] + [c for c in history.columns if c != "run"]]
        tables["comparison"] = result.comparison
        tables["ranking"] = result.ranking
    if result.failures:
        tables["failures"] = pd.DataFrame([{"run": f.name, "error": f.error} for f in result.failures])
    if result.predictions:
        tables["predictions"] = pd.concat([p.table.assign(model=p.name) for p in result.predictions], ignore_index=True)
        tables["correlation"] = pd.concat(
            [p.correlation.assign(model=p.name, loss_factor=p.loss_factor) for p in result.predictions], ignore_index=True)
    if result.validation is not None:
        tables["validation"] = result.validation.table()
    if result.fe_validation is not None:  # the study reader allows one of [validation] and [fe_validation]
        tables["fe_modes"] = result.fe_validation.modes
        tables["validation"] = result.fe_validation.table
    if result.amplitude is not None:
        tables["amplitude_backbone"] = result.amplitude.curve
    return tables
