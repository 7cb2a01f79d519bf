"""The mode's linear limit from an impact record, kept beside the held-out levels.

``nlupdate validate --impact FILE`` and a study's ``[validation] impact`` read it the same
way here: the record's response channels (``channel`` alone when given) and its force,
the linear limit fitted to the quietest part of the decay
(:func:`~nlupdate.core.identification.impact.fit_linear_limit`) in the measured band —
``band_hz`` when given, else the lines' own band — widened to ±20 % about its centre (the
decay's band-pass needs room on both sides of the mode).
"""
from __future__ import annotations

import os

from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.impact import LinearLimit, fit_linear_limit, split_force
from nlupdate.core.identification.ring_down import read_channels
from nlupdate.core.validation.models import WITH_RUNS

#: The models that can keep a linear limit beside the levels (``auto`` chooses among them then).
LIMIT_MODELS = (*WITH_RUNS, "auto")


def impact_linear_limit(path: str | os.PathLike, channel: str | None, band_hz: tuple[float, float] | None,
                        data: FRFLevels) -> LinearLimit:
    """The linear limit (Hz, damping ratio, their standard errors) of the impact record at
    ``path`` (.csv or .mat: ``time_s``, one column per channel, optional force) for the mode
    of the measured curves ``data`` (module docstring); ``RingDownError`` (a ValueError)
    naming the file when the record cannot give one."""
    low, high = band_hz or (min(float(f.min()) for f in data.frequencies),
                            max(float(f.max()) for f in data.frequencies))
    centre = 0.5 * (low + high)
    time_s, responses, force = split_force(read_channels(path, "impact record"), channel)
    return fit_linear_limit(time_s, responses, (min(low, 0.8 * centre), max(high, 1.2 * centre)), None, force,
                            source=str(path))


def refused_model(models: tuple[str, ...] | list[str]) -> str | None:
    """The first of ``models`` that cannot keep a linear limit beside the levels (None if all can)."""
    return next((m for m in models if m not in LIMIT_MODELS), None)
