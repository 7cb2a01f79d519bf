"""The declared keys of the study tables that the reader turns into something else: the
``[study]`` header, an FE model's table (an :class:`~nlupdate.fe.adapters.registry.AdapterSpec`
and the fixed parameters), one ``[[parameters]]`` entry (a
:class:`~nlupdate.fe.adapters.base.Parameter`), the parameter sets of ``[eigensensitivity]``,
``[measured]`` and ``[measured.simulate]`` (a :class:`~nlupdate.study.spec.MeasuredSpec`).
Each field is a key (:func:`nlupdate.settings.setting`); defaults that the built object has
are taken from it, not repeated.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

from nlupdate.core.updating.sensitivity import FORMULAS
from nlupdate.fe.adapters.base import Parameter
from nlupdate.fe.adapters.registry import ADAPTER_KINDS, AdapterSpec
from nlupdate.settings import setting
from nlupdate.study.spec import MeasuredSpec, SimulationSpec


@dataclass(frozen=True)
class StudyInfo:
    """``[study]``: the study's name (None: the file's name) and description."""

    name: str | None = setting(
        None, kind="string", default_text="the file's name without `.toml`",
        meaning="names the run: archive folder `results/<name>/`, report title, Prefect flow-run name (one folder "
                "name: printable, no `/` or `\\`, not starting with `.`)")
    description: str = setting("", kind="string", meaning="one line for the report and `manifest.json`")


@dataclass(frozen=True)
class AdapterTable:
    """An FE model as a study names it (``[adapter]``, ``[measured.simulate.adapter]``)."""

    kind: str = setting(kind="choice", choices=ADAPTER_KINDS, required=True, meaning="FE code, options below")
    model: str | None = setting(None, kind="string", default_text="—",
                                meaning='**required** for `surrogate` (`"tbeam"` | `"gunbarrel"`) and `calculix` '
                                        '(`"tbeam"` | `"brb"`); not used by `lumped` and `mapdl`')
    options: dict[str, Any] = setting(default_factory=dict, kind="table",
                                      meaning="constructor options of that kind (below); `[adapter.options]` or inline "
                                              "`options = {…}`")

    def spec(self) -> AdapterSpec:
        return AdapterSpec(self.kind, self.model, self.options)


@dataclass(frozen=True)
class StudyAdapterTable(AdapterTable):
    """``[adapter]``: the FE model to update, and parameters held at other values."""

    fixed: dict[str, float] = setting(
        default_factory=dict, kind="number_table", unit="parameter units",
        meaning="adapter parameters set to a value other than the adapter's default but not updated; merged into "
                "every FE evaluation and every prediction; must not name a `[[parameters]]` entry")


@dataclass(frozen=True)
class ParameterEntry:
    """One ``[[parameters]]`` table: an updating parameter
    (:class:`~nlupdate.fe.adapters.base.Parameter`)."""

    name: str = setting(kind="string", required=True,
                        meaning="a parameter the adapter accepts (lumped `m1`, `k1`, …; surrogate/CalculiX field "
                                "names; MAPDL `parameter_names`); distinct")
    start: float = setting(kind="number", required=True, unit="parameter unit",
                           meaning="initial value, lower ≤ start ≤ upper; also the normalisation scale (the bound "
                                   "width when 0)")
    lower: float = setting(kind="number", required=True, unit="parameter unit",
                           meaning="lower bound of the updated value")
    upper: float = setting(kind="number", required=True, unit="parameter unit", meaning="upper bound, > lower")
    unit: str = setting("", kind="string", meaning="label for tables and reports")
    description: str = setting("", kind="string",
                               meaning='what the parameter is, in a few words (`"thickness of the two thin beams"`): '
                                       "the progress line before the updating runs and the report's summary say it")
    relative_step: float = setting(
        Parameter.relative_step, kind="number", minimum=0, maximum=1, above_minimum=True, below_maximum=True,
        meaning="finite-difference step h = relative_step·|p| (relative_step·(upper − lower) when p = 0)")

    def parameter(self) -> Parameter:
        return Parameter(self.name, self.unit, self.start, self.lower, self.upper, self.relative_step,
                         self.description)


@dataclass(frozen=True)
class EigensensitivityKeys:
    """The keys of ``[eigensensitivity]`` besides the iteration's settings
    (:class:`~nlupdate.core.updating.eigensensitivity.EigensensitivityOptions`)."""

    formulas: tuple[str, ...] = setting(
        ("forward",), kind="strings", min_length=1,
        form_text=f"a list of distinct names from {list(FORMULAS)}",
        meaning="finite-difference sensitivities: O(h) one-sided (1 new point per parameter), central O(h²) (2), "
                "central O(h⁴) (4)")
    parameter_sets: tuple[tuple[str, ...], ...] | None = setting(
        None, kind="string_rows", default_text="one set of all `[[parameters]]`",
        meaning="distinct sets, each updated separately")
    parameters: tuple[str, ...] | None = setting(
        None, kind="strings", min_length=1, default_text="all",
        meaning="shorthand for one set; not together with `parameter_sets`")


@dataclass(frozen=True)
class MeasuredTable:
    """``[measured]``: exactly one of ``file``, ``files``, ``time_histories`` or ``simulate``
    (the reader's rule), and what the files do not say."""

    file: str | None = setting(
        None, kind="path", default_text="—",
        meaning="an existing measured-FRF table, `.parquet`, `.csv`, `.uff`/`.unv` or `.mat` (receptance m/N per "
                "frequency, force level, response and input coordinate; format in [measured data](measured-data.md))")
    files: tuple[str, ...] | Mapping[str, float] | None = setting(
        None, kind="strings|number_table", min_length=1, unit="reference unit", default_text="levels from the files",
        form_text='a list of files, or a table "<file>" = level',
        meaning="several files of one measurement (one per level or run); the table form gives each file's level (> 0)")
    time_histories: tuple[str, ...] | None = setting(
        None, kind="strings", min_length=1, default_text="—",
        meaning="time records turned into FRFs as `nlupdate frf` does "
                "([measured data](measured-data.md#time-histories-nlupdate-frf))")
    input_dof: str | None = setting(None, kind="string", default_text="the reference column's name",
                                    meaning="`time_histories` only: name of the excited coordinate")
    excitation: str = setting(MeasuredSpec.excitation, kind="choice",
                              choices=("auto", "stepped_sine", "sine_sweep", "random", "burst"),
                              meaning="`time_histories` only")
    response_quantity: str = setting(MeasuredSpec.response_quantity, kind="choice",
                                     choices=("displacement", "velocity", "acceleration"),
                                     meaning="`time_histories` only: what the response columns measure")
    reference_unit: str | None = setting(
        MeasuredSpec.reference_unit, kind="choice", choices=("N", "V"), default_text="as the files say",
        meaning='the FRFs\' reference; `"V"`: the amplifier voltage, levels and FRFs per volt (required to read a '
                "per-volt UFF file)")
    reference_calibration: float | None = setting(
        MeasuredSpec.reference_calibration, kind="number", minimum=0, above_minimum=True, unit="N/V",
        default_text="—", meaning="converts per-volt data to newtons on reading (with `reference_unit = \"V\"`)")
    levels: Mapping[str, float] | None = setting(
        None, kind="table", unit="reference unit", default_text="levels from the files",
        form_text='a table "<file>" | "<file>#<run>" | "<run>" = level',
        meaning="`file`/`files` only: the level (> 0) of a file, of one run of a file, or of a run by its name, as "
                "`--level` takes them (runs of a test system's export: "
                "[measured data](measured-data.md#uff-58-from-a-test-system-lms--several-levels))")
    coordinates: Mapping[str, Any] | None = setting(
        None, kind="table", default_text="—", form_text='a table "<file>" = ["<response>", "<input>"]',
        meaning="`file`/`files` only: the coordinates of a file that names none (MATLAB stepped-sine runs, as "
                '`--coordinates`); `"NODE:-DIR"` states a sensor or force along the negative direction and negates '
                "the FRF")
    simulate: Mapping[str, Any] | None = setting(None, kind="table", default_text="—",
                                                 meaning="a simulated stepped-sine test on a hidden truth, below")


@dataclass(frozen=True)
class SimulationTable:
    """``[measured.simulate]``: the truth (a model file, or an FE model with its parameters,
    loss factor and elements) and the test (:class:`~nlupdate.study.spec.SimulationSpec`)."""

    input_dof: str = setting(kind="string", required=True, meaning="the excited coordinate (a name of the truth)")
    forces_n: tuple[float, ...] = setting(kind="numbers", required=True, min_length=1, unit="N",
                                          meaning="the force amplitudes of the test, distinct, > 0")
    frequencies_hz: Any = setting(
        kind="numbers|table", required=True, unit="Hz",
        form_text="[start, stop, count] (Hz, count ≥ 2) or {list = [f1, f2, …]}",
        meaning="the test's frequency grid: `count` points from `start` to `stop`, or these (at most 200000)")
    model: str | None = setting(
        None, kind="path", default_text="—",
        meaning="existing [model file](model-files.md) (`[model]` lumped or modal, plus `[[nonlinear]]`)")
    adapter: Mapping[str, Any] | None = setting(
        None, kind="table", default_text="the study's `[adapter]`",
        meaning="truth FE model: `kind`, `model`, `options` as in [`[adapter]`](#adapter) (no `fixed`), below")
    parameters: Mapping[str, float] = setting(
        default_factory=dict, kind="number_table", unit="parameter units", default_text="`{}` (adapter defaults)",
        meaning="truth parameter values for that adapter; `[adapter.fixed]` is **not** applied to the truth")
    loss_factor: float = setting(SimulationSpec.loss_factor, kind="number", minimum=0,
                                 meaning="structural modal loss factor η of every mode of the truth FE model")
    nonlinear: tuple[Mapping[str, Any], ...] = setting(
        (), kind="tables", default_text="none",
        meaning="`[[measured.simulate.nonlinear]]` elements: `type`, `dofs`, parameters exactly as in "
                "[model files](model-files.md#nonlinear); `dofs` are coordinate names of the truth adapter (or "
                "indices into its coordinate list)")
    noise: float = setting(SimulationSpec.noise, kind="number", minimum=0,
                           meaning="relative noise on every FRF value (docs/methods.md §8)")
    seed: int = setting(SimulationSpec.seed, kind="integer", minimum=0, meaning="seed of the noise")
    sweep: str = setting(SimulationSpec.sweep, kind="choice", choices=("up", "down"),
                         meaning="stepped-sine direction (picks the branch where the response curve is multi-valued)")
