"""Choice of the PRD excitation frequency.

The source finds the identification most accurate when the excitation frequency is
near a resonance of the *underlying linear* system (thesis §3.4, Table 3 of the 2-DOF
paper). ``benchmarks/identification_study.py`` (5 % noise, 100 seeds) confirms it and
refines it. §3.1 SDOF (linear resonance 711.8 Hz): with the improved estimator and
cubic + Jenkins elements the errors are flat from 690 to 720 Hz (k3 ± 3–6 %, kf ± 1–2 %)
and grow above (730 Hz: k3 ± 14 %, 740 Hz: −11 % ± 17 %, 760 Hz: −22 % ± 18 %). §3.2
2-DOF (linear mode 732.2 Hz): flat from 715 to 740 Hz (k3 ± 3–4 %, kf ± 2–5 %),
745 Hz kf ± 7 %. The naive least squares gets worse monotonically with frequency over
both ranges (2-DOF kf: ± 23 % at 715, ± 49 % at 725, ± 91 % at 730, ± 613 % at 745 Hz —
the source's 0.4 / 4.1 / 104 % at 725 / 730 / 745 Hz are single draws of this). Above
the linear resonance the hardening high-force responses sit on their upper branches, the
amplitudes of all high levels bunch together and extrapolating the PRD curve to zero
amplitude (which gives Δ_f1, i.e. kf) is ill-conditioned. The low-force resonance is
*not* a good choice: the stuck friction shifts it above the linear one (763 vs 712 Hz
for §3.1, 745 vs 732 Hz for §3.2).

Recommendation: excite at the linear natural frequency (or up to ~2 % below it for a
hardening nonlinearity). On the noisy study data :func:`recommend_frequency` picks
712 Hz (711–714) for the SDOF and 732 Hz (731–733) for the 2-DOF with elements, where the
improved estimator gives k3 +0.6 % ± 3.2 %, kf +0.1 % ± 1.1 % (SDOF) and k3 +0.6 % ± 3.0 %,
kf +0.2 % ± 3.0 % (2-DOF). With a polynomial model the extracted linear FRF is noisier and
the choice wanders more (2-DOF: 729–746 Hz).

The linear natural frequency is unknown before the identification, so
:func:`recommend_frequency` iterates: identify at a start frequency (the low-force
resonance), extract the linear FRF, locate its natural frequency and move to the measured
frequency nearest to it; stop when the frequency moves by less than ``tolerance``
(relative, default 0.5 %: the noise of the estimate itself) or returns to one already
visited. The natural
frequency is located as the report and the updating targets locate it
(:func:`nlupdate.core.identification.modal_fit.fit_mode_near`: the resonance crossing of the
averaged ``Re(1/H^L)``, refined by a one-mode fit over ±10 % weighted by the noise of
``1/H̃_1``), not by the highest peak of |H^L|: with friction stuck at low force the
extracted FRF is noisiest at its own resonance, and its highest sample is often a noise
spike several hertz away (the demo's T-beam once chose 49.4 Hz for a 44.5 Hz mode).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from nlupdate.core.correlation.metrics import peak
from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.modal_fit import fit_mode_near, resonance_crossings
from nlupdate.core.identification.prd import (DEFAULT_HALF_WINDOW, IdentificationError, Model, PRDResult, identify_prd,
                                              prd_setup)


@dataclass(frozen=True)
class FrequencyChoice:
    """The recommended excitation frequency (Hz), the frequencies visited and the natural
    frequency (Hz) of the last extracted linear FRF."""

    frequency_hz: float
    visited_hz: tuple[float, ...]
    linear_natural_frequency_hz: float | None
    reason: str


def recommend_frequency(
    data: FRFLevels,
    model: Model,
    *,
    low_force: float | None = None,
    high_forces: ArrayLike | None = None,
    estimator: str = "improved",
    half_window: float = DEFAULT_HALF_WINDOW,
    max_iterations: int = 8,
    tolerance: float = 0.005,
    fits: dict[float, PRDResult] | None = None,
) -> FrequencyChoice:
    """Measured frequency nearest to the natural frequency of the extracted linear FRF.
    ``fits``, when given, receives the identification made at each visited frequency (Hz →
    result): the caller fits at the chosen one again otherwise (a free Iwan fit: 2 s)."""
    first = prd_setup(data, _any_common(data, low_force, high_forces), low_force, high_forces)
    levels = (first.low_force,) + first.high_forces
    candidates = data.common_frequencies(levels)
    if candidates.size == 1:  # the source's protocol: one sine per high level
        only = float(candidates[0])
        return FrequencyChoice(only, (only,), None, "the only frequency measured at every level")
    f_low, h_low = data.curve(first.low_force)
    low_resonance = peak(f_low, h_low)[0]
    start = float(candidates[np.argmin(np.abs(candidates - low_resonance))])
    visited = [start]
    natural = None
    for _ in range(max_iterations):
        try:
            result = identify_prd(data, visited[-1], model, low_force=first.low_force, high_forces=first.high_forces,
                                  estimator=estimator, half_window=half_window)
            if fits is not None:
                fits[visited[-1]] = result
        except (IdentificationError, ValueError, ArithmeticError, np.linalg.LinAlgError) as error:
            return FrequencyChoice(visited[-1], tuple(visited), natural,
                                   f"stopped: identification failed at {visited[-1]:g} Hz ({error})")
        h_linear = result.extract_linear_frf(f_low, h_low)
        crossings = resonance_crossings(f_low, h_linear)
        if crossings.size == 0:
            return FrequencyChoice(visited[-1], tuple(visited), None,
                                   "the extracted linear FRF has no resonance in the band; kept the low-force resonance")
        # stuck friction stiffens the low-force test: the linear mode lies at or below its
        # resonance; a crossing only above it belongs to another mode, never to move to
        reference = low_resonance if natural is None else natural
        below = crossings[crossings <= reference * 1.01]
        if below.size == 0:
            return FrequencyChoice(visited[-1], tuple(visited), natural,
                                   f"the extracted linear FRF has no resonance at or below {reference:.2f} Hz "
                                   f"(only at {', '.join(f'{c:.4g}' for c in crossings)} Hz, another mode); "
                                   f"kept {visited[-1]:g} Hz")
        near = float(below[np.argmin(np.abs(below - reference))])
        try:
            natural = float(fit_mode_near(f_low, h_linear, near, inverse_noise=np.abs(1.0 / h_low),
                                          band_fraction=0.1).natural_frequencies_hz[0])
        except (ValueError, np.linalg.LinAlgError):
            natural = near
        nearest = float(candidates[np.argmin(np.abs(candidates - natural))])
        if nearest in visited or abs(nearest - visited[-1]) <= tolerance * visited[-1]:
            return FrequencyChoice(nearest, tuple(visited), natural,
                                   f"measured frequency nearest to the linear natural frequency {natural:.2f} Hz "
                                   f"(one-mode fit of the extracted linear FRF)")
        visited.append(nearest)
    return FrequencyChoice(visited[-1], tuple(visited), natural,
                           f"iteration limit: last linear natural frequency {natural:.2f} Hz")


def _any_common(data: FRFLevels, low_force: float | None, high_forces: ArrayLike | None) -> float:
    """A frequency measured at every selected level (to validate the level choice)."""
    if data.levels.size < 2:
        return float(data.frequencies[0][0])
    low = data.levels[0] if low_force is None else low_force
    highs = data.levels[data.levels > low] if high_forces is None else np.atleast_1d(high_forces)
    common = data.common_frequencies(np.concatenate([[low], highs]))
    if common.size == 0:
        raise IdentificationError("no frequency is measured at every selected force level")
    return float(common[0])
