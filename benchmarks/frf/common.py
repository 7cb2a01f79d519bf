"""Shared by every part: the reference Duffing case, timing, tables, the exact single-harmonic
relation and the project's fixed-grid Newton sweep."""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.optimize import brentq

from benchmarks.docs_block import cpu_seconds, load_average, machine_description  # noqa: F401 (shared with the parts)
from nlupdate.core.model.elements import CubicStiffness
from nlupdate.core.model.linear import LumpedModel
from nlupdate.core.model.system import CondensedProblem, NonlinearSystem, newton_fixed_frequency
from nlupdate.core.response.continuation import default_x_scale

MASS, DAMPING, STIFFNESS, K3, FORCE = 1.0, 0.05, 1.0, 1.0, 0.5
BAND = (0.5, 3.5)
N_GRID = 200
BRANCH = 0.10  # relative amplitude difference beyond which two responses are on different branches

# Step controls chosen (and checked in every run: the point counts are printed) so that the
# two tools put the same number of points on the curve; see design (b) in the docstring.
PYHARM_STEP_78 = 0.182  # pyHarm constant arc-length step in (x, ω) → 78 points, as the project's default
PYHARM_STEP_FORMER = {"ds0": 0.01, "ds_max": 0.05}  # earlier setting → 283 points
PROJECT_MAX_STEP_283 = 0.0092  # project's max_step (scaled arc length) → 285 points

# Part 1c (multi-harmonic balance): both tools at constant step, chosen (and printed in every
# run) to put 79–81 points on the curve at every H; both with 64 samples per period.
HB_HARMONICS = (1, 3, 5, 7)
HB_SAMPLES = 64  # the project's default_samples(H) for H ≤ 7; pyHarm's default nti is 128
HB_STEP = 0.046  # project: step = max_step (scaled arc length) → 79 points at H = 1, 80 at H = 3, 81 at H = 5, 7
PYHARM_HB_STEP = 0.175  # pyHarm constant ds → 81 points at nh = 1, 80 at nh = 3, 5, 7
HB_REFERENCE_HARMONICS = 7  # harmonics taken from the time-integration reference
HB_RESOLVED = 1e-3  # higher harmonics compared where they carry at least this share of |X1|
HB_GOAL = 5.0  # issue 13: ≥ 5× faster than pyHarm-os at every H
HB_HILL_GOAL = 1.0  # issue 13: with stability on (Hill) at least as fast as pyHarm-os without it
HB_SCALING_HARMONICS = 5  # Part 2's multi-harmonic rows



# --------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------
@dataclass
class Timing:
    """Wall times and CPU times (s, process and children) of the repeats, and the last result."""

    times: np.ndarray
    result: object
    cpu: np.ndarray

    @property
    def best(self) -> float:
        return float(self.times.min())

    @property
    def median(self) -> float:
        return float(np.median(self.times))

    @property
    def cpu_median(self) -> float:
        return float(np.median(self.cpu))

    @property
    def cpu_best(self) -> float:
        return float(self.cpu.min())


def timed(function: Callable[[], object]) -> Callable[[], tuple[float, object]]:
    """Wrap ``function`` to return (wall time in s, result)."""

    def run():
        start = time.perf_counter()
        result = function()
        return time.perf_counter() - start, result

    return run


def interleaved(tasks: dict[str, Callable[[], tuple]], repeats: int) -> dict[str, Timing]:
    """``repeats`` rounds, one call of every task per round (order rotated each round).

    Each task returns (wall seconds, result) or (wall seconds, result, CPU seconds); without
    the third, the CPU time (process and children) of the whole call is taken. The last
    result of each is kept. Compare tools by the medians (``median``, ``cpu_median``): the
    CPU time does not count the time other users of a shared machine take the core away.
    """
    names = list(tasks)
    times: dict[str, list[float]] = {name: [] for name in names}
    cpu: dict[str, list[float]] = {name: [] for name in names}
    results: dict[str, object] = {}
    for round_ in range(repeats):
        shift = round_ % len(names)
        for name in names[shift:] + names[:shift]:
            start = cpu_seconds()
            answer = tasks[name]()
            used = cpu_seconds() - start
            seconds, results[name] = answer[0], answer[1]
            times[name].append(seconds)
            cpu[name].append(answer[2] if len(answer) > 2 else used)
    return {name: Timing(np.array(times[name]), results[name], np.array(cpu[name])) for name in names}


def fmt_cpu_wall(timing: Timing) -> str:
    """``CPU s / wall s``, medians of the repeats."""
    return f"{fmt_time(timing.cpu_median)} / {fmt_time(timing.median)}"


def print_table(title: str, header: list[str], rows: list[list[str]]) -> None:
    widths = [max(len(str(row[i])) for row in [header] + rows) for i in range(len(header))]
    print(f"\n{title}")
    print("  ".join(h.ljust(w) for h, w in zip(header, widths)))
    print("  ".join("-" * w for w in widths))
    for row in rows:
        print("  ".join(str(cell).ljust(w) for cell, w in zip(row, widths)))


def fmt_time(seconds: float) -> str:
    return f"{seconds:.4f}" if seconds < 1 else f"{seconds:.2f}"


def fmt_ms(seconds: float) -> str:
    ms = 1e3 * seconds
    return f"{ms:.3f}" if ms < 10 else f"{ms:.1f}"


def fmt_ratio(ratio: float) -> str:
    return f"{ratio:.2f}" if ratio < 10 else f"{ratio:.1f}" if ratio < 100 else f"{ratio:.0f}"


def fmt_list(values) -> str:
    values = list(values)
    return ", ".join(f"{v:.4f}" for v in values) if values else "—"


def duffing() -> NonlinearSystem:
    return NonlinearSystem(LumpedModel([[MASS]], [[STIFFNESS]], [[DAMPING]]), (CubicStiffness((0,), K3),))


def relative_error(a: np.ndarray, reference: np.ndarray) -> np.ndarray:
    return np.abs(np.abs(a) - np.abs(reference)) / np.abs(reference)


def nearest_branch(a: np.ndarray, up: np.ndarray, down: np.ndarray) -> np.ndarray:
    """Per point, the reference amplitude (up- or down-sweep branch) closest to ``a``."""
    a, up, down = np.abs(a), np.abs(up), np.abs(down)
    return np.where(np.abs(up - a) <= np.abs(down - a), up, down)


def simple_jumps(omega: np.ndarray, amplitude: np.ndarray, threshold: float = 0.25) -> list[float]:
    """Frequencies (rad/s, sweep order) where the amplitude changes by more than ``threshold``."""
    return [
        float(omega[i])
        for i in range(1, omega.size)
        if abs(amplitude[i] - amplitude[i - 1]) > threshold * max(amplitude[i], amplitude[i - 1])
    ]


# --------------------------------------------------------------------------------------
# the exact single-harmonic Duffing relation (the reference of Part 1a)
# --------------------------------------------------------------------------------------
def _cubic(omega: float) -> np.ndarray:
    """Coefficients of the single-harmonic relation as a cubic in u = a²."""
    p = STIFFNESS - MASS * omega**2
    return np.array([(0.75 * K3) ** 2, 1.5 * K3 * p, p**2 + (DAMPING * omega) ** 2, -(FORCE**2)])


def exact_amplitude(omega: np.ndarray, amplitude: np.ndarray) -> np.ndarray:
    """At each ω, the root a(ω) of the single-harmonic relation nearest to ``amplitude``."""
    out = np.empty(len(omega))
    for index, (w, a) in enumerate(zip(omega, amplitude)):
        roots = np.roots(_cubic(w))
        u = roots.real[(np.abs(roots.imag) <= 1e-6 * np.abs(roots)) & (roots.real > 0)]
        candidates = np.sqrt(u)
        out[index] = candidates[np.argmin(np.abs(candidates - a))]
    return out


def curve_distance(omega: np.ndarray, amplitude: np.ndarray) -> np.ndarray:
    """Relative distance of (ω, a) from the exact curve G = 0: |G| / ‖(a ∂G/∂a, ω ∂G/∂ω)‖."""
    w, a = np.asarray(omega, dtype=float), np.abs(np.asarray(amplitude))
    q = STIFFNESS - MASS * w**2 + 0.75 * K3 * a**2
    g = a**2 * (q**2 + (DAMPING * w) ** 2) - FORCE**2
    g_a = 2 * a * (q**2 + (DAMPING * w) ** 2) + 3 * K3 * a**3 * q
    g_w = a**2 * (-4 * MASS * w * q + 2 * DAMPING**2 * w)
    return np.abs(g) / np.hypot(a * g_a, w * g_w)


def exact_accuracy(omega: np.ndarray, amplitude: np.ndarray) -> tuple[float, float]:
    """(max relative amplitude error, max relative distance) against the exact relation."""
    amplitude = np.abs(amplitude)
    exact = exact_amplitude(omega, amplitude)
    return float(np.max(np.abs(amplitude - exact) / exact)), float(curve_distance(omega, amplitude).max())


def exact_folds() -> np.ndarray:
    """Fold frequencies (rad/s) of the single-harmonic relation in the band (discriminant = 0)."""

    def discriminant(w: float) -> float:
        a, b, c, d = _cubic(w)
        return 18 * a * b * c * d - 4 * b**3 * d + b**2 * c**2 - 4 * a * c**3 - 27 * a**2 * d**2

    scan = np.linspace(*BAND, 3001)
    values = np.array([discriminant(w) for w in scan])
    change = np.flatnonzero(np.sign(values[1:]) != np.sign(values[:-1]))
    return np.array([brentq(discriminant, scan[i], scan[i + 1], xtol=1e-14) for i in change])


# --------------------------------------------------------------------------------------
# this project's fixed-grid sweep: Newton at each frequency from the previous solution
# --------------------------------------------------------------------------------------
def newton_sweep(system: NonlinearSystem, forcing: dict, omega_sweep: np.ndarray, tolerance: float = 1e-10):
    """Complex amplitudes and convergence flags along ``omega_sweep`` (sweep order).

    The same scaling and corrector as the continuation (``newton_fixed_frequency``, scaled
    residual ``tolerance``); the first frequency starts from the linear response.
    """
    problem = CondensedProblem(system, forcing)
    problem.x_scale = default_x_scale(problem, *BAND)
    _, x_lin = problem.linear_terms(omega_sweep[0], derivative=False)
    y = problem.to_real(x_lin)
    x = np.empty(omega_sweep.size, complex)
    converged = np.zeros(omega_sweep.size, bool)
    for index, w in enumerate(omega_sweep):
        y, converged[index], _ = newton_fixed_frequency(problem, w, y, tol=tolerance)
        x[index] = problem.to_complex(y)[0]
    return x, converged


