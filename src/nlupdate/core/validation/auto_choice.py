"""``auto``: the model ``nlupdate validate`` chooses itself, on the kept curves alone.

**Ranking.** The candidates (:data:`~nlupdate.core.validation.models.AUTO_CANDIDATES`) are
ranked by their leave-one-kept-out error: the RMS over every kept level and every kept
response-controlled run, each predicted from the others, of that curve's receptance error
‖H_p − H_m‖₂/‖H_m‖₂ (:func:`~nlupdate.core.validation.models.curve_error`; ``lines`` with
fewer than three kept levels). Leaving out the highest (lowest) kept level makes one of
those terms an extrapolation within the kept data. Each line weighs by what its curve holds,
the resonance first: scored by the RMS of the per-line |H_p − H_m|/|H_m|, as before, one
line at an antiresonance (|H_m| near zero) decided the choice (a closed-form SDOF with
another mode's constant share, tests/test_validate_response_controlled.py: lines-background
picked, its held-out miss 1.24 % against lines' 0.57 %).

**Extrapolation.** A held-out level above (below) every kept level is an extrapolation, which
that ranking does not guard: on the transmitter beam (docs/validation.md) the per-line score
ranked ``lines`` first for the top level (0.397 against ``amplitude-polynomial``'s 0.457;
the curve score ranks them 0.402 and 0.378) and its damping quadratic, already falling at the
largest kept amplitude, falls to zero beyond it: peak +9306 %. Ranking by the in-kept
extrapolation term alone (per-line score) did no better on the real data (the BRB's lowest
level: ``lines`` 0.371 against ``lines-background`` 0.397, whose predictions then miss it by
0.615 and 0.478; the transmitter beam's top: ``lines-background`` 0.192, whose prediction
misses it by 0.955 against ``amplitude-polynomial``'s 0.412). So for an
extrapolation each candidate's prediction at the held-out level is checked in rank order
(:func:`outside_physical_range`): the first within the physical range is chosen, each one
before it is refused with the reason stated, and when every one is refused the log-amplitude
baseline (``baseline``) is used — each refusal and the fallback stated in
:attr:`ModelChoice.warning`.

**A near tie.** The two best candidates are scored on the same kept curves, so their
difference is judged paired: when the mean over the curves of the runner-up's squared error
less the first's is within two standard errors of zero (:func:`near_tie`), the reason says
that the kept curves do not tell the two apart (the BRB with 0.4886 N held out: ``lines``
0.549 against ``lines-background`` 0.564 over three kept levels; with 0.1947 N held out
``lines-background`` 0.235 against ``lines`` 0.237 is told apart, lower on each kept curve —
since the ``lines`` models take the modal constant of every level at once, issue 34; before,
at 0.1947 N ``lines`` 0.501 against 0.503 tied, at 0.4886 N ``lines-background`` 0.438 against
``lines`` 0.537 was told apart). The choice stands; the other model is one ``--model`` away.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.response_controlled import HeldRun
from nlupdate.core.validation.models import AUTO_CANDIDATES, BASELINE, WITH_RUNS, Fitted, curve_error, model_fitter

#: How far an extrapolated peak |H| may rise above the larger of the largest kept peak and
#: the kept peaks' power law in level (:func:`outside_physical_range`): a one-mode peak is
#: |A|/(2ζω²), so twice it is a mode whose damping ratio fell to half the least damped kept
#: curve's at the same modal constant. A joint damps more with amplitude; a hardening or
#: softening at constant damping moves the peak by the squared frequency ratio (1.2 for a
#: 10 % shift); the tests' peaks scatter by 3–6 % (1σ, the BRB and the transmitter beam).
PEAK_GROWTH = 2.0


@dataclass(frozen=True)
class ModelChoice:
    """The model ``auto`` chose, each candidate's leave-one-kept-out error (module docstring; NaN
    where a candidate failed on the kept levels), why, the candidates refused for an
    extrapolation (name → reason) and, when any was, the warning stating it."""

    name: str
    scores: dict[str, float]
    reason: str
    refused: dict[str, str] = field(default_factory=dict)
    warning: str = ""

    def as_dict(self) -> dict:
        return {"model": self.name, "reason": self.reason, "scores": self.scores,
                **({"refused": self.refused, "warning": self.warning} if self.refused else {})}


def extrapolated(kept: FRFLevels, level: float | None) -> bool:
    """Whether ``level`` lies outside the kept levels' range (above the highest or below the lowest)."""
    return level is not None and not (float(np.min(kept.levels)) <= float(level) <= float(np.max(kept.levels)))


def level_extrapolation(kept: FRFLevels, level: float) -> str:
    """The warning that the held-out ``level`` lies outside the kept levels' range — an
    extrapolation, whose jackknife band refits the same form and so does not measure the
    form's error (as a response-controlled run's outside the kept amplitudes:
    :mod:`~nlupdate.core.validation.held_response`) —, or '' inside it. A linear limit kept
    (an impact: the mode at vanishing amplitude) covers every level below the kept ones."""
    low, high, unit = float(np.min(kept.levels)), float(np.max(kept.levels)), kept.reference_unit
    if not extrapolated(kept, level) or (level < low and kept.linear_limit is not None):
        return ""
    side = "below the lowest" if level < low else "above the highest"
    return (f"held-out level {level:g} {unit} lies {side} kept level ({low:g}–{high:g} {unit}): an extrapolation; "
            f"its bands come from refits that extrapolate the same form, so they do not measure the form's error")


def outside_physical_range(kept: FRFLevels, fitted: Fitted, level: float) -> str | None:
    """Why the prediction of ``fitted`` (fitted on ``kept``) at ``level`` — over the lines of
    the kept level nearest it, at the nominal level — leaves the range a physical mode can
    reach, or None when it does not: a curve not finite, its largest |H| at the first or last
    line (its resonance left the measured band), or its peak |H| above :data:`PEAK_GROWTH`
    times the larger of the largest kept peak and the kept peaks' power law in level through
    the two kept levels nearest ``level``, continued to it."""
    levels = np.asarray(kept.levels, dtype=float)
    order = np.argsort(np.abs(np.log(levels / float(level))))
    f = kept.frequencies[order[0]]
    h = fitted(f, float(level))
    size = np.abs(h)
    if not np.all(np.isfinite(h)):
        return f"its curve at {level:g} {kept.reference_unit} is not finite"
    k = int(np.argmax(size))
    if k in (0, size.size - 1):
        return (f"its largest |H| lies at the band's {'first' if k == 0 else 'last'} line ({f[k]:.6g} Hz): its "
                f"resonance leaves the measured band")
    peaks = np.array([float(np.max(np.abs(h_kept))) for h_kept in kept.receptances])
    trend = peaks.max()
    if levels.size >= 2:
        (i, j) = order[:2]
        slope = np.log(peaks[j] / peaks[i]) / np.log(levels[j] / levels[i])
        trend = max(trend, float(peaks[i] * (float(level) / levels[i]) ** slope))
    if size[k] > PEAK_GROWTH * trend:
        return (f"its peak |H| {size[k]:.4g} is {size[k] / peaks.max():.3g} × the largest kept one ({peaks.max():.4g}), "
                f"above {PEAK_GROWTH:g} × the kept peaks' trend ({trend:.4g}): a damping ratio below half the least "
                f"damped kept curve's")
    return None


def near_tie(first: np.ndarray, second: np.ndarray) -> bool:
    """Whether the per-curve errors ``second`` (the runner-up's) exceed ``first`` (the
    chosen candidate's, on the same curves) by less than two standard errors of their
    paired squared difference (module docstring); False with fewer than two curves."""
    gap = np.square(second) - np.square(first)
    if gap.size < 2:
        return False
    return bool(gap.mean() < 2 * gap.std(ddof=1) / np.sqrt(gap.size))


def _scores(kept: FRFLevels, runs: Sequence[HeldRun]) -> tuple[dict[str, float], dict[str, str], dict[str, np.ndarray]]:
    """Each candidate's leave-one-kept-out error (module docstring; NaN where it
    failed), for each that failed why (its error's message), and each scored candidate's
    per-curve errors."""
    scores, failed, per_curve = {}, {}, {}
    for name in [c for c in AUTO_CANDIDATES if not (runs or kept.linear_limit is not None) or c in WITH_RUNS]:
        errors = []
        try:
            for level, f, h in zip(kept.levels, kept.frequencies, kept.receptances):
                inner = kept.subset([lv for lv in kept.levels if lv != level])
                predicted = model_fitter(name, runs)(inner)(f, float(level), kept.force_at(level, f))
                errors.append(curve_error(h, predicted))
            for k, run in enumerate(runs):
                others = [r for j, r in enumerate(runs) if j != k]
                errors.append(curve_error(run.h, model_fitter(name, others)(kept).at_response(
                    run.frequency_hz, run.held_on_lines)))  # the displacement each line achieved
            scores[name] = float(np.sqrt(np.mean(np.square(errors))))
            per_curve[name] = np.asarray(errors, dtype=float)
        except (ValueError, ArithmeticError, np.linalg.LinAlgError) as error:
            scores[name] = float("nan")
            failed[name] = str(error) or type(error).__name__
    return scores, failed, per_curve


def choose_model(kept: FRFLevels, runs: Sequence[HeldRun] = (), level: float | None = None) -> ModelChoice:
    """``auto`` (module docstring) on the ``kept`` levels; with response-controlled ``runs``
    kept, among the candidates that can take them, and judged on every kept curve: each
    level predicted from the other levels and all runs, each run (at its held amplitude)
    from all levels and the other runs — a run a fit keeps is evidence it must predict too
    (on the BRB's top level the three kept levels alone score ``lines`` 0.474 against
    ``lines-background`` 0.395; with the eight runs 0.596 against 0.330 — each run
    predicted at the displacement it achieved on each line). ``level``: the
    held-out level the choice predicts; outside the kept range the physical-range check
    applies (module docstring)."""
    if kept.levels.size < 3:
        scores, ranked = {}, ["lines"]
        reason = f"{kept.levels.size} kept levels: too few to compare models on them"
    else:
        scores, failed, per_curve = _scores(kept, runs)
        usable = {name: score for name, score in scores.items() if np.isfinite(score)}
        ranked = sorted(usable, key=usable.get) or ["lines"]
        curves = f"{kept.levels.size} levels and {len(runs)} response-controlled runs" if runs else "levels"
        reason = (f"the smallest leave-one-kept-out error over the kept {curves}: "
                  f"{', '.join(f'{n} {s:.3g}' for n, s in usable.items())}" if usable
                  else "no candidate predicted the kept levels from each other")
        if len(ranked) > 1 and near_tie(per_curve[ranked[0]], per_curve[ranked[1]]):
            reason += (f"; {ranked[1]} is within two standard errors of {ranked[0]} over the "
                       f"{per_curve[ranked[0]].size} kept curves: they do not tell the two apart")
        reason += "".join(f"; {n} failed to fit with one kept curve left out: {why}" for n, why in failed.items())
    if not extrapolated(kept, level):
        return ModelChoice(ranked[0], scores, reason)
    refused: dict[str, str] = {}
    for name in ranked:
        try:
            why = outside_physical_range(kept, model_fitter(name, runs)(kept), float(level))
        except (ValueError, ArithmeticError, np.linalg.LinAlgError) as error:
            why = f"it cannot be fitted on the kept levels: {error}"
        if why is None:
            break
        refused[name] = why
    else:
        name = BASELINE
    if not refused:
        return ModelChoice(name, scores, reason)
    stated = "; ".join(f"{n} refused: {why}" for n, why in refused.items())
    fallback = ("every candidate refused: the log-amplitude baseline of the kept levels is used" if name == BASELINE
                else f"{name} used")
    warning = f"auto at {float(level):g} {kept.reference_unit} (an extrapolation): {stated}; {fallback}"
    return ModelChoice(name, scores, f"{reason}; for the extrapolation {stated}; {fallback}", refused, warning)
