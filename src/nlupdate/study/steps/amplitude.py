"""``[amplitude]`` of a study: one mode's amplitude-dependent modal model from any mix of tests,
fitted as ``nlupdate amplitude`` fits it — the same functions
(:func:`~nlupdate.core.identification.amplitude_inputs.read_sources`,
:func:`~nlupdate.core.identification.amplitude_joint.measured_source`,
:func:`~nlupdate.core.identification.amplitude_joint.fit_sources`,
:func:`~nlupdate.core.identification.amplitude_joint.backbone_table`), so the archive's
``amplitude/`` files are the command's for the same inputs. Sources are named by their
paths as written in the study."""
from __future__ import annotations

import dataclasses

import pandas as pd

from nlupdate.core.identification.amplitude_inputs import read_sources
from nlupdate.core.identification.amplitude_joint import (
    AmplitudeFit, BandCut, backbone_table, fit_sources, measured_source,
)
from nlupdate.core.measurement.band import excited_band_of_table, table_within
from nlupdate.study.amplitude import FILE_KEYS
from nlupdate.study.spec import Study, StudyError
from nlupdate.study.steps.measured import measured_description


def _measured_name(study: Study) -> str:
    """The ``[measured]`` files as written in the study (as the command names ``--measured``)."""
    written = {str(path): name for name, path in study.input_files.items()}
    spec = study.measured
    files = [spec.file] if spec.file is not None else [path for path, _ in spec.files] or list(spec.time_histories)
    return ", ".join(written.get(str(f), str(f)) for f in files) if files else measured_description(study)


def _stepped_sine(study: Study, table: pd.DataFrame) -> tuple[pd.DataFrame, str, BandCut | None]:
    """The study's measured table cut to ``band_hz`` or, without it, to its excited band
    (as ``nlupdate amplitude --measured`` cuts an FRF table; a note saying which), and, when
    ``band_hz`` leaves out lines of the excited band, that band's table to check the samples
    against (as the command does)."""
    band = study.amplitude.band_hz
    excited, reason = excited_band_of_table(table)
    found, how = ((band[0], band[1]), "band_hz") if band is not None else (excited, reason)
    kept, left_out = table_within(table, found)
    if kept.empty:
        raise ValueError(f"the [measured] data have no line between {found[0]:g} and {found[1]:g} Hz ({how})")
    note = (f"stepped sine ({_measured_name(study)}): band {found[0]:g}–{found[1]:g} Hz ({how}), "
            f"{left_out} of {len(table)} measured rows outside it left out")
    whole = table_within(table, excited)[0]
    cut = None if band is None or not table_within(whole, found)[1] else BandCut(found, whole)
    return kept, note, cut


def amplitude_step(study: Study, measured: pd.DataFrame | None) -> AmplitudeFit:
    """The model of ``[amplitude]``'s sources (``measured``: the study's measured table, used
    when ``measured = true``), with its backbone table and a note per source."""
    spec = study.amplitude
    written = {str(study.resolve(p)): p for key in FILE_KEYS for p in getattr(spec, key)}
    try:
        options = None if study.measured is None else study.measured.read_options()
        found, channel, notes = read_sources(spec.sources(study.resolve, options), spec.shapes)
        found = [(written.get(path, path), *rest) for path, *rest in found]
        for path, name in written.items():
            notes = [note.replace(path, name) for note in notes]
        part, name = None, ""
        if spec.measured:
            table, note, cut = _stepped_sine(study, measured)
            notes.insert(0, note)
            name = _measured_name(study)
            part = measured_source(table, spec.shapes, spec.fit_options(), name, spec.input_dof, spec.response_dof,
                                   cut)
        fit = fit_sources(found, channel, spec.shapes, spec.fit_options(), part, name)
        curve = backbone_table(fit)
    except ValueError as error:
        raise StudyError(f"{study.path}: [amplitude]: {error}") from None
    return dataclasses.replace(fit, curve=curve, notes=tuple(notes))
