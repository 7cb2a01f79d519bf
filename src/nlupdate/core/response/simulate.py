"""Simulated measurements: nonlinear FRFs at several force levels as a measured-FRF table.

A harmonic force of amplitude F (N) acts at one input coordinate; for each level the
receptance ``H = X/F`` (m/N) is computed at every coordinate of the model on a
frequency grid (Hz) with one of three methods:

* ``continuation`` — the describing-function balance read like a stepped-sine test sweeping
  ``up`` or ``down`` (:mod:`nlupdate.core.response.sweep`: closed-form roots, one batched solve of a
  fold-free branch, or the traced curve (:mod:`nlupdate.core.response.continuation`) read by
  :mod:`nlupdate.core.response.stepped_sine`);
* ``hb`` — the same with H harmonics and the constant term, stability by Hill's method
  (:mod:`nlupdate.core.response.harmonic_balance`); the table holds the first harmonic;
* ``fixed-point`` — the source's relaxed iteration from the linear response; points
  that do not converge are dropped and counted in the returned report;
* ``time`` — steady-state first harmonic from direct time integration (no
  describing-function assumption), sweeping like a test.

Optional measurement noise follows docs/methods.md §8 (:func:`nlupdate.core.measurement.noise.add_frf_noise`).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike

from nlupdate.core.response.fixed_point import fixed_point_response
from nlupdate.core.response.harmonic_balance import HarmonicSettings, trace_harmonic_balance
from nlupdate.core.model.linear import dof_index
from nlupdate.core.measurement.frf_table import frf_table
from nlupdate.core.measurement.noise import add_table_noise
from nlupdate.core.response.stepped_sine import stepped_sine
from nlupdate.core.response.sweep import frequency_sweeps
from nlupdate.core.model.system import NonlinearSystem
from nlupdate.core.response.time_integration import time_sweep
from nlupdate.progress import ProgressCallback, no_progress

METHODS = ("continuation", "hb", "fixed-point", "time")


@dataclass
class SimulationReport:
    """What happened per force level: dropped (non-converged) points, jumps (Hz) and, for the
    describing function, the route that solved it (:attr:`~nlupdate.core.response.stepped_sine.SweepResult.route`)."""

    dropped_points: dict[float, int] = field(default_factory=dict)
    jumps_hz: dict[float, tuple[float, ...]] = field(default_factory=dict)
    harmonics: dict[float, int] = field(default_factory=dict)
    harmonic_share: dict[float, float] = field(default_factory=dict)
    bifurcations: dict[float, tuple] = field(default_factory=dict)
    routes: dict[float, str] = field(default_factory=dict)


def _read_curve(curve, system, omega, sweep):
    result = stepped_sine(curve, omega, sweep)
    valid = np.isfinite(result.x_nonlinear.reshape(omega.size, -1)).all(axis=1)
    return result.response(range(system.model.n_dof)), valid, result.jumps_hz


def _read_sweep(result, system, omega):
    valid = np.isfinite(result.x_nonlinear.reshape(omega.size, -1)).all(axis=1)
    return result.response(range(system.model.n_dof)), valid, result.jumps_hz


def _responses_hb(system, forcing, omega, sweep, progress, settings, report):
    curve = trace_harmonic_balance(
        system, forcing, float(omega.min()), float(omega.max()), harmonics=settings.harmonics,
        samples=settings.samples, stability=settings.stability, share_limit=settings.share_limit,
    )
    level = float(abs(next(iter(forcing.values()))))
    report.harmonics[level] = curve.problem.harmonics
    report.harmonic_share[level] = curve.harmonic_share
    report.bifurcations[level] = tuple((b.kind, b.frequency_hz) for b in curve.bifurcations)
    return _read_curve(curve, system, omega, sweep)


def _responses_fixed_point(system, forcing, omega, sweep, progress, settings, report):
    result = fixed_point_response(system, forcing, omega)
    return result.response(range(system.model.n_dof)), result.converged, ()


def _responses_time(system, forcing, omega, sweep, progress, settings, report):
    result = time_sweep(system, forcing, omega, sweep, progress=progress)
    return result.x, result.converged, result.jumps_hz


_SOLVERS: dict[str, Callable] = {
    "hb": _responses_hb,
    "fixed-point": _responses_fixed_point,
    "time": _responses_time,
}


def simulate_frf_table(
    system: NonlinearSystem,
    input_dof: int | str,
    frequency_hz: ArrayLike,
    force_levels_n: Sequence[float],
    *,
    method: str = "continuation",
    sweep: str = "up",
    noise: float = 0.0,
    seed: int | None = None,
    harmonic_balance: HarmonicSettings = HarmonicSettings(),
    progress: ProgressCallback = no_progress,
) -> tuple[pd.DataFrame, SimulationReport]:
    """Measured-FRF table (all response coordinates) for each force level.

    ``frequency_hz`` is the test grid (Hz, > 0), ``force_levels_n`` the force amplitudes
    (N, > 0). Returns the table and a :class:`SimulationReport`. ``progress`` hears
    ``("force levels (<method>)", done, total)`` and, for the time-domain method, each
    frequency of each level. ``harmonic_balance`` sets harmonics, samples per period and
    stability for ``method="hb"``; the report then says per level the harmonics used, the
    share of the highest ones and the bifurcations found (kind, Hz).
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    if sweep not in ("up", "down"):
        raise ValueError(f"sweep must be 'up' or 'down', got {sweep!r}")
    frequency_hz = np.sort(np.atleast_1d(np.asarray(frequency_hz, dtype=float)))
    if frequency_hz.size < 2 or frequency_hz[0] <= 0:
        raise ValueError("the frequency grid needs at least two frequencies, all > 0 Hz")
    levels = [float(f) for f in force_levels_n]
    if not levels or min(levels) <= 0:
        raise ValueError(f"force levels must be positive amplitudes in N, got {levels}")
    if not (np.isfinite(noise) and noise >= 0):
        raise ValueError(f"noise fraction must be a finite number >= 0 (e.g. 0.05 for 5 %), got {noise!r}")
    input_index = dof_index(system.model, input_dof)
    names = list(system.model.dof_names)
    omega = 2 * np.pi * frequency_hz
    report = SimulationReport()
    solved = {}
    if method == "continuation":  # every level at once: the traced ones in lockstep
        order = sorted(set(levels))
        sweeps = frequency_sweeps(system, [{input_index: level} for level in order], omega, sweep)
        solved = dict(zip(order, sweeps))
        report.routes = {level: result.route for level, result in solved.items()}
    tables = []
    progress(f"force levels ({method})", 0, len(levels))
    for done, level in enumerate(levels, start=1):
        level_progress = lambda task, i, n, level=level: progress(f"{level:g} N: {task}", i, n)  # noqa: E731
        if method == "continuation":
            x, valid, jumps = _read_sweep(solved[level], system, omega)
        else:
            x, valid, jumps = _SOLVERS[method](
                system, {input_index: level}, omega, sweep, level_progress, harmonic_balance, report
            )
        report.dropped_points[level] = int((~valid).sum())
        report.jumps_hz[level] = tuple(jumps)
        h = x[valid] / level
        tables.append(
            frf_table(
                frequency_hz[valid][:, None],
                level,
                np.array(names, dtype=object)[None, :],
                names[input_index],
                h,
            )
        )
        progress(f"force levels ({method})", done, len(levels))
    table = pd.concat(tables, ignore_index=True)
    if noise:
        table = add_table_noise(table, noise, seed)
    return table, report
