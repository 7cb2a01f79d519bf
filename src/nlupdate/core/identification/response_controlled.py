"""Backbone samples of one mode from response-controlled stepped-sine runs.

A response-controlled run holds the first-harmonic amplitude of the response at one
coordinate while the frequency is stepped through the resonance, letting the force vary.
At a held amplitude the joint's describing function is fixed, so the run is a *linear*
one-mode FRF (METHODS.md §9): a one-mode fit of it gives the natural frequency ω(a) and
damping ratio ζ(a) at that amplitude directly — no force-level bookkeeping, no peak picking.

Reading (MATLAB stepped-sine runs as :mod:`nlupdate.core.measurement.matfile` reads them:
``frequency``, ``force``, ``amplitude``, ``phase``, ``units``): a run is response-controlled
when its response amplitude varies less along the run than its force (the rule that reader
uses to leave them out of force-controlled data). The FRF ``H = amplitude·e^{i·phase}/force``
is converted to receptance (m/N) with the sign of ``--coordinates`` (a sensor along −y), and
the held displacement amplitude is the median of ``|amplitude|/ω^p`` over the run (p = 0, 1, 2
for displacement, velocity, acceleration); each line keeps the displacement it achieved,
``|amplitude|/ω^p`` (``HeldRun.held_line_m``: a run holding acceleration holds a
displacement that falls as 1/ω² across the band, and a controller settles on the first lines).

Universal files (``.uff``/``.unv``: docs/ring-down.md states the layouts): datasets 58 grouped
into runs by their ID lines as for force-controlled exports
(:mod:`nlupdate.core.measurement.uff.run_records`). A run holds an FRF (function type 4) or a
response spectrum (type 12, complex), and optionally the force's spectrum (type 12, or auto
spectrum type 2, N²). Its **held amplitude** (the controller's target) is the one the user
gives, keyed as levels are (``options.levels``: ``nlupdate amplitude`` fills them from
``--held-amplitude FILE#RUN=VALUE``, ``RUN=VALUE``, or ``FILE=VALUE`` for a file of one run),
VALUE in the unit of the run's response record, else the amplitude its run name or ID lines name with a response unit
(:func:`~nlupdate.core.measurement.run_levels.held_amplitudes_in_text`: ``ResponseControl 20
m/s2``, ``Rc5ms2``, ``a=0.5 g``). The held displacement is the median of ``target/Ω^p`` over the
run (p of the target's unit). The **force** at each line is the force spectrum's amplitude,
else ``target/(Ω^p·|H|)``; with a force spectrum, the response it implies (``|H|·F``, or the
response spectrum) is compared with the target and a median difference above 10 % is warned
about (an RMS spectrum read as peak is 29 % low). Each line keeps the displacement ``|H|·F``
(the target's, without a force spectrum).

Each run: one mode fitted by :func:`~nlupdate.core.identification.modal_fit.fit_mode_near` near
the run's peak (residual terms for the other modes; structural damping, loss factor η, so
``ζ = η/2`` at resonance). The modal amplitude is ``a = X/|φ_r|`` with φ_r the shape at the
held coordinate: given, or from the lowest-amplitude run's modal constant, ``φ_r² = Re A``
at a driving point (the held response collocated with the force).
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.identification.modal_fit import fit_mode_near
from nlupdate.core.identification.modal_samples import ModalSamples
from nlupdate.core.measurement.frf_table import MeasurementTableError
from nlupdate.input_files import read_input_bytes, sniff
from nlupdate.core.measurement.matfile import (
    _RUN_FIELDS, _raw_variables, _run_coordinates, _run_groups, _run_units, _run_vector, _spread,
)
from nlupdate.core.measurement.run_levels import held_amplitudes_in_text
from nlupdate.core.measurement.uff.codes import field_label, id_lines
from nlupdate.core.measurement.uff.levels import named_in_id_lines
from nlupdate.core.measurement.uff.run_records import RunRecord, by_run, run_records, uff_content
from nlupdate.core.measurement.units import ReadOptions
from nlupdate.notices import NlupdateWarning


@dataclass(frozen=True)
class HeldRun:
    """One response-controlled run: ``frequency_hz``, receptance ``h`` (m/N, the sensor's
    sign applied), the held displacement amplitude ``held_m`` (m), the force at each line
    ``force_n`` (N) and the run's name. ``held_line_m``: the displacement the controller
    achieved on each line (m) — a run holding acceleration A holds A/Ω² (±2.5 % over the
    BRB's band), and the response on its first lines may lag the target — None for
    ``held_m`` on every line."""

    name: str
    response_dof: str
    input_dof: str
    frequency_hz: NDArray[np.float64]
    h: NDArray[np.complex128]
    held_m: float
    force_n: NDArray[np.float64]
    held_line_m: NDArray[np.float64] | None = None

    @property
    def held_on_lines(self) -> NDArray[np.float64]:
        """The displacement held on each line (m): ``held_line_m``, else ``held_m`` everywhere."""
        if self.held_line_m is None:
            return np.full(np.shape(self.frequency_hz), float(self.held_m))
        return np.asarray(self.held_line_m, dtype=float)


def read_response_controlled(path: str | Path, options: ReadOptions | None = None) -> list[HeldRun]:
    """The response-controlled runs of a MATLAB stepped-sine file (module docstring), lowest
    held amplitude first; ``options`` carries ``--coordinates`` and the reference unit."""
    path = Path(path)
    options = options or ReadOptions()
    data = read_input_bytes(path, "response-controlled stepped-sine file")
    kind = sniff(data[:4096])
    if path.suffix.lower() in (".uff", ".unv") and uff_content(data, kind):
        return sorted(_read_uff(data, path, options), key=lambda r: r.held_m)
    if path.suffix.lower() != ".mat" or kind not in ("mat5", "hdf5"):
        raise MeasurementTableError(f"{path}: a {path.suffix or 'suffix-less'} file holding {kind}; response-controlled "
                                    f"runs are read from MATLAB stepped-sine files (.mat: runs with fields "
                                    f"{', '.join(_RUN_FIELDS)}, units) or universal files (.uff/.unv: datasets 58, "
                                    f"an FRF or spectra per run)")
    runs = []
    for group, members in _run_groups(_raw_variables(data, path, kind, "response-controlled stepped-sine file")):
        for index, run in enumerate(members, start=1):
            where = f"{path}: {group}({index})" if len(members) > 1 else f"{path}: {group}"
            frequency = np.asarray(run["frequency"], dtype=float).ravel()
            force, amplitude, phase = (_run_vector(run, name, frequency.size, where) for name in _RUN_FIELDS[1:])
            if _spread(np.abs(amplitude)) >= _spread(force):
                continue  # force-controlled
            if np.any(force <= 0) or np.any(frequency <= 0):
                raise MeasurementTableError(f"{where}: field '{'force' if np.any(force <= 0) else 'frequency'}' holds a "
                                            f"value ≤ 0; expected forces > 0 (N) and frequencies > 0 (Hz)")
            power, response_factor, unit, reference_factor, phase_factor = _run_units(run, where, options.reference_unit)
            if unit != "N":
                raise MeasurementTableError(f"{where}: the reference is a voltage; response-controlled runs are read with "
                                            f"a force reference (N)")
            response, inp, sign = _run_coordinates(run, where, path, options)
            iw = 1j * 2 * np.pi * frequency
            h = sign * amplitude * response_factor * np.exp(1j * phase * phase_factor) / (force * reference_factor)
            achieved = np.abs(amplitude) * response_factor / np.abs(iw) ** power  # displacement on each line, m
            runs.append(HeldRun(where.split(": ", 1)[1], response, inp, frequency, h / iw**power,
                                float(np.median(achieved)), force * reference_factor, achieved))
    if not runs:
        raise MeasurementTableError(f"{path}: holds no response-controlled run (none holds its response amplitude "
                                    f"more steadily than its force)")
    return sorted(runs, key=lambda r: r.held_m)


_HELD_FORMS = "'ResponseControl 20 m/s2', 'Rc5ms2', 'a=0.5 g', 'Target_0p1mm'"


def _held_target(main: RunRecord, path: Path, options: ReadOptions, several: bool) -> tuple[float, int]:
    """(value in SI, power of iΩ that makes it a displacement) of a run's held amplitude
    (module docstring); one line naming the file, run and the forms expected when none."""
    file_level = options.level_of(str(path))
    if file_level is not None and several:
        raise MeasurementTableError(f"{path}: holds several runs; a held amplitude given for the file ({file_level:g}) "
                                    f"fits a file of one run: give each with --held-amplitude {path.name}#RUN=VALUE")
    given = options.level_of_run(str(path), main.run) if main.run else None
    given = file_level if given is None else given
    if given is not None:
        return given * main.to_si, main.power
    named = sorted(named_in_id_lines(main.dataset, held_amplitudes_in_text))
    if len(named) > 1:
        raise MeasurementTableError(f"{main.where}: the ID lines name several held amplitudes {named} (SI value, power "
                                    f"of iΩ); give it with --held-amplitude {path.name}#RUN=VALUE")
    if named:
        return named[0]
    forces = sorted(named_in_id_lines(main.dataset))
    hint = (f"; they name the force level {forces[0][0]:g} {forces[0][1] or ''}: a force-controlled run is read "
            f"with --measured") if forces else ""
    raise MeasurementTableError(
        f"{main.where}: no held response amplitude: expected the controller's target with a response unit (m, mm, "
        f"m/s, m/s^2, ms2, g …) in the run name or an ID line ({_HELD_FORMS}), or --held-amplitude "
        f"{path.name}#{main.run or 'RUN'}=VALUE in the unit of the response record "
        f"({field_label(main.dataset, 'ordinate_axis_units_lab') or 'unlabelled'}); found ID lines "
        f"{[line.strip() for line in id_lines(main.dataset)]}{hint}")


def _one(records: list[RunRecord], kind: str, where: str, what: str) -> RunRecord | None:
    chosen = [r for r in records if r.kind == kind]
    if len(chosen) > 1:
        raise MeasurementTableError(f"{where}: {len(chosen)} {what} (datasets {[r.index for r in chosen]}); a "
                                    f"response-controlled run holds one, at the controlled sensor")
    return chosen[0] if chosen else None


def _read_uff(data: bytes, path: Path, options: ReadOptions) -> list[HeldRun]:
    """The runs of a universal file (module docstring)."""
    records, others = run_records(data, path)
    if others:
        warnings.warn(f"{path}: skipped datasets that are no FRF nor spectrum: "
                      f"{', '.join(what + f' (dataset {i})' for i, _, what in others)}", NlupdateWarning, stacklevel=3)
    groups = by_run(records)
    runs = []
    for run, members in groups.items():
        where = f"{path}, run {run!r}" if run else f"{path}, dataset {members[0].index}"
        main = _one(members, "frf", where, "FRFs") or _one(members, "response", where, "response spectra")
        if main is None:
            raise MeasurementTableError(f"{where}: no FRF (function type 4) nor response spectrum (type 12); a "
                                        f"response-controlled run holds an FRF, or spectra of the response and force")
        forces = [r for r in members if r.kind == "force"]
        at_input = [r for r in forces if r.response_dof == main.input_dof]
        force = at_input[0] if len(at_input) == 1 else forces[0] if len(forces) == 1 else None
        if len(forces) > 1 and force is None:
            raise MeasurementTableError(f"{where}: {len(forces)} force spectra (datasets {[r.index for r in forces]}) "
                                        f"and none at the FRF's input {main.input_dof!r}; expected one")
        if main.kind == "response" and (force is None or not (main.has_phase and force.has_phase)):
            raise MeasurementTableError(f"{main.where}: a response spectrum needs the force's complex spectrum "
                                        f"(function type 12) in its run to make the FRF; expected that, or an FRF "
                                        f"(type 4)")
        frequency = main.frequency_hz
        if force is not None and (force.frequency_hz.shape != frequency.shape
                                  or not np.allclose(force.frequency_hz, frequency, rtol=1e-6)):
            raise MeasurementTableError(f"{force.where}: its frequency lines differ from those of dataset "
                                        f"{main.index}; expected the force at the same lines")
        h = main.values if main.kind == "frf" else main.values / force.values
        value, power = _held_target(main, path, options, len(groups) > 1)
        target = value / (2 * np.pi * frequency) ** power  # displacement, m
        if force is None:
            force_n = target / np.abs(h)
        else:
            force_n = np.abs(force.values)
            ratio = float(np.median(np.abs(h) * force_n / target))
            if abs(ratio - 1) > 0.1:
                warnings.warn(f"{where}: the response the force spectrum implies is {ratio:.3g} × the held amplitude "
                              f"({value:.4g} SI, power {power}): an RMS spectrum read as peak (0.707), or another "
                              f"target?", NlupdateWarning, stacklevel=3)
        runs.append(HeldRun(run or f"dataset {main.index}", main.response_dof,
                            main.input_dof if main.kind == "frf" else force.response_dof, frequency, h,
                            float(np.median(target)), force_n, np.abs(h) * force_n))
    return runs


def samples_from_held_runs(runs: list[HeldRun], shape: float | None = None,
                           band_fraction: float = 0.02) -> ModalSamples:
    """One sample per run (module docstring): ``(a, f, ζ)`` from a one-mode fit over the run's
    peak frequency × (1 ± ``band_fraction``); ``shape`` |φ_r| (1/√kg) at the held coordinate,
    default from the lowest-amplitude run's modal constant (a driving point)."""
    fits = []
    for run in runs:
        peak = float(run.frequency_hz[np.argmax(np.abs(run.h))])
        try:
            fits.append(fit_mode_near(run.frequency_hz, run.h, peak, band_fraction=band_fraction))
        except ValueError as error:
            raise MeasurementTableError(f"{run.name}: no one-mode fit ({error})") from None
    if shape is None:
        if runs[0].response_dof != runs[0].input_dof:
            raise MeasurementTableError(f"{runs[0].name}: the held response ({runs[0].response_dof}) is not at the force "
                                        f"({runs[0].input_dof}); give the shape at the held coordinate")
        constant = complex(fits[0].modal_constants[0])
        if constant.real <= 0:
            raise MeasurementTableError(f"{runs[0].name}: the one-mode fit's modal constant {constant:.4g} is not > 0 at "
                                        f"a driving point: a sensor along the negative direction? (--coordinates "
                                        f"FILE=NODE:-DIR,NODE:DIR)")
        shape = float(np.sqrt(constant.real))
    phi = abs(float(shape))
    held = np.array([run.held_m for run in runs])
    frequency = np.array([float(fit.natural_frequencies_hz[0]) for fit in fits])
    zeta = np.array([float(fit.loss_factors[0]) / 2 for fit in fits])
    force = np.array([float(np.min(run.force_n)) for run in runs])  # at resonance the force is least
    return ModalSamples(held / phi, frequency, zeta, force, phi)
