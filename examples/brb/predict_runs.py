"""The Brake–Reuss beam's joint, identified from the force-controlled runs, and every forced run predicted.

    python examples/brb/predict_runs.py DIR      # DIR as given to `nlupdate run examples/brb/brb.toml --out DIR`

Reads the study's archive (the newest under DIR; its ``study.toml`` and the updated parameters in
``tables/runs.parquet``), builds the reduced nonlinear model — the Craig–Bampton model of
:class:`nlupdate.fe.adapters.calculix_brb.BRBAdapter` with the joint's linear springs and one
Iwan element per bolt along x between the bolt's two reference points — for the initial and
the updated FE parameters, identifies the Iwan elements' slip force and exponent χ from the
four force-controlled runs (on the updated model), and predicts every force- and
response-controlled run of ``tests/data/brb/ForcedFrequencyResponses.mat`` with both models.
Writes into DIR:

* ``tables/fe_modes.parquet``: ``model`` (initial | updated), ``mode``, ``frequency_hz``,
  ``frequency_hz_measured`` (the impact record's modes where paired, else NaN);
* ``tables/validation.parquet``: one row per run and model: ``run``, ``control`` (force |
  response), ``level`` (the run's mean force in N, or its held displacement amplitude at
  acc3 in m), ``model``, and the measured and predicted ``resonance_hz``, ``damping_ratio``
  (half-power) and ``peak`` (|H| in m/N), all by
  :func:`nlupdate.core.validation.resonance.resonance` on the measured frequency lines;
* ``brb_joint.json``: the identified joint and the fit.

Each line of a run is predicted as the test ran it: at the force the shaker achieved on that
line (force control) or at the held amplitude (response control), by the single-harmonic
balance of the whole reduced model (:func:`harmonic_response`).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
import tomllib
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import scipy.optimize

from nlupdate.core.identification.response_controlled import read_response_controlled
from nlupdate.core.identification.impact import fit_linear_limit
from nlupdate.core.measurement.frf_files import read_frf_table
from nlupdate.core.measurement.units import ReadOptions
from nlupdate.core.model.model_file import system_from_dict
from nlupdate.core.model.system import CondensedProblem, newton_fixed_frequency
from nlupdate.core.validation.resonance import resonance
from nlupdate.fe.adapters.calculix_brb import BOLTS, BRBAdapter, from_options, joint_stiffness

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "tests" / "data" / "brb"
DRIVE = "acc3:uy"
#: The impact record's modes (Hz) and mode 1's damping ratio when HammerImpact.mat is not in DATA
#: (the values brb.toml quotes: each mode's linear limit, LSCE).
IMPACT_FALLBACK = {"frequencies_hz": (80.569, 297.683), "damping_ratio": 0.001435}


def impact_damping(folder: Path) -> tuple[float, str]:
    """Mode 1's linear damping ratio from the impact record: the linear limit of acc3 in 72–88 Hz
    (:func:`nlupdate.core.identification.impact.fit_linear_limit`)."""
    for name in ("HammerImpact_1600Hz.mat", "HammerImpact.mat"):
        path = folder / name
        if path.is_file():
            import scipy.io

            record = scipy.io.loadmat(path, squeeze_me=True, struct_as_record=False)["HIdata"]
            limit = fit_linear_limit(np.asarray(record.time, float), {"acc3": np.asarray(record.acc3, float)},
                                     band_hz=(72.0, 88.0))
            return float(limit.damping_ratio), f"{name}, acc3, linear limit (LSCE)"
    return IMPACT_FALLBACK["damping_ratio"], "brb.toml's value (no impact record in the data folder)"


def nonlinear_model(adapter: BRBAdapter, parameters: dict, damping_ratio: float, joint: dict, shaker_mass: float = 0.0):
    """The reduced model with the joint's linear springs (y, z, rotations), structural damping
    η = 2ζ, the shaker's moving mass (kg) at the drive point and one Iwan element per bolt
    along x (stuck stiffness ``kt``)."""
    deck, springs = adapter.split(parameters)
    reduced = adapter.reduced(deck)
    mass = reduced.mass.copy()
    drive = reduced.index(DRIVE)
    mass[drive, drive] += shaker_mass
    stiffness = reduced.stiffness + joint_stiffness(reduced, springs["kt"], springs["kn"], springs["kr"],
                                                    tangential_x=False)
    elements = [{"type": "iwan", "dofs": [f"{bolt}_a:ux", f"{bolt}_b:ux"], "kt": springs["kt"],
                 "slip_force": joint["slip_force"], "chi": joint["chi"], "beta": joint["beta"]} for bolt in BOLTS]
    return system_from_dict({"model": {"kind": "lumped", "mass": mass.tolist(), "stiffness": stiffness.tolist(),
                                       "loss_factor": 2 * damping_ratio, "dof_names": list(reduced.dof_names)},
                             "nonlinear": elements}, "BRB reduced model")


def harmonic_response(system, frequency_hz: np.ndarray, force_n: np.ndarray | None = None, held_m: float | None = None,
                      x_scale: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """First-harmonic response at the drive point, ``(H (m/N), F (N))`` per line.

    Force control: ``force_n`` per line. Response control: the force that holds ``|X_drive| = held_m``
    (a secant iteration on log F). Each point is the single-harmonic balance of the whole reduced
    model condensed to the joint coordinates (:class:`~nlupdate.core.model.system.CondensedProblem`,
    Newton from the previous line's solution)."""
    drive = system.model.dof_names.index(DRIVE)
    h_out = np.empty(len(frequency_hz), dtype=complex)
    f_out = np.empty(len(frequency_hz))
    y, force = None, None
    for line, frequency in enumerate(frequency_hz):
        omega = 2 * np.pi * frequency

        def solve(amplitude: float, start):
            problem = CondensedProblem(system, {drive: amplitude}, x_scale)
            guesses = ([start] if start is not None else []) + list(problem.initial_guesses(omega))
            for guess in guesses:
                solution, converged, _ = newton_fixed_frequency(problem, omega, guess, tol=1e-10, max_iter=80)
                if converged:
                    return solution, complex(problem.response_at(omega, problem.to_complex(solution), [drive])[0, 0])
            raise RuntimeError(f"harmonic balance at {frequency:.3f} Hz, force {amplitude:.4g} N did not converge")

        if held_m is None:
            y, x = solve(float(force_n[line]), y)
            force = float(force_n[line])
        else:
            force = force or held_m / abs(system.model.receptance(np.array([omega]), [drive], [drive])[0, 0, 0])
            y, x = solve(force, y)
            log_f, log_x = [np.log(force)], [np.log(abs(x))]
            for _ in range(30):
                if abs(log_x[-1] - np.log(held_m)) < 1e-6:
                    break
                slope = 1.0 if len(log_f) < 2 else (log_x[-1] - log_x[-2]) / (log_f[-1] - log_f[-2])
                force = float(np.exp(log_f[-1] + (np.log(held_m) - log_x[-1]) / max(slope, 0.05)))
                y, x = solve(force, y)
                log_f.append(np.log(force))
                log_x.append(np.log(abs(x)))
            else:
                raise RuntimeError(f"no force holds {held_m:.4g} m at {frequency:.3f} Hz")
        h_out[line], f_out[line] = x / force, force
    return h_out, f_out


def features(frequency_hz: np.ndarray, h: np.ndarray) -> dict[str, float]:
    r = resonance(frequency_hz, h)
    return {"resonance_hz": r.resonance_hz, "damping_ratio": r.damping_ratio, "peak": r.peak_abs}


def measured_runs(path: Path) -> list[dict]:
    """Every forced run: name, control, level, frequency lines, receptance (m/N), line forces (N)."""
    options = ReadOptions(coordinates={str(path): ("acc3:-y", "acc3:y")})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        table = read_frf_table(path, options=options)
    runs = []
    for number, (level, lines) in enumerate(table.groupby("force_level_n", sort=True), start=1):
        runs.append({"run": f"FRdata.ForceControl({number})", "control": "force", "level": float(level),
                     "frequency_hz": lines.frequency_hz.to_numpy(), "h": (lines.h_real + 1j * lines.h_imag).to_numpy(),
                     "force_n": lines.level_achieved.to_numpy()})
    for held in read_response_controlled(path, options):
        runs.append({"run": held.name, "control": "response", "level": held.held_m, "frequency_hz": held.frequency_hz,
                     "h": held.h, "force_n": held.force_n})
    return runs


def predict(system, run: dict, margin_hz: float = 0.0) -> dict[str, float]:
    """The run's resonance, damping and peak as the model predicts them on the run's lines, the
    grid extended by ``margin_hz`` at each end at the same spacing (the force of the end lines held)."""
    frequency = run["frequency_hz"]
    step = float(np.median(np.diff(frequency)))
    extra = int(round(margin_hz / step))
    below, above = frequency[0] - step * np.arange(extra, 0, -1), frequency[-1] + step * np.arange(1, extra + 1)
    grid = np.concatenate([below, frequency, above])
    if run["control"] == "force":
        h, _ = harmonic_response(system, grid, force_n=np.interp(grid, frequency, run["force_n"]))
    else:
        h, _ = harmonic_response(system, grid, held_m=run["level"])
    return features(grid, h)


def shaker_mass(adapter: BRBAdapter, parameters: dict, forced_low: dict, impact_hz: float) -> float:
    """The shaker's moving mass (kg) at the drive point that moves mode 1 from the impact record's
    frequency to the lowest force-controlled run's resonance: first order in the mass,
    ``(f_impact/f_forced)² − 1 = m φ²`` with φ the FE model's mass-normalised shape at acc3."""
    result = adapter.evaluate(parameters)
    phi = result.mode_shapes[result.coordinates.index(DRIVE), 0]
    forced_hz = features(forced_low["frequency_hz"], forced_low["h"])["resonance_hz"]
    return max(((impact_hz / forced_hz) ** 2 - 1) / phi**2, 0.0)


def identify_joint(adapter, parameters, damping_ratio, runs, mass: float,
                   max_evaluations: int = 60) -> tuple[dict, dict]:
    """Slip force F_S (N) and χ of the three identical Iwan elements (β = 0), and the linear damping
    ratio with the shaker attached, from the force-controlled runs: least squares of the relative
    peak and half-power damping errors of every run."""
    forced = [run for run in runs if run["control"] == "force"]
    measured = [features(run["frequency_hz"], run["h"]) for run in forced]

    def residuals(x):
        joint = {"slip_force": float(np.exp(x[0])), "chi": float(x[1]), "beta": 0.0}
        system = nonlinear_model(adapter, parameters, float(np.exp(x[2])), joint, mass)
        out = []
        for run, m in zip(forced, measured):
            p = predict(system, run)
            out += [np.log(p["peak"] / m["peak"]), (p["damping_ratio"] - m["damping_ratio"]) / m["damping_ratio"]]
        return np.nan_to_num(np.array(out), nan=10.0)

    fit = scipy.optimize.least_squares(residuals, x0=[np.log(1000.0), -0.3, np.log(damping_ratio)],
                                       bounds=([np.log(10.0), -0.95, np.log(1e-4)], [np.log(1e6), 0.0, np.log(0.05)]),
                                       x_scale=[1.0, 0.2, 0.3], diff_step=[1e-3, 1e-2, 1e-3], max_nfev=max_evaluations)
    joint = {"slip_force": float(np.exp(fit.x[0])), "chi": float(fit.x[1]), "beta": 0.0,
             "damping_ratio_forced": float(np.exp(fit.x[2]))}
    return joint, {"rms_residual": float(np.sqrt(np.mean(fit.fun**2))), "residuals": fit.fun.tolist(),
                   "evaluations": int(fit.nfev), "status": fit.message}


def run(archive: Path, data: Path = DATA, max_evaluations: int = 60) -> dict:
    started, cpu = time.perf_counter(), time.process_time()
    study = tomllib.loads((archive / "study.toml").read_text())
    adapter = from_options(dict(study["adapter"].get("options", {})))
    initial = {p["name"]: float(p["start"]) for p in study["parameters"]}
    best = pd.read_parquet(archive / "tables" / "runs.parquet")
    best = best[best.converged].iloc[0] if best.converged.any() else best.iloc[0]
    updated = {name: float(best[f"p:{name}"]) for name in initial}
    targets = study["targets"]
    pairing = dict(zip(targets["model_modes"], targets["frequencies_hz"]))

    modes = []
    for label, parameters in (("initial", initial), ("updated", updated)):
        result = adapter.evaluate(parameters)
        for mode, frequency in enumerate(result.natural_frequencies_hz, start=1):
            modes.append({"model": label, "mode": mode, "frequency_hz": float(frequency),
                          "frequency_hz_measured": float(pairing.get(mode, np.nan))})
    damping_ratio, damping_source = impact_damping(data)
    runs = measured_runs(data / "ForcedFrequencyResponses.mat")
    impact_hz = float(pairing[min(pairing)])
    mass = shaker_mass(adapter, updated, runs[0], impact_hz)
    joint, fit = identify_joint(adapter, updated, damping_ratio, runs, mass, max_evaluations)

    rows = []
    for label, parameters in (("initial", initial), ("updated", updated)):
        system = nonlinear_model(adapter, parameters, joint["damping_ratio_forced"], joint, mass)
        for test in runs:
            measured, predicted = features(test["frequency_hz"], test["h"]), predict(system, test, margin_hz=2.5)
            rows.append({"run": test["run"], "control": test["control"], "level": test["level"], "model": label,
                         **{f"{q}_measured": measured[q] for q in measured},
                         **{f"{q}_predicted": predicted[q] for q in predicted}})
    validation = pd.DataFrame(rows)
    (archive / "tables").mkdir(exist_ok=True)
    pd.DataFrame(modes).to_parquet(archive / "tables" / "fe_modes.parquet", index=False)
    validation.to_parquet(archive / "tables" / "validation.parquet", index=False)
    record = {"joint": {"type": "iwan", "per_bolt": True, "bolts": list(BOLTS), **joint}, "fit": fit,
              "linear_damping_ratio": damping_ratio, "linear_damping_source": damping_source, "shaker_mass_kg": mass,
              "initial": initial, "updated": updated,
              "wall_time_s": time.perf_counter() - started, "cpu_time_s": time.process_time() - cpu}
    (archive / "brb_joint.json").write_text(json.dumps(record, indent=2))
    return {"modes": pd.DataFrame(modes), "validation": validation, **record}


def find_archive(folder: Path) -> Path:
    """``folder`` itself when it is an archive (`nlupdate update --out`), else the newest archive
    `nlupdate run --out` wrote under it (``<folder>/<study>/<time stamp>``)."""
    if (folder / "study.toml").is_file():
        return folder
    found = sorted(folder.glob("*/*/study.toml"), key=lambda path: path.parent.name)
    return found[-1].parent if found else folder


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("archive", type=Path, help="the archive of `nlupdate run examples/brb/brb.toml --out DIR`")
    parser.add_argument("--data", type=Path, default=DATA,
                        help="folder of ForcedFrequencyResponses.mat (and HammerImpact.mat)")
    parser.add_argument("--fit-evaluations", type=int, default=60,
                        help="limit on the joint fit's model evaluations (default 60)")
    args = parser.parse_args(argv)
    args.archive = find_archive(args.archive)
    if not (args.archive / "study.toml").is_file() or not (args.archive / "tables" / "runs.parquet").is_file():
        print(f"predict_runs.py: error: {args.archive}: not the archive of an updating study (no study.toml or "
              "tables/runs.parquet); run `nlupdate run examples/brb/brb.toml --out DIR` first", file=sys.stderr)
        return 2
    if args.fit_evaluations < 1:
        print(f"predict_runs.py: error: --fit-evaluations must be ≥ 1, got {args.fit_evaluations}", file=sys.stderr)
        return 2
    result = run(args.archive, args.data, args.fit_evaluations)
    pd.set_option("display.width", 200)
    print(result["modes"].to_string(index=False))
    j = result["joint"]
    print(f"\njoint: one Iwan element per bolt, F_S = {j['slip_force']:.4g} N, chi = {j['chi']:.3f}, beta = 0; linear "
          f"damping ratio with the shaker {j['damping_ratio_forced']:.5f} "
          f"(impact record: {result['linear_damping_ratio']:.5f}, "
          f"{result['linear_damping_source']}); shaker mass at acc3 {1e3 * result['shaker_mass_kg']:.1f} g; "
          f"fit rms {result['fit']['rms_residual']:.3f} over {len(result['fit']['residuals'])} residuals")
    v = result["validation"]
    print(v.to_string(index=False, float_format=lambda x: f"{x:.5g}"))
    print(f"\n{result['wall_time_s']:.1f} s wall, {result['cpu_time_s']:.1f} s CPU")
    return 0


if __name__ == "__main__":
    sys.exit(main())
