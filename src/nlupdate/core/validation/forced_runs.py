"""Every forced run of a stepped-sine test against a nonlinear model, run as the test ran it.

A run is force-controlled (the shaker's force set per level; the force it achieved on each
line is kept) or response-controlled (the drive point's response held; ``level`` the median
displacement amplitude, ``held_line_m`` the displacement achieved on each line, the
reader's ``HeldRun.held_on_lines`` (:mod:`~nlupdate.core.identification.response_controlled`):
a run holding acceleration A holds A/Ω², 3.8–4.0 % more on the BRB's lowest lines than on
its highest). The model answers each line as the test asked: at the achieved force (force
control) or at the force that holds the line's achieved displacement (response control), by the
single-harmonic balance of the whole system condensed to its nonlinear coordinates
(:class:`~nlupdate.core.model.system.CondensedProblem`, Newton from the previous line's
solution). Measured and predicted curves go through the same estimator
(:func:`nlupdate.core.validation.resonance.resonance`): resonance (Hz), damping ratio (circle
fit) and peak |H| (m/N).
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.response_controlled import read_response_controlled
from nlupdate.core.measurement.frf_files import read_frf_table
from nlupdate.core.measurement.units import ReadOptions
from nlupdate.core.model.system import CondensedProblem, NonlinearSystem, newton_fixed_frequency
from nlupdate.core.validation.held_out import Repeatability, repeatability
from nlupdate.core.validation.resonance import resonance


@dataclass(frozen=True, eq=False)
class ForcedRun:
    """One measured run: ``run`` (its name in the file), ``control`` (force | response),
    ``level`` (the force level in N, or the median held displacement amplitude in m), the lines
    ``frequency_hz`` (Hz), the receptance ``h`` (m/N), the force on each line ``force_n`` (N) and,
    for a response-controlled run, the displacement it achieved on each line ``held_line_m`` (m;
    None: ``level`` on every line)."""

    run: str
    control: str
    level: float
    frequency_hz: NDArray[np.float64]
    h: NDArray[np.complex128]
    force_n: NDArray[np.float64]
    held_line_m: NDArray[np.float64] | None = None


def read_forced_runs(path: str | Path, coordinates: tuple[str, str]) -> list[ForcedRun]:
    """Every run of a MATLAB stepped-sine file: the force-controlled levels (ascending), then the
    response-controlled runs (lowest held amplitude first). ``coordinates``: the (response,
    input) names of the file's curve, as ``--coordinates`` takes them."""
    options = ReadOptions(coordinates={str(path): tuple(coordinates)})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the reader's notes on the file's units and fields
        table = read_frf_table(path, options=options)
    runs = []
    for number, (level, lines) in enumerate(table.groupby("force_level_n", sort=True), start=1):
        lines = lines.sort_values("frequency_hz")
        runs.append(ForcedRun(f"FRdata.ForceControl({number})", "force", float(level), lines.frequency_hz.to_numpy(),
                              (lines.h_real + 1j * lines.h_imag).to_numpy(), lines.level_achieved.to_numpy()))
    for held in read_response_controlled(path, options):
        runs.append(ForcedRun(held.name, "response", float(held.held_m), np.asarray(held.frequency_hz, float),
                              np.asarray(held.h, complex), np.asarray(held.force_n, float), held.held_on_lines))
    return runs


def features(frequency_hz: NDArray, h: NDArray) -> dict[str, float]:
    """``resonance_hz`` (Hz), ``damping_ratio`` (circle fit) and ``peak`` (|H|) of one curve."""
    found = resonance(frequency_hz, h)
    return {"resonance_hz": found.resonance_hz, "damping_ratio": found.damping_ratio, "peak": found.peak_abs}


def runs_repeatability(runs: list[ForcedRun]) -> Repeatability:
    """The test's own scatter (1σ) of resonance and damping ratio over its force-controlled runs
    (:func:`nlupdate.core.validation.held_out.repeatability`), each run placed at the response
    it reached at resonance (:func:`~nlupdate.core.validation.held_out.resonance_amplitudes`:
    the peak |H| times the force the run achieved there — its level on lines recording none —
    not its nominal level)."""
    forced = [run for run in runs if run.control == "force"]
    levels = FRFLevels("response", "input", np.array([run.level for run in forced]),
                       tuple(run.frequency_hz for run in forced), tuple(run.h for run in forced),
                       achieved=tuple(np.where(np.isfinite(run.force_n), run.force_n, run.level) for run in forced))
    return repeatability(levels)


@dataclass(frozen=True)
class RunErrors:
    """One model's errors over the forced runs: the largest |resonance error| (Hz), the median
    |damping-ratio error| (%), and how many of ``runs`` miss their resonance by more than
    ``factor`` × the test's repeatability (1σ, Hz)."""

    runs: int
    largest_resonance_error_hz: float
    median_damping_error_percent: float
    beyond_repeatability: int
    repeatability_hz: float
    factor: float


def run_errors(table: pd.DataFrame, repeatability_hz: float, factor: float = 2.0) -> dict[str, RunErrors]:
    """Per ``model`` of a validation table (``resonance_hz_*``, ``damping_ratio_*`` columns,
    ``_measured``/``_predicted``) its :class:`RunErrors`."""
    out = {}
    for model, rows in table.groupby("model", sort=False):
        resonance = (rows.resonance_hz_predicted - rows.resonance_hz_measured).abs()
        damping = (100 * (rows.damping_ratio_predicted / rows.damping_ratio_measured - 1)).abs()
        out[str(model)] = RunErrors(len(rows), float(resonance.max()), float(damping.median()),
                                    int((resonance > factor * repeatability_hz).sum()), repeatability_hz, factor)
    return out


def harmonic_response(system: NonlinearSystem, drive_dof: str, frequency_hz: NDArray,
                      force_n: NDArray | None = None, held_m: float | NDArray | None = None,
                      x_scale: float = 1e-6) -> tuple[NDArray[np.complex128], NDArray[np.float64]]:
    """First-harmonic receptance at ``drive_dof`` on each line, ``(H (m/N), F (N))``.

    Force control: ``force_n`` per line. Response control: the force that holds
    ``|X_drive| = held_m`` (m; one value, or one per line) (a secant iteration on log F, to 1e-6
    in log amplitude). Raises
    ``RuntimeError`` naming the line when the balance or the held amplitude is not found."""
    drive = system.model.dof_names.index(drive_dof)
    h_out = np.empty(len(frequency_hz), dtype=complex)
    f_out = np.empty(len(frequency_hz))
    y, force = None, None
    held_lines = None if held_m is None else np.broadcast_to(np.asarray(held_m, float), np.shape(frequency_hz))
    for line, frequency in enumerate(frequency_hz):
        omega = 2 * np.pi * frequency

        def solve(amplitude: float, start):
            problem = CondensedProblem(system, {drive: amplitude}, x_scale)
            guesses = ([start] if start is not None else []) + list(problem.initial_guesses(omega))
            for guess in guesses:
                # a guess at zero joint amplitude overflows in a hysteretic law's derivative (Iwan:
                # 1/a); Newton then fails from it and the next guess is tried
                with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
                    solution, converged, _ = newton_fixed_frequency(problem, omega, guess, tol=1e-10, max_iter=80)
                if converged:
                    return solution, complex(problem.response_at(omega, problem.to_complex(solution), [drive])[0, 0])
            raise RuntimeError(f"harmonic balance at {frequency:.3f} Hz, force {amplitude:.4g} N did not converge")

        if held_lines is None:
            force = float(force_n[line])
            y, x = solve(force, y)
        else:
            held = float(held_lines[line])
            force = force or held / abs(system.model.receptance(np.array([omega]), [drive], [drive])[0, 0, 0])
            y, x = solve(force, y)
            log_f, log_x = [np.log(force)], [np.log(abs(x))]
            for _ in range(30):
                if abs(log_x[-1] - np.log(held)) < 1e-6:
                    break
                slope = 1.0 if len(log_f) < 2 else (log_x[-1] - log_x[-2]) / (log_f[-1] - log_f[-2])
                force = float(np.exp(log_f[-1] + (np.log(held) - log_x[-1]) / max(slope, 0.05)))
                y, x = solve(force, y)
                log_f.append(np.log(force))
                log_x.append(np.log(abs(x)))
            else:
                raise RuntimeError(f"no force holds {held:.4g} m at {frequency:.3f} Hz")
        h_out[line], f_out[line] = x / force, force
    return h_out, f_out


def predict_run(system: NonlinearSystem, drive_dof: str, run: ForcedRun, margin_hz: float = 0.0) -> dict[str, float]:
    """The run's :func:`features` as the model predicts them on the run's lines, the grid extended
    by ``margin_hz`` (Hz) at each end at the median spacing (the end lines' force, or achieved
    displacement, held there), so that a predicted resonance outside the tested band is still
    found. A response-controlled run is held on each line at the displacement it achieved there
    (``held_line_m``), not at its median."""
    frequency = run.frequency_hz
    step = float(np.median(np.diff(frequency)))
    extra = int(round(margin_hz / step))
    below, above = frequency[0] - step * np.arange(extra, 0, -1), frequency[-1] + step * np.arange(1, extra + 1)
    grid = np.concatenate([below, frequency, above])
    if run.control == "force":
        h, _ = harmonic_response(system, drive_dof, grid, force_n=np.interp(grid, frequency, run.force_n))
    else:
        held = run.level if run.held_line_m is None else np.interp(grid, frequency, run.held_line_m)
        h, _ = harmonic_response(system, drive_dof, grid, held_m=held)
    return features(grid, h)
