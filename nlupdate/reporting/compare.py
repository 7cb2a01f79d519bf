"""What changed between two archived runs: inputs (study fields, data hashes, versions,
seeds) and results (identified and updated parameters with uncertainty, candidates and
ranking, FRAC per force level), field by field.

Each field is a dotted name with a value per run. Inputs compare exactly. A result
number matches when ``|a − b| ≤ rtol·max(|a|, |b|) + atol``; where the runs give a
standard deviation, the row also gives the difference in σ, so "changed" can be read
against the run's own uncertainty. Timings and FE-run counts (new vs cached) are not
results and are left out.
"""
from __future__ import annotations

import math
import tomllib
from dataclasses import asdict, dataclass
from pathlib import Path
from types import SimpleNamespace
from typing import Any, Iterable

import pandas as pd

from nlupdate.reporting.catalogue import ArchivedRun
from nlupdate.fingerprints import table_hash
from nlupdate.reporting.figures import save_figure
from nlupdate.reporting.prediction_plots import predictions_figure

DEFAULT_RTOL = 1e-6
DEFAULT_ATOL = 1e-12


@dataclass(frozen=True)
class FieldChange:
    """One field of the comparison; ``status`` is ``same``, ``changed``, ``only A`` or ``only B``."""

    section: str
    field: str
    a: Any
    b: Any
    status: str
    sigmas: float | None = None

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


def _flatten(value: Any, prefix: str = "") -> dict[str, Any]:
    if isinstance(value, dict):
        out: dict[str, Any] = {}
        for key, item in value.items():
            out.update(_flatten(item, f"{prefix}.{key}" if prefix else str(key)))
        return out
    if isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
        out = {}
        for i, item in enumerate(value, start=1):
            out.update(_flatten(item, f"{prefix}[{i}]"))
        return out
    return {prefix: value}


def study_fields(run: ArchivedRun) -> dict[str, Any]:
    """The study file as run, flattened to dotted keys (``eigensensitivity.formulas``)."""
    path = run.folder / "study.toml"
    return _flatten(tomllib.loads(path.read_text())) if path.is_file() else {}


def input_fields(run: ArchivedRun) -> dict[str, dict[str, Any]]:
    """Every input of a run by section: study fields, data, seeds, versions, solvers."""
    manifest = run.manifest
    inputs = manifest.get("inputs", {})
    data: dict[str, Any] = {}
    if inputs.get("measured"):
        data["measured data sha256"] = inputs["measured"].get("sha256")
    for entry in inputs.get("files", []):
        data[f"file {entry['as_written']} sha256"] = entry["sha256"]
    environment = manifest.get("environment", {})
    versions = {"python": environment.get("python"), "platform": environment.get("platform")}
    versions.update({f"package {name}": version for name, version in environment.get("packages", {}).items()})
    source = environment.get("source") or {}
    if source:
        versions["nlupdate source commit"] = source.get("commit")
        versions["nlupdate source local changes"] = source.get("local_changes")
    solvers = {f"{role} solver": (spec or {}).get("solver") for role, spec in manifest.get("adapters", {}).items()}
    return {"study": study_fields(run), "data": data, "seeds": dict(manifest.get("seeds", {})), "versions": versions,
            "solvers": solvers}


def _pair(value: float, std: float | None = None) -> tuple[float, float | None]:
    return float(value), None if std is None or not math.isfinite(std) else float(std)


def result_fields(run: ArchivedRun) -> dict[str, dict[str, Any]]:
    """Every result of a run by section; numbers as (value, std or None)."""
    out: dict[str, dict[str, Any]] = {"identified": {}, "linear modes": {}, "updated": {}, "ranking": {}, "FRAC": {}}
    identified = run.table("identification")
    if identified is not None:
        for row in identified.itertuples():
            out["identified"][row.parameter] = _pair(row.value, row.std)
    modes = run.table("linear_modes")
    if modes is not None:
        for row in modes.itertuples():
            out["linear modes"][f"mode {row.mode} frequency (Hz)"] = _pair(row.natural_frequency_hz,
                                                                            row.natural_frequency_std_hz)
            out["linear modes"][f"mode {row.mode} loss factor"] = _pair(row.loss_factor, row.loss_factor_std)
    runs = run.table("runs")
    if runs is not None:
        for row in runs.to_dict("records"):
            for column, value in row.items():
                if column.startswith("p:") and pd.notna(value):
                    std = row.get(f"std:{column[2:]}")
                    out["updated"][f"{row['candidate']}: {column[2:]}"] = _pair(value, None if pd.isna(std) else std)
            out["updated"][f"{row['candidate']}: converged"] = bool(row["converged"])
    failures = run.table("failures")
    if failures is not None:
        for row in failures.itertuples():
            out["updated"][f"{row.run}: failed"] = row.error
    ranking = run.table("ranking")
    if ranking is not None:
        ordered = ranking.sort_values("rank")
        out["ranking"]["order"] = " > ".join(map(str, ordered["candidate"]))
        for row in ordered.itertuples():
            out["ranking"][f"{row.candidate}: weighted |error| (%)"] = _pair(row.weighted_abs_error_pct)
    correlation = run.table("correlation")
    if correlation is not None:
        for row in correlation.itertuples():
            out["FRAC"][f"{row.model} at {row.force_level_n:g} N"] = _pair(row.frac)
    return {section: values for section, values in out.items() if values}


def _numbers_match(a: tuple, b: tuple, rtol: float, atol: float) -> tuple[bool, float | None]:
    (va, sa), (vb, sb) = a, b
    if math.isnan(va) and math.isnan(vb):
        return True, None
    same = abs(va - vb) <= rtol * max(abs(va), abs(vb)) + atol
    if sa is not None and sa >= 0 and va == va and vb == vb:
        std = sa if sb is None else max(sa, sb)
        std_same = sb is None or abs(sa - sb) <= rtol * max(sa, sb) + atol
        sigmas = abs(va - vb) / std if std > 0 else (0.0 if va == vb else math.inf)
        return same and std_same, sigmas
    return same, None


def _compare_section(section: str, a: dict, b: dict, rtol: float, atol: float) -> list[FieldChange]:
    rows = []
    for key in list(a) + [k for k in b if k not in a]:
        if key not in b:
            rows.append(FieldChange(section, key, a[key], None, "only A"))
        elif key not in a:
            rows.append(FieldChange(section, key, None, b[key], "only B"))
        elif isinstance(a[key], tuple) and isinstance(b[key], tuple):
            same, sigmas = _numbers_match(a[key], b[key], rtol, atol)
            rows.append(FieldChange(section, key, list(a[key]), list(b[key]), "same" if same else "changed", sigmas))
        else:
            rows.append(FieldChange(section, key, a[key], b[key], "same" if a[key] == b[key] else "changed"))
    return rows


def compare_inputs(a: ArchivedRun, b: ArchivedRun) -> list[FieldChange]:
    """Every input field of both runs, exactly compared."""
    fa, fb = input_fields(a), input_fields(b)
    return [row for section in fa for row in _compare_section(section, fa[section], fb.get(section, {}), 0.0, 0.0)]


def compare_results(a: ArchivedRun, b: ArchivedRun, rtol: float = DEFAULT_RTOL,
                    atol: float = DEFAULT_ATOL) -> list[FieldChange]:
    """Every result field of both runs; numbers within the tolerance are ``same``."""
    fa, fb = result_fields(a), result_fields(b)
    sections = list(fa) + [s for s in fb if s not in fa]
    return [row for s in sections for row in _compare_section(s, fa.get(s, {}), fb.get(s, {}), rtol, atol)]


def changed(rows: Iterable[FieldChange]) -> list[FieldChange]:
    return [row for row in rows if row.status != "same"]


def format_value(value: Any) -> str:
    """A field value as a short string: ``v ± s`` for (value, std) pairs."""
    if isinstance(value, list) and len(value) == 2 and isinstance(value[0], float):
        v, s = value
        return f"{v:.6g}" + (f" ± {s:.2g}" if s is not None else "")
    if isinstance(value, float):
        return f"{value:.6g}"
    if value is None:
        return "–"
    text = str(value)
    if len(text) == 64 and all(c in "0123456789abcdef" for c in text):  # a SHA-256
        return text[:12] + "…"
    return text if len(text) <= 60 else text[:57] + "…"


def change_table(rows: Iterable[FieldChange]) -> pd.DataFrame:
    """The rows as a table of strings (section, field, A, B, status, Δ/σ)."""
    return pd.DataFrame([{"section": r.section, "field": r.field, "A": format_value(r.a), "B": format_value(r.b),
                          "status": r.status, "Δ/σ": "" if r.sigmas is None else f"{r.sigmas:.2g}"} for r in rows],
                        columns=["section", "field", "A", "B", "status", "Δ/σ"])


def best_prediction(run: ArchivedRun) -> SimpleNamespace | None:
    """The best updated model's prediction of ``run`` (highest mean FRAC over the force
    levels) as ``name``, ``table`` (predicted FRFs) and ``correlation``; None without one."""
    predictions, correlation = run.table("predictions"), run.table("correlation")
    if predictions is None or correlation is None:
        return None
    models = [m for m in predictions["model"].unique() if m != "initial"]
    if not models:
        return None
    model = str(correlation[correlation["model"].isin(models)].groupby("model")["frac"].mean().idxmax())
    return SimpleNamespace(name=model, table=predictions[predictions["model"] == model],
                           correlation=correlation[correlation["model"] == model])


def plot_comparison(a: ArchivedRun, b: ArchivedRun, path: Path) -> Path | None:
    """Both runs' best predictions against the measurements at every force level (B's
    measurement drawn too when its data differ); None when a run has no prediction."""
    pa, pb = best_prediction(a), best_prediction(b)
    measured_a, measured_b = a.table("measured"), b.table("measured")
    if pa is None or pb is None or measured_a is None:
        return None
    first = pa.table.iloc[0]
    pair = (str(first["response_dof"]), str(first["input_dof"]))
    pa.name, pb.name = f"A {a.run_id}: {pa.name}", f"B {b.run_id}: {pb.name}"
    same_data = measured_b is not None and table_hash(measured_a) == table_hash(measured_b)
    other = None if same_data or measured_b is None else ("measured (B)", measured_b)
    styles = [dict(color="C0", lw=1.4), dict(color="C3", lw=1.1, ls="--")]
    return save_figure(predictions_figure(measured_a, [pa, pb], *pair, f"{a.study}: run A vs run B", styles, other,
                                          short_names=["A", "B"]), path, dpi=110)
