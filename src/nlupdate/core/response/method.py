"""The response method a user chooses, checked the same way everywhere it is chosen.

A model's nonlinear response is the describing-function continuation (``"continuation"``,
the default everywhere) or the multi-harmonic balance (``"hb"``,
:mod:`nlupdate.core.response.harmonic_balance`) with its
:class:`~nlupdate.core.response.harmonic_balance.HarmonicSettings`. Study files
(``[prediction]``), :class:`~nlupdate.core.discovery.DiscoveryOptions` and the ``simulate`` and
``discover`` commands take the choice; they check it with these rules and word their
errors with these expected forms.
"""
from __future__ import annotations

from nlupdate.core.response.harmonic_balance import AUTO_HARMONICS, HarmonicSettings

RESPONSE_METHODS = ("continuation", "hb")
#: The most harmonics and samples per period a user may ask for (more is a mistake: the
#: unknowns grow as 2H + 1 and every force evaluation as the samples).
MAX_HARMONICS = 64
MAX_SAMPLES = 65_536
#: The most frequencies of one simulated curve, by ``simulate --freqs`` or a study's
#: ``frequencies_hz`` (a finer grid is a mistake, or hours of work).
MAX_FREQUENCIES = 200_000
HARMONICS_FORM = f'an integer from 1 to {MAX_HARMONICS}, or "auto"'


def valid_harmonics(value: object) -> bool:
    """An integer from 1 to :data:`MAX_HARMONICS` (not a bool) or ``"auto"``."""
    return value == "auto" or (isinstance(value, int) and not isinstance(value, bool) and 1 <= value <= MAX_HARMONICS)


def fewest_samples(harmonics: int | str) -> int:
    """The fewest samples per period that carry ``harmonics`` harmonics: 2H + 1 (for
    ``"auto"`` with the most it may try, :data:`~nlupdate.core.response.harmonic_balance.AUTO_HARMONICS`)."""
    return 2 * (max(AUTO_HARMONICS) if harmonics == "auto" else int(harmonics)) + 1


def valid_samples(value: object, harmonics: int | str) -> bool:
    """An integer from :func:`fewest_samples` to :data:`MAX_SAMPLES` (``None``: the
    default, always valid)."""
    return value is None or (isinstance(value, int) and not isinstance(value, bool)
                             and fewest_samples(harmonics) <= value <= MAX_SAMPLES)


def samples_form(harmonics: int | str) -> str:
    """The expected form of ``samples`` for ``harmonics``, as an error states it."""
    carried = f'the up to {max(AUTO_HARMONICS)} harmonics of "auto"' if harmonics == "auto" else f"{harmonics} harmonics"
    fewest = fewest_samples(harmonics)
    return (f"an integer from {fewest} to {MAX_SAMPLES} (samples per period; {carried} need more than "
            f"{fewest - 1})")


def describe(settings: HarmonicSettings | None) -> str:
    """The method in words, e.g. ``harmonic balance (H = 5, 64 samples per period, Floquet stability)``."""
    if settings is None:
        return "describing-function continuation"
    samples = "default samples" if settings.samples is None else f"{settings.samples} samples"
    stability = "Floquet stability" if settings.stability else "no Floquet stability"
    return f"harmonic balance (H = {settings.harmonics}, {samples} per period, {stability})"
