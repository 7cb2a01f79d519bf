"""The two identification methods behind one interface: PRD (docs/methods.md §4) and DDF (§5).

:func:`nlupdate.core.identification.pipeline.identify` runs the same steps for both — fit the
nonlinearity, extract the linear FRF, locate its modes, Monte Carlo — and asks the
method (:data:`METHODS`) only what differs: its settings' defaults, the fit, which level
the linear FRF comes from, and its own part of ``identification.json``. The report and the
fit figure (:mod:`nlupdate.reporting`) take their method-specific wording from here too, so
nothing outside this module branches on a method's name.
"""
from __future__ import annotations

import dataclasses
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.ddf import DDF_ESTIMATORS, DDFResult, identify_ddf
from nlupdate.core.identification.dfmodels import PhysicalModel
from nlupdate.core.identification.linear_frf import LinearExtraction, from_all_levels, from_low_force
from nlupdate.core.identification.prd import DEFAULT_HALF_WINDOW, ESTIMATORS, PRDResult, identify_prd


class Method(Protocol):
    """What an identification method supplies (see the module docstring)."""

    #: What its abbreviation (the key in :data:`METHODS`, upper-cased) stands for, where a
    #: reader first meets it (progress line, report summary).
    long_name: str
    estimators: tuple[str, ...]
    default_estimator: str
    #: Does the fit take one excitation frequency (chosen by the program when not given)?
    uses_excitation_frequency: bool
    #: What the fit figure plots against the response amplitude (its title).
    fitted_quantity: str

    def defaults(self, settings: Any, data: FRFLevels) -> tuple[dict[str, Any], dict[str, Any]]:
        """(changes to the settings, the defaults to list) for its own settings."""

    def defaults_after_fit(self, settings: Any, result: Any) -> dict[str, Any]:
        """Defaults the fit chose (to list)."""

    def check_settings(self, settings: Any) -> None:
        """Its rules on the settings (``ValueError``: keys that belong to the other method)."""

    def sweeps_needed(self, settings: Any, data: FRFLevels) -> dict[float, str]:
        """The levels that must be sweeps, each with its role (``ValueError`` when none can be chosen)."""

    def refit_levels(self, result: Any) -> tuple[float, ...]:
        """The levels a refit may leave out one at a time (the model-form part of the bands)."""

    def point_forces(self, result: Any) -> NDArray[np.float64]:
        """The force level of each fitted point (in the order of ``result.amplitude``)."""

    def amplitude_grid(self, low: float, high: float) -> NDArray[np.float64]:
        """Amplitudes to draw the fitted curve over (``low``, ``high``: the fitted range)."""

    def fit(self, data: FRFLevels, settings: Any, frequency_hz: float | None, model: Any) -> PRDResult | DDFResult:
        """The nonlinearity fit."""

    def linear_frf(self, data: FRFLevels, settings: Any, result: Any) -> LinearExtraction:
        """The extracted linear receptance."""

    def summary(self, result: Any, settings: Any, real: list, imag: list, order: int) -> dict[str, Any]:
        """Its own part of ``identification.json``."""

    def describe_fit(self, result: Any) -> str:
        """The report's sentence on the fit: the levels and frequencies it used, its estimator
        (forces in N)."""

    def describe_points(self, result: Any, unit: str) -> str:
        """The fit figure's caption: how many points, from which levels (``unit``: N, or V
        for a voltage reference), at which frequencies."""


class PRD:
    """Pseudo receptance difference at one excitation frequency."""

    long_name = "pseudo-receptance difference"
    estimators = ESTIMATORS
    default_estimator = "improved"
    uses_excitation_frequency = True
    fitted_quantity = "y = 1/H_i − 1/H_1"

    def defaults(self, settings: Any, data: FRFLevels) -> tuple[dict[str, Any], dict[str, Any]]:
        changes: dict[str, Any] = {}
        listed: dict[str, Any] = {}
        if settings.half_window is None:
            changes["half_window"] = DEFAULT_HALF_WINDOW
            if (settings.estimator or self.default_estimator) == "improved":
                listed["half_window"] = DEFAULT_HALF_WINDOW
        if settings.low_force_n is None and data.levels.size:
            changes["low_force_n"] = listed["low_force_n"] = float(data.levels[0])
        if settings.high_forces_n is None:
            listed["high_forces_n"] = "all levels above the low force"
        if settings.linear_from is None:
            changes["linear_from"], listed["linear_from"] = self._linear_from(settings, data,
                                                                              changes.get("low_force_n"))
        return changes, listed

    @staticmethod
    def _linear_from(settings: Any, data: FRFLevels, default_low: float | None) -> tuple[str, str]:
        """The default linear-FRF route and why: every level where physical elements give
        the DF everywhere and the high levels are sweeps; else the low-force sweep (the
        source's eq. 2.55). Single-frequency high levels (the source's own protocol) add a
        line each, and the slip force they leave undetermined would decide how the
        low-force sweep is corrected near its resonance."""
        if settings.smoothing_window or settings.amplitude_dependent_delta:
            return "low force", "low force (the source's eq. 2.55; smoothing or Δ(A) options given)"
        if not settings.elements:
            return "low force", "low force (the source's eq. 2.55; a polynomial DF is known only over its fitted " \
                                "amplitudes)"
        low = settings.low_force_n if settings.low_force_n is not None else default_low
        highs = settings.high_forces_n if settings.high_forces_n is not None else \
            tuple(float(level) for level in data.levels if low is not None and level > low)
        sweeps = data.sweep_levels()
        single = [level for level in highs if float(data.levels[data.level_index(level)]) not in sweeps]
        if single:
            return "low force", (f"low force (the source's eq. 2.55; {len(single)} high level(s) measured at single "
                                 f"frequencies)")
        return "all levels", "all levels (each line weighted by its noise; physical elements give the DF everywhere)"

    def defaults_after_fit(self, settings: Any, result: PRDResult) -> dict[str, Any]:
        return {}

    def check_settings(self, settings: Any) -> None:
        if settings.force_pair_n is not None:
            raise ValueError("force_pair_n applies to the DDF method")
        if settings.linear_from == "all levels" and not settings.elements:
            raise ValueError("linear_from = 'all levels' needs physical elements (a polynomial DF is known only "
                             "over the amplitudes it was fitted to); use 'low force'")
        if settings.linear_from == "all levels" and (settings.smoothing_window or settings.amplitude_dependent_delta):
            raise ValueError("smoothing_window and amplitude_dependent_delta apply to linear_from = 'low force'")

    def sweeps_needed(self, settings: Any, data: FRFLevels) -> dict[float, str]:
        return {float(settings.low_force_n): "the PRD low force: the linear FRF comes from its sweep"}

    def refit_levels(self, result: PRDResult) -> tuple[float, ...]:
        return tuple(float(level) for level in result.setup.high_forces)

    def point_forces(self, result: PRDResult) -> NDArray[np.float64]:
        forces = np.asarray(result.setup.high_forces, dtype=float)
        size = np.size(result.amplitude)
        return np.tile(forces, max(size // forces.size, 1))[:size]

    def amplitude_grid(self, low: float, high: float) -> NDArray[np.float64]:
        # from 0 (y(0) = −Δ_f1), denser towards 0 where friction's DF turns fastest
        return np.concatenate([np.linspace(0.0, 1.1 * high, 301), np.geomspace(min(1e-3 * high, 0.1 * low), low, 120)])

    def fit(self, data: FRFLevels, settings: Any, frequency_hz: float | None, model: Any) -> PRDResult:
        return identify_prd(data, frequency_hz, model, low_force=settings.low_force_n,
                            high_forces=settings.high_forces_n, estimator=settings.estimator,
                            half_window=settings.half_window)

    def linear_frf(self, data: FRFLevels, settings: Any, result: PRDResult) -> LinearExtraction:
        if settings.linear_from == "all levels":
            return from_all_levels(data, result.df_for_force)
        level = result.setup.low_force
        f, h = data.curve(level)
        return from_low_force(data, level, result.extract_linear_frf(
            f, h, data.force_at(level, f), amplitude_dependent=settings.amplitude_dependent_delta,
            smoothing_window=settings.smoothing_window))

    def summary(self, result: PRDResult, settings: Any, real: list, imag: list, order: int) -> dict[str, Any]:
        prd_real, prd_imag = result.prd_polynomial(order)
        delta = result.delta_f1
        out = {
            "excitation_frequency_hz": result.setup.frequency_hz,
            "low_force_n": result.setup.low_force,
            "high_forces_n": list(result.setup.high_forces),
            "describing_function": {
                "real": real, "imag": imag, "amplitude_range_m": list(result.amplitude_range),
                "definition": "high-force DF nu(|X|) in N/m, first-harmonic force = nu*X at the response dof; "
                              "1/H = 1/H_linear + nu; coefficients highest order first (m -> N/m)",
            },
            "prd_fit": {"real": prd_real, "imag": prd_imag,
                        "definition": "y(|X|) = 1/H_i - 1/H_1 fitted against |X_i| = |H_i| F_i; y(0) = -delta_f1"},
            "delta_f1": {"real": delta.real, "imag": delta.imag,
                         "definition": "DF at the low-force amplitude (stuck friction: kf); "
                                       "1/H_linear = 1/H_1 - delta_f1"},
            "linear_extraction": (
                {"from": "all levels", "definition": "1/H_linear = weighted mean over the levels of 1/H_L - nu(|X_L|), "
                 "weights the inverse noise variance of each term"}
                if settings.linear_from == "all levels" else
                {"from": "low force", "delta_f1": "amplitude dependent" if settings.amplitude_dependent_delta else "constant",
                 "smoothing_window_points": settings.smoothing_window}),
        }
        if result.extras:
            out["estimator_details"] = dict(result.extras, noise_fraction_from_fit=result.noise_fraction)
        return out

    def describe_fit(self, result: PRDResult, unit: str = "N") -> str:
        """One sentence for a report: frequency, levels (in the reference ``unit``, N or V), estimator."""
        setup = result.setup
        low, high = min(setup.high_forces), max(setup.high_forces)
        levels = f"{len(setup.high_forces)} high levels ({low:g}–{high:g} {unit})" if len(setup.high_forces) > 1 \
            else f"1 high level ({high:g} {unit})"
        return f"PRD at **{setup.frequency_hz:g} Hz** from the {setup.low_force:g} {unit} (low) and {levels}, " \
               f"{result.estimator} estimator."

    def describe_points(self, result: PRDResult, unit: str) -> str:
        setup = result.setup
        levels = sorted(setup.high_forces)
        span = f"{levels[0]:g}–{levels[-1]:g} {unit}" if len(levels) > 1 else f"{levels[0]:g} {unit}"
        window = result.extras.get("half_window") if result.estimator == "improved" else None
        where = f"within ±{100 * window:g} % of {setup.frequency_hz:g} Hz" if window else f"at {setup.frequency_hz:g} Hz"
        return (f"{len(result.amplitude)} points: {len(levels)} force level{'s' if len(levels) > 1 else ''} ({span}) "
                f"against {setup.low_force:g} {unit}, {where}")


class DDF:
    """Direct describing function from two force levels over many frequencies."""

    long_name = "direct describing function"
    estimators = DDF_ESTIMATORS
    default_estimator = "naive"
    uses_excitation_frequency = False
    fitted_quantity = "Δ(x₂) implied by 1/H₂ − 1/H₁ + Δ(x₁)"
    #: PRD's keys, refused with DDF.
    PRD_KEYS = ("frequency_hz", "low_force_n", "high_forces_n", "smoothing_window", "amplitude_dependent_delta",
                "linear_from", "half_window", "imag_order", "complex_delta_f1")

    def defaults(self, settings: Any, data: FRFLevels) -> tuple[dict[str, Any], dict[str, Any]]:
        sweeps = data.sweep_levels()  # default pair: the lowest and the highest sweep
        if settings.force_pair_n is not None or len(sweeps) < 2:
            return {}, {}
        pair = (sweeps[0], sweeps[-1])
        return {"force_pair_n": pair}, {"force_pair_n": list(pair)}

    def defaults_after_fit(self, settings: Any, result: DDFResult) -> dict[str, Any]:
        return {"band_hz": list(result.setup.band_hz)} if settings.band_hz is None else {}

    def check_settings(self, settings: Any) -> None:
        defaults = {f.name: f.default for f in dataclasses.fields(settings)}
        given = [name for name in self.PRD_KEYS if getattr(settings, name) != defaults[name]]
        if given:
            raise ValueError(f"{', '.join(given)} apply to the PRD method")

    def sweeps_needed(self, settings: Any, data: FRFLevels) -> dict[float, str]:
        if settings.force_pair_n is None:
            raise ValueError(f"DDF compares two sweeps; the swept levels are {list(data.sweep_levels())}")
        return {float(level): "a DDF level: DDF compares two sweeps" for level in settings.force_pair_n}

    def refit_levels(self, result: DDFResult) -> tuple[float, ...]:
        return ()  # two levels: none to spare

    def point_forces(self, result: DDFResult) -> NDArray[np.float64]:
        return np.full(np.size(result.amplitude), float(result.setup.force_pair[1]))

    def amplitude_grid(self, low: float, high: float) -> NDArray[np.float64]:
        return np.linspace(0.5 * low, 1.1 * high, 301)

    def fit(self, data: FRFLevels, settings: Any, frequency_hz: float | None, model: Any) -> DDFResult:
        return identify_ddf(data, settings.force_pair_n, settings.band_hz, settings.order,
                            physical=model if isinstance(model, PhysicalModel) else None, estimator=settings.estimator)

    def linear_frf(self, data: FRFLevels, settings: Any, result: DDFResult) -> LinearExtraction:
        level = result.setup.linear_level
        f, h = data.curve(level)
        return from_low_force(data, level, result.extract_linear_frf(f, h, data.force_at(level, f)))

    def summary(self, result: DDFResult, settings: Any, real: list, imag: list, order: int) -> dict[str, Any]:
        return {
            "excitation_frequency_hz": None,
            "force_pair_n": list(result.setup.force_pair),
            "band_hz": list(result.setup.band_hz),
            "describing_function": {
                "real": real, "imag": imag, "amplitude_range_m": list(result.amplitude_range),
                "definition": "DF Delta(|X|) in N/m (no constant term), first-harmonic force = Delta*X; "
                              "coefficients highest order first (m -> N/m)",
            },
        }

    def describe_fit(self, result: DDFResult, unit: str = "N") -> str:
        """One sentence for a report: the pair of levels (in the reference ``unit``), band, estimator."""
        low, high = result.setup.force_pair
        band = result.setup.band_hz
        return (f"DDF between {low:g} and {high:g} {unit} over {band[0]:g}–{band[1]:g} Hz, "
                f"{result.estimator} estimator.")

    def describe_points(self, result: DDFResult, unit: str) -> str:
        low, high = result.setup.force_pair
        band = result.setup.band_hz
        return f"{len(result.amplitude)} points: {high:g} {unit} against {low:g} {unit}, {band[0]:g}–{band[1]:g} Hz"


#: The methods by name.
METHODS: dict[str, Method] = {"prd": PRD(), "ddf": DDF()}


def spelled_out(method: str) -> str:
    """A method's abbreviation with what it stands for, as a reader first meets it:
    ``PRD (pseudo-receptance difference)``."""
    return f"{method.upper()} ({METHODS[method].long_name})"
