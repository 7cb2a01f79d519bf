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
for displacement, velocity, acceleration).

Each run: one mode fitted by :func:`~nlupdate.core.identification.modal_fit.fit_mode_near` near
the run's peak (residual terms for the other modes; structural damping, loss factor η, so
``ζ = η/2`` at resonance). The modal amplitude is ``a = X/|φ_r|`` with φ_r the shape at the
held coordinate: given, or from the lowest-amplitude run's modal constant, ``φ_r² = Re A``
at a driving point (the held response collocated with the force).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.identification.amplitude_modal_fit import ModalSamples
from nlupdate.core.identification.modal_fit import fit_mode_near
from nlupdate.input_files import read_input_bytes, sniff
from nlupdate.core.measurement.frf_table import MeasurementTableError
from nlupdate.core.measurement.matfile import (
    _RUN_FIELDS, _raw_variables, _run_coordinates, _run_groups, _run_units, _run_vector, _spread,
)
from nlupdate.core.measurement.units import ReadOptions


@dataclass(frozen=True)
class HeldRun:
    """One response-controlled run: ``frequency_hz``, receptance ``h`` (m/N, the sensor's
    sign applied), the held displacement amplitude ``held_m`` (m), the force at each line
    ``force_n`` (N) and the run's name."""

    name: str
    response_dof: str
    input_dof: str
    frequency_hz: NDArray[np.float64]
    h: NDArray[np.complex128]
    held_m: float
    force_n: NDArray[np.float64]


def read_response_controlled(path: str | Path, options: ReadOptions | None = None) -> list[HeldRun]:
    """The response-controlled runs of a MATLAB stepped-sine file (module docstring), lowest
    held amplitude first; ``options`` carries ``--coordinates`` and the reference unit."""
    path = Path(path)
    options = options or ReadOptions()
    data = read_input_bytes(path, "response-controlled stepped-sine file")
    kind = sniff(data[:4096])
    if path.suffix.lower() != ".mat" or kind not in ("mat5", "hdf5"):
        raise MeasurementTableError(f"{path}: a {path.suffix or 'suffix-less'} file holding {kind}; response-controlled "
                                    f"runs are read from MATLAB stepped-sine files (.mat: runs with fields "
                                    f"{', '.join(_RUN_FIELDS)}, units)")
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
            held = float(np.median(np.abs(amplitude) * response_factor / np.abs(iw) ** power))
            runs.append(HeldRun(where.split(": ", 1)[1], response, inp, frequency, h / iw**power, held,
                                force * reference_factor))
    if not runs:
        raise MeasurementTableError(f"{path}: holds no response-controlled run (none holds its response amplitude "
                                    f"more steadily than its force)")
    return sorted(runs, key=lambda r: r.held_m)


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
