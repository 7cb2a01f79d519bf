"""The study's ``[amplitude]`` table: one mode's amplitude-dependent modal model from any mix
of tests, as ``nlupdate amplitude`` fits it (docs/ring-down.md). Its keys are declared once on
:class:`AmplitudeSpec` (:mod:`nlupdate.settings`); the reader
(:func:`nlupdate.study.sections.read_amplitude`) checks them from it, and
docs/study-files.md's table of keys is generated from it. Files are as written in the study
(relative to the study file): the reader resolves and records them (archived with the run,
part of the step's cache key).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Mapping

from nlupdate.core.identification.amplitude_inputs import RING_DOWN_FITS, SourceFiles
from nlupdate.core.identification.amplitude_joint import FitOptions
from nlupdate.core.identification.amplitude_modal_fit import FIT_BACKBONES
from nlupdate.core.identification.backbone_samples import BOOTSTRAP_DEFAULT
from nlupdate.core.measurement.units import ReadOptions
from nlupdate.core.validation.held_type import HELD_TYPES
from nlupdate.settings import setting

WHERE = "amplitude"
#: the keys naming files of a test type (``measured``: the study's own stepped sine instead)
FILE_KEYS = ("ring_down", "impact", "response_controlled", "phase_resonance")


@dataclass(frozen=True)
class AmplitudeSpec:
    """``[amplitude]``: the sources of one mode and how its model is fitted (each key: its
    declaration; ``nlupdate amplitude`` has an option of each meaning)."""

    measured: bool = setting(
        False, kind="boolean",
        meaning="the study's `[measured]` stepped sine (its FRF table, force-controlled levels) as a source, as "
                "`--measured` is read: the driving point at `input_dof`, cut to `band_hz` or its excited band")
    ring_down: tuple[str, ...] = setting(
        (), kind="strings", default_text="`[]`",
        meaning="free-decay records of the mode (.csv: `time_s` and one column per channel; or .mat), as "
                "`--ring-down`")
    ring_down_fit: str = setting("envelope", kind="choice", choices=RING_DOWN_FITS,
                                 meaning="how a ring-down is read: the envelope, complex exponential segments or the "
                                         "decay fit (docs/ring-down.md), as `--ring-down-fit`")
    impact: tuple[str, ...] = setting(
        (), kind="strings", default_text="`[]`",
        meaning="impact or low-level free decays (.csv or .mat: `time_s`, one column per channel, optional `force`): "
                "the linear limit, as `--impact`")
    response_controlled: tuple[str, ...] = setting(
        (), kind="strings", default_text="`[]`",
        meaning="response-controlled stepped-sine runs (.mat or .uff/.unv), one sample per held amplitude, as "
                "`--response-controlled`")
    phase_resonance: tuple[str, ...] = setting(
        (), kind="strings", default_text="`[]`",
        meaning="phase-resonance points (.csv, .mat or .uff/.unv), one sample per level; needs `shapes` at their "
                "response and input, as `--phase-resonance`")
    shapes: Mapping[str, float] = setting(
        default_factory=dict, kind="number_table", unit="1/√kg",
        meaning="the mass-normalised mode shape at each coordinate a source is measured at (a ring-down's or "
                "impact's channel, the stepped sine's input, a phase-resonance point's response and input): one "
                "modal amplitude across the sources, as `--shape NAME=VALUE`")
    channel: str | None = setting(None, kind="string", default_text="a ring-down's only one, an impact's every one",
                                  meaning="the ring-down and impact records' channel, as `--channel`")
    band_hz: tuple[float, ...] | None = setting(
        None, kind="numbers", length=2, minimum=0, unit="Hz",
        default_text="around the spectrum's largest peak (a record); the excited band (the stepped sine)",
        meaning="the mode's band [low, high]: a record's band-pass, the stepped sine's lines kept (a warning when "
                "it changes their damping samples from the excited band's), as `--band`")
    response_unit: str = setting("m", kind="string",
                                 meaning="unit of the ring-down and impact records: m, mm, m/s, mm/s, m/s^2, g, …; "
                                         "their amplitudes are made displacement, as `--response-unit`")
    held_amplitudes: Mapping[str, float] = setting(
        default_factory=dict, kind="number_table", minimum=0, above_minimum=True,
        unit="the response record's", default_text="as the run names say",
        meaning='held amplitude of a response-controlled UFF run whose name does not state it: { "FILE#RUN" = '
                'value }, { RUN = value } or { FILE = value }, as `--held-amplitude`')
    coordinates: Mapping[str, tuple[str, ...]] = setting(
        default_factory=dict, kind="table", form_text='a table { FILE = ["RESPONSE", "INPUT"] }',
        meaning="response and input coordinates of a MATLAB file that names none (response-controlled or "
                "phase-resonance runs), as `--coordinates`; `NODE:-DIR` along the negative direction. A file "
                "`[measured]` reads is read with `[measured]`'s statements (coordinates, levels, reference unit)")
    input_dof: str | None = setting(None, kind="string", default_text="the table's only input",
                                    meaning="with `measured`: the excited coordinate, as `--input-dof`")
    response_dof: str | None = setting(None, kind="string", default_text="the driving point, else the only response",
                                       meaning="with `measured`: the response coordinate, as `--response-dof`")
    backbone: str = setting("iwan", kind="choice", choices=FIT_BACKBONES,
                            meaning="backbone model: a modal Iwan joint, its Jenkins limit or a polynomial of `order`, "
                                    "as `--backbone`")
    order: int = setting(2, kind="integer", minimum=1, meaning="polynomial order, as `--order`")
    mode: int = setting(1, kind="integer", minimum=1, meaning="the mode's number (in a modal table and the model)")
    bootstrap: int | None = setting(
        None, kind="integer", minimum=0, unit="refits", default_text=BOOTSTRAP_DEFAULT,
        meaning="refits of a residual bootstrap for backbone.csv's 95 % bands (0: none, NaN), as `--bootstrap`")
    hold_out_type: str | None = setting(
        None, kind="choice", choices=HELD_TYPES, default_text="none",
        meaning="fit without the sources of this test type and predict them (held_out.csv), as `--hold-out`")

    def sources(self, study_path_of, measured: ReadOptions | None = None) -> SourceFiles:
        """The files of each test type (``study_path_of``: a path as written → the file read)
        and how to read them: through ``measured``, the study's ``[measured]`` statements
        (:meth:`~nlupdate.study.spec.MeasuredSpec.read_options`: a file it reads is read here as
        there, as ``nlupdate amplitude`` reads every file with one set of options), with this
        table's ``coordinates`` added."""
        resolved = {key: tuple(str(study_path_of(p)) for p in getattr(self, key)) for key in FILE_KEYS}
        base = measured or ReadOptions()
        coordinates = {**base.coordinates,
                       **{str(study_path_of(name)): tuple(pair) for name, pair in self.coordinates.items()}}
        held = {self._held_key(name, study_path_of): value for name, value in self.held_amplitudes.items()}
        return SourceFiles(**resolved, ring_down_fit=self.ring_down_fit,
                           band=None if self.band_hz is None else (self.band_hz[0], self.band_hz[1]),
                           response_unit=self.response_unit, channel=self.channel, held=held,
                           options=dataclasses.replace(base, coordinates=coordinates))

    def _held_key(self, name: str, study_path_of) -> str:
        """A ``FILE`` or ``FILE#RUN`` key with the file resolved; a run's name as it is."""
        written, sep, run = name.partition("#")
        if written in self.response_controlled:
            return str(study_path_of(written)) + sep + run
        return name

    def fit_options(self) -> FitOptions:
        return FitOptions(self.backbone, self.order, self.mode, self.bootstrap, self.hold_out_type)

    @property
    def file_count(self) -> int:
        return sum(len(getattr(self, key)) for key in FILE_KEYS)


__all__ = ["AmplitudeSpec", "FILE_KEYS"]
