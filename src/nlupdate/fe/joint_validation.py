"""The reduced FE model of a bolted structure with a friction element per bolt: the joint
identified from the force-controlled runs, then every forced run predicted by the initial
and the updated FE model.

The model (:func:`nonlinear_model`): the Craig–Bampton model of
:class:`~nlupdate.fe.adapters.calculix_brb.BRBAdapter` at the FE parameters, the joint's
linear springs normal to the interface, across it and in rotation, structural damping
η = 2ζ, the shaker's moving mass at the drive point and, along the interface (x), one
friction element per bolt between the bolt's two reference points, its stuck stiffness the
FE model's ``kt``. The joint (:func:`identify_joint`) is fitted on the updated model: the
slip force F_S per bolt (and Iwan's χ, β = 0) and the linear damping ratio with the shaker
attached, least squares of the relative peak and damping errors of every
force-controlled run (evaluations bounded). Units SI; frequencies in Hz.
"""
from __future__ import annotations

import dataclasses
import io
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Mapping, Sequence

import numpy as np
import pandas as pd
import scipy.io
import scipy.linalg
import scipy.optimize

from nlupdate.core.identification.impact import fit_linear_limit
from nlupdate.core.model.model_file import system_from_dict
from nlupdate.core.model.system import NonlinearSystem
from nlupdate.core.validation.fe_settings import FEValidationSettings
from nlupdate.core.validation.forced_runs import (ForcedRun, RunErrors, features, predict_run, run_errors,
                                                  runs_repeatability)
from nlupdate.core.validation.held_out import Repeatability
from nlupdate.fe.adapters.calculix_brb import BOLTS, BRBAdapter, joint_stiffness
from nlupdate.input_files import read_input_bytes

#: The columns of the validation table, in order (one row per run and model).
VALIDATION_COLUMNS = ("run", "control", "level", "model", "resonance_hz_measured", "resonance_hz_predicted",
                      "damping_ratio_measured", "damping_ratio_predicted", "peak_measured", "peak_predicted")


def impact_damping(path: Path, channel: str, band_hz: Sequence[float]) -> float:
    """Mode 1's linear damping ratio from a hammer-impact record (``HIdata`` with ``time`` and one
    field per channel): the linear limit of ``channel`` in ``band_hz``
    (:func:`nlupdate.core.identification.impact.fit_linear_limit`). Read as the run pinned it."""
    record = scipy.io.loadmat(io.BytesIO(read_input_bytes(path, "hammer-impact record")), squeeze_me=True,
                              struct_as_record=False)
    if "HIdata" not in record or not hasattr(record["HIdata"], channel):
        raise ValueError(f"{path}: expected a struct HIdata with fields time and {channel}")
    data = record["HIdata"]
    limit = fit_linear_limit(np.asarray(data.time, float), {channel: np.asarray(getattr(data, channel), float)},
                             band_hz=tuple(band_hz))
    return float(limit.damping_ratio)


def nonlinear_model(adapter: BRBAdapter, parameters: Mapping[str, float], damping_ratio: float,
                    joint: Mapping[str, float], element: str, drive_dof: str,
                    shaker_mass: float = 0.0) -> NonlinearSystem:
    """The reduced model at the FE ``parameters`` with one ``element`` per bolt along x
    (``joint``: ``slip_force`` (N) and, for an Iwan element, ``chi``, ``beta``), structural
    damping η = 2·``damping_ratio`` and ``shaker_mass`` (kg) at ``drive_dof``."""
    deck, springs = adapter.split(parameters)
    reduced = adapter.reduced(deck)
    mass = reduced.mass.copy()
    drive = reduced.index(drive_dof)
    mass[drive, drive] += shaker_mass
    stiffness = reduced.stiffness + joint_stiffness(reduced, springs["kt"], springs["kn"], springs["kr"],
                                                    tangential_x=False)
    law = JOINT_LAWS[element].law(springs["kt"], joint)
    elements = [{**law, "dofs": [f"{bolt}_a:ux", f"{bolt}_b:ux"]} for bolt in BOLTS]
    return system_from_dict({"model": {"kind": "lumped", "mass": mass.tolist(), "stiffness": stiffness.tolist(),
                                       "loss_factor": 2 * damping_ratio, "dof_names": list(reduced.dof_names)},
                             "nonlinear": elements}, "reduced FE model with a joint element per bolt")


def shaker_mass(adapter: BRBAdapter, parameters: Mapping[str, float], drive_dof: str, lowest: ForcedRun,
                impact_hz: float) -> float:
    """The shaker's moving mass (kg) at ``drive_dof`` that moves mode 1 from ``impact_hz`` to the
    lowest force-controlled run's resonance, first order in the mass: ``(f_impact/f_forced)² − 1
    = m φ²`` with φ the FE model's mass-normalised mode-1 shape there (never negative)."""
    result = adapter.evaluate(dict(parameters))
    phi = result.mode_shapes[result.coordinates.index(drive_dof), 0]
    forced_hz = features(lowest.frequency_hz, lowest.h)["resonance_hz"]
    return float(max(((impact_hz / forced_hz) ** 2 - 1) / phi**2, 0.0))


@dataclass(frozen=True)
class JointLaw:
    """How the joint fit parametrises one element kind per bolt: the element's model-file entry
    from the stuck stiffness ``kt`` (N/m) and the identified ``joint``; the fitted shape
    parameters between log F_S and log ζ (their start, bounds, scale and finite-difference step);
    the values held fixed."""

    law: Callable[[float, Mapping[str, float]], dict]
    shape: tuple[str, ...] = ()
    start: tuple[float, ...] = ()
    low: tuple[float, ...] = ()
    high: tuple[float, ...] = ()
    scale: tuple[float, ...] = ()
    step: tuple[float, ...] = ()
    fixed: Mapping[str, float] = field(default_factory=dict)


#: The element kinds ``[fe_validation] element`` offers: Segalman's Iwan element (χ fitted in
#: [−0.95, 0], β = 0: microslip only — one driving-point curve per level does not separate β)
#: and the Jenkins element (slip force only).
JOINT_LAWS: dict[str, JointLaw] = {
    "iwan": JointLaw(lambda kt, joint: {"type": "iwan", "kt": kt, "slip_force": joint["slip_force"],
                                        "chi": joint["chi"], "beta": joint["beta"]},
                     shape=("chi",), start=(-0.3,), low=(-0.95,), high=(0.0,), scale=(0.2,), step=(1e-2,),
                     fixed={"beta": 0.0}),
    "jenkins": JointLaw(lambda kt, joint: {"type": "jenkins", "kf": kt, "slip_force": joint["slip_force"]}),
}


def _joint_of(x: np.ndarray, element: str) -> tuple[dict[str, float], float]:
    """(joint, ζ) from the fit's vector [log F_S, shape parameters…, log ζ]."""
    kind = JOINT_LAWS[element]
    joint = {"slip_force": float(np.exp(x[0])), **dict(zip(kind.shape, map(float, x[1:-1]))), **kind.fixed}
    return joint, float(np.exp(x[-1]))


def identify_joint(adapter: BRBAdapter, parameters: Mapping[str, float], damping_ratio: float,
                   runs: Sequence[ForcedRun], element: str, drive_dof: str, mass: float,
                   max_evaluations: int) -> tuple[dict[str, float], dict]:
    """The joint per bolt and the linear damping ratio with the shaker attached
    (``damping_ratio_forced``), fitted to the force-controlled ``runs`` from ``damping_ratio``;
    and the fit (rms residual, residuals, evaluations, status)."""
    forced = [run for run in runs if run.control == "force"]
    measured = [features(run.frequency_hz, run.h) for run in forced]

    def residuals(x: np.ndarray) -> np.ndarray:
        joint, zeta = _joint_of(x, element)
        system = nonlinear_model(adapter, parameters, zeta, joint, element, drive_dof, mass)
        out = []
        for run, m in zip(forced, measured):
            p = predict_run(system, drive_dof, run)
            out += [np.log(p["peak"] / m["peak"]), (p["damping_ratio"] - m["damping_ratio"]) / m["damping_ratio"]]
        return np.nan_to_num(np.array(out), nan=10.0)  # a curve without a damping ratio: penalised

    kind = JOINT_LAWS[element]  # x = [log F_S, shape parameters…, log ζ]
    x0 = [np.log(1000.0), *kind.start, np.log(damping_ratio)]
    low, high = [np.log(10.0), *kind.low, np.log(1e-4)], [np.log(1e6), *kind.high, np.log(0.05)]
    scale, step = [1.0, *kind.scale, 0.3], [1e-3, *kind.step, 1e-3]
    x0 = np.clip(x0, low, high)
    fit = scipy.optimize.least_squares(residuals, x0=x0, bounds=(low, high), x_scale=scale, diff_step=step,
                                       max_nfev=max_evaluations)
    joint, zeta = _joint_of(fit.x, element)
    return {**joint, "damping_ratio_forced": zeta}, {
        "rms_residual": float(np.sqrt(np.mean(fit.fun**2))), "residuals": [float(r) for r in fit.fun],
        "evaluations": int(fit.nfev), "status": str(fit.message)}


@dataclass(frozen=True, eq=False)
class FEValidation:
    """The outcome: ``modes`` (``model`` initial | updated, ``mode``, ``frequency_hz``,
    ``frequency_hz_measured`` where paired, else NaN), ``table`` (:data:`VALIDATION_COLUMNS`, one
    row per run and model), the identified ``joint`` per bolt and its ``fit``, the starting
    ``damping_ratio`` and where it came from, the ``shaker_mass_kg``, the test's
    ``repeatability`` over its force-controlled runs, the FE points and the time taken."""

    modes: pd.DataFrame
    table: pd.DataFrame
    element: str
    joint: dict[str, float]
    fit: dict
    damping_ratio: float
    damping_source: str
    shaker_mass_kg: float
    repeatability: Repeatability
    points: dict[str, dict[str, float]] = field(default_factory=dict)
    wall_time_s: float = float("nan")
    cpu_time_s: float = float("nan")

    @property
    def errors(self) -> dict[str, RunErrors]:
        """Per model its errors over the runs, judged by the test's repeatability (:func:`run_errors`)."""
        return run_errors(self.table, self.repeatability.resonance_hz)

    def summary(self) -> dict:
        """The ``fe_validation.json`` content."""
        return {"joint": {"element": self.element, "per_bolt": list(BOLTS), **self.joint}, "fit": self.fit,
                "linear_damping_ratio": self.damping_ratio, "linear_damping_source": self.damping_source,
                "shaker_mass_kg": self.shaker_mass_kg, "repeatability": self.repeatability.as_dict(),
                "errors": {model: dataclasses.asdict(e) for model, e in self.errors.items()},
                "points": self.points, "wall_time_s": self.wall_time_s, "cpu_time_s": self.cpu_time_s}


def fe_modes(adapter: BRBAdapter, points: Mapping[str, Mapping[str, float]],
             pairing: Mapping[int, float]) -> pd.DataFrame:
    """Every elastic mode of each model (``points``: model name → FE parameters), with the
    measured frequency where ``pairing`` (1-based FE mode → Hz) pairs one."""
    rows = []
    for label, point in points.items():
        for mode, frequency in enumerate(adapter.evaluate(dict(point)).natural_frequencies_hz, start=1):
            rows.append({"model": label, "mode": mode, "frequency_hz": float(frequency),
                         "frequency_hz_measured": float(pairing.get(mode, np.nan))})
    return pd.DataFrame(rows, columns=["model", "mode", "frequency_hz", "frequency_hz_measured"])


def validate_fe(adapter: BRBAdapter, initial: Mapping[str, float], updated: Mapping[str, float],
                pairing: Mapping[int, float], runs: Sequence[ForcedRun], settings: FEValidationSettings,
                damping_ratio: float, damping_source: str) -> FEValidation:
    """The FE modes of both models, the joint identified on the updated one from the
    force-controlled ``runs`` (starting from ``damping_ratio``), and the runs ``settings.runs``
    asks for predicted by both (:class:`FEValidation`). ``pairing``: 1-based FE mode → the
    test's frequency (Hz); the lowest paired mode is the one the shaker's mass moves."""
    started, cpu = time.perf_counter(), time.process_time()
    points = {"initial": dict(initial), "updated": dict(updated)}
    modes = fe_modes(adapter, points, pairing)
    forced = [run for run in runs if run.control == "force"]
    if not forced:
        raise ValueError("the measured file holds no force-controlled run to identify the joint from")
    drive = settings.drive_dof
    mass = shaker_mass(adapter, updated, drive, forced[0], float(pairing[min(pairing)])) if settings.shaker_mass else 0.0
    joint, fit = identify_joint(adapter, updated, damping_ratio, runs, settings.element, drive, mass,
                                settings.fit_evaluations)
    rows = []
    for label, point in points.items():
        system = nonlinear_model(adapter, point, joint["damping_ratio_forced"], joint, settings.element, drive, mass)
        for run in runs:
            if run.control not in settings.runs:
                continue
            measured = features(run.frequency_hz, run.h)
            predicted = predict_run(system, drive, run, margin_hz=settings.margin_hz)
            rows.append({"run": run.run, "control": run.control, "level": run.level, "model": label,
                         **{f"{q}_{side}": values[q] for q in measured
                            for side, values in (("measured", measured), ("predicted", predicted))}})
    return FEValidation(modes, pd.DataFrame(rows, columns=list(VALIDATION_COLUMNS)), settings.element, joint, fit,
                        damping_ratio, damping_source, mass, runs_repeatability(runs), points,
                        time.perf_counter() - started, time.process_time() - cpu)
