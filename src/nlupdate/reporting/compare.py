"""What changed between two archived runs: what the runs are (study, chain steps, FE model,
parameters, targets, measured curves and force levels), inputs (study fields, data hashes,
versions, seeds) and results (identified and updated parameters with uncertainty,
candidates and ranking, FRAC per force level, the held-out predictions of ``[validation]``),
field by field.

Runs of different studies are compared too: the overview says how they differ, fields
both runs have are compared, and the plot draws only the curves and force levels both
runs measured and predicted (none when they share none, with the reason).

Each field is a dotted name with a value per run. Inputs compare exactly. A result
number matches when ``|a − b| ≤ rtol·max(|a|, |b|) + atol``; where the runs give a
standard deviation, the row also gives the difference in σ, so "changed" can be read
against the run's own uncertainty. Timings and FE-run counts (new vs cached) are not
results and are left out.
"""
from __future__ import annotations

import json
import math
import tomllib
from dataclasses import asdict, dataclass
from pathlib import Path
from types import SimpleNamespace
from typing import Any, Iterable, NamedTuple

import numpy as np
import pandas as pd

from nlupdate.reporting.catalogue import ArchiveError, ArchivedRun, archived_study_text, best_candidate
from nlupdate.core.measurement.units import table_reference_unit
from nlupdate.fingerprints import table_hash
from nlupdate.reporting.figures import save_figure
from nlupdate.reporting.prediction_plots import predictions_figure

DEFAULT_RTOL = 1e-6
DEFAULT_ATOL = 1e-12
#: The chain's steps (src/nlupdate/study/chain.py) by what each leaves in an archive: a table or a plot.
STEP_EVIDENCE = (("measured data", "table", "measured"), ("identification", "table", "identification"),
                 ("targets", "table", "targets"), ("updating", "table", "runs"), ("comparison", "table", "ranking"),
                 ("candidate FRFs", "plot", "frf_comparison"), ("predictions", "table", "predictions"),
                 ("validation", "plot", "validation"), ("amplitude", "table", "amplitude_backbone"),
                 ("FE validation", "table", "fe_modes"))
#: a held-out level's or run's predicted quantities in validation.json, as compare names them
HELD_OUT_QUANTITIES = {"resonance_hz": "resonance (Hz)", "damping_ratio": "damping ratio", "peak_abs": "peak |H|"}
ONE_SIDED = ("only A", "only B")


class Estimate(NamedTuple):
    """A result number and its standard deviation (None where the run gives none)."""

    value: float
    std: float | None


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
    text = archived_study_text(run.folder)
    return _flatten(tomllib.loads(text)) if text is not None else {}


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
    if environment.get("code_sha256"):  # archives written before it was recorded have none
        versions["nlupdate code sha256"] = environment["code_sha256"]
    source = environment.get("source") or {}
    if source:
        versions["nlupdate source commit"] = source.get("commit")
        versions["nlupdate source local changes"] = source.get("local_changes")
    solvers = {f"{role} solver": (spec or {}).get("solver") for role, spec in manifest.get("adapters", {}).items()}
    return {"study": study_fields(run), "data": data, "seeds": dict(manifest.get("seeds", {})), "versions": versions,
            "solvers": solvers}


def _pair(value: float, std: float | None = None) -> Estimate:
    return Estimate(float(value), None if std is None or not math.isfinite(std) else float(std))


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
            out["FRAC"][f"{row.model} at {row.force_level_n:g} {level_unit(run)}"] = _pair(row.frac)
    held_out = _held_out_fields(run)
    if held_out:
        out["held-out levels"] = held_out
    backbone = run.table("amplitude_backbone")
    if backbone is not None and len(backbone):  # [amplitude]: its ends and middle
        out["amplitude backbone"] = {}
        for row in backbone.iloc[sorted({0, len(backbone) // 2, len(backbone) - 1})].itertuples():
            at = f"a = {row.modal_amplitude:.4g} m·√kg"
            out["amplitude backbone"][f"{at}: natural frequency (Hz)"] = _pair(row.natural_frequency_hz)
            out["amplitude backbone"][f"{at}: damping ratio"] = _pair(row.damping_ratio)
    return {section: values for section, values in out.items() if values}


def _held_out_fields(run: ArchivedRun) -> dict[str, Any]:
    """``[validation]``'s predictions (validation.json): per held-out level and response-controlled
    run, the model that predicted it, and each quantity's prediction and 95 % band; with
    ``hold_out_type``, the model fitted without that type and its largest errors on it."""
    path = run.folder / "validation.json"
    if not path.is_file():
        return {}
    try:
        validation = json.loads(path.read_text())
    except (OSError, ValueError) as error:
        raise ArchiveError(f"{path}: cannot be read ({type(error).__name__}: {error})") from None
    out: dict[str, Any] = {}
    rows = [(f"{row['requested']} at {row['level']:g}", row) for row in validation.get("held_out", [])]
    rows += [(f"{row['requested']}, run {row['run']}", row) for row in validation.get("response_controlled", [])]
    for name, row in rows:
        out[f"{name}: model"] = row["model"]
        for key, label in HELD_OUT_QUANTITIES.items():
            for end in ("predicted", "low", "high"):
                value = row[key][end]
                out[f"{name}: {label} {end}"] = _pair(math.nan if value is None else value)
    held = validation.get("held_out_type")
    if held:  # hold_out_type: the model fitted without the type, and its largest errors on it
        name = f"{held['test_type']} held out"
        out[f"{name}: linear limit (Hz)"] = _pair(held["model"]["natural_frequency_hz"])
        out[f"{name}: damping ratio at the limit"] = _pair(held["model"]["damping_ratio"])
        for key, value in held.get("worst_within_fit", {}).items():
            out[f"{name}: largest |relative error| of {key} within the fit"] = _pair(value)
    return out


def _numbers_match(a: Estimate, b: Estimate, rtol: float, atol: float) -> tuple[bool, float | None]:
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
        elif isinstance(a[key], Estimate) and isinstance(b[key], Estimate):
            same, sigmas = _numbers_match(a[key], b[key], rtol, atol)
            rows.append(FieldChange(section, key, a[key], b[key], "same" if same else "changed", sigmas))
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


def _numbers(values: Iterable[float]) -> str:
    return ", ".join(f"{v:g}" for v in values)


def steps_present(run: ArchivedRun) -> list[str]:
    """The chain's steps whose results the archive holds, in chain order."""
    tables, plots = set(run.manifest.get("tables", [])), set(run.manifest.get("plots", {}))
    return [step for step, kind, name in STEP_EVIDENCE if name in (tables if kind == "table" else plots)]


def level_unit(run: ArchivedRun) -> str:
    """The unit of a run's levels, its measured table's reference: ``"N"``, or ``"V"`` per volt."""
    measured = run.table("measured")
    return "N" if measured is None else table_reference_unit(measured)


def curves(table: pd.DataFrame | None) -> dict[tuple[str, str], list[float]]:
    """(response dof, input dof) → ascending levels of an FRF table (in its reference unit)."""
    if table is None:
        return {}
    out: dict[tuple[str, str], list[float]] = {}
    for (response, inp), rows in table.groupby([table["response_dof"].astype(str), table["input_dof"].astype(str)],
                                               sort=False):
        out[(response, inp)] = sorted(float(level) for level in rows["force_level_n"].unique())
    return out


def overview_fields(run: ArchivedRun) -> dict[str, str]:
    """What a run is, one line each: study, chain steps, FE model, parameters, targets,
    measured curves and force levels, identified parameters, updating runs, predicted models."""
    text = archived_study_text(run.folder)
    study = tomllib.loads(text) if text is not None else {}
    out = {"study": run.study, "chain steps": ", ".join(steps_present(run)) or "none"}
    adapter = run.manifest.get("adapters", {}).get("updating")
    if adapter:
        out["FE model"] = " ".join(str(part) for part in (adapter.get("kind"), adapter.get("model")) if part)
    parameters = study.get("parameters", [])
    if isinstance(parameters, list) and parameters:
        out["parameters"] = ", ".join(f"{p.get('name')} ({p.get('unit')})" if p.get("unit") else str(p.get("name"))
                                      for p in parameters if isinstance(p, dict))
    targets = run.table("targets")
    if targets is not None and len(targets):
        out["targets"] = ", ".join(f"{row.mode} {row.frequency_hz:.6g} Hz" for row in targets.itertuples())
    measured = curves(run.table("measured"))
    if measured:
        out["measured curves (response/input)"] = ", ".join(f"{r}/{i}" for r, i in measured)
        out[f"force levels ({level_unit(run)})"] = _numbers(sorted({level for levels in measured.values()
                                                                    for level in levels}))
    identified = run.table("identification")
    if identified is not None and len(identified):
        out["identified"] = ", ".join(map(str, identified["parameter"]))
    runs, failures = run.table("runs"), run.table("failures")
    if runs is not None or failures is not None:
        n_failed = 0 if failures is None else len(failures)
        out["updating runs"] = f"{0 if runs is None else len(runs)}" + (f" ({n_failed} failed)" if n_failed else "")
    predictions = run.table("predictions")
    if predictions is not None and len(predictions):
        out["predicted models"] = ", ".join(map(str, predictions["model"].unique()))
    return out


def compare_overview(a: ArchivedRun, b: ArchivedRun) -> list[FieldChange]:
    """What the two runs are, side by side (section ``overview``)."""
    return _compare_section("overview", overview_fields(a), overview_fields(b), 0.0, 0.0)


def same_study(a: ArchivedRun, b: ArchivedRun) -> bool:
    return a.study == b.study


def changed(rows: Iterable[FieldChange]) -> list[FieldChange]:
    return [row for row in rows if row.status != "same"]


def format_value(value: Any, limit: int = 60) -> str:
    """A field value as a short string (at most ``limit`` characters): ``v ± s`` for an
    :class:`Estimate`, a SHA-256 by its first 12 digits."""
    if isinstance(value, Estimate):
        return f"{value.value:.6g}" + (f" ± {value.std:.2g}" if value.std is not None else "")
    if isinstance(value, float):
        return f"{value:.6g}"
    if value is None:
        return "–"
    text = str(value)
    if len(text) == 64 and all(c in "0123456789abcdef" for c in text):  # a SHA-256
        return text[:12] + "…"
    return text if len(text) <= limit else text[:limit - 1] + "…"


def change_table(rows: Iterable[FieldChange], limit: int = 60) -> pd.DataFrame:
    """The rows as a table of strings (section, field, A, B, status, Δ/σ); values cut at ``limit`` characters."""
    return pd.DataFrame([{"section": r.section, "field": r.field, "A": format_value(r.a, limit),
                          "B": format_value(r.b, limit),
                          "status": r.status, "Δ/σ": "" if r.sigmas is None else f"{r.sigmas:.2g}"} for r in rows],
                        columns=["section", "field", "A", "B", "status", "Δ/σ"])


def best_prediction(run: ArchivedRun) -> SimpleNamespace | None:
    """The prediction of the updated model the study ranked best (its archived ranking:
    :func:`~nlupdate.reporting.catalogue.best_candidate`) as ``name``, ``table`` (predicted
    FRFs) and ``correlation``; None when the study ranked no updated model or did not predict it."""
    predictions, correlation, model = run.table("predictions"), run.table("correlation"), best_candidate(run)
    if predictions is None or correlation is None or model is None or not (predictions["model"] == model).any():
        return None
    return SimpleNamespace(name=model, table=predictions[predictions["model"] == model],
                           correlation=correlation[correlation["model"] == model])


@dataclass(frozen=True)
class PlotScope:
    """What both runs' predictions can be drawn against: one (response, input) curve at
    the force levels both runs measured and predicted; ``pair`` None when there is none,
    ``note`` saying what is drawn or why nothing is."""

    pair: tuple[str, str] | None
    levels: tuple[float, ...]
    note: str


def _common_levels(*level_lists: Iterable[float]) -> tuple[float, ...]:
    first, *others = [list(levels) for levels in level_lists]
    return tuple(level for level in first
                 if all(any(math.isclose(level, other, rel_tol=1e-9) for other in levels) for levels in others))


def _curve_list(curves_of: dict[tuple[str, str], list[float]], unit: str) -> str:
    return "; ".join(f"{r}/{i} at {_numbers(levels)} {unit}" for (r, i), levels in curves_of.items()) or "none"


def plot_scope(a: ArchivedRun, b: ArchivedRun, pa: SimpleNamespace | None,
               pb: SimpleNamespace | None) -> PlotScope:
    """The curve and force levels both runs' best predictions can be drawn at, against A's
    measurement (and B's)."""
    if pa is None or pb is None:
        return PlotScope(None, (), f"run {'A' if pa is None else 'B'} has no prediction of the updated model its "
                                   f"study ranked best")
    measured_a, measured_b = curves(a.table("measured")), curves(b.table("measured"))
    if not measured_a:
        return PlotScope(None, (), "run A has no measured data")
    unit, unit_b = level_unit(a), level_unit(b)
    if unit != unit_b:
        return PlotScope(None, (), f"A's levels are in {unit}, B's in {unit_b}: no level is in both")
    predicted_a, predicted_b = curves(pa.table), curves(pb.table)
    pairs = [pair for pair in predicted_a if pair in predicted_b and pair in measured_a
             and (not measured_b or pair in measured_b)]
    if not pairs:
        return PlotScope(None, (), f"the runs measured and predicted no curve in common "
                                   f"(A: {_curve_list(predicted_a, unit)}; B: {_curve_list(predicted_b, unit)})")
    best = None
    for pair in pairs:
        sides = [predicted_a[pair], predicted_b[pair], measured_a[pair]] + ([measured_b[pair]] if measured_b else [])
        levels = _common_levels(*sides)
        if levels:
            best = (pair, levels)
            break
    if best is None:
        pair = pairs[0]
        return PlotScope(None, (), f"the runs have no force level in common on {pair[0]}/{pair[1]} "
                                   f"(A: {_numbers(predicted_a[pair])} {unit}; "
                                   f"B: {_numbers(predicted_b[pair])} {unit})")
    pair, levels = best
    left_out = sorted({level for level in predicted_a[pair] + predicted_b[pair]
                       if not any(math.isclose(level, kept, rel_tol=1e-9) for kept in levels)})
    note = f"response {pair[0]}, input {pair[1]} at {_numbers(levels)} {unit}"
    if left_out:
        note += f" (the force levels both runs have; {_numbers(left_out)} {unit} left out)"
    return PlotScope(pair, levels, note)


def _at_levels(table: pd.DataFrame, pair: tuple[str, str], levels: tuple[float, ...]) -> pd.DataFrame:
    force = table["force_level_n"].to_numpy(dtype=float)
    keep = np.zeros(len(table), dtype=bool)
    for level in levels:
        keep |= np.isclose(force, level, rtol=1e-9, atol=0.0)
    keep &= (table["response_dof"].astype(str).to_numpy() == pair[0]) & (table["input_dof"].astype(str).to_numpy() == pair[1])
    return table[keep]


def plot_comparison(a: ArchivedRun, b: ArchivedRun, path: Path) -> tuple[Path | None, str]:
    """Both runs' best predictions against the measurements (B's measurement drawn too when
    its data differ), at the curve and force levels both runs have (:func:`plot_scope`).
    Returns (the plot, or None when there is nothing to draw together; what is drawn or why not)."""
    pa, pb = best_prediction(a), best_prediction(b)
    scope = plot_scope(a, b, pa, pb)
    if scope.pair is None:
        return None, scope.note
    measured_a, measured_b = a.table("measured"), b.table("measured")
    pa.table, pb.table = _at_levels(pa.table, scope.pair, scope.levels), _at_levels(pb.table, scope.pair, scope.levels)
    pa.name, pb.name = f"A {a.run_id}: {pa.name} (ranked best)", f"B {b.run_id}: {pb.name} (ranked best)"
    same_data = measured_b is not None and table_hash(measured_a) == table_hash(measured_b)
    other = None if same_data or measured_b is None else ("measured (B)", measured_b)
    styles = [dict(color="C0", lw=1.4), dict(color="C3", lw=1.1, ls="--")]
    title = f"{a.study}: run A vs run B" if same_study(a, b) else f"A {a.study} vs B {b.study}"
    figure = predictions_figure(measured_a, [pa, pb], *scope.pair, title, styles, other, short_names=["A", "B"])
    return save_figure(figure, path, dpi=110), f"{scope.note}; each run's updated model its study ranked best"
