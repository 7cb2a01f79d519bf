"""A study as read from its TOML file: :class:`Study` and one typed section per table.

What each table and key means — type, unit, default, allowed values, with an example per
table — is documented once, in docs/study-files.md. Reading and checking the tables is
:mod:`nlupdate.study.sections`; loading a file, :mod:`nlupdate.study.loading`. Defaults
live with the settings they configure (:class:`~nlupdate.core.updating.eigensensitivity.EigensensitivityOptions`,
:class:`~nlupdate.core.identification.pipeline.IdentificationSettings`, …) and are not repeated.
"""
from __future__ import annotations

import contextlib
import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator, Mapping

from nlupdate.fe.adapters.base import Parameter
from nlupdate.fe.adapters.registry import AdapterSpec
from nlupdate.fingerprints import text_hash
from nlupdate.core.identification.pipeline import IdentificationSettings
from nlupdate.input_files import pinned, snapshot
from nlupdate.core.response.harmonic_balance import HarmonicSettings
from nlupdate.study.reader import StudyError
from nlupdate.core.updating.eigensensitivity import EigensensitivityOptions
from nlupdate.core.updating.optimisation import OptimisationOptions
from nlupdate.core.updating.residuals import ResponseOptions

__all__ = [
    "CandidateEntry", "ComparisonSpec", "EigensensitivitySpec", "MeasuredSpec", "PredictionSpec", "SimulationSpec", "ValidationSpec",
    "Study", "StudyError", "TargetsSpec", "inputs_read_once",
]

LOSS_FACTOR_SOURCES = ("low_force_fit", "identified")


@dataclass(frozen=True)
class SimulationSpec:
    """A simulated stepped-sine test on a hidden truth (``[measured.simulate]``).

    Either ``model_file`` (a model file with its elements) or ``adapter`` + ``parameters``
    (+ ``loss_factor``, ``elements``: element tables with coordinate-name dofs).
    frequencies_hz: the test grid (Hz); forces_n: force amplitudes (N); noise: docs/methods.md §8
    fraction (docs/methods.md §8); sweep: stepped-sine direction.
    """

    input_dof: str
    forces_n: tuple[float, ...]
    frequencies_hz: tuple[float, ...]
    noise: float = 0.0
    seed: int = 0
    sweep: str = "up"
    model_file: str | None = None
    adapter: AdapterSpec | None = None
    parameters: Mapping[str, float] = field(default_factory=dict)
    loss_factor: float = 0.0
    elements: tuple[Mapping[str, Any], ...] = ()


@dataclass(frozen=True)
class MeasuredSpec:
    """``[measured]``: a file (absolute path), several files of one measurement (``files``:
    absolute path → level, None when the file holds it), time histories turned into FRFs
    (``time_histories``, with ``input_dof``, ``excitation``, ``response_quantity``), or a
    :class:`SimulationSpec`. ``reference_unit`` (``"N"``/``"V"``, None: as the files say)
    and ``reference_calibration`` (N per V) state what the reference is; ``coordinates``
    (absolute path → (response, input)) names the coordinates of files that do not;
    ``levels`` ((key, level): a file's absolute path, ``<path>#<run>`` or a run name, as
    ``--level`` takes them) gives the levels of files and runs that do not hold them."""

    file: str | None = None
    simulate: SimulationSpec | None = None
    files: tuple[tuple[str, float | None], ...] = ()
    time_histories: tuple[str, ...] = ()
    reference_unit: str | None = None
    reference_calibration: float | None = None
    input_dof: str | None = None
    excitation: str = "auto"
    response_quantity: str = "displacement"
    coordinates: tuple[tuple[str, tuple[str, str]], ...] = ()
    levels: tuple[tuple[str, float], ...] = ()

    def read_options(self):
        """The :class:`~nlupdate.core.measurement.units.ReadOptions` of these statements."""
        from nlupdate.core.measurement.units import ReadOptions

        levels = {path: level for path, level in self.files if level is not None}
        levels.update(dict(self.levels))
        return ReadOptions(self.reference_unit, self.reference_calibration, levels, dict(self.coordinates))


@dataclass(frozen=True)
class CandidateEntry:
    """One ``[[optimisation.candidates]]`` entry."""

    name: str
    parameters: tuple[str, ...]
    weights: tuple[float, ...] | None
    start: Mapping[str, float]


@dataclass(frozen=True)
class PredictionSpec:
    """``[prediction]`` (see the module docstring). ``harmonic_balance``: None for the
    describing-function continuation (``method = "continuation"``), else the harmonic
    balance settings of ``method = "hb"``."""

    force_levels_n: tuple[float, ...] | None = None
    candidates: str | tuple[str, ...] = "best"
    loss_factor: str | float = "low_force_fit"
    sweep: str = "up"
    adapter_options: Mapping[str, Any] = field(default_factory=dict)
    harmonic_balance: HarmonicSettings | None = None


@dataclass(frozen=True)
class ValidationSpec:
    """``[validation]``: the measured driving-point curve judged on held-out levels, as
    ``nlupdate validate`` does (docs/methods.md §10): ``hold_out`` (``"each"``, ``"top"`` or
    levels in the reference unit), ``models`` (:mod:`nlupdate.core.validation.models` names or
    ``"auto"``), ``input_dof`` (default: the identification's input, else the table's only
    one), ``response_controlled`` (predict the response-controlled runs of the measured
    MATLAB files from all force-controlled levels; default true)."""

    hold_out: str | tuple[float, ...] = "each"
    models: tuple[str, ...] = ("auto",)
    input_dof: str | None = None
    response_controlled: bool = True


@dataclass(frozen=True)
class TargetsSpec:
    """``[targets]``: what the updated model must match — ``frequencies_hz`` (Hz, with
    ``std_hz``), the modes of the study's extracted linear FRF (``from_identification``,
    ``modes``), the peaks of an earlier identification's linear FRF (``identification``:
    the path as written; ``n_modes``, ``band_hz``, ``force_level_n``, ``frf_method``), or
    the linear limits of amplitude-dependent modal models (``amplitude_models``, paths as
    written); the measured pair (``response_dof``, ``input_dof``) and its coordinates in
    the FE model; per target mode ``weights``, ``labels``, ``model_modes`` and mode shapes
    (``mode_shapes``, one row per mode, at ``coordinates``)."""

    frequencies_hz: tuple[float, ...] | None = None
    std_hz: tuple[float, ...] | None = None
    from_identification: bool = False
    modes: tuple[int, ...] | None = None
    identification: str | None = None
    n_modes: int | None = None
    band_hz: tuple[float, float] | None = None
    force_level_n: float | None = None
    frf_method: str = "peak"
    amplitude_models: tuple[str, ...] = ()
    response_dof: str | None = None
    input_dof: str | None = None
    model_response_dof: str | None = None
    model_input_dof: str | None = None
    weights: tuple[float, ...] | None = None
    labels: tuple[str, ...] = ()
    model_modes: tuple[int, ...] = ()
    coordinates: tuple[str, ...] = ()
    mode_shapes: tuple[tuple[float, ...], ...] | None = None


@dataclass(frozen=True)
class EigensensitivitySpec:
    """``[eigensensitivity]``: the formulas × parameter sets of the sweep and the iteration's
    settings (with the ``[updating]`` ones; each run sets its formula)."""

    formulas: tuple[str, ...]
    parameter_sets: tuple[tuple[str, ...], ...]
    options: EigensensitivityOptions = EigensensitivityOptions()


@dataclass(frozen=True)
class ComparisonSpec:
    """``[comparison]``: the user's weights of the target modes (a list, or label → weight;
    None: the target weights), the modal damping of the candidates' FRFs (None: see
    :func:`nlupdate.study.steps.updating.comparison_damping`), the FRAC band around each mode
    (fraction of its frequency) and an FRF to compare with (path, or None)."""

    user_weights: tuple[float, ...] | Mapping[str, float] | None = None
    damping_ratios: float | tuple[float, ...] | None = None
    loss_factors: float | tuple[float, ...] | None = None
    band_fraction: float = 0.1
    frf: str | None = None


@dataclass(frozen=True, eq=False)
class Study:
    """A parsed and checked study file. ``sha256`` is the hash of its text; ``input_files``
    maps every path the study names (as written) to the file read for it; ``snapshots``
    holds their bytes once a run has read them (:func:`inputs_read_once`)."""

    path: Path
    name: str
    description: str
    text: str
    measured: MeasuredSpec | None
    identification: IdentificationSettings | None
    adapter: AdapterSpec | None
    fixed: Mapping[str, float]
    parameters: tuple[Parameter, ...]
    targets: TargetsSpec | None
    updating: ResponseOptions
    eigensensitivity: EigensensitivitySpec | None
    optimisation: OptimisationOptions | None
    candidates: tuple[CandidateEntry, ...]
    comparison: ComparisonSpec
    prediction: PredictionSpec | None
    validation: ValidationSpec | None = None
    input_files: Mapping[str, Path] = field(default_factory=dict)
    snapshots: Mapping[str, bytes] = field(default_factory=dict, repr=False)

    @property
    def sha256(self) -> str:
        return text_hash(self.text)

    def resolve(self, written: str) -> Path:
        """The file read for a path as written in the study (see :attr:`input_files`)."""
        if written in self.input_files:
            return self.input_files[written]
        path = Path(written)
        return path if path.is_absolute() else self.path.parent / path

    def parameter(self, name: str) -> Parameter:
        return next(p for p in self.parameters if p.name == name)


@contextlib.contextmanager
def inputs_read_once(study: Study) -> Iterator[Study]:
    """``study`` with the bytes of every file it names read now, and pinned for the block
    (:func:`nlupdate.input_files.pinned`): every step, hash and archive copy of the run sees
    those bytes, even if a file is replaced on disk meanwhile."""
    taken = study if study.snapshots else dataclasses.replace(study, snapshots=snapshot(study.input_files.values()))
    with pinned(taken.snapshots):
        yield taken
