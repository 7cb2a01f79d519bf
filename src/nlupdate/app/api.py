"""The public Python API: the CLI's work as plain function calls (``import nlupdate as nlu``).

Each function here is a thin front to the numerics the commands run — the same calls with
friendlier arguments (a path or an object where a path or an object is natural, defaults
chosen as the CLI chooses them) — so a notebook gets exactly the numbers the CLI prints.
The modules they call are imported inside each function: ``import nlupdate`` stays light.

Conventions everywhere: SI units (m, N, kg, s, Pa); frequencies in Hz at every interface
(rad/s only inside the solvers); harmonic motion ``x(t) = Re(X e^{iωt})``; FRFs are
receptances ``H = X/F`` in m/N; ``Z = K − ω²M + iωC + iD``. Coordinates (dofs) are named
by strings (``"0"``, ``"x1"``, ``"tip:uz"``); an integer index is accepted where a model is
at hand. Measured FRFs travel as the long measured-FRF table of
:mod:`nlupdate.core.measurement.frf_table` (columns ``frequency_hz``, ``force_level_n``,
``response_dof``, ``input_dof``, ``h_real``, ``h_imag``).

Running a study as Prefect flows is one layer up and is imported from there:
``from nlupdate.orchestration.flows.run import run_study_flow`` (docs/python-api.md).
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Mapping, Sequence

if TYPE_CHECKING:
    import numpy as np
    import pandas as pd
    from numpy.typing import ArrayLike, NDArray

    from nlupdate.fe.adapters.base import FEAdapter, ModalResult, Parameter
    from nlupdate.fe.adapters.registry import AdapterSpec
    from nlupdate.core.discovery.workflow import DiscoveryResult
    from nlupdate.core.identification.pipeline import Identification
    from nlupdate.core.model.system import NonlinearSystem
    from nlupdate.core.prediction.predict import LevelPredictions
    from nlupdate.core.response.harmonic_balance import HarmonicSettings
    from nlupdate.study.chain import StudyResult
    from nlupdate.study.spec import Study
    from nlupdate.core.updating.eigensensitivity import UpdatingResult
    from nlupdate.core.updating.targets import UpdatingTargets

PathLike = str | os.PathLike


# ----------------------------------------------------------------------------- models
def load_model(path: PathLike) -> NonlinearSystem:
    """Read a TOML model file: a linear model (``[model]``: lumped matrices in kg, N/m,
    N·s/m and a loss factor, or modal: natural frequencies in Hz, mass-normalised shapes
    in 1/√kg, damping ratios) plus ``[[nonlinear]]`` elements (``cubic`` k3 in N/m³,
    ``jenkins`` kf in N/m and slip_force in N, …; README "Model files").

    Returns a :class:`~nlupdate.core.model.system.NonlinearSystem` (``.model``: the linear
    model, ``.elements``: the elements). A file that cannot be used raises
    :class:`~nlupdate.core.model.model_file.ModelFileError` naming the file, table and key."""
    from nlupdate.core.model.model_file import load_system

    return load_system(path)


def model_from_dict(data: Mapping[str, Any], source: str = "<model>") -> NonlinearSystem:
    """The model a TOML model file would hold, from the same tables as a dict
    (``{"model": {...}, "nonlinear": [{...}, ...]}``; units as in :func:`load_model`);
    ``source`` names it in error messages."""
    from nlupdate.core.model.model_file import system_from_dict

    return system_from_dict(data, source)


def save_model(model: NonlinearSystem, path: PathLike) -> Path:
    """Write ``model`` as a TOML model file that :func:`load_model` reads back to the same
    model (written atomically); returns the path."""
    from nlupdate.core.model.model_file import write_system

    return write_system(model, path)


def _model(model: NonlinearSystem | PathLike) -> NonlinearSystem:
    return load_model(model) if isinstance(model, (str, os.PathLike)) else model


# ----------------------------------------------------------------------------- measurements
def load_measurements(
    *paths: PathLike,
    reference_unit: str | None = None,
    newtons_per_volt: float | None = None,
    levels: Mapping[str, float] | None = None,
    coordinates: Mapping[str, tuple[str, str]] | None = None,
) -> pd.DataFrame:
    """Measured FRFs from one file or several (one per force level or run) as one
    measured-FRF table: ``.parquet``, ``.csv``, UFF 58 (``.uff``/``.unv``; mobility and
    accelerance are converted to receptance, m/N) or MATLAB ``.mat`` (docs/measured-data.md).

    ``reference_unit``: ``"N"`` or ``"V"`` when the files do not say (``"V"``: FRFs and
    levels per volt of the excitation); ``newtons_per_volt`` converts per-volt data to
    per-newton; ``levels``: file name → force level (N) of a file that does not hold it;
    ``coordinates``: file name → (response, input) of a file that does not name them
    (``"acc3:-y"`` states a sensor along the negative axis). Bad input raises
    :class:`~nlupdate.core.measurement.frf_table.MeasurementTableError` naming file, row and column."""
    from nlupdate.core.measurement.frf_files import read_frf_tables
    from nlupdate.core.measurement.units import ReadOptions

    options = ReadOptions(reference_unit, newtons_per_volt, dict(levels or {}), dict(coordinates or {}))
    return read_frf_tables(paths, options=options)


def save_measurements(table: pd.DataFrame, path: PathLike) -> Path:
    """Write a measured-FRF table as ``.parquet``, ``.csv`` or ``.uff`` (by the suffix),
    validated and atomically; returns the path."""
    from nlupdate.core.measurement.frf_files import write_frf_table

    return write_frf_table(table, path)


def select_frf(
    table: pd.DataFrame, response_dof: str, input_dof: str, force_level_n: float,
) -> tuple[NDArray[np.float64], NDArray[np.complex128]]:
    """One curve of a measured-FRF table: (frequencies in Hz, ascending; complex receptance
    H in m/N) of the ``response_dof``/``input_dof`` pair at ``force_level_n`` (N, matched
    within 1e-9 relative). A missing curve raises an error listing the curves there are."""
    from nlupdate.core.measurement.frf_table import select_frf as select

    return select(table, str(response_dof), str(input_dof), force_level_n)


def _measurements(measured: pd.DataFrame | PathLike | Sequence[PathLike]) -> pd.DataFrame:
    if isinstance(measured, (str, os.PathLike)):
        return load_measurements(measured)
    if isinstance(measured, (list, tuple)):
        return load_measurements(*measured)
    return measured


# ----------------------------------------------------------------------------- simulate
def simulate(
    model: NonlinearSystem | PathLike,
    input_dof: int | str,
    frequency_hz: ArrayLike,
    force_levels_n: Sequence[float],
    *,
    method: str = "continuation",
    sweep: str = "up",
    noise: float = 0.0,
    seed: int | None = None,
    harmonic_balance: HarmonicSettings | None = None,
) -> pd.DataFrame:
    """Nonlinear FRFs of ``model`` (a :class:`~nlupdate.core.model.system.NonlinearSystem` or a
    model file) as a stepped-sine test would measure them: a harmonic force of amplitude F
    (each of ``force_levels_n``, N) at ``input_dof``, the receptance ``H = X/F`` (m/N, first
    harmonic, ``x(t) = Re(X e^{iωt})``) of every coordinate at each of ``frequency_hz`` (Hz).

    ``method``: ``"continuation"`` (describing function, the traced curve read as a test
    sweeping ``sweep`` = ``"up"``/``"down"``, with its jumps), ``"hb"`` (multi-harmonic
    balance with ``harmonic_balance`` settings, default 3 harmonics), ``"fixed-point"`` or
    ``"time"`` (direct time integration). ``noise``: complex Gaussian noise of std
    ``noise·|H|`` (e.g. 0.05), reproducible with ``seed``. Returns the measured-FRF table;
    frequencies where a method does not converge are left out."""
    from nlupdate.core.response.harmonic_balance import HarmonicSettings
    from nlupdate.core.response.simulate import simulate_frf_table

    table, _ = simulate_frf_table(_model(model), input_dof, frequency_hz, force_levels_n, method=method, sweep=sweep,
                                  noise=noise, seed=seed, harmonic_balance=harmonic_balance or HarmonicSettings())
    return table


# ----------------------------------------------------------------------------- identify
def identify(
    measured: pd.DataFrame | PathLike | Sequence[PathLike],
    *,
    response_dof: str | None = None,
    input_dof: str | None = None,
    method: str = "prd",
    elements: Sequence[str] = (),
    samples: int = 200,
    seed: int = 0,
    **settings: Any,
) -> Identification:
    """Identify the nonlinearity and the *linear* FRF from FRFs measured at several force
    levels (a measured-FRF table or its file(s)), as ``nlupdate identify`` does.

    ``response_dof``/``input_dof``: the measured pair (default: the table's only input, at
    the driving point); the nonlinearity acts at the response coordinate, to ground.
    ``method``: ``"prd"`` (default) or ``"ddf"``. ``elements``: physical elements to fit
    (``("cubic", "jenkins")``, ``("iwan",)``, …); empty: a polynomial describing function.
    ``samples``/``seed``: Monte-Carlo samples of the uncertainty. Further keywords are the
    fields of :class:`~nlupdate.core.identification.settings.IdentificationSettings`
    (``frequency_hz``, ``low_force_n``, ``band_hz``, ``noise_fraction``, …); every one left
    out is chosen and listed in ``defaults_used``.

    Returns an :class:`~nlupdate.core.identification.pipeline.Identification`: ``parameters()``
    (SI: k3 N/m³, kf N/m, slip_force N, …), ``uncertainty.parameters[name]`` (value, std,
    ci95), ``linear_frequency_hz``/``linear_frf`` (extracted receptance, m/N),
    ``natural_frequencies_hz`` (Hz) and ``loss_factors`` of its modes, ``warnings``,
    ``summary()`` (the content of identification.json)."""
    from nlupdate.core.identification.data import FRFLevels
    from nlupdate.core.identification.pipeline import identify as run
    from nlupdate.core.identification.settings import IdentificationSettings
    from nlupdate.core.measurement.frf_table import measured_pair

    table = _measurements(measured)
    response_dof, input_dof, _ = measured_pair(table, input_dof, response_dof)
    settings = IdentificationSettings(response_dof=response_dof, input_dof=input_dof, method=method,
                                      elements=tuple(elements), samples=samples, seed=seed, **settings)
    return run(FRFLevels.from_table(table, settings.response_dof, settings.input_dof), settings)


# ----------------------------------------------------------------------------- update
def fe_model(kind: str, model: str | None = None, **options: Any) -> FEAdapter:
    """An FE model behind the adapter interface: ``kind`` ``"lumped"`` (spring–mass chain,
    ``masses`` kg, ``stiffnesses`` N/m; parameters ``m1…``, ``k1…``, coordinates ``x1…``),
    ``"surrogate"`` (``model`` ``"tbeam"`` or ``"gunbarrel"``; parameters such as ``E`` in
    Pa, ``h2`` in m), ``"calculix"`` or ``"mapdl"``; ``options`` as in a study's
    ``[adapter.options]`` (docs/study-files.md). ``adapter.evaluate({name: value})``
    returns the natural frequencies (Hz) and mass-normalised mode shapes (1/√kg) at the
    named coordinates (:class:`~nlupdate.fe.adapters.base.ModalResult`)."""
    from nlupdate.fe.adapters.registry import AdapterSpec, build_adapter

    return build_adapter(AdapterSpec(kind, model, options))


def update(
    model: FEAdapter | AdapterSpec,
    parameters: Sequence[Parameter],
    targets_hz: Sequence[float] | UpdatingTargets,
    *,
    method: str = "eigensensitivity",
    formula: str | None = None,
    weights: Sequence[float] | None = None,
    model_modes: Sequence[int] = (),
    fixed: Mapping[str, float] | None = None,
    name: str = "",
    **options: Any,
) -> UpdatingResult:
    """Update the linear FE ``model`` so its natural frequencies meet ``targets_hz`` (Hz,
    e.g. the modes of the linear FRF :func:`identify` extracted), as one run of a study.

    ``parameters``: :class:`~nlupdate.fe.adapters.base.Parameter` (name, unit, start, lower,
    upper bound, relative finite-difference step), in the model's units (SI: E in Pa, k in N/m).
    ``method``: ``"eigensensitivity"`` (inverse eigensensitivity, iterations of a
    finite-difference Jacobian: ``formula`` ``forward``, ``backward``, ``central2`` or
    ``central4``; default the one the study's ``[updating]`` table declares, ``forward``) or ``"optimisation"`` (bounded weighted least squares). ``weights``:
    per target mode; ``model_modes``: 1-based model modes paired with the targets (default
    1, 2, …); ``fixed``: values of other model parameters; further keywords are the fields
    of the method's options (``max_iterations``, ``frequency_tolerance``, ``pairing``, …).

    Returns an :class:`~nlupdate.core.updating.eigensensitivity.UpdatingResult`:
    ``parameters`` (updated values), ``converged``, ``stop`` (why it stopped: converged,
    iteration limit, cycle detected, parameter at bound, no decrease), ``reason``, ``iterations``, ``history``,
    ``frequencies_hz("initial"|"final")`` (paired, Hz), ``final`` (the updated modes),
    ``counts`` (FE runs new/cached)."""
    from nlupdate.fe.adapters.registry import AdapterSpec, build_adapter
    from nlupdate.core.updating.eigensensitivity import EigensensitivityOptions
    from nlupdate.core.updating.optimisation import OptimisationOptions
    from nlupdate.core.updating.runs import run_method
    from nlupdate.core.updating.targets import UpdatingTargets

    adapter = build_adapter(model) if isinstance(model, AdapterSpec) else model
    targets = targets_hz if isinstance(targets_hz, UpdatingTargets) else \
        UpdatingTargets(frequencies_hz=targets_hz, weights=weights, model_modes=tuple(model_modes))
    kinds = {"eigensensitivity": EigensensitivityOptions, "optimisation": OptimisationOptions}
    if method not in kinds:
        raise ValueError(f"updating method must be one of {list(kinds)}, got {method!r}")
    if formula is not None:
        options["formula"] = formula
    method_options = kinds[method](**options)
    return run_method(method, adapter, tuple(parameters), targets, method_options,
                      fixed, name or f"{method} {method_options.formula}")


# ----------------------------------------------------------------------------- predict
def predict(
    modes: ModalResult | UpdatingResult,
    identification: Identification,
    measured: pd.DataFrame | PathLike | Sequence[PathLike],
    *,
    response_dof: str | None = None,
    input_dof: str | None = None,
    model_response_dof: str | None = None,
    model_input_dof: str | None = None,
    loss_factor: float | str = "low_force_fit",
    force_levels_n: Sequence[float] | None = None,
    sweep: str = "up",
    harmonic_balance: HarmonicSettings | None = None,
) -> LevelPredictions:
    """Predict the measurement at every force level with the updated nonlinear model — the
    FE ``modes`` (an :class:`~nlupdate.core.updating.eigensensitivity.UpdatingResult`'s final
    model, or a :class:`~nlupdate.fe.adapters.base.ModalResult`) plus the elements
    ``identification`` found — and correlate it with the measurement level by level.

    ``response_dof``/``input_dof``: the measured pair (default: the identification's);
    ``model_response_dof``/``model_input_dof``: the same coordinates in the FE model
    (default: the measured names; at a driving point the input defaults to the response). ``loss_factor``: the modal loss factor η of every mode,
    ``"low_force_fit"`` (default: fitted to the lowest level, where the joint sticks) or
    ``"identified"`` (the extracted linear FRF's modes). ``force_levels_n``: default every
    measured level (N), at every measured frequency (Hz). Solver: describing function, or
    ``harmonic_balance``.

    Returns :class:`~nlupdate.core.prediction.predict.LevelPredictions`: ``loss_factor``,
    ``table`` (predicted receptances, m/N) and ``correlation`` (per level: ``frac``,
    ``normalised_error``, ``peak_frequency_error_pct``, ``peak_amplitude_ratio``)."""
    from nlupdate.core.prediction.predict import chosen_loss_factor, model_dofs, predict_measured

    final = getattr(modes, "final", modes)
    response = str(response_dof or identification.settings.response_dof)
    inp = str(input_dof or identification.settings.input_dof)
    model_response, model_input = model_dofs(response, inp, model_response_dof or None, model_input_dof)
    coordinates = list(final.coordinates)
    if model_response not in coordinates:
        raise ValueError(f"model_response_dof {model_response!r} is not a coordinate of the FE model {coordinates}")
    elements = identification.elements((coordinates.index(model_response),))
    return predict_measured(final, elements, _measurements(measured), response, inp, model_response_dof=model_response,
                            model_input_dof=model_input,
                            loss_factor=chosen_loss_factor(loss_factor, identification),
                            force_levels_n=force_levels_n, sweep=sweep,
                            harmonic_balance=harmonic_balance)


# ----------------------------------------------------------------------------- discover
def discover(
    model: NonlinearSystem | PathLike,
    measured: pd.DataFrame | PathLike,
    **options: Any,
) -> DiscoveryResult:
    """Find the effects ``model`` is missing against measurements at several force levels —
    where, which (friction, cubic stiffness, gap, quadratic damping, …) and their
    parameters — add them and show the gap shrink, as ``nlupdate discover`` does.

    ``measured``: a measured-FRF table, or a file of one, or a modal table (CSV with
    ``force_level_n``, ``mode``, ``natural_frequency_hz``, ``damping_ratio``). Keywords are
    the fields of :class:`~nlupdate.core.discovery.workflow.DiscoveryOptions` (``effects``,
    ``max_effects``, ``criterion``, ``noise_fraction``, ``sweep``, …).

    Returns a :class:`~nlupdate.core.discovery.workflow.DiscoveryResult`: ``effects`` (each with
    ``name``, ``dofs``, ``parameters`` in SI), ``augmented`` (the model with them, ready for
    :func:`save_model`), ``gap_before.gap``/``gap_after.gap`` (mean 1 − FRAC over the
    levels), ``misfit_ratio`` (residual over noise), ``summary()`` and ``warnings``."""
    from nlupdate.core.discovery.workflow import DiscoveryOptions
    from nlupdate.core.discovery.workflow import discover as run
    from nlupdate.core.measurement.modal_table import is_modal_table_file, read_modal_table

    source = "measured"
    if isinstance(measured, (str, os.PathLike)):
        source = str(measured)
        measured = read_modal_table(measured) if is_modal_table_file(measured) else load_measurements(measured)
    return run(_model(model), measured, DiscoveryOptions(**options), source=source)


# ----------------------------------------------------------------------------- studies
def load_study(path: PathLike) -> Study:
    """Read and check a study file (TOML: measured data, identification, FE model,
    parameters, targets, updating runs, prediction; docs/study-files.md). Raises
    :class:`~nlupdate.study.spec.StudyError` naming the file, table and key."""
    from nlupdate.study.loading import load_study as load

    return load(path)


def run_study(study: Study | PathLike, say: Callable[[str], None] | None = None) -> StudyResult:
    """Run every step a study asks for, in order, in this process, without Prefect (as
    ``nlupdate update``; the Prefect flows give the same numbers). ``say`` hears one line
    per step (e.g. ``print``). The study's input files are read once, as it starts.

    Returns a :class:`~nlupdate.study.chain.StudyResult`: ``measured``, ``identification``,
    ``targets``, ``runs`` (updating results) and ``failures``, ``comparison`` and
    ``ranking`` (tables), ``predictions`` (each with ``correlation`` per force level) and
    ``warnings``. ``nlupdate.reporting.archive.write_archive(result, folder, run_info)``
    writes it as an archive with report.md."""
    from nlupdate.study.sequential import run_study as run

    return run(load_study(study) if isinstance(study, (str, os.PathLike)) else study, say or (lambda message: None))
