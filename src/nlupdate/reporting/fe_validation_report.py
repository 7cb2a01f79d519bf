"""The report's section on ``[fe_validation]``: the FE modes before and after updating, the
joint identified per bolt, and every forced run as the initial and the updated model predict
it, beside the test's own repeatability. Renders the step's result; computes only differences."""
from __future__ import annotations

from typing import Callable

import pandas as pd

from nlupdate.reporting.markdown import markdown_table as _markdown
from nlupdate.reporting.markdown import number as _g


def modes_table(found) -> pd.DataFrame:
    """Paired modes: measured frequency, each model's frequency and its error (%)."""
    modes = found.modes.dropna(subset=["frequency_hz_measured"])
    rows = []
    for mode, pair in modes.groupby("mode", sort=True):
        row = {"FE mode": str(mode), "measured (Hz)": _g(pair.frequency_hz_measured.iloc[0], 6)}
        for _, model in pair.iterrows():
            error = 100 * (model.frequency_hz / model.frequency_hz_measured - 1)
            row[f"{model.model} (Hz)"] = _g(model.frequency_hz, 6)
            row[f"{model.model} error (%)"] = f"{error:+.3f}"
        rows.append(row)
    return pd.DataFrame(rows)


def runs_table(found) -> pd.DataFrame:
    """One row per run: the measured resonance, damping and peak, each model's error beside it
    (initial / updated): resonance in Hz, damping ratio and peak relative (%)."""
    table = found.table
    by_model = {model: rows.set_index("run") for model, rows in table.groupby("model", sort=False)}
    models = [m for m in ("initial", "updated") if m in by_model]
    first = by_model[models[0]]

    def errors(run: str, quantity: str, how: Callable[[float, float], float], fmt: str) -> str:
        return " / ".join(fmt.format(how(by_model[m].at[run, f"{quantity}_measured"],
                                         by_model[m].at[run, f"{quantity}_predicted"])) for m in models)

    relative = lambda measured, predicted: 100 * (predicted / measured - 1)  # noqa: E731
    rows = []
    for run, row in first.iterrows():
        unit = "N" if row.control == "force" else "m"
        rows.append({
            "run": run.replace("FRdata.", ""), "level": f"{_g(row.level, 3)} {unit}",
            "f meas. (Hz)": _g(row.resonance_hz_measured, 6),
            f"f error {' / '.join(models)} (Hz)": errors(run, "resonance_hz", lambda m, p: p - m, "{:+.3f}"),
            "ζ meas. (%)": _g(100 * row.damping_ratio_measured, 3),
            f"ζ error {' / '.join(models)} (%)": errors(run, "damping_ratio", relative, "{:+.0f}"),
            "peak meas. (m/N)": _g(row.peak_measured, 3),
            f"peak error {' / '.join(models)} (%)": errors(run, "peak", relative, "{:+.0f}"),
        })
    return pd.DataFrame(rows)


def joint_line(found) -> str:
    """The identified joint, the damping it started from and the shaker's mass, in one sentence."""
    joint, fit = found.joint, found.fit
    chi = "" if "chi" not in joint else \
        f", χ = {joint['chi']:.3f}, β = 0" if abs(joint["chi"]) >= 5e-4 else ", χ = 0 (its upper bound), β = 0"
    return (f"Joint: one {found.element} element per bolt along the interface (stuck stiffness: the FE model's `kt`), "
            f"identified on the updated model from the force-controlled runs: F_S = {_g(joint['slip_force'])} N{chi}, "
            f"linear damping ratio with the shaker attached {_g(100 * joint['damping_ratio_forced'], 3)} % (started "
            f"from {_g(100 * found.damping_ratio, 3)} %: {found.damping_source}); shaker mass at the drive point "
            f"{_g(1e3 * found.shaker_mass_kg, 3)} g; fit rms {fit['rms_residual']:.3f} over "
            f"{len(fit['residuals'])} residuals after {fit['evaluations']} evaluations ({fit['status']}).")


def fe_validation_section(found) -> list[str]:
    """The section's markdown lines."""
    repeat = found.repeatability
    lines = ["## FE model against every forced run", "",
             "The initial and the updated FE model (reduced at the bolts), each with the joint identified per bolt, "
             "predicting every forced run as the test ran it (force control: the force achieved on each line; "
             "response control: the displacement achieved on each line). Resonance, damping ratio (circle fit) "
             "and peak |H| by one estimator for the measured and predicted curves.", "",
             _markdown(modes_table(found)), "", joint_line(found), "",
             f"The test's own scatter over its {repeat.levels} force-controlled runs (1σ about a line in log "
             f"amplitude): resonance {_g(repeat.resonance_hz, 3)} Hz, damping ratio "
             f"{_g(100 * repeat.damping_ratio, 3)} % (points) — errors within these are within the test's "
             "repeatability.", "",
             _markdown(runs_table(found)), "", "![FE model against every forced run](plots/fe_validation.png)", "",
             f"Tables `fe_modes` and `validation`; `fe_validation.json` (the joint and the fit). The step took "
             f"{_g(found.wall_time_s, 3)} s wall, {_g(found.cpu_time_s, 3)} s CPU.", ""]
    return lines


def fe_validation_summary(found) -> list[str]:
    """The summary's lines: per model how many runs miss their resonance beyond the test's
    repeatability (bold when any does: a model that cannot be trusted says so first), the
    largest resonance error and the median damping error."""
    lines = []
    for model, errors in found.errors.items():
        verdict = (f"{errors.beyond_repeatability} of {errors.runs} forced runs miss their resonance by more than "
                   f"{errors.factor:g}× the test's repeatability ({_g(errors.repeatability_hz, 3)} Hz)")
        if errors.beyond_repeatability:
            verdict = f"**{verdict}: the model does not predict them**"
        lines.append(f"* FE validation, {model} model: {verdict}; largest resonance error "
                     f"{errors.largest_resonance_error_hz:.3f} Hz, median damping error "
                     f"{errors.median_damping_error_percent:.0f} %")
    return lines
