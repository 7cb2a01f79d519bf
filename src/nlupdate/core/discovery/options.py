"""The settings of discovery (:func:`nlupdate.core.discovery.workflow.discover`), checked when made."""
from __future__ import annotations

from dataclasses import dataclass

from nlupdate.core.discovery.candidates import CRITERIA
from nlupdate.core.discovery.effects import Effect, library
from nlupdate.core.discovery.errors import DiscoveryError
from nlupdate.core.discovery.frf_data import SWEEP_DIRECTIONS
from nlupdate.core.response.harmonic_balance import HarmonicSettings
from nlupdate.core.response.method import HARMONICS_FORM, samples_form, valid_harmonics, valid_samples


@dataclass(frozen=True)
class DiscoveryOptions:
    """Settings of :func:`discover`.

    effects: names of library effects or :class:`~nlupdate.core.discovery.effects.Effect`
    instances (None: the whole library). criterion: ``"bic"`` or ``"aic"``.
    max_effects: most effects to add. min_evidence, min_explained: significance rule
    (:func:`~nlupdate.core.discovery.candidates.is_significant`); min_evidence is also the
    criterion margin by which a joint refit must prefer a swap or may lose an effect.
    place_share, max_places: candidates are fitted at every place that explains at least
    ``place_share`` of what the best place explains, at most ``max_places`` of them.
    noise_fraction: relative noise std of the FRFs (None: from the data — their stated
    uncertainty, repeats, or the model-free estimate), never below min_noise_fraction.
    sweep: how the test reached each frequency — "up", "down" or "unknown"; None: as the
    measured table states (its ``sweep_direction`` column), else unknown. It only decides
    which points are marked as following another branch: every point is compared with the
    model's nearest stable solution.
    frequency_uncertainty, damping_uncertainty: relative std of modal-table frequencies
    and damping ratios. harmonic_balance: None to simulate the model by the describing
    function (default), or the settings of a multi-harmonic balance (measured FRFs only;
    the candidates' fits stay describing-function fits, the simulated gap and the check of
    every added effect use the balance). equivalence_tolerance: DF deviation within which a
    candidate counts as its simpler equivalent. poor_fit_ratio: RMS residual over noise
    level above which the fit is reported poor. joint_refit: refit every effect together
    after each addition and reconsider earlier choices (switch off only to compare).
    restarts: when a search ends with an RMS residual above 1.5× the noise level, search
    again without its first choice (then without the next first choice), up to this many times, and keep the result
    with the lower criterion.
    """

    effects: tuple[str | Effect, ...] | None = None
    criterion: str = "bic"
    max_effects: int = 3
    min_evidence: float = 10.0
    min_explained: float = 0.5
    max_places: int = 10
    place_share: float = 0.5
    noise_fraction: float | None = None
    min_noise_fraction: float = 0.002
    sweep: str | None = None
    frequency_uncertainty: float = 0.002
    damping_uncertainty: float = 0.05
    harmonic_balance: HarmonicSettings | None = None
    equivalence_tolerance: float = 0.1
    poor_fit_ratio: float = 5.0
    joint_refit: bool = True
    restarts: int = 2

    def __post_init__(self) -> None:
        if self.criterion not in CRITERIA:
            raise DiscoveryError(f"options.criterion: expected one of {CRITERIA}, got {self.criterion!r}")
        if self.sweep is not None and self.sweep not in SWEEP_DIRECTIONS:
            raise DiscoveryError(f"options.sweep: expected one of {', '.join(SWEEP_DIRECTIONS)} or None (as the data "
                                 f"state), got {self.sweep!r}")
        if int(self.restarts) < 0:
            raise DiscoveryError(f"options.restarts: expected an integer ≥ 0, got {self.restarts!r}")
        for name in ("max_effects", "max_places"):
            if int(getattr(self, name)) < 1:
                raise DiscoveryError(f"options.{name}: expected a positive integer, got {getattr(self, name)!r}")
        for name in ("min_noise_fraction", "frequency_uncertainty", "damping_uncertainty", "poor_fit_ratio"):
            if not getattr(self, name) > 0:
                raise DiscoveryError(f"options.{name}: expected a positive number, got {getattr(self, name)!r}")
        for name in ("place_share", "equivalence_tolerance"):
            if not 0 <= getattr(self, name) <= 1:
                raise DiscoveryError(f"options.{name}: expected a fraction in [0, 1], got {getattr(self, name)!r}")
        if self.noise_fraction is not None and not self.noise_fraction > 0:
            raise DiscoveryError(f"options.noise_fraction: expected a positive fraction (e.g. 0.01), got {self.noise_fraction!r}")
        settings = self.harmonic_balance
        if settings is not None:
            if not isinstance(settings, HarmonicSettings):
                raise DiscoveryError(f"options.harmonic_balance: expected None or HarmonicSettings, got {settings!r}")
            if not valid_harmonics(settings.harmonics):
                raise DiscoveryError(f"options.harmonic_balance.harmonics: expected {HARMONICS_FORM}, "
                                     f"got {settings.harmonics!r}")
            if not valid_samples(settings.samples, settings.harmonics):
                raise DiscoveryError(f"options.harmonic_balance.samples: expected {samples_form(settings.harmonics)}, "
                                     f"got {settings.samples!r}")
        library(self.effects)

