"""What to identify and how: the one declaration of the identification settings.

The study's ``[identification]`` table, the options of ``nlupdate identify`` and the
keywords of ``nlupdate.identify`` are read from these fields (:mod:`nlupdate.settings`);
docs/study-files.md's table of keys is generated from them. ``None`` means "choose a
default" — the choice is made by :func:`~nlupdate.core.identification.pipeline.identify`
and listed in ``defaults_used``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nlupdate.core.identification.dfmodels import parse_elements
from nlupdate.core.identification.linear_frf import LINEAR_FROM
from nlupdate.core.identification.methods import METHODS
from nlupdate.settings import setting

#: The most Monte-Carlo samples one identification may ask for (more is a typing mistake,
#: or hours of work).
MAX_MONTE_CARLO_SAMPLES = 100_000
ELEMENT_NAMES = '"cubic", "jenkins", "coulomb", "quadratic_damping", "gap", "iwan"'


@dataclass(frozen=True)
class IdentificationSettings:
    """What to identify and how (each field's meaning, unit and default: its declaration)."""

    response_dof: str = setting(kind="string", required=True, flag="",
                                meaning="response coordinate of the measured curve (where the nonlinearity acts)")
    input_dof: str = setting(kind="string", required=True, flag="", meaning="input coordinate of that curve")
    method: str = setting("prd", kind="choice", choices=tuple(METHODS),
                          meaning="PRD (excitation-frequency method) or DDF")
    elements: tuple[str, ...] = setting(
        (), kind="strings", default_text="`[]` (a polynomial DF)",
        meaning=f"physical elements to fit ({ELEMENT_NAMES}); empty: a polynomial describing function of degree "
                "`order`")
    order: int | None = setting(
        None, kind="integer", minimum=1, default_text="`2`",
        meaning="polynomial degree when `elements` is empty (PRD: real powers `order`…0; DDF: Δ(x) = Σ c_k x^k, "
                "k = 1…`order`)")
    imag_order: int | None = setting(None, kind="integer", minimum=1, method="prd", default_text="`order`",
                                     meaning="polynomial: degree of the imaginary part")
    complex_delta_f1: bool = setting(
        False, kind="boolean", method="prd",
        meaning="polynomial: Δ_f1 = −y(0) complex (default: −Re y(0), i.e. stuck friction at the low force)")
    estimator: str | None = setting(
        None, kind="string", default_text='PRD `"improved"`, DDF `"naive"`',
        meaning='PRD: `"improved"` or `"naive"`; DDF: `"naive"` or `"weighted"`')
    half_window: float | None = setting(
        None, kind="number", minimum=0, maximum=0.5, below_maximum=True, unit="fraction of f", method="prd",
        default_text="`0.01`",
        meaning="improved estimator: pools points within ±`half_window`·f_e of the excitation frequency")
    frequency_hz: float | None = setting(
        None, kind="number", minimum=0, unit="Hz", method="prd", flag="--frequency",
        default_text="recommended by the program (reason in the JSON)", meaning="excitation frequency")
    low_force_n: float | None = setting(
        None, kind="number", minimum=0, unit="N (V per volt)", method="prd", flag="--low-force",
        default_text="lowest measured level",
        meaning="low force level (the linear FRF's reference level; with `linear_from = \"low force\"` extracted "
                "from it alone); a sweep")
    high_forces_n: tuple[float, ...] | None = setting(
        None, kind="numbers", minimum=0, unit="N (V per volt)", method="prd", flag="--high-forces",
        default_text="every level above the low one", meaning="high force levels (sweeps or single frequencies)")
    force_pair_n: tuple[float, float] | None = setting(
        None, kind="numbers", length=2, minimum=0, unit="N (V per volt)", method="ddf", flag="--force-pair",
        default_text="lowest and highest level", meaning="pair of levels")
    band_hz: tuple[float, float] | None = setting(
        None, kind="numbers", length=2, minimum=0, unit="Hz", flag="",
        default_text="the excited band: coherence ≥ `coherence_threshold`, or where the FRF is smooth (reason in "
                     "the JSON)",
        meaning="band every method works in (excitation frequency, fits, linear FRF and its modes); on the "
                "command line `--band LOW:HIGH` of the measured-data options")
    linear_from: str | None = setting(
        None, kind="choice", choices=LINEAR_FROM, method="prd",
        default_text='`"all levels"` with `elements` and sweeps at every level, else `"low force"`',
        meaning="where the linear FRF comes from — every level, line by line, each weighted by the noise of its "
                "1/H_L − ν(|X_L|) (needs physical elements: their DF is known at every amplitude); or the low level "
                "alone with the constant Δ_f1 (the source's eq. 2.55)")
    smoothing_window: int = setting(
        0, kind="integer", minimum=0, unit="points", method="prd", flag="--smooth-linear",
        default_text="`0` (none)",
        meaning="with `linear_from = \"low force\"`: smooth 1/H of the low-force curve over this many points (odd "
                "≥ 5) before extracting the linear FRF")
    amplitude_dependent_delta: bool = setting(
        False, kind="boolean", method="prd",
        meaning="with `linear_from = \"low force\"`: Δ_f1 evaluated at the low-force amplitude at every frequency "
                "(for a slider that slips at the low force) instead of the constant found at f_e")
    noise_fraction: float | None = setting(
        None, kind="number", minimum=0, unit="fraction of |H|", default_text="estimated from the lowest-force curve",
        meaning="noise std / |H| used by the Monte Carlo")
    samples: int = setting(200, kind="integer", minimum=2, maximum=MAX_MONTE_CARLO_SAMPLES,
                           meaning="Monte-Carlo samples of the uncertainty of the parameters and the linear modes")
    seed: int = setting(0, kind="integer", minimum=0, meaning="Monte-Carlo seed")
    linear_modes_hz: tuple[float, ...] | None = setting(
        None, kind="numbers", minimum=0, unit="Hz", default_text="every resonance of the extracted FRF",
        meaning="approximate frequencies of the linear modes to fit")
    modal_band_fraction: float = setting(
        0.1, kind="number", minimum=0, maximum=0.5, above_minimum=True, below_maximum=True, unit="fraction of f",
        meaning="half-width of each one-mode fit, ±fraction·f_r")
    coherence_threshold: float | None = setting(
        None, kind="number", minimum=0, maximum=1, default_text="`0.8` when the data carry coherence",
        meaning="lines with a lower coherence are left out")

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ValueError(f"identification method must be one of {list(METHODS)}, got {self.method!r}")
        method = METHODS[self.method]
        if self.estimator is not None and self.estimator not in method.estimators:
            raise ValueError(f"estimator {self.estimator!r}: {self.method.upper()} estimators are "
                             f"{', '.join(method.estimators)}")
        if not 2 <= self.samples <= MAX_MONTE_CARLO_SAMPLES:
            raise ValueError(f"Monte-Carlo samples must be from 2 to {MAX_MONTE_CARLO_SAMPLES}, got {self.samples}")
        if self.noise_fraction is not None and not (np.isfinite(self.noise_fraction) and self.noise_fraction >= 0):
            raise ValueError(f"noise_fraction must be a number ≥ 0 (std / |H|), got {self.noise_fraction}")
        if self.band_hz is not None:
            low, high = (float(v) for v in self.band_hz)
            if not (np.isfinite(low) and np.isfinite(high) and 0 <= low < high):
                raise ValueError(f"band_hz {list(self.band_hz)}: expected LOW < HIGH, both ≥ 0 Hz")
        if self.coherence_threshold is not None and not 0 <= self.coherence_threshold <= 1:
            raise ValueError(f"coherence_threshold must be between 0 and 1, got {self.coherence_threshold}")
        if self.linear_from is not None and self.linear_from not in LINEAR_FROM:
            raise ValueError(f"linear_from must be one of {list(LINEAR_FROM)}, got {self.linear_from!r}")
        method.check_settings(self)
        parse_elements(self.elements)  # unknown element names fail here
        if not 0 < self.modal_band_fraction < 0.5:
            raise ValueError(f"modal_band_fraction must be in (0, 0.5), got {self.modal_band_fraction}")
