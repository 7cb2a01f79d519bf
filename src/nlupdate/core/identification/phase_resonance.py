"""Backbone samples of one mode from phase-resonance tests: one point per level at 90° phase.

A phase-resonance test holds the response's first harmonic 90° behind the force's (a
phase-locked loop, or a controller stepping the frequency until the phase is in quadrature)
and records one point per level: the excitation frequency Ω, the first-harmonic force
amplitude F and the response's first harmonic X_r (amplitude, and phase relative to the
force). Each point is a backbone point directly; the damping comes from the force needed
to hold it there.

Derivation (single-nonlinear-mode theory, :mod:`nlupdate.core.model.single_mode`). With
the mode mass-normalised (shape φ in 1/√kg, modal coordinate q in m·√kg), the first harmonic
of a force at coordinate f balances::

    (ω(a)² − Ω² + 2iζ(a)ω(a)²) q = φ_f F,      X_r = φ_r q,      a = |q| = |X_r|/|φ_r|,

the damping hysteretic (a friction joint's; ζ the viscous damping ratio at resonance).

Write ``q = a·e^{iθ}`` with θ the phase of the modal coordinate behind the modal force φ_f F
(θ = arg X_r − arg(φ_rφ_f), F real) and ``P = |φ_f|F/a`` (rad²/s²). The real and imaginary
parts of ``D = φ_f F/q = P e^{−iθ}`` give::

    ω(a)² = Ω² + P cos θ,          ζ(a) = −P sin θ / (2 ω(a)²)

(:func:`~nlupdate.core.model.single_mode.natural_and_damping`).

At quadrature (θ = −90°) they are ω = Ω and ``ζ = |φ_f| F / (2 Ω² a) = |φ_f φ_r| F /
(2 Ω² |X_r|)``: units (1/kg)·N / (s⁻²·m) = 1. A point off quadrature (the loop locked at
−88°, or a deliberate phase offset) is corrected to its own amplitude exactly under the same
theory; a phase outside (−180°, 0°) (the displacement leading its force) gives ζ ≤ 0 and is
refused. The modal force of a structure in one mode is exact only when the force appropriates
the mode (single-point excitation near a well-separated mode: the other modes add a
quasi-static share; METHODS.md §9).

The frequency comes from the measured Ω (a PLL locks to a frequency reading far more precise
than any amplitude), the damping from F and |X_r|: a 2 % error in either is a 2 % error in ζ.

Files (docs/ring-down.md, "Phase resonance", states the layout):

* CSV: columns ``frequency_hz`` (Hz), ``force_n`` (N, first-harmonic amplitude),
  ``response_amplitude`` (first-harmonic amplitude in ``response_unit``),
  ``response_phase_deg`` (degrees, of the response relative to the force); optional
  ``response_unit`` (one of :data:`~nlupdate.core.measurement.units.RESPONSE_UNIT_LABELS`,
  the same on every row; default m), ``response_dof`` and ``input_dof`` (text; or
  ``--coordinates FILE=RESPONSE,INPUT``, which also gives a sensor's sign as NODE:-DIR).
  One row per level.
* MATLAB (.mat v5 or v7.3): struct(s) with the stepped-sine run fields ``frequency``,
  ``force``, ``amplitude``, ``phase`` (one value per level) and ``units`` (e.g.
  ``'Hz, N, m/s^2, rad'``), as :mod:`nlupdate.core.measurement.matfile` reads runs.
* Universal file (.uff/.unv; :mod:`nlupdate.core.measurement.uff.run_records`): one run per
  level (runs told apart by their ID lines, as for force-controlled exports), each of datasets
  58 with **one frequency line**, the locked frequency Ω: a spectrum (function type 12,
  complex) of the response and one of the force — the response's phase relative to the force
  is ``arg X − arg F`` — or an FRF (type 4) at Ω with the force's spectrum (type 12, or auto
  spectrum type 2 in N²) or, without one, its level as ``--measured`` finds it
  (:mod:`nlupdate.core.measurement.uff.levels`: ``F=2.5N`` in the run name, a z-axis force,
  ``--level FILE#RUN=VALUE``). The coordinates are the records' node and direction fields
  (the force spectrum's node is the input), a negative direction applied. Any other record
  (a time record, an auto spectrum of the response, several lines) is refused naming it.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from nlupdate.core.identification.modal_samples import ModalSamples
from nlupdate.core.measurement.frf_table import MeasurementTableError
from nlupdate.core.measurement.matfile import (
    _RUN_FIELDS, _raw_variables, _run_coordinates, _run_groups, _run_units, _run_vector, _signed,
)
from nlupdate.core.measurement.time_history import csv_frame
from nlupdate.core.measurement.uff.levels import dataset_level
from nlupdate.core.measurement.uff.run_records import RunRecord, by_run, run_records, uff_content
from nlupdate.core.measurement.units import RESPONSE_UNIT_LABELS, ReadOptions
from nlupdate.core.model.single_mode import natural_and_damping
from nlupdate.input_files import read_input_bytes, sniff

CSV_COLUMNS = ("frequency_hz", "force_n", "response_amplitude", "response_phase_deg")


@dataclass(frozen=True)
class PhaseResonancePoints:
    """The points of a phase-resonance test, one per level: excitation ``frequency_hz`` (Hz),
    first-harmonic force amplitude ``force_n`` (N) and the response's first-harmonic
    displacement ``x`` (complex, m, its phase relative to the force, the sensor's sign
    applied) at ``response_dof``, the force at ``input_dof``."""

    source: str
    response_dof: str
    input_dof: str
    frequency_hz: NDArray[np.float64]
    force_n: NDArray[np.float64]
    x: NDArray[np.complex128]


def _displacement(frequency: NDArray, amplitude: NDArray, phase_rad: NDArray, power: int, factor: float,
                  sign: float) -> NDArray[np.complex128]:
    """The displacement's first harmonic (m) of a response of ``power`` (0, 1, 2: displacement,
    velocity, acceleration) in units ``factor`` × SI: ``X = A/(iΩ)^power``."""
    return sign * amplitude * factor * np.exp(1j * phase_rad) / (2j * np.pi * frequency) ** power


def _checked(where: str, frequency: NDArray, force: NDArray, amplitude: NDArray) -> None:
    for name, values in (("frequency", frequency), ("force", force), ("amplitude", amplitude)):
        if not np.all(np.isfinite(values)) or np.any(values <= 0):
            raise MeasurementTableError(f"{where}: '{name}' holds a value that is not a finite number > 0; expected "
                                        f"the excitation frequency (Hz), force amplitude (N) and response amplitude of "
                                        f"each level")


def _read_csv(data: bytes, path: Path, options: ReadOptions) -> PhaseResonancePoints:
    frame = csv_frame(data, path, "phase-resonance file", MeasurementTableError)
    frame.columns = [str(c).strip() for c in frame.columns]
    missing = [c for c in CSV_COLUMNS if c not in frame.columns]
    if missing:
        raise MeasurementTableError(f"{path}: no column {', '.join(repr(m) for m in missing)}; a phase-resonance table "
                                    f"holds {', '.join(CSV_COLUMNS)} (optional response_unit, response_dof, "
                                    f"input_dof), "
                                    f"one row per level")
    values = {}
    for name in CSV_COLUMNS:
        column = pd.to_numeric(frame[name], errors="coerce").to_numpy(dtype=float)
        if np.any(~np.isfinite(column)):
            row = int(np.argmax(~np.isfinite(column)))
            raise MeasurementTableError(f"{path}: row {row}, column {name!r}: {frame[name].iloc[row]!r} is not a "
                                        f"finite number")
        values[name] = column
    units = sorted(set(frame["response_unit"].astype(str).str.strip())) if "response_unit" in frame.columns else ["m"]
    if len(units) != 1 or units[0] not in RESPONSE_UNIT_LABELS:
        raise MeasurementTableError(f"{path}: column 'response_unit' holds {units}; expected one of "
                                    f"{', '.join(RESPONSE_UNIT_LABELS)}, the same on every row")
    power, factor = RESPONSE_UNIT_LABELS[units[0]]
    stated = options.coordinates_of(str(path))
    if stated is None and {"response_dof", "input_dof"} <= set(frame.columns):
        pairs = set(zip(frame["response_dof"].astype(str), frame["input_dof"].astype(str)))
        if len(pairs) != 1:
            raise MeasurementTableError(f"{path}: columns response_dof, input_dof hold {len(pairs)} pairs; a "
                                        f"phase-resonance table is of one mode at one response and one force")
        stated = pairs.pop()
    if stated is None:
        raise MeasurementTableError(f"{path}: names no coordinates (columns response_dof, input_dof); state them with "
                                    f"--coordinates {path.name}=RESPONSE,INPUT (a sensor along −z as NODE:-uz), in a "
                                    f"study with [amplitude] coordinates = {{ \"{path.name}\" = [\"RESPONSE\", "
                                    f"\"INPUT\"] }}")
    (response, sign_r), (inp, sign_i) = _signed(stated[0]), _signed(stated[1])
    f, force = values["frequency_hz"], values["force_n"]
    _checked(str(path), f, force, values["response_amplitude"])
    x = _displacement(f, values["response_amplitude"], np.deg2rad(values["response_phase_deg"]), power, factor,
                      sign_r * sign_i)
    return PhaseResonancePoints(str(path), response, inp, f, force, x)


def _read_mat(data: bytes, path: Path, kind: str, options: ReadOptions) -> PhaseResonancePoints:
    groups = _run_groups(_raw_variables(data, path, kind, "phase-resonance file"))
    if not groups:
        raise MeasurementTableError(f"{path}: holds no struct with fields {', '.join(_RUN_FIELDS)}, units; a "
                                    f"phase-resonance file holds one value per level in each")
    parts = []
    for group, members in groups:
        for index, run in enumerate(members, start=1):
            where = f"{path}: {group}({index})" if len(members) > 1 else f"{path}: {group}"
            frequency = np.asarray(run["frequency"], dtype=float).ravel()
            force, amplitude, phase = (_run_vector(run, name, frequency.size, where) for name in _RUN_FIELDS[1:])
            power, factor, unit, reference_factor, phase_factor = _run_units(run, where, options.reference_unit)
            if unit != "N":
                raise MeasurementTableError(f"{where}: the reference is a voltage; phase-resonance damping needs the "
                                            f"force (N)")
            response, inp, sign = _run_coordinates(run, where, path, options)
            _checked(where, frequency, force, amplitude)
            parts.append((response, inp, frequency, force * reference_factor,
                          _displacement(frequency, amplitude, phase * phase_factor, power, factor, sign)))
    if len({(r, i) for r, i, *_ in parts}) != 1:
        raise MeasurementTableError(f"{path}: its structs name {len({(r, i) for r, i, *_ in parts})} coordinate pairs; "
                                    f"a phase-resonance file is of one mode at one response and one force")
    return PhaseResonancePoints(str(path), parts[0][0], parts[0][1], *(np.concatenate([p[k] for p in parts])
                                                                        for k in (2, 3, 4)))


UFF_FORM = ("a phase-resonance point is one frequency line, the locked frequency, per level (run): a spectrum "
            "(function type 12, complex) of the response and one of the force, or an FRF (type 4) with the force's "
            "spectrum or level")


def _uff_point(run: str, members: list[RunRecord], path: Path, options: ReadOptions, listing: str):
    """(response, input, Ω Hz, F N, X complex m relative to the force) of one run's records."""
    where = f"{path}, run {run!r}" if run else f"{path}, dataset {members[0].index}"
    for record in members:
        if record.frequency_hz.size != 1:
            raise MeasurementTableError(f"{record.where}: {record.frequency_hz.size} frequency lines; {UFF_FORM} (a "
                                        f"stepped-sine run is read with --measured or --response-controlled)")
    mains = [r for r in members if r.kind in ("frf", "response")]
    forces = [r for r in members if r.kind == "force"]
    if len(mains) != 1 or len(forces) > 1:
        raise MeasurementTableError(f"{where}: {len(mains)} FRF/response spectra and {len(forces)} force spectra "
                                    f"(datasets {[r.index for r in members]}); {UFF_FORM}")
    main, force = mains[0], forces[0] if forces else None
    if force is not None and not np.isclose(force.frequency_hz[0], main.frequency_hz[0], rtol=1e-9):
        raise MeasurementTableError(f"{force.where}: at {force.frequency_hz[0]:.8g} Hz, its response's record at "
                                    f"{main.frequency_hz[0]:.8g} Hz; expected both at the locked frequency")
    if main.kind == "frf":
        if force is not None:
            amplitude = float(abs(force.values[0]))
        else:
            given = options.level_of_run(str(path), run) if run else None
            if given is None and listing and options.level_of(str(path)) is not None:
                raise MeasurementTableError(f"{path}: holds several levels (runs); a level given for the file fits a "
                                            f"file of one: give each with --level {path.name}#RUN=VALUE{listing}")
            amplitude = dataset_level(main.dataset, main.where, "N", options.level_of(str(path)) if given is None
                                      else given, listing)
        return main.response_dof, main.input_dof, main.frequency_hz[0], amplitude, main.values[0] * amplitude
    if force is None or not (force.has_phase and main.has_phase):
        raise MeasurementTableError(f"{main.where}: a response spectrum without the force's complex spectrum (type "
                                    f"12) in its run: no phase relative to the force; {UFF_FORM}")
    f = complex(force.values[0])
    return main.response_dof, force.response_dof, main.frequency_hz[0], abs(f), main.values[0] * f.conjugate() / abs(f)


def _read_uff(data: bytes, path: Path, options: ReadOptions) -> PhaseResonancePoints:
    records, others = run_records(data, path)
    if others:
        raise MeasurementTableError(f"{others[0][1]}: {others[0][2]}; {UFF_FORM}")
    groups = by_run(records)
    listing = f"; the file's runs: {', '.join(repr(r) for r in groups)}" if len(groups) > 1 else ""
    points = [_uff_point(run, members, path, options, listing) for run, members in groups.items()]
    if len({(r, i) for r, i, *_ in points}) != 1:
        raise MeasurementTableError(f"{path}: its runs name {len({(r, i) for r, i, *_ in points})} coordinate pairs "
                                    f"{sorted({(r, i) for r, i, *_ in points})}; a phase-resonance file is of one mode "
                                    f"at one response and one force")
    frequency, force, x = (np.array([p[k] for p in points]) for k in (2, 3, 4))
    _checked(str(path), frequency, force, np.abs(x))
    return PhaseResonancePoints(str(path), points[0][0], points[0][1], frequency.astype(float), force.astype(float),
                                x.astype(complex))


def read_phase_resonance(path: str | Path, options: ReadOptions | None = None) -> PhaseResonancePoints:
    """The points of a phase-resonance file (CSV or MATLAB; module docstring), read through
    the input gate; ``options`` carries ``--coordinates``. Lowest force first."""
    path = Path(path)
    options = options or ReadOptions()
    data = read_input_bytes(path, "phase-resonance file")
    kind = sniff(data[:4096])
    suffix = path.suffix.lower()
    if suffix == ".csv" and kind == "text":
        points = _read_csv(data, path, options)
    elif suffix == ".mat" and kind in ("mat5", "hdf5"):
        points = _read_mat(data, path, kind, options)
    elif suffix in (".uff", ".unv") and uff_content(data, kind):
        points = _read_uff(data, path, options)
    else:
        raise MeasurementTableError(f"{path}: a {suffix or 'suffix-less'} file holding {kind}; phase-resonance points "
                                    f"are read from .csv ({', '.join(CSV_COLUMNS)}), .mat or .uff/.unv (datasets 58: "
                                    f"one frequency line per level)")
    order = np.argsort(points.force_n, kind="stable")
    return PhaseResonancePoints(points.source, points.response_dof, points.input_dof, points.frequency_hz[order],
                                points.force_n[order], points.x[order])


def samples_from_phase_resonance(points: PhaseResonancePoints, response_shape: float,
                                 input_shape: float | None = None) -> ModalSamples:
    """One backbone sample per point (module docstring): ``a = |X_r|/|φ_r|``, ω and ζ from the
    force balance at the point's phase. ``response_shape`` φ_r and ``input_shape`` φ_f
    (1/√kg, signed; φ_f defaults to φ_r: a driving point)."""
    phi_r = float(response_shape)
    phi_f = phi_r if input_shape is None else float(input_shape)
    if not (np.isfinite(phi_r) and phi_r != 0 and np.isfinite(phi_f) and phi_f != 0):
        raise MeasurementTableError(f"{points.source}: the mode shape at {points.response_dof} and {points.input_dof} "
                                    f"must be finite and ≠ 0 (1/√kg)")
    omega_x = 2 * np.pi * points.frequency_hz
    a = np.abs(points.x) / abs(phi_r)
    theta = np.angle(points.x * np.sign(phi_r * phi_f))
    p = abs(phi_f) * points.force_n / a
    omega, zeta = natural_and_damping(p * np.exp(-1j * theta), omega_x)
    bad = ~np.isfinite(omega) | (np.sin(theta) >= 0)
    if np.any(bad):
        i = int(np.argmax(bad))
        raise MeasurementTableError(
            f"{points.source}: the point at {points.frequency_hz[i]:.6g} Hz, {points.force_n[i]:.4g} N has its "
            f"displacement {np.degrees(theta[i]):.1f}° from the modal force; expected between −180° and 0° (−90° at "
            f"phase resonance): a sensor along the negative direction? (NODE:-DIR in --coordinates)")
    return ModalSamples(a, omega / (2 * np.pi), zeta, points.force_n, abs(phi_f))
