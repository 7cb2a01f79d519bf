"""The identification step of the chain as one call: :func:`identify`.

From the measured curves of one (response, input) pair at several force levels
(:class:`~nlupdate.core.identification.data.FRFLevels`) it

1. chooses the PRD excitation frequency (given, or :func:`recommend_frequency`);
2. fits the nonlinearity (PRD or DDF; physical elements or a polynomial DF);
3. extracts the linear FRF (:mod:`nlupdate.core.identification.linear_frf`): with physical
   elements from every level, each line weighted by its noise; with a polynomial DF from
   the low-force sweep (PRD) or the lower DDF level;
4. locates the linear modes of the extracted FRF (one-mode fits around each resonance,
   :func:`~nlupdate.core.identification.linear_frf.locate_linear_modes`): their natural
   frequencies are the updating targets, their loss factors the linear damping;
5. estimates the uncertainty of everything above by Monte Carlo over the noise model
   (:mod:`nlupdate.core.identification.uncertainty`): each sample re-identifies at the chosen
   frequency, re-extracts the linear FRF from its own perturbed curves and re-fits the
   modes, so the natural frequencies carry the uncertainty of the fitted DF *and* of the
   measurement noise, ready to be propagated into updated parameters; the fitted curve
   (over :func:`fit_amplitude_grid`) and the extracted linear FRF get a 95 % band from the
   same samples (:attr:`Identification.fit_band`, :attr:`Identification.linear_frf_band`);
6. checks that the linear FRF each level gives is the same at every level, within the
   noise (physical elements; :mod:`nlupdate.core.identification.consistency`): when it is not,
   the identified model does not describe the structure at the measured coordinate and
   the result is marked not trustworthy (:attr:`Identification.trustworthy`).

Every option left out is filled by a default, listed in ``defaults_used``. The result,
:class:`Identification`, is plain data (picklable) and :meth:`Identification.summary`
is the content of ``identification.json``. Conventions: SI units, Hz at interfaces.
"""
from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from nlupdate.core.identification.bands import MIN_JACKKNIFE, leave_one_level_out, parameter_bounds, positive_names
from nlupdate.core.identification.data import MIN_SWEEP_LINES, FRFLevels
from nlupdate.core.identification.ddf import DDFResult
from nlupdate.core.identification.dfmodels import PhysicalModel, PolynomialModel, iwan_identifiability, parse_elements
from nlupdate.core.identification.frequency import FrequencyChoice, recommend_frequency
from nlupdate.core.identification.consistency import LevelConsistency, level_consistency
from nlupdate.core.identification.linear_frf import LINEAR_FROM, LinearExtraction, level_terms, locate_linear_modes
from nlupdate.core.identification.modal_fit import ModalFit
from nlupdate.core.identification.methods import METHODS
from nlupdate.core.identification.prd import IdentificationError, PRDResult
from nlupdate.core.identification.settings import MAX_MONTE_CARLO_SAMPLES, IdentificationSettings
from nlupdate.core.identification.summary import identification_summary, linear_frf_table, residual_in_noise_units
from nlupdate.core.identification.trust import (
    TrustWarning, consistency_warnings, dissipation_warnings, diverged_names, diverged_text, excitation_warnings,
    fit_verdict, identification_warnings, mode_fit_warnings, sign_warnings,
)
from nlupdate.core.identification.uncertainty import CurveBand, Uncertainty, monte_carlo
from nlupdate.core.measurement.band import COHERENCE_THRESHOLD, Band, excited_band
from nlupdate.core.measurement.coherence import noise_fraction_from_coherence, noise_fraction_from_std
from nlupdate.core.measurement.noise import estimate_noise_fraction
from nlupdate.core.measurement.units import parameter_unit
from nlupdate.progress import ProgressCallback, no_progress



@dataclass(frozen=True, eq=False)
class Identification:
    """Outcome of :func:`identify` (SI units, Hz).

    settings: as given; defaults_used: every default chosen, with its value.
    result: the PRD/DDF fit (:class:`~nlupdate.core.identification.prd.PRDResult` or
    :class:`~nlupdate.core.identification.ddf.DDFResult`). frequency_choice: how the PRD
    frequency was chosen (None when given, and for DDF). linear_frequency_hz,
    linear_frf: the extracted linear receptance (m/N) on the grid of the lowest level it
    came from (``linear_from_level_n``, the measured curve drawn beside it);
    linear_from_levels_n: every level it came from. modes: one-mode fits of the
    extracted FRF, ascending.
    uncertainty: Monte-Carlo statistics of the parameters and of ``linear_f<i>_hz``
    (natural frequency of mode i, 1-based) and ``linear_eta<i>`` (its loss factor).
    noise_fraction, noise_source: the noise level used and where it came from.
    warnings: reasons not to trust parts of the result (:mod:`nlupdate.core.identification.trust`).
    level_consistency: is the linear FRF each level gives the same at every level
    (:mod:`nlupdate.core.identification.consistency`)? None when not checked (a polynomial DF
    is known only over its fitted amplitudes; fewer than two levels per line).
    """

    settings: IdentificationSettings
    defaults_used: dict[str, Any]
    result: PRDResult | DDFResult
    frequency_choice: FrequencyChoice | None
    linear_from_level_n: float
    linear_frequency_hz: NDArray[np.float64]
    linear_frf: NDArray[np.complex128]
    modes: tuple[ModalFit, ...]
    uncertainty: Uncertainty
    noise_fraction: float
    noise_source: str
    model_description: str = field(default="")
    band_hz: tuple[float, float] | None = None
    band_reason: str = ""
    reference_unit: str = "N"
    excitation: str = "unknown"
    lines_below_coherence: int = 0
    linear_from_levels_n: tuple[float, ...] = ()
    level_consistency: LevelConsistency | None = None

    @property
    def trustworthy(self) -> bool:
        """False when the levels' linear FRFs disagree beyond their noise: the identified
        model does not describe the structure at the measured coordinate."""
        return self.level_consistency is None or self.level_consistency.passed

    @property
    def linear_source(self) -> str:
        """Where the extracted linear FRF came from, in words."""
        unit = self.reference_unit
        levels = self.linear_from_levels_n or (self.linear_from_level_n,)
        if len(levels) == 1:
            return f"the {levels[0]:g} {unit} sweep"
        return (f"all {len(levels)} levels ({min(levels):g}–{max(levels):g} {unit}), each line weighted by the noise "
                f"of 1/H − ν(|X|) at that level")

    @property
    def fit_band(self) -> CurveBand | None:
        """95 % Monte-Carlo band of the fitted curve ``result.fitted_y`` (N/m) over the
        amplitudes (m) of :func:`fit_amplitude_grid`; None for results made without it."""
        return self.uncertainty.curves.get("fit")

    @property
    def linear_frf_band(self) -> CurveBand | None:
        """95 % Monte-Carlo band of the extracted linear receptance (m/N) over
        ``linear_frequency_hz``; None for results made without it."""
        return self.uncertainty.curves.get("linear_frf")

    @property
    def natural_frequencies_hz(self) -> NDArray[np.float64]:
        """Natural frequencies (Hz) of the linear modes of the extracted FRF."""
        return np.array([float(m.natural_frequencies_hz[0]) for m in self.modes])

    @property
    def natural_frequency_std_hz(self) -> NDArray[np.float64]:
        """Monte-Carlo standard deviation (Hz) of each natural frequency."""
        return np.array([self.uncertainty.parameters[f"linear_f{i + 1}_hz"].std for i in range(len(self.modes))])

    def nearest_mode(self, frequency_hz: float) -> int | None:
        """The index of the extracted FRF's mode nearest ``frequency_hz`` (Hz); None without modes."""
        if not self.modes:
            return None
        return int(np.argmin(np.abs(self.natural_frequencies_hz - frequency_hz)))

    @property
    def loss_factors(self) -> NDArray[np.float64]:
        """Loss factors of the linear modes of the extracted FRF."""
        return np.array([float(m.loss_factors[0]) for m in self.modes])

    def modal_receptance(self, frequency_hz: NDArray) -> NDArray[np.complex128]:
        """The fitted modes' receptance (m/N) over their fit bands, NaN elsewhere."""
        f = np.asarray(frequency_hz, dtype=float)
        out = np.full(f.shape, np.nan + 0j)
        fraction = self.settings.modal_band_fraction
        for mode in self.modes:
            natural = float(mode.natural_frequencies_hz[0])
            band = np.abs(f - natural) <= fraction * natural
            out[band] = mode.receptance(f[band])
        return out

    @property
    def residual_noise_fraction(self) -> float | None:
        """The noise level (std / |H|) implied by the fit's residuals; about
        ``noise_fraction`` when the model fits (None when the fit has no spare degrees of
        freedom)."""
        return getattr(self.result, "residual_noise_fraction", None)

    @property
    def warnings(self) -> tuple[TrustWarning, ...]:
        """Parameters on a bound or not determined by the data, a residual far above the
        noise (:func:`nlupdate.core.identification.trust.identification_warnings`), a parameter
        that must be positive and is not, data that are not stepped-sine FRFs; empty when
        nothing is suspicious."""
        energy = dissipation_warnings(self.result, self.reference_unit)
        return consistency_warnings(self.level_consistency, self.settings.response_dof) + \
            identification_warnings(self) + \
            sign_warnings(self.result.parameters(), self.reference_unit, dissipates=not energy) + energy + \
            mode_fit_warnings(self.modes) + excitation_warnings(self.excitation, self.settings.method)

    def parameters(self) -> dict[str, float]:
        """Identified nonlinearity parameters (SI) by name."""
        return self.result.parameters()

    @property
    def diverged(self) -> dict[str, str]:
        """Each parameter the fit ran off with (a ``diverged`` warning) → what its number means,
        to stand where the number would (:func:`~nlupdate.core.identification.trust.diverged_text`)."""
        stats = self.uncertainty.parameters
        return {name: diverged_text(name, stats[name].value if name in stats else self.parameters()[name],
                                    self.reference_unit) for name in diverged_names(self.warnings)}

    def unit_of(self, name: str) -> str:
        """The unit of parameter ``name`` as its element declares it, per volt with a V reference
        (:func:`~nlupdate.core.measurement.units.parameter_unit`; '' when dimensionless)."""
        return parameter_unit(name, self.reference_unit)

    def elements(self, dofs: tuple[int, ...]) -> list:
        """Forward-model elements at model coordinate(s) ``dofs``."""
        return self.result.elements(dofs)

    def parameter_meanings(self) -> list[tuple[tuple[str, ...], str]]:
        """(reported names, meaning) of each identified element parameter
        (:meth:`~nlupdate.core.identification.dfmodels.PhysicalModel.parameter_meanings`);
        none for a polynomial describing function."""
        model = getattr(self.result, "physical", None) or getattr(self.result, "model", None)
        return model.parameter_meanings() if isinstance(model, PhysicalModel) else []

    def misfit_in_noise_units(self) -> NDArray[np.float64]:
        """Each PRD/DDF point's misfit over the noise it carries — about 1 where the model
        fits (:func:`nlupdate.core.identification.summary.residual_in_noise_units`)."""
        return residual_in_noise_units(self.result, self.noise_fraction)

    def linear_frf_table(self) -> pd.DataFrame:
        """The extracted linear FRF as a measured-FRF table (``force_level_n = 0``)."""
        return linear_frf_table(self.linear_frequency_hz, self.linear_frf, self.settings.response_dof,
                                self.settings.input_dof)

    def summary(self) -> dict[str, Any]:
        """The ``identification.json`` content (:func:`nlupdate.core.identification.summary.identification_summary`)."""
        return identification_summary(self)

    def __repr__(self) -> str:
        """One line: method, curve, parameters ± Monte-Carlo std, linear modes, warnings
        (``summary()`` holds the whole record)."""
        stats = self.uncertainty.parameters
        values = ", ".join(f"{name} = {value:.4g}" + (f" ± {stats[name].std:.2g}" if name in stats and
                                                      np.isfinite(stats[name].std) else "")
                           for name, value in self.parameters().items())
        modes = ", ".join(f"{f:.2f}" for f in self.natural_frequencies_hz)
        return (f"<Identification {self.settings.method.upper()} at {self.settings.response_dof}/"
                f"{self.settings.input_dof}: {values or 'no parameters'}; linear modes {modes or '–'} Hz; "
                f"{len(self.warnings)} warning(s)>")


# ------------------------------------------------------------------------------------ steps
def _resolved(settings: IdentificationSettings, data: FRFLevels) -> tuple[IdentificationSettings, dict[str, Any]]:
    """Settings with every default filled in, and the defaults that were used."""
    method = METHODS[settings.method]
    defaults: dict[str, Any] = {}
    changes: dict[str, Any] = {}
    if settings.order is None:
        changes["order"] = defaults["order"] = 2
    if settings.estimator is None:
        changes["estimator"] = defaults["estimator"] = method.default_estimator
    own_changes, own_defaults = method.defaults(dataclasses.replace(settings, **changes), data)
    return dataclasses.replace(settings, **changes, **own_changes), {**defaults, **own_defaults}


def _model(settings: IdentificationSettings) -> PhysicalModel | PolynomialModel:
    physical = parse_elements(settings.elements)
    return physical or PolynomialModel.of_order(settings.order, settings.imag_order, settings.complex_delta_f1)


def _fit(data: FRFLevels, settings: IdentificationSettings, frequency_hz: float | None,
         model: PhysicalModel | PolynomialModel | None = None,
         first: PRDResult | DDFResult | None = None) -> PRDResult | DDFResult:
    """The nonlinearity fit alone (also each Monte-Carlo sample's, given the point estimate's
    ``model``); an Iwan joint no level drives into macroslip is refitted with what the data
    cannot show fixed (:func:`~nlupdate.core.identification.dfmodels.iwan_identifiability`). A
    sample given such a refit model fits it at once, its φ_max moved to the sample's own
    largest amplitude — the refit its free fit would have led to; that free fit runs into
    the directions the data do not show (1000 evaluations, 1.8 s on the BRB) to be thrown
    away. ``first``: the free fit of the settings' own model at ``frequency_hz``, when
    already made (the PRD frequency choice fits there)."""
    def fit(model):
        return METHODS[settings.method].fit(data, settings, frequency_hz, model)

    result = first if first is not None and model is None else fit(model or _model(settings))
    refit = iwan_identifiability(getattr(result, "physical", None) or getattr(result, "model", None), result.p,
                                 float(np.max(result.amplitude)))
    return result if refit is None else fit(refit)


def _linear_frf(data: FRFLevels, settings: IdentificationSettings, result: PRDResult | DDFResult) -> LinearExtraction:
    return METHODS[settings.method].linear_frf(data, settings, result)


def fit_amplitude_grid(result: PRDResult | DDFResult) -> NDArray[np.float64]:
    """Amplitudes (m) to draw a fitted curve and its band over: from 0 (PRD: y(0) = −Δ_f1)
    or half the smallest fitted amplitude (DDF) to 1.1 × the largest, denser towards 0
    (down to a tenth of the smallest fitted amplitude, for a log axis) where friction's
    describing function turns fastest. Outside ``result.amplitude_range``
    the curve is an extrapolation."""
    low, high = result.amplitude_range
    grid = METHODS[result.method].amplitude_grid(low, high)
    return np.unique(np.concatenate([grid, [low, high]]))


def _sample_values(
    data: FRFLevels, settings: IdentificationSettings, frequency_hz: float | None, modes_hz: tuple[float, ...],
    amplitude_grid: NDArray | None = None, model: PhysicalModel | PolynomialModel | None = None,
) -> dict[str, Any]:
    """One Monte-Carlo sample: the parameters and the linear modes of perturbed data, its
    extracted linear FRF (``linear_frf``) and, given ``amplitude_grid``, its fitted curve
    over it (``fit``); ``model``: the point estimate's (:func:`_fit`)."""
    result = _fit(data, settings, frequency_hz, model)
    values: dict[str, Any] = dict(result.parameters())
    linear = _linear_frf(data, settings, result)
    values["linear_frf"] = linear.receptance
    if amplitude_grid is not None:
        values["fit"] = result.fitted_y(amplitude_grid)
    for i, fit in enumerate(locate_linear_modes(linear.frequency_hz, linear.receptance, linear.inverse_noise, modes_hz,
                                                settings.modal_band_fraction)):
        values[f"linear_f{i + 1}_hz"] = float(fit.natural_frequencies_hz[0])
        values[f"linear_eta{i + 1}"] = float(fit.loss_factors[0])
    return values


def _level_jackknife(data: FRFLevels, settings: IdentificationSettings, result: PRDResult | DDFResult,
                     frequency_hz: float | None, modes_hz: tuple[float, ...], model: Any,
                     amplitude_grid: NDArray) -> list[dict[str, Any]]:
    """The values and curves of each PRD refit with one high level left out (the model-form
    part of the intervals, :mod:`nlupdate.core.identification.bands`); none for DDF (two
    levels) or fewer than :data:`~nlupdate.core.identification.bands.MIN_JACKKNIFE` high levels."""
    highs = METHODS[settings.method].refit_levels(result)
    if len(highs) < MIN_JACKKNIFE:
        return []

    def refit(level: float) -> dict[str, Any]:
        kept = [v for v in data.levels if not np.isclose(v, level, rtol=1e-9)]
        fewer = dataclasses.replace(settings, high_forces_n=tuple(h for h in highs if h != level))
        return _sample_values(data.subset(kept), fewer, frequency_hz, modes_hz, amplitude_grid, model)

    return leave_one_level_out(refit, highs)[0]


def identify(data: FRFLevels, settings: IdentificationSettings, progress: ProgressCallback = no_progress) -> Identification:
    """Run the identification step (module docstring) on measured curves ``data``;
    ``progress`` hears the Monte-Carlo samples as they finish."""
    if (data.response_dof, data.input_dof) != (str(settings.response_dof), str(settings.input_dof)):
        raise ValueError(
            f"the data are response {data.response_dof!r} / input {data.input_dof!r}, the settings ask for "
            f"{settings.response_dof!r} / {settings.input_dof!r}"
        )
    data, settings, defaults, band = prepared_data(data, settings)
    lines_masked = int(sum(f.size for f in data.frequencies))
    data = data.coherent(settings.coherence_threshold) if settings.coherence_threshold is not None else data
    lines_masked -= int(sum(f.size for f in data.frequencies))
    resolved, more = _resolved(settings, data)
    settings, defaults = resolved, {**defaults, **more}
    _check_levels(data, settings)
    choice = None
    frequency = settings.frequency_hz
    visited: dict[float, PRDResult] = {}  # the choice's fits, by frequency: the fit at the chosen one is reused
    if METHODS[settings.method].uses_excitation_frequency and frequency is None:
        choice = recommend_frequency(data, _model(settings), low_force=settings.low_force_n,
                                     high_forces=settings.high_forces_n, estimator=settings.estimator,
                                     half_window=settings.half_window, fits=visited)
        frequency = choice.frequency_hz
        defaults["frequency_hz"] = f"{frequency:g} ({choice.reason}; visited {list(choice.visited_hz)} Hz)"
    result = _fit(data, settings, frequency, first=visited.get(frequency))
    defaults.update(METHODS[settings.method].defaults_after_fit(settings, result))
    linear = _linear_frf(data, settings, result)
    f_linear, h_linear = linear.frequency_hz, linear.receptance
    modes = locate_linear_modes(f_linear, h_linear, linear.inverse_noise, settings.linear_modes_hz,
                                settings.modal_band_fraction)

    k = data.level_index(data.sweep_levels()[0])  # the noise of the lowest sweep
    if settings.noise_fraction is not None:
        noise, source = float(settings.noise_fraction), "given"
    elif data.h_stds is not None:
        noise = noise_fraction_from_std(data.receptances[k], data.h_stds[k])
        source = f"the stated standard deviations (h_std) of the {data.levels[k]:g} {data.reference_unit} curve"
        defaults["noise_fraction"] = f"{noise:.4g} ({source})"
    elif data.coherences is not None and data.averages is not None:
        noise = noise_fraction_from_coherence(data.coherences[k], data.averages[k])
        source = (f"coherence and averages of the {data.levels[k]:g} {data.reference_unit} curve "
                  f"(H1 random error, Bendat & Piersol)")
        defaults["noise_fraction"] = f"{noise:.4g} ({source})"
    else:
        f_low, h_low = data.curve(data.levels[k])
        try:
            noise = estimate_noise_fraction(f_low, h_low)
            source = f"estimated from the {data.levels[k]:g} {data.reference_unit} sweep (local quadratic fits of 1/H)"
        except ValueError as error:
            if getattr(result, "noise_fraction", None) is None:
                raise IdentificationError(f"cannot estimate the noise level ({error}); give noise_fraction") from None
            noise, source = float(result.noise_fraction), "estimated from the residuals of the fit"
        defaults["noise_fraction"] = f"{noise:.4g} ({source})"

    modes_hz = tuple(float(m.natural_frequencies_hz[0]) for m in modes)
    point = dict(result.parameters())
    for i, m in enumerate(modes):
        point[f"linear_f{i + 1}_hz"] = float(m.natural_frequencies_hz[0])
        point[f"linear_eta{i + 1}"] = float(m.loss_factors[0])
    grid = fit_amplitude_grid(result)
    fitted = getattr(result, "physical", None) or getattr(result, "model", None)
    estimate = functools.partial(_sample_values, settings=settings, frequency_hz=frequency, modes_hz=modes_hz,
                                 amplitude_grid=grid, model=fitted)
    ratio = fit_verdict(result.residual_noise_fraction, noise)[1]
    jackknife = _level_jackknife(data, settings, result, frequency, modes_hz, fitted, grid) if (ratio or 0) > 1 \
        else []
    uncertainty = monte_carlo(estimate, data, point, noise, settings.samples, settings.seed, progress,
                              curves={"fit": (grid, result.fitted_y(grid)), "linear_frf": (f_linear, h_linear)},
                              residual_ratio=ratio, jackknife=jackknife,
                              bounds=parameter_bounds(fitted, point, getattr(result, "at_bound", ())),
                              positive=positive_names(fitted, point))
    consistency = level_consistency(level_terms(data, result.df_for_force), noise) if settings.elements else None
    model = getattr(result, "physical", None) or getattr(result, "model", None) or parse_elements(settings.elements)
    description = model.description() if model is not None else (
        f"DDF polynomial Δ(x) = Σ c_k x^k, k = 1..{result.setup.order}")
    return Identification(
        settings=settings, defaults_used=defaults, result=result, frequency_choice=choice,
        linear_from_level_n=linear.reference_level_n, linear_from_levels_n=linear.levels_n,
        linear_frequency_hz=f_linear, linear_frf=h_linear, modes=modes, uncertainty=uncertainty,
        noise_fraction=noise, noise_source=source, model_description=description,
        band_hz=band.hz, band_reason=band.reason, reference_unit=data.reference_unit, excitation=data.excitation,
        lines_below_coherence=lines_masked, level_consistency=consistency,
    )


def prepared_data(data: FRFLevels, settings: IdentificationSettings):
    """(data within the band, settings with the band and coherence threshold filled in,
    the defaults chosen, the :class:`~nlupdate.core.measurement.band.Band`). The band comes
    from the settings or from the lowest swept level's excited band; every later step (the
    excitation frequency, the fits, the linear FRF and its modes) sees only it."""
    defaults: dict[str, Any] = {}
    changes: dict[str, Any] = {}
    if settings.coherence_threshold is None and data.coherences is not None:
        changes["coherence_threshold"] = defaults["coherence_threshold"] = COHERENCE_THRESHOLD
    threshold = changes.get("coherence_threshold", settings.coherence_threshold)
    if settings.band_hz is not None:
        band = Band(float(settings.band_hz[0]), float(settings.band_hz[1]), "given")
    else:
        sweeps = data.sweep_levels()
        if not sweeps:
            most = max(f.size for f in data.frequencies)
            raise IdentificationError(f"no level is a sweep: the most lines a level has is {most}, a sweep has at "
                                      f"least {MIN_SWEEP_LINES}; identification needs at least the low force "
                                      f"measured over a band")
        k = data.level_index(sweeps[0])
        f, h = data.frequencies[k], data.receptances[k]
        coherence = None if data.coherences is None else data.coherences[k]
        band = excited_band(f, h, coherence, threshold if threshold is not None else COHERENCE_THRESHOLD)
        changes["band_hz"] = band.hz
        defaults["band_hz"] = f"{band.low_hz:g}:{band.high_hz:g} Hz ({band.reason}, {sweeps[0]:g} " \
                              f"{data.reference_unit} curve)"
    inside = data.within(band.hz)
    return inside, dataclasses.replace(settings, **changes), defaults, band



def _check_levels(data: FRFLevels, settings: IdentificationSettings) -> None:
    """Levels > 0, each with a line left in the band; the levels the method reads as sweeps
    (PRD's low force, from which the linear FRF comes; DDF's pair) with at least
    :data:`MIN_SWEEP_LINES` lines. Single-frequency high levels are PRD's own protocol."""
    unit = data.reference_unit
    zero = [float(level) for level in data.levels if not level > 0]
    if zero:
        raise IdentificationError(
            f"level {zero[0]:g} {unit}: identification needs measured levels > 0 (force_level_n = 0 marks an "
            f"extracted linear FRF); leave that curve out")
    where = f"the band {settings.band_hz[0]:g}–{settings.band_hz[1]:g} Hz" if settings.band_hz else "the data"
    if settings.coherence_threshold is not None and data.coherences is not None:
        where += f" with coherence ≥ {settings.coherence_threshold:g}"
    for level, f in zip(data.levels, data.frequencies):
        if f.size == 0:
            raise IdentificationError(f"level {level:g} {unit}: no line in {where}; widen the band, lower the "
                                      f"coherence threshold or leave the level out")
    try:
        needed = METHODS[settings.method].sweeps_needed(settings, data)
    except ValueError as error:
        raise IdentificationError(f"{error} {unit} (a sweep has at least {MIN_SWEEP_LINES} lines in {where})") from None
    sweeps = data.sweep_levels()
    for level, role in needed.items():
        if level not in sweeps:
            lines = data.frequencies[data.level_index(level)].size
            raise IdentificationError(
                f"level {level:g} {unit} is {role}, but it has {lines} line(s) in {where}; "
                f"need a sweep of at least {MIN_SWEEP_LINES} lines")
