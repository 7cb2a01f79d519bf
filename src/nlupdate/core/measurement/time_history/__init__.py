"""First-harmonic FRFs from measured time histories: stepped-sine dwells, sine sweeps, random/burst.

A time record holds the sample times ``time_s`` (s), the reference — the excitation ``force``
(N) or the amplifier ``voltage`` (V) — and one signal per response coordinate (displacement in
m by default; velocity or acceleration are converted, ``H = V/(iω)``, ``A/(iω)²``).
Conventions: ``x(t) = Re(X e^{iωt})`` for every first harmonic, H = X/F.

* :mod:`~nlupdate.core.measurement.time_history.records` — reading a record (CSV, parquet, UFF 58, MATLAB);
* :mod:`~nlupdate.core.measurement.time_history.harmonic_fit` — the least-squares harmonic fit, the
  transient rule and the sample-rate, reference and distortion checks of a dwell;
* :mod:`~nlupdate.core.measurement.time_history.stepped_sine` — one estimate per dwell (a ``frequency_hz`` column);
* :mod:`~nlupdate.core.measurement.time_history.sweep` — sine sweeps (no ``frequency_hz``, constant envelope),
  with the sweep-rate limit;
* :mod:`~nlupdate.core.measurement.time_history.broadband` — random and burst (H1, coherence);
* :mod:`~nlupdate.core.measurement.time_history.estimate` — the excitation detected or told, and the table.

Each level's ``force_level_n`` is the mean achieved first-harmonic reference amplitude over its
dwells (its spread is reported); the table records ``excitation``, and for a sweep its
``sweep_direction``.
"""
from nlupdate.core.measurement.time_history.estimate import (
    EXCITATION_CHOICES, RESPONSE_QUANTITIES, FRFEstimate, detect_excitation, estimate_frf,
)
from nlupdate.core.measurement.time_history.harmonic_fit import (
    DISTORTION_LIMIT, DISTORTION_WARNING, MIN_SETTLE_PERIODS, REFERENCE_POWER_SHARE,
)
from nlupdate.core.measurement.time_history.records import TimeHistoryError, TimeRecord, csv_frame, read_time_record
from nlupdate.core.measurement.time_history.sweep import SWEEP_RATE_LIMIT

__all__ = [
    "DISTORTION_LIMIT", "DISTORTION_WARNING", "EXCITATION_CHOICES", "MIN_SETTLE_PERIODS", "REFERENCE_POWER_SHARE",
    "RESPONSE_QUANTITIES", "SWEEP_RATE_LIMIT", "FRFEstimate", "TimeHistoryError", "TimeRecord", "csv_frame",
    "detect_excitation", "estimate_frf", "read_time_record",
]
