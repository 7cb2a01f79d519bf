"""pyHarm-os, the optional comparison (``benchmark`` extra): its input, runs and results in this
project's convention."""
from __future__ import annotations

import contextlib
import io
import logging
import time

import numpy as np


from benchmarks.frf.common import BAND, DAMPING, FORCE, K3, MASS, STIFFNESS

# --------------------------------------------------------------------------------------
# pyHarm-os
# --------------------------------------------------------------------------------------
def pyharm_version() -> str | None:
    """pyHarm-os version, or None when it is not importable."""
    try:
        from importlib.metadata import version

        from pyHarm.Maestro import Maestro  # noqa: F401
    except Exception:  # pragma: no cover - depends on the optional install
        return None
    try:
        return version("pyHarm-os")
    except Exception:  # pragma: no cover
        return "?"


def pyharm_input(analysis: dict, harmonics: int = 1, samples: int = 64) -> dict:
    """pyHarm input for the Duffing case: harmonics 0 … nh (the constant term included), nti
    time samples per period (pyHarm's default is 128; the benchmark sets 64, as the project's)."""
    return {
        "system": {"type": "Base", "nh": int(harmonics), "nti": int(samples)},
        "substructures": {
            "sub": {
                "type": "substructure",
                "ndofs": 1,
                "matrix": {"M": np.array([[MASS]]), "K": np.array([[STIFFNESS]]), "C": np.array([[DAMPING]])},
            }
        },
        "connectors": {
            "cubic": {"type": "CubicSpring", "connect": {"sub": [0]}, "dirs": [0], "k": K3},
            "force": {"type": "CosinusForcing", "connect": {"sub": [0]}, "dirs": [0], "amp": FORCE},
        },
        "analysis": {"frf": {"study": "frf", "verbose": False, **analysis}},
    }


def pyharm_continuation(**step) -> dict:
    """pyHarm's default continuation (tangent predictor, arc-length corrector, hybr) over the band."""
    return {"puls_inf": BAND[0], "puls_sup": BAND[1], "ds_min": 1e-6, **step}


def pyharm_constant_step(step: float) -> dict:
    return pyharm_continuation(ds0=step, ds_max=step, stepsizer="constant")


def pyharm_grid_sweep(omega_sweep: np.ndarray) -> dict:
    """pyHarm stepped sweep over an evenly spaced grid (in sweep order): fixed ω per point.

    Previous-solution predictor, no-continuation corrector (ω fixed at the prediction),
    constant step = grid step, stop after as many solutions as grid points.
    """
    h = abs(omega_sweep[1] - omega_sweep[0])
    low, high = min(omega_sweep[0], omega_sweep[-1]), max(omega_sweep[0], omega_sweep[-1])
    return {
        "puls_inf": low - h / 2,
        "puls_sup": high + h / 2,
        "puls_start": float(omega_sweep[0]),
        "sign_ds": 1 if omega_sweep[-1] > omega_sweep[0] else -1,
        "ds0": h,
        "ds_max": h,
        "ds_min": h / 10,  # below the step: pyHarm's bound stopper quits after two steps at ds_min
        "predictor": "previous",
        "corrector": "nocontinuation",
        "stepsizer": "constant",
        "stopper": "solnumber",
        "stopper_options": {"max_solutions": int(omega_sweep.size)},
    }


def pyharm_run(analysis: dict, harmonics: int = 1, samples: int = 64) -> tuple[float, dict]:
    """Build and operate pyHarm; returns (operate() time in s, results).

    Results: accepted points' ``omega``, first harmonic ``x``, ``harmonics`` (n_points,
    nh+1) complex X₀ … X_nh in the project's convention x(t) = X₀ + Σ Re(X_k e^{ikωt})
    (pyHarm: x = c₀ + Σ c_k cos kωt + s_k sin kωt, so X_k = c_k − i s_k), ``folds`` (its
    turning curve points), the Maestro build time, the CPU time of ``operate()`` (s) and the
    accepted/total solution counts.
    """
    from pyHarm.Maestro import Maestro

    logging.disable(logging.CRITICAL)
    try:
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            start = time.perf_counter()
            maestro = Maestro(pyharm_input(analysis, harmonics, samples))
            build = time.perf_counter() - start
            start, cpu = time.perf_counter(), time.process_time()
            maestro.operate()
            solve, cpu = time.perf_counter() - start, time.process_time() - cpu
    finally:
        logging.disable(logging.NOTSET)
    edf = maestro.system.expl_dofs
    solutions = maestro.nls["frf"].SolList
    points = np.array([s.x for s in solutions if s.flag_accepted])
    omega = points[:, -1]
    states = np.zeros((omega.size, harmonics + 1), complex)
    for k in range(harmonics + 1):
        cos_index = int(edf.index[(edf["harm"] == k) & (edf["cs"] == "c")][0])
        states[:, k] = points[:, cos_index]
        if k:  # x = c cos kωt + s sin kωt = Re((c − i s) e^{ikωt})
            states[:, k] -= 1j * points[:, int(edf.index[(edf["harm"] == k) & (edf["cs"] == "s")][0])]
    turn = np.flatnonzero(np.diff(np.sign(np.diff(omega))) != 0) + 1
    return solve, {
        "omega": omega,
        "x": states[:, 1],
        "harmonics": states,
        "folds": omega[turn],
        "build": build,
        "cpu": cpu,
        "accepted": omega.size,
        "solutions": len(solutions),
    }




def with_cpu(run: tuple[float, dict]) -> tuple[float, dict, float]:
    """A :func:`pyharm_run` answer as an interleaved task's (wall, result, CPU) of ``operate()``."""
    return run[0], run[1], run[1]["cpu"]
