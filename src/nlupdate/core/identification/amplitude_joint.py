"""One amplitude-dependent modal model of one mode from any mix of tests, and the tables it
is written as: what ``nlupdate amplitude`` and a study's ``[amplitude]`` step both compute
(:func:`measured_source`, :func:`fit_sources`, :func:`backbone_table`, :meth:`AmplitudeFit.write`).

Stepped sine (an FRF table at several force levels, or a modal table) gives the existing
single-nonlinear-mode fit; every other test type its samples
(:func:`nlupdate.core.identification.amplitude_inputs.read_sources`). One source alone is
fitted alone; several are fitted jointly, each weighted by its own noise, and checked for
consistency (:mod:`nlupdate.core.identification.backbone_samples`: which sources disagree
with the joint fit beyond their uncertainty). A test type held out is left out of the fit
and predicted (``held_out.csv``).

With the ``jenkins`` backbone and a driving-point stepped sine whose shape is given, the fit
(alone or joint) is then refined on every line of the stepped sine by output error, the other
sources' samples in the same least squares (:mod:`nlupdate.core.identification.line_refine`:
the lines pass through the stick–slip kink on their flanks and place the slip amplitude
about ten times better than the peaks). The consistency table is that of the sample fit.
The ``jenkins`` backbone's bands are those of the estimator that gave the model (the line
refinement's or the sample fit's residual, linearised, the phase-resonance points'
amplitude noise included: :mod:`nlupdate.core.identification.joint_band`); for the phase
resonance's own fit the residual bootstrap held the truth at 51–59 % of the amplitudes next to
the stick–slip kink, this band at 100 % (docs/ring-down.md, "Honest bands at the kink"). The
line refinement's band holds the linear-damping law's uncertainty and the leave-one-level-out
spread too (:mod:`nlupdate.core.identification.line_band`).

Files written (:meth:`AmplitudeFit.write`): ``amplitude_model.json`` (the model, its reference
unit), ``backbone.csv`` (the fitted backbone over the samples' amplitudes: ``modal_amplitude``
m·√kg, ``natural_frequency_hz``, ``damping_ratio`` and their 95 % ``*_low``/``*_high`` bands,
NaN without resamples unless the backbone is ``jenkins``), ``backbone_points.csv`` (every
source's samples, with ``source`` and ``test_type``), ``consistency.csv`` (several sources)
and ``held_out.csv`` (a type held out).
The figures ``backbone.png`` and ``damping.png`` are drawn by
:func:`nlupdate.reporting.backbone_plots.plot_sources`.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping

import numpy as np
import pandas as pd

from nlupdate.core.identification.amplitude_inputs import Source
from nlupdate.core.identification.amplitude_modal_fit import (
    KINKED_BACKBONES, fit_amplitude_model, model_of_frf_samples,
)
from nlupdate.core.identification.modal_samples import ModalSamples, samples_from_frfs, samples_from_modal_table
from nlupdate.core.identification.backbone_samples import (
    DEFAULT_NOISE, backbone_curve, backbone_points, bootstrap_refits, check_common_scale, consistency, held_out_errors,
    join_samples, own_fit_for, source_noise,
)
from nlupdate.core.identification.band_dependence import band_changes, band_warning
from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.joint_band import covariance_band, joint_fixed, noisy_fit_residual, sample_fit_residual
from nlupdate.core.identification.line_band import line_refinement_band
from nlupdate.core.identification.line_refine import line_misfit, refine_on_lines, stepped_sine_lines
from nlupdate.core.identification.sample_residuals import (
    EIV_BACKBONES, amplitude_std, locked_frequency_std, sample_noise,
)
from nlupdate.core.measurement.frf_table import MeasurementTableError, measured_pair
from nlupdate.core.measurement.units import table_reference_unit
from nlupdate.core.model.amplitude_modal import AmplitudeModalModel, AmplitudeModelError, write_amplitude_model
from nlupdate.core.run_cache import one_run
from nlupdate.progress import ProgressCallback, no_progress

#: rms relative misfits (frequency, damping ratio) of the samples about the model above which
#: the fit is called poor: the accuracy issue 37 asks of each test type (0.2 %, 5 %)
POOR_FIT = (2e-3, 0.05)


@dataclass(frozen=True)
class FitOptions:
    """How the model is fitted: ``backbone`` (iwan, jenkins, polynomial) of ``order``; the
    ``mode`` number; ``bootstrap`` refits for the bands (None: 200 for the polynomial, 0 for
    the others); ``hold_out``: a test type to leave out and predict (None: none)."""

    backbone: str = "iwan"
    order: int = 2
    mode: int = 1
    bootstrap: int | None = None
    hold_out: str | None = None


@dataclass(frozen=True)
class MeasuredSource:
    """The stepped-sine part (an FRF table or a modal table): its samples, the model fitted to
    it alone, the FRFs (None for a modal table), the reference unit, the excited coordinate and
    the test type."""

    samples: ModalSamples
    model: AmplitudeModalModel
    data: FRFLevels | None
    unit: str
    input_dof: str
    kind: str
    warnings: tuple[str, ...] = ()


@dataclass(frozen=True)
class BandCut:
    """A band the user cut an FRF table to (``band_hz``, Hz) and the table as the file gives it
    without that band (``whole``: its excited band), to check the samples against
    (:mod:`nlupdate.core.identification.band_dependence`)."""

    band_hz: tuple[float, float]
    whole: pd.DataFrame


@one_run()  # band_changes reads the band's samples (its share and resonances) again: computed once
def measured_source(table: pd.DataFrame, shapes: Mapping[str, float], options: FitOptions, name: str,
                    input_dof: str | None = None, response_dof: str | None = None,
                    cut: BandCut | None = None) -> MeasuredSource:
    """The single-nonlinear-mode fit of a measured table (``name`` its files, for messages): a
    modal table needs the shape at its excited coordinate; an FRF table is read at its driving
    point (or the only response) and its shape comes from the modal constant of every level at
    once (:func:`~nlupdate.core.identification.level_residual.frf_residual`) unless given. With ``cut`` (the band the table was cut to and the table without it), a
    warning when the band changes the levels' damping ratios beyond the noise
    (:mod:`~nlupdate.core.identification.band_dependence`), which then also keeps the
    samples' own warning of a share on its box (``bound_warning``: the cause) and, when the
    band changes nothing beyond the noise, drops it (on the BRB cut to 79.5–81 Hz the slope S
    ends on its box and the damping ratios move at most 0.8 % from the whole band's: a warning
    there cried wolf). ValueError (one line) when the
    coordinates are ambiguous."""
    if "natural_frequency_hz" in table.columns:
        inputs = sorted(set(table["input_dof"])) if "input_dof" in table.columns else []
        input_dof = input_dof or (inputs[0] if len(inputs) == 1 else None)
        if input_dof is None:
            raise ValueError(f"{name}: name the excited coordinate (input_dof)")
        if input_dof not in shapes:
            raise ValueError(f"a modal table needs the mass-normalised shape at the excited coordinate {input_dof!r} "
                             f"(1/√kg; --shape {input_dof}=VALUE) to know the modal amplitude of each level")
        samples = samples_from_modal_table(table, shapes[input_dof], options.mode, name)
        model = fit_amplitude_model(samples, tuple(shapes.items()), options.backbone, options.order, mode=options.mode)
        return MeasuredSource(samples, model, None, "N", input_dof, "modal-table")
    try:  # the driving point at the table's (only) input, or the input's only response
        response_dof, input_dof, _ = measured_pair(table, input_dof, response_dof)
    except MeasurementTableError as error:
        raise ValueError(f"{name}: {error}") from None
    data = FRFLevels.from_table(table, response_dof, input_dof)
    samples = samples_from_frfs(data, shapes.get(input_dof))
    model = model_of_frf_samples(data, samples, options.backbone, options.order, options.mode)
    if samples.shape_free and model.joint is not None:  # the samples at the shape the fit found
        samples = samples.with_shape(model.shapes[0][1])
    unit = table_reference_unit(table)
    warnings = samples.warnings
    if cut is not None:
        try:  # lines the band left out may hold what the reading refuses (a receptance of 0): nothing to compare
            whole = FRFLevels.from_table(cut.whole, response_dof, input_dof)
        except ValueError:
            whole = None
        if whole is not None:  # the file's whole band measures what the cut changed: its verdict, not the box's
            f = cut.whole["frequency_hz"]
            warning = band_warning(band_changes(whole, data, cut.band_hz, shapes.get(input_dof)), cut.band_hz,
                                   (float(f.min()), float(f.max())), unit)
            warnings = (warning,) + warnings if warning else ()
    return MeasuredSource(samples, model, data, unit, input_dof, "stepped-sine", warnings)


@dataclass(frozen=True)
class HeldWorst:
    """One held-out source's samples within (or outside) the fitted amplitudes: how many, the
    largest |relative error| of the predicted frequency, damping ratio and, for phase
    resonance, amplitude at its force (NaN for the others), and whether every prediction is
    read at a = 0 (an impact below the fitted samples, against the model's linear limit)."""

    source: str
    test_type: str
    within_fit: bool
    samples: int
    frequency_error: float
    damping_error: float
    amplitude_error: float
    at_linear_limit: bool


@dataclass(frozen=True, eq=False)
class AmplitudeFit:
    """The model of one mode and what it was fitted to.

    model: the fitted model (its ``reference_unit`` the measurement's); samples: the samples
    it was fitted to (joined); points: the sources fitted; held: the sources held out;
    agreement: the consistency table (several sources) or None; held_errors: what the model
    predicts for the held-out sources or None; noise: the relative standard deviations
    (frequency, damping) per sample of the fit, for the bootstrap; resamples: the bootstrap's
    refits; input_dof: the coordinate a predicted FRF is driven at; data: the stepped sine's
    FRFs or None; options: as given.
    """

    model: AmplitudeModalModel
    samples: ModalSamples
    points: tuple[Source, ...]
    held: tuple[Source, ...]
    agreement: pd.DataFrame | None
    held_errors: pd.DataFrame | None
    noise: tuple
    resamples: int
    input_dof: str
    data: FRFLevels | None
    options: FitOptions
    curve: pd.DataFrame | None = None
    notes: tuple[str, ...] = ()

    @property
    def unit(self) -> str:
        return self.model.reference_unit

    def misfit(self) -> tuple[float, float]:
        """The rms relative misfits (frequency, damping ratio) of the fitted samples about the
        model, ``f_i/f(a_i) − 1`` and ``ζ_i/ζ(a_i) − 1``."""
        f, z = self.model.frequency_hz(self.samples.amplitude), self.model.damping(self.samples.amplitude)
        return (float(np.sqrt(np.mean((self.samples.frequency_hz / f - 1) ** 2))),
                float(np.sqrt(np.mean((self.samples.damping_ratio / z - 1) ** 2))))

    def poor(self) -> bool:
        """Whether the model misses its samples by more than :data:`POOR_FIT` (rms)."""
        return any(value > bound for value, bound in zip(self.misfit(), POOR_FIT))

    def held_worst(self) -> list[HeldWorst]:
        """:class:`HeldWorst` of :attr:`held_errors` per held-out source, in order, and within or
        outside the fitted amplitudes (empty when nothing is held out)."""
        out: list[HeldWorst] = []
        if self.held_errors is None:
            return out
        for source, all_rows in self.held_errors.groupby("source", sort=False):
            for inside, rows in all_rows.groupby("within_fit", sort=False):
                worst = rows[["frequency_error", "damping_error", "amplitude_error"]].abs().max()
                out.append(HeldWorst(str(source), str(rows["test_type"].iloc[0]), bool(inside), len(rows),
                                     float(worst["frequency_error"]), float(worst["damping_error"]),
                                     float(worst["amplitude_error"]), bool((rows["predicted_at_amplitude"] == 0).all())))
        return out

    def disagreeing(self) -> list[str]:
        """The sources that disagree with the joint fit beyond their uncertainty, by file (with
        its test type when the file is read as several: a hammer record as ring-down and impact)."""
        if self.agreement is None:
            return []
        shared = self.agreement["source"].duplicated(keep=False)
        return [f"{row.source} ({row.test_type})" if twice else str(row.source)
                for row, twice in zip(self.agreement.itertuples(), shared) if not row.consistent]

    def write(self, folder: Path) -> list[str]:
        """``amplitude_model.json``, ``backbone.csv`` (:attr:`curve`, from :func:`backbone_table`),
        ``backbone_points.csv`` and, when there are, ``consistency.csv`` and ``held_out.csv`` in
        ``folder``: the names written."""
        if self.curve is None:
            raise ValueError("the fit has no backbone table yet: dataclasses.replace(fit, curve=backbone_table(fit))")
        write_amplitude_model(self.model, folder / "amplitude_model.json")
        self.curve.to_csv(folder / "backbone.csv", index=False)
        backbone_points([(name, s, kind) for name, s, _, kind in self.points]).to_csv(folder / "backbone_points.csv",
                                                                                      index=False)
        names = ["amplitude_model.json", "backbone.csv", "backbone_points.csv"]
        if self.agreement is not None:
            self.agreement.to_csv(folder / "consistency.csv", index=False)
            names.append("consistency.csv")
        if self.held_errors is not None:
            self.held_errors.to_csv(folder / "held_out.csv", index=False)
            names.append("held_out.csv")
        return names


def _one_source_model(samples: ModalSamples, shapes, options: FitOptions, kind: str = "") -> AmplitudeModalModel:
    """The fit to one source's samples of test type ``kind`` (phase resonance: its noisy amplitudes,
    :mod:`~nlupdate.core.identification.sample_residuals`); one sample (an impact's pole) is the linear
    limit alone, with no amplitude dependence (a polynomial of no terms)."""
    if samples.amplitude.size > 1:
        stds = sample_noise([kind], [samples.amplitude.size], [DEFAULT_NOISE], options.backbone in EIV_BACKBONES)
        return fit_amplitude_model(samples, shapes, options.backbone, options.order, *stds[:2], mode=options.mode,
                                   amplitude_std=stds[2])
    return AmplitudeModalModel(float(samples.frequency_hz[0]), float(samples.damping_ratio[0]), shapes,
                               reference_amplitude=float(samples.amplitude[0]), mode=options.mode,
                               note="the linear limit of one impact or low-level record: no amplitude dependence "
                                    "(join it with other test types for a backbone)")


def _refines_on_lines(measured: MeasuredSource | None, options: FitOptions) -> bool:
    """Whether the fit is refined on the stepped sine's lines (:mod:`~nlupdate.core.identification.line_refine`):
    the ``jenkins`` backbone and driving-point FRFs with the shape given."""
    return (options.backbone in KINKED_BACKBONES and measured is not None and measured.data is not None
            and measured.data.response_dof == measured.data.input_dof and not measured.samples.shape_free)


def _refined(model: AmplitudeModalModel, measured: MeasuredSource, points: list, noise: tuple) -> AmplitudeModalModel:
    """``model`` refined on every line of the stepped sine (``points[0]``) with the other
    sources' samples at their noise (``noise``: per sample of ``points``, in order)."""
    lines = stepped_sine_lines(measured.data, measured.samples.input_shape)
    if len(points) == 1:
        return refine_on_lines(model, lines)[0]
    keep = np.concatenate([np.full(p[1].amplitude.size, i > 0) for i, p in enumerate(points)])
    others = join_samples([p[1] for p in points[1:]])
    return refine_on_lines(model, lines, others, noise[0][keep], noise[1][keep])[0]


def _shape_needed(name: str, input_dof: str, sources: list[Source], channel: str, shapes: Mapping[str, float]) -> str:
    """The refusal of FRFs (``name``) whose shape is to be fitted joining other ``sources``: no
    common amplitude scale. It says which value the other sources read when they read one: the
    response-controlled runs print the shape they took from their lowest run's modal constant
    (offered when the runs' coordinate ``channel`` is the FRFs' excited one, ``input_dof``)."""
    read = [(source, samples.input_shape) for source, samples, _, kind in sources
            if kind == "response-controlled" and np.isfinite(samples.input_shape) and channel == input_dof]
    hint = "" if not read else (f"; {read[0][0]} (response-controlled) took {read[0][1]:.4g} 1/√kg from its lowest "
                                f"run's modal constant: e.g. --shape {input_dof}={read[0][1]:.4g}")
    return (f"{name}: joining its FRFs with other sources needs the mass-normalised mode shape at the excited "
            f"coordinate {input_dof}: give --shape {input_dof}=VALUE (1/√kg; shapes given at: "
            f"{', '.join(shapes) or 'none'}), the same for every source, or their modal amplitudes have no common "
            f"scale{hint}")


def fit_sources(sources: list[Source], channel: str, shapes: Mapping[str, float], options: FitOptions,
                measured: MeasuredSource | None = None, measured_name: str = "") -> AmplitudeFit:
    """The model of the measured part (``measured``, named ``measured_name``) and the other
    ``sources`` (the last one's coordinate ``channel``): module docstring. ValueError (one
    line) when a held-out type leaves nothing to fit or is not given."""
    if measured is None and not sources:
        raise ValueError("no source: give stepped-sine data or a ring-down, response-controlled, phase-resonance "
                         "or impact file")
    named = ([(measured_name, measured.samples)] if measured is not None else []) + [(n, s) for n, s, _, _ in sources]
    check_common_scale([s for _, s in named], [n for n, _ in named], shapes)  # records without a shape, named
    if measured is None:  # the sensor's coordinate stands for the input of any predicted FRF (a driving point)
        samples = join_samples([s for _, s, _, _ in sources])
        shapes_fit = ((channel, samples.input_shape),)
        model, unit, points, input_dof, data = None, "N", list(sources), channel, None
    else:
        samples, model, unit, input_dof, data = (measured.samples, measured.model, measured.unit, measured.input_dof,
                                                 measured.data)
        points = [(measured_name, samples, None, measured.kind)] + list(sources)
        shapes_fit = model.shapes
        if sources:  # the measured samples and the other sources, fitted together at the given shape
            if samples.shape_free:
                raise AmplitudeModelError(_shape_needed(measured_name, input_dof, sources, channel, shapes))
            samples = join_samples([s for _, s, _, _ in points])
    held = [p for p in points if p[3] == options.hold_out]
    if held:
        points = [p for p in points if p[3] != options.hold_out]
        if not points:
            raise ValueError(f"hold-out {options.hold_out}: every source is of that type; give another to fit")
        samples = join_samples([s for _, s, _, _ in points])
    elif options.hold_out:
        raise ValueError(f"hold-out {options.hold_out}: no source of that type is given")
    if len(points) == 1 and (model is None or held):
        model = _one_source_model(samples, shapes_fit, options, points[0][3])
    # several sources: one backbone fitted jointly, each source weighted by its own noise
    own_fit = own_fit_for(options.backbone, shapes_fit)
    noises = [source_noise(s, stated, own_fit) for _, s, stated, _ in points]

    def joint_fit(chosen: list[int]) -> AmplitudeModalModel:
        """The model of the sources at ``chosen``, each weighted by its noise."""
        f_std, z_std, a_std = sample_noise([points[i][3] for i in chosen], [points[i][1].amplitude.size for i in chosen],
                                           [noises[i] for i in chosen], options.backbone in EIV_BACKBONES)
        return fit_amplitude_model(join_samples([points[i][1] for i in chosen]), shapes_fit, options.backbone,
                                   options.order, f_std, z_std, mode=options.mode, amplitude_std=a_std)

    noise: tuple = DEFAULT_NOISE
    agreement = None
    if len(points) > 1:
        noise = tuple(np.concatenate([np.full(p[1].amplitude.size, n[k]) for p, n in zip(points, noises)])
                      for k in (0, 1))
        model = joint_fit(list(range(len(points))))
        agreement = consistency(model, [(name, s, kind) for name, s, _, kind in points], noises, joint_fit)
    if _refines_on_lines(measured, options) and points[0][3] == "stepped-sine" and measured.data is not None:
        model = _refined(model, measured, points, noise)
    resamples = bootstrap_refits(options.bootstrap, options.backbone)
    if samples.amplitude.size == 1:
        resamples = 0  # one linear limit: nothing to resample
    held_errors = None
    if held:
        held_errors = held_out_errors(model, [(name, s, kind) for name, s, _, kind in held],
                                      (float(samples.amplitude.min()), float(samples.amplitude.max())))
    if measured is not None and measured.warnings:  # the band's, first: the samples themselves are in question
        model = dataclasses.replace(model, warnings=measured.warnings + model.warnings)
    return AmplitudeFit(dataclasses.replace(model, reference_unit=unit), samples, tuple(points), tuple(held),
                        agreement, held_errors, noise, resamples, input_dof, data, options)


def joint_covariance_band(fit: AmplitudeFit, amplitude: np.ndarray) -> tuple[np.ndarray, ...]:
    """(frequency low, high, damping low, high) of a ``jenkins`` fit at ``amplitude`` from the
    linearised residual of the estimator that gave it (module docstring): the line refinement
    when the fit was refined on the stepped sine's lines, else the weighted sample fit — with
    noisy amplitudes (phase resonance) its errors-in-variables residual, the true amplitudes
    nuisance unknowns (:func:`~nlupdate.core.identification.joint_band.noisy_fit_residual`)."""
    model = fit.model
    kinds = [p[3] for p in fit.points for _ in range(p[1].amplitude.size)]
    f_std, z_std = (np.broadcast_to(np.asarray(n, float), (len(kinds),)) for n in fit.noise)
    a_std = amplitude_std(kinds, z_std)
    first = fit.points[0]
    refined = (fit.data is not None and fit.data.response_dof == fit.data.input_dof and first[3] == "stepped-sine"
               and not first[1].shape_free)  # as fit_sources refines (_refines_on_lines)
    if not refined and a_std.any() and fit.options.backbone in EIV_BACKBONES:  # the fit's own estimator
        residual, true = noisy_fit_residual(model, fit.samples, locked_frequency_std(kinds, f_std), z_std, a_std)
        return covariance_band(model, residual, amplitude, nuisance=true)
    if not refined:
        noisy = (fit.samples, f_std, z_std, a_std) if a_std.any() else None
        return covariance_band(model, sample_fit_residual(model, fit.samples, f_std, z_std), amplitude,
                               noisy_amplitudes=noisy)
    lines = stepped_sine_lines(fit.data, fit.points[0][1].input_shape)
    keep = np.array([kind != "stepped-sine" for kind in kinds])
    others = join_samples([p[1] for p in fit.points[1:]]) if len(fit.points) > 1 else None
    fs, zs = (f_std[keep], z_std[keep]) if others is not None else (1e-3, 0.05)
    misfit = line_misfit(model, lines)
    noise = float(np.sqrt(2 * np.sum(misfit**2) / max(misfit.size - 4, 1)))  # as refine_on_lines states it
    noisy = (others, fs, zs, a_std[keep]) if others is not None and a_std[keep].any() else None
    source = np.concatenate([np.full(p[1].amplitude.size, i) for i, p in enumerate(fit.points)])[keep]
    return line_refinement_band(model, lines, noise, amplitude, others, fs, zs, source, noisy)


def backbone_table(fit: AmplitudeFit, progress: ProgressCallback = no_progress) -> pd.DataFrame:
    """``backbone.csv``: the model over the fitted samples' amplitudes with its band (module
    docstring): the ``jenkins`` backbone's from its estimator's covariance
    (:func:`joint_covariance_band`), the others' from the bootstrap; one impact's pole alone:
    its own 95 % interval."""
    model, options = fit.model, fit.options
    if model.joint is not None and joint_fixed(model) and fit.samples.amplitude.size > 1:
        curve = backbone_curve(model, fit.samples)
        a = curve["modal_amplitude"].to_numpy()
        (curve["natural_frequency_hz_low"], curve["natural_frequency_hz_high"], curve["damping_ratio_low"],
         curve["damping_ratio_high"]) = joint_covariance_band(fit, a)
        return curve
    curve = backbone_curve(model, fit.samples, refit=lambda draw: fit_amplitude_model(
        draw, model.shapes, options.backbone, options.order, *fit.noise, mode=options.mode),
        resamples=fit.resamples, progress=progress, noise=fit.noise)
    if fit.samples.amplitude.size == 1 and fit.points[0][2] is not None:
        for column, relative in zip(("natural_frequency_hz", "damping_ratio"), fit.points[0][2]):
            curve[f"{column}_low"], curve[f"{column}_high"] = (curve[column] * (1 + k * 1.96 * relative)
                                                               for k in (-1, 1))
    return curve
