"""A study as read from its TOML file: :class:`Study` and one typed section per table.

The keys of a table whose values are plain settings are declared once, on the class the
table becomes (:func:`nlupdate.settings.setting`: form, unit, default, meaning; the keys of tables the
reader turns into something else, on :mod:`nlupdate.study.table_keys`): the study
reader checks the table from the declaration (:mod:`nlupdate.study.declared` lists which
classes declare which table) and docs/study-files.md's tables of keys are generated from it.
Defaults live with the settings they configure (:class:`~nlupdate.core.updating.eigensensitivity.EigensensitivityOptions`,
:class:`~nlupdate.core.identification.pipeline.IdentificationSettings`, …) and are not repeated.
Rules across keys (which keys go together, a length set by another table) are the readers'
(:mod:`nlupdate.study.sections` and its siblings); loading a file, :mod:`nlupdate.study.loading`.
"""
from __future__ import annotations

import contextlib
import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator, Mapping

from nlupdate.core.response.method import HARMONICS_FORM, MAX_HARMONICS, RESPONSE_METHODS
from nlupdate.core.updating.targets import FRF_METHODS
from nlupdate.core.validation.held_response import RESPONSE_CONTROLLED
from nlupdate.core.validation.held_type import BACKBONE_OF_MODEL, HELD_TYPES
from nlupdate.fe.adapters.base import Parameter
from nlupdate.fe.adapters.registry import AdapterSpec
from nlupdate.fingerprints import text_hash
from nlupdate.core.identification.pipeline import IdentificationSettings
from nlupdate.core.prediction.predict import LOSS_FACTOR_SOURCES
from nlupdate.input_files import pinned, snapshot
from nlupdate.core.response.harmonic_balance import HarmonicSettings
from nlupdate.study.reader import StudyError
from nlupdate.core.updating.eigensensitivity import EigensensitivityOptions
from nlupdate.core.updating.optimisation import OptimisationOptions
from nlupdate.core.updating.residuals import ResponseOptions
from nlupdate.core.validation.fe_settings import FEValidationSettings
from nlupdate.settings import setting
from nlupdate.study.amplitude import AmplitudeSpec

__all__ = [
    "CandidateEntry", "ComparisonSpec", "EigensensitivitySpec", "MeasuredSpec", "PredictionSpec", "SimulationSpec", "ValidationSpec",
    "Study", "StudyError", "TargetsSpec", "inputs_read_once",
]



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

    name: str = setting(kind="string", default_text='`"candidate <i>"`', meaning='run name; distinct, not `"initial"`')
    parameters: tuple[str, ...] = setting(kind="strings", required=True, min_length=1,
                                          meaning="distinct names from `[[parameters]]`")
    weights: tuple[float, ...] | None = setting(
        None, kind="numbers", default_text="the `[targets]` weights",
        meaning="mode weights of this candidate, one per target mode (needs the number of targets known: not with "
                "`from_identification` without `modes`)")
    start: Mapping[str, float] = setting(
        default_factory=dict, kind="number_table", unit="parameter units", default_text="each parameter's `start`",
        meaning="other start values for this candidate; names from its `parameters`, within bounds")


@dataclass(frozen=True)
class PredictionSpec:
    """``[prediction]``: each key's declaration says its meaning. ``harmonic_balance``: None
    for the describing-function continuation (``method = "continuation"``), else the harmonic
    balance settings of ``method = "hb"``."""

    force_levels_n: tuple[float, ...] | None = setting(
        None, kind="numbers", min_length=1, minimum=0, above_minimum=True, unit="N",
        default_text="every level of the measured curve",
        meaning="levels to predict. At present it must list exactly the measured levels of the curve: a measured "
                "level left out stops the correlation and an unmeasured level stops the archive's plots, both with "
                "`no measured FRF for … force_level_n=…`")
    candidates: str | tuple[str, ...] = setting(
        "best", kind="choice|strings", choices=("best", "all"), min_length=1,
        form_text='"best", "all" or a list of run names',
        meaning="runs to predict with besides `initial`: the best-ranked run, every run, or named runs "
                "(eigensensitivity names as above, candidate names)")
    loss_factor: str | float = setting(
        "low_force_fit", kind="choice|number", choices=LOSS_FACTOR_SOURCES, minimum=0,
        meaning="modal loss factor η of every mode: fitted to the lowest predicted level's measurement (searched in "
                "1e-4–0.2; a fit that ends on either end is a warning, `loss_factor_at_bound`), the mean of the "
                "identified modes' loss factors, or this value")
    sweep: str = setting("up", kind="choice", choices=("up", "down"), meaning="stepped-sine direction of the prediction")
    adapter_options: Mapping[str, Any] = setting(
        default_factory=dict, kind="table",
        meaning="overrides of `[adapter.options]` for the prediction model (e.g. more modes, local ones included); "
                "its coordinates must include the prediction coordinates")
    method: str = setting(
        "continuation", kind="choice", choices=RESPONSE_METHODS,
        meaning="how the nonlinear response is computed, for the prediction and the `low_force_fit` of the loss "
                "factor: the describing-function continuation, or multi-harmonic balance (its first harmonic, read as "
                "the same stepped-sine test; stability by Floquet multipliers). The keys below apply to `\"hb\"` "
                "only, and are an error otherwise")
    harmonics: int | str = setting(
        HarmonicSettings.harmonics, kind="integer|choice", choices=("auto",), minimum=1, maximum=MAX_HARMONICS,
        form_text=HARMONICS_FORM,
        meaning='harmonics H of the balance; `"auto"` takes the first of 3, 5, 7, 9, 11, 15, … 31 whose two highest '
                "harmonics carry ≤ 0.1 % of the response. `1` gives the describing-function result for elements "
                "symmetric in displacement (no constant term)")
    samples: int | None = setting(
        HarmonicSettings.samples, kind="integer", minimum=1, unit="per period",
        default_text="power of two ≥ max(64, 8·(H+1))",
        form_text='an integer > 2·harmonics (> 62 with "auto")',
        meaning="time samples per period of the element forces (alternating frequency–time)")
    stability: bool = setting(
        HarmonicSettings.stability, kind="boolean",
        meaning="Floquet multipliers at every curve point (Hill's method); `false`: stability from the sign of the "
                "Jacobian (folds only)")

    @property
    def harmonic_balance(self) -> HarmonicSettings | None:
        """The harmonic balance settings of ``method = "hb"`` (None: the continuation)."""
        if self.method != "hb":
            return None
        return HarmonicSettings(harmonics=self.harmonics, samples=self.samples, stability=self.stability)


@dataclass(frozen=True)
class ValidationSpec:
    """``[validation]``: the measured driving-point curve judged on held-out levels, as
    ``nlupdate validate`` does (docs/methods.md §10), and a whole test type held out, as
    ``nlupdate validate --hold-out-type`` does (each key: its declaration; the command's
    options of the same meaning are made from it)."""

    hold_out: str | tuple[float, ...] = setting(
        "each", kind="choice|numbers", choices=("each", "top"), minimum=0, above_minimum=True, min_length=1,
        unit="reference unit", form_text='"each", "top" or a list of measured levels > 0',
        meaning="every level in turn, the highest (an extrapolation), or these measured levels")
    models: tuple[str, ...] = setting(
        ("auto",), kind="strings", min_length=1, flag="",
        meaning="`lines`, `lines-background`, `amplitude-polynomial`, `amplitude-iwan`, `prd:ELEMENTS` (e.g. "
                "`prd:cubic,jenkins`), `baseline` (the log-amplitude baseline itself) or `auto` (the one of the first "
                "four that predicts the kept levels from each other best; for a level outside the kept range, the "
                "best whose prediction stays in the physical range, else `baseline`, with a warning); with "
                f"`hold_out_type`, the first is one of {', '.join(BACKBONE_OF_MODEL)}")
    input_dof: str | None = setting(
        None, kind="string", default_text="the identification's input (in a study), else the table's only one",
        meaning="the driving point whose curve is judged")
    response_controlled: str = setting(
        "auto", kind="choice|boolean", choices=RESPONSE_CONTROLLED,
        form_text='"auto", "off" or "kept" (true and false, the earlier form, are read as "auto" and "off")',
        meaning="the response-controlled runs of the measured MATLAB files: `auto` predicts them at their held "
                "amplitude from all force-controlled levels; `off` leaves them out; `kept` keeps them beside the "
                "force-controlled levels as backbone evidence of every fit (models `lines`, `lines-background` and "
                "`auto` among them; the held-out levels are still force-controlled ones). With `hold_out_type`, "
                "`auto` and `kept` make them a source")
    impact: str | None = setting(
        None, kind="string", default_text="none", flag="",
        meaning="with levels held out (not with `hold_out_type`): an impact or low-level free decay (.csv or .mat: "
                "`time_s`, one column per channel, optional `force`) whose linear limit, fitted to its quietest decay "
                "in the measured band widened to ±20 %, is kept beside the levels as one more sample of the `lines` "
                "models' backbone and damping curve at zero amplitude (`validation.json`'s `linear_limit`); models "
                "`lines`, `lines-background` or `auto` only; as `nlupdate validate --impact`")
    channel: str | None = setting(
        None, kind="string", default_text="every response channel", flag="",
        meaning="with `impact`: the record's channel fitted, as `--channel`")
    hold_out_type: str | None = setting(
        None, kind="choice", choices=HELD_TYPES, default_text="none", flag="",
        meaning="hold out a whole test type as well: the amplitude-dependent modal model fitted on the other "
                "sources (the measured stepped sine, its response-controlled runs, `ring_down` records) predicts it "
                "(validation.json's `held_out_type`); needs `shapes`")
    shapes: Mapping[str, float] = setting(
        default_factory=dict, kind="number_table", unit="1/√kg", flag="",
        meaning="with `hold_out_type`: the mass-normalised mode shape at each coordinate a source is measured at "
                "(the stepped sine's input, a ring-down's channel), for one modal amplitude across the test types")
    ring_down: tuple[str, ...] = setting(
        (), kind="strings", flag="", default_text="`[]`",
        meaning="with `hold_out_type`: free-decay records of the mode (.csv: `time_s` and one column per channel; "
                "or .mat), read as `nlupdate amplitude --ring-down` reads them (displacement, m), band-passed in "
                "the measured band")

    def __post_init__(self) -> None:
        if isinstance(self.response_controlled, bool):  # the earlier true/false form
            object.__setattr__(self, "response_controlled", "auto" if self.response_controlled else "off")


@dataclass(frozen=True)
class TargetsSpec:
    """``[targets]``: what the updated model must match — exactly one source: frequencies,
    the modes of the study's extracted linear FRF, the peaks of an earlier identification's
    linear FRF (the path as written) or the linear limits of amplitude-dependent modal models
    (paths as written); then the measured pair and its coordinates in the FE model, and per
    target mode weights, labels, model modes and mode shapes. Each key: its declaration."""

    frequencies_hz: tuple[float, ...] | None = setting(
        None, kind="numbers", min_length=1, unit="Hz", default_text="—",
        meaning="source 1: the target natural frequencies, increasing, > 0 (at most 1000 target modes, whatever the "
                "source)")
    std_hz: tuple[float, ...] | None = setting(
        None, kind="numbers", min_length=1, unit="Hz", default_text="none",
        meaning="only with `frequencies_hz`, one per target: standard deviations, propagated to parameter "
                "uncertainties")
    from_identification: bool = setting(
        False, kind="boolean", default_text="—",
        meaning="source 2 (`true`): the modes of the linear FRF extracted by this study's `[identification]` (needs "
                "that table); their Monte-Carlo std and loss factors come along")
    modes: tuple[int, ...] | None = setting(
        None, kind="integers", min_length=1, minimum=1, default_text="all modes found",
        meaning="only with `from_identification`: which modes (numbered in ascending frequency, each once)")
    identification: str | None = setting(
        None, kind="path", default_text="—",
        meaning="source 3: an `nlupdate identify` output folder (its `linear_frf.parquet`), its "
                "`identification.json` (entry `linear_frf`), or any FRF table")
    n_modes: int | None = setting(None, kind="integer", minimum=1, default_text="—",
                                  meaning="**required** with source 3: number of peaks to pick")
    band_hz: tuple[float, float] | None = setting(
        None, kind="numbers", length=2, minimum=0, unit="Hz", default_text="whole FRF",
        meaning="source 3: search band [low, high], low < high")
    force_level_n: float | None = setting(
        None, kind="number", minimum=0, above_minimum=True, unit="N", default_text="the curve's only level",
        meaning="source 3: which curve when the table has several levels")
    frf_method: str = setting(
        "peak", kind="choice", choices=FRF_METHODS,
        meaning="source 3: parabola-refined |H| peaks, or line fit of Re(1/H) in ω² (±1 %)")
    amplitude_models: tuple[str, ...] = setting(
        (), kind="strings", min_length=1, default_text="—",
        meaning="source 4: amplitude-dependent modal models (`amplitude_model.json` of `nlupdate amplitude`, "
                "docs/iwan.md), one per target mode; the target is each one's linear limit f(a → 0) — the joint "
                "stuck, as an FE model with tied contact has it; `model_modes` defaults to their `mode`")
    response_dof: str | None = setting(
        None, kind="string", default_text="`[identification]`'s",
        meaning="the measured curve's response: **required** with source 3; otherwise the curve used for FRAC and "
                "prediction")
    input_dof: str | None = setting(None, kind="string", default_text="`[identification]`'s",
                                    meaning="the measured curve's input (as `response_dof`)")
    model_response_dof: str | None = setting(None, kind="string", default_text="`response_dof`",
                                             meaning="the same response coordinate named as in the FE model")
    model_input_dof: str | None = setting(None, kind="string",
                                          default_text="`input_dof`; at a driving point `model_response_dof`",
                                          meaning="the same input coordinate named as in the FE model")
    weights: tuple[float, ...] | None = setting(
        None, kind="numbers", min_length=1, default_text="`1` each",
        meaning="mode weights, one per target, ≥ 0, not all 0; residual i is multiplied by √w_i")
    labels: tuple[str, ...] = setting((), kind="strings", min_length=1, default_text="`mode1`, `mode2`, …",
                                      meaning="names of the target modes, distinct, one per target")
    model_modes: tuple[int, ...] = setting(
        (), kind="integers", min_length=1, minimum=1, default_text="1, 2, …, n",
        meaning='with `pairing = "order"`: model modes paired with the targets, distinct, one per target')
    coordinates: tuple[str, ...] = setting(
        (), kind="strings", min_length=1, default_text="—",
        meaning="model coordinate names of measured mode shapes; together with `mode_shapes`")
    mode_shapes: tuple[tuple[float, ...], ...] | None = setting(
        None, kind="number_rows", unit="any scaling", default_text="—",
        meaning="measured shapes, one list per target of one value per coordinate, for MAC pairing and "
                "`use_mode_shapes`")


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

    user_weights: tuple[float, ...] | Mapping[str, float] | None = setting(
        None, kind="numbers|number_table", min_length=1, default_text="the `[targets]` weights",
        form_text="a list of numbers (one per target mode) or a table {label = weight}",
        meaning="ranking weights, ≥ 0, not all 0; modes missing from a table weigh 0")
    damping_ratios: float | tuple[float, ...] | None = setting(
        None, kind="number|numbers", minimum=0, min_length=1, unit="fraction", default_text="`0`",
        meaning="viscous modal damping of the candidates' modal FRFs (a list: one per target mode)")
    loss_factors: float | tuple[float, ...] | None = setting(
        None, kind="number|numbers", minimum=0, min_length=1,
        default_text="the identified modes' loss factors with `from_identification` (when `damping_ratios` is not "
                     "given), else `0`",
        meaning="structural modal damping of the candidates' FRFs (a list: one per target mode)")
    band_fraction: float = setting(0.1, kind="number", minimum=0, above_minimum=True, unit="fraction of f",
                                   meaning="FRAC band ±band_fraction·f_target around each target")
    frf: str | None = setting(
        None, kind="path", default_text="none",
        meaning="reference FRF instead of the default one (an identify folder, its JSON, or an FRF table); needs the "
                "measured curve (`[targets] response_dof`/`input_dof` or `[identification]`)")


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
    fe_validation: FEValidationSettings | None = None
    amplitude: AmplitudeSpec | None = None
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

    @property
    def hidden_truth(self) -> dict[str, float]:
        """The truth of a simulated study, by name: its adapter parameters and its elements'
        numeric parameters (none for a measured study or a truth from a model file)."""
        sim = self.measured.simulate if self.measured is not None else None
        if sim is None or sim.model_file is not None:
            return {}
        truth = dict(sim.parameters)
        for element in sim.elements:
            truth.update({key: float(value) for key, value in element.items()
                          if key not in ("type", "dofs") and isinstance(value, (int, float))})
        return truth


@contextlib.contextmanager
def inputs_read_once(study: Study) -> Iterator[Study]:
    """``study`` with the bytes of every file it names read now, and pinned for the block
    (:func:`nlupdate.input_files.pinned`): every step, hash and archive copy of the run sees
    those bytes, even if a file is replaced on disk meanwhile."""
    taken = study if study.snapshots else dataclasses.replace(study, snapshots=snapshot(study.input_files.values()))
    with pinned(taken.snapshots):
        yield taken
