"""Warnings about identified values that should not be trusted as they stand.

A fit always returns numbers; these checks say when the numbers are not measurements.
:func:`identification_warnings` looks at an
:class:`~nlupdate.core.identification.pipeline.Identification` and returns one
:class:`TrustWarning` per finding (none for a well-identified result):

* ``uncertainty_exceeds_value`` — the Monte-Carlo standard deviation of a parameter (or
  of a linear mode's natural frequency or loss factor) is larger than its magnitude: the
  data do not distinguish it from zero. Raw coefficients of a polynomial DF
  (``re_c<k>``, ``im_c<k>``) are not checked: a polynomial term consistent with zero is
  the normal case, not a failure. ``uncertainty_unknown``: the Monte Carlo gave fewer
  than two values for it.
* ``at_bound`` — the value sits where the fit or the data put a limit, not where the
  data put the parameter (its interval is then one-sided, :mod:`nlupdate.core.identification.bands`):

  - a naive PRD/DDF fit of physical elements keeps every log-parameter within a factor
    1e6 of its start; a parameter that ends on that box (``at_bound`` of the fit);
  - a Jenkins slip force at the edges of what the data can show. The PRD relies on the
    low force leaving the slider stuck, so the data say ``slip_force > kf·A₁`` (A₁: the
    largest low-force amplitude the fit used), and the fit's start is clipped to at
    least ``2·kf·A₁`` (:meth:`~nlupdate.core.identification.dfmodels.PhysicalModel.initial_guesses`).
    A slip force the data do not otherwise determine ends in between: at the limit (on
    the §3.1 SDOF at 5 % noise half of the seeds end at 0.97–1.0 × kf·A₁, truth
    100 × kf·A₁) or where it started (the review's 0.0199 N = 1.9 × kf·A₁ on the
    demo's T-beam, truth 0.5 N = 48 × kf·A₁). Warned: ``kf·A₁/1.1 ≤ slip_force ≤
    2.2·kf·A₁`` (``SLIP_TOLERANCE`` = 10 % beyond both). Far below kf·A₁ the model has
    the low level slipping, which the data can show. At the other end, a slip force at
    or above ``kf·A_max/1.1`` (A_max: the largest high-force amplitude) means no
    measured level slips (or barely): the data bound it from below only.

* ``diverged`` — a log-parameter (a positive element parameter) the fit ran off with: the
  improved PRD fit, unbounded, carried it further than the factor 1e6 the bounded fits keep
  from its start (:func:`~nlupdate.core.identification.prd.diverged`), or it reached the end
  of the number range (e^±699). Its number is no estimate of anything and is not printed as
  one: :func:`diverged_text` says what it means (``kf diverged (8.95e+47 N/m): the data
  support no finite value of it``) wherever the value would stand — the terminal, the
  report, identification.json (``diverged``). Seen: the BRB read with its sensor's sign
  reversed, Jenkins kf from a start of 8.4e6 N/m to 9e47 N/m (every level then slips at
  Fs/kf ≈ 1e-49 m, where kf has no effect); the correctly signed beam moves kf 0.55× from
  its start.
* ``not_identifiable`` — parameters the data cannot show were fixed, and why (an Iwan joint
  no level drives into macroslip: :func:`~nlupdate.core.identification.dfmodels.iwan_identifiability`),
  or an Iwan joint fitted at χ ≤ −0.98, which acts as a Jenkins element whose K_T and β the
  data cannot separate (only βK_T/(1+β)).
* ``residual_above_noise`` — the fit's residual, as a relative noise level
  (:attr:`~nlupdate.core.identification.pipeline.Identification.residual_noise_fraction`),
  is more than ``RESIDUAL_FACTOR`` (3) times the noise level the identification used
  (given, or estimated from the low-force sweep; at least ``RESIDUAL_FLOOR``, 0.1 %).
  For a model that fits, the ratio is 1 within a few per cent (hundreds of residuals;
  the noise estimate itself is good to ~10 %), and the naive estimators sit below 1;
  a ratio above 3 means the misfit has about ten times the variance of the noise: the
  model misses part of the behaviour (e.g. a polynomial DF across a friction transition
  gives 9–15×), or the noise level is understated. The intervals then carry the
  model-form error too (the leave-one-level-out spread, or the Monte-Carlo spread times
  the ratio: :mod:`nlupdate.core.identification.bands`). 3 is also the factor the improved PRD
  estimator uses to detect a poor start. The floor keeps noise-free simulated data from
  warning about round-off.

* ``moves_with_noise`` — the Monte-Carlo re-identifications of a value are centred
  further from it than their 95 % half-width (:mod:`nlupdate.core.identification.uncertainty`):
  adding noise moves the estimate more than the noise spreads it, so it is biased by the
  noise — most often because the model does not describe the data. Its interval is
  centred on the estimate; the bias is of the size of the shift. Judged from
  ``SHIFT_MIN_SAMPLES`` (20) samples on, with the median's own sampling error allowed for.
* ``levels_disagree`` — the linear FRF each level gives, 1/H_j − ν(|X_j|), differs between
  the levels by more than their noise (:mod:`nlupdate.core.identification.consistency`): the
  identified model does not describe the structure at the measured coordinate. Either
  the nonlinearity is not there (between other coordinates, or between the measured one
  and another) or the element set is wrong; the extracted linear FRF and its modes are
  then a blend of levels, not the linear structure. ``nlupdate discover`` places it.

* ``mode_fit_poor`` — the one-mode fit of the extracted linear FRF misses it by more than
  ``MODE_FIT_LIMIT`` (20 %) RMS: the linear mode's natural frequency and loss factor do not
  describe that curve (:func:`mode_fit_warnings`; the BRB's fits miss by 3–10 %, the
  transmitter beam's two lowest levels' by 44 %, with η = 0.3 against the curve's half-power 9.5e-4).

Three more look at the data rather than the fit: :func:`sign_warnings` (``negative`` — a
stuck friction stiffness below zero), :func:`dissipation_warnings` (``generates_energy`` —
a describing function whose imaginary part is negative at every fitted amplitude, the sign
a reversed sensor or force direction gives) and :func:`excitation_warnings`
(``not_stepped_sine`` — FRFs from sweeps or random excitation, which PRD and DDF do not
assume).
"""
from __future__ import annotations

import re
from dataclasses import asdict, dataclass
from typing import Any, Sequence

import numpy as np

from nlupdate.core.identification.consistency import SPREAD_LIMIT
from nlupdate.core.identification.dfmodels import PhysicalModel
from nlupdate.core.identification.prd import SEARCH_FACTOR
from nlupdate.core.model.elements import ELEMENT_TYPES
from nlupdate.core.measurement.units import parameter_unit

RESIDUAL_FACTOR = 3.0
POOR_FIT_FACTOR = 5.0  # a residual this many times the noise: "fit": "poor"
RESIDUAL_FLOOR = 1e-3
SLIP_TOLERANCE = 0.1
SHIFT_MIN_SAMPLES = 20  # fewer Monte-Carlo samples: no moves_with_noise judgement
LOG_LIMIT = 699.0  # PhysicalModel.values clips log-parameters at ±700
_RAW_COEFFICIENT = re.compile(r"^(re|im)_c\d+$")


@dataclass(frozen=True)
class TrustWarning:
    """One reason not to trust a result as it stands.

    subject: what it is about (a parameter name, ``fit``, ``run`` or ``prediction``); kind:
    ``at_bound``, ``diverged``, ``uncertainty_exceeds_value``, ``uncertainty_unknown``,
    ``residual_above_noise``, ``not_converged`` (an updating run), ``prediction_worse``
    (the best model predicts worse than the initial one) or ``loss_factor_at_bound`` (the
    predictions' low-force loss factor fit ended on its search's bound) or ``targets_missed``
    (a converged updating run's model misses target frequencies beyond their noise);
    message: one plain sentence with the numbers; source: where the result came from
    (``identification``, or an updating run's name).
    """

    subject: str
    kind: str
    message: str
    source: str = ""

    def as_dict(self) -> dict[str, str]:
        return asdict(self)

    def __str__(self) -> str:
        return f"{self.source}: {self.message}" if self.source else self.message


def warning_texts(warnings: Sequence[TrustWarning]) -> list[str]:
    """One line per distinct warning message, the sources that share it named together
    (the four difference formulas of one parameter set miss their targets alike), in the
    order the warnings first appear."""
    sources: dict[str, list[str]] = {}
    for w in warnings:
        sources.setdefault(w.message, [])
        if w.source and w.source not in sources[w.message]:
            sources[w.message].append(w.source)
    return [f"{'; '.join(names)}: {message}" if names else message for message, names in sources.items()]


def uncertainty_warnings(values: dict[str, float], std: dict[str, float], what: str, source: str = "") -> list[TrustWarning]:
    """``uncertainty_exceeds_value`` for every value whose std exceeds its magnitude."""
    out = []
    for name, value in values.items():
        s = std.get(name)
        if s is None or not np.isfinite(value):
            continue
        if np.isnan(s):
            out.append(TrustWarning(name, "uncertainty_unknown", f"{name} = {value:.4g}: no {what} uncertainty could "
                                                                  f"be computed for it", source))
        elif s > abs(value):
            out.append(TrustWarning(name, "uncertainty_exceeds_value",
                                    f"{name} = {value:.4g} ± {s:.3g}: the {what} uncertainty exceeds the value, so the "
                                    f"data do not determine it", source))
    return out


def _stick_slip_slots(model: PhysicalModel) -> list[tuple[str, str]]:
    """(stuck stiffness name, slip force name) of every element of a physical model the PRD
    assumes stuck at the low force (a Jenkins element's kf and slip_force: its ``stick_slip``)."""
    return [(pair[0] + suffix, pair[1] + suffix) for element, suffix in model._suffixes()
            if (pair := ELEMENT_TYPES[element].stick_slip) is not None]


def _slip_force_warnings(result: Any, values: dict[str, float], source: str, unit: str = "N") -> list[TrustWarning]:
    """Slip forces the data bound from one side only; forces in ``unit`` (N, or V per volt)."""
    model = getattr(result, "physical", None) or getattr(result, "model", None)
    if not isinstance(model, PhysicalModel):
        return []
    out = []
    a_low = getattr(result, "amplitude_low_max", None)  # PRD: the low level's largest amplitude
    a_high = float(np.max(result.amplitude)) if np.size(result.amplitude) else None
    for kf_name, slip_name in _stick_slip_slots(model):
        kf, slip = values[kf_name], values[slip_name]
        if a_low is not None and a_low > 0:
            lower = kf * a_low
            if lower / (1 + SLIP_TOLERANCE) <= slip <= 2 * lower * (1 + SLIP_TOLERANCE):
                out.append(TrustWarning(
                    slip_name, "at_bound",
                    f"{slip_name} = {slip:.4g} {unit} sits at the lower limit of what the data can show ({slip / lower:.2g} × "
                    f"kf·A₁ = {lower:.4g} {unit}, the slip force at which the {result.setup.low_force:g} {unit} level would start "
                    f"to slip; the fit starts at 2 × kf·A₁ or above): the data show only that the low level is stuck, "
                    f"not the slip force", source))
                continue
        if a_high is not None and a_high > 0:
            upper = kf * a_high
            if slip >= upper / (1 + SLIP_TOLERANCE):
                out.append(TrustWarning(
                    slip_name, "at_bound",
                    f"{slip_name} = {slip:.4g} {unit} is at or above kf·A_max = {upper:.4g} {unit} (the largest measured "
                    f"amplitude): no measured level slips, so the data bound the slip force from below only", source))
    return out


#: the bounded fits' box (:data:`~nlupdate.core.identification.prd.SEARCH_FACTOR`) as the warnings print it: "1e6"
_SEARCH = f"1e{np.log10(SEARCH_FACTOR):.0f}"


def diverged_text(name: str, value: float, reference_unit: str = "N") -> str:
    """What a diverged parameter's number means, where the number would stand: ``kf diverged
    (8.95e+47 N/m): the data support no finite value of it`` (units per volt with a V reference)."""
    unit = parameter_unit(name, reference_unit)
    return f"{name} diverged ({value:.3g}{' ' + unit if unit else ''}): the data support no finite value of it"


def diverged_names(warnings: Sequence[TrustWarning]) -> set[str]:
    """The parameters ``warnings`` call diverged."""
    return {w.subject for w in warnings if w.kind == "diverged"}


def _bound_warnings(result: Any, values: dict[str, float], source: str, unit: str = "N") -> list[TrustWarning]:
    out = []
    flagged = set()
    for name, start in getattr(result, "diverged", ()):
        flagged.add(name)
        value = values.get(name, float("nan"))
        where = f"{start:.4g} {parameter_unit(name, unit)}".rstrip()
        out.append(TrustWarning(name, "diverged", f"{diverged_text(name, value, unit)} — the fit carried it "
                                f"{value / start:.2g}× from where it started ({where}), beyond the factor {_SEARCH} "
                                f"within which the bounded fits keep it: the number is no estimate (a sensor's sign "
                                f"reversed, or an element the data do not show); its interval is no band either",
                                source))
    for name in getattr(result, "at_bound", ()):
        if name in flagged:
            continue
        flagged.add(name)
        out.append(TrustWarning(name, "at_bound",
                                f"{name} = {values.get(name, float('nan')):.4g} ended on a bound of the fit (log-parameters "
                                f"are kept within a factor {_SEARCH} of their start): the data do not determine it",
                                source))
    model = getattr(result, "physical", None) or getattr(result, "model", None)
    if isinstance(model, PhysicalModel):
        positive = {name: pos for (_, name, pos) in model._slots}
        for name, value in values.items():
            if name in flagged or not positive.get(name) or not value > 0:
                continue
            if abs(np.log(value)) >= LOG_LIMIT:
                flagged.add(name)
                out.append(TrustWarning(name, "diverged", f"{diverged_text(name, value, unit)} — it ran off to the "
                                                          f"end of the number range: the number is no estimate",
                                        source))
    return out + [w for w in _slip_force_warnings(result, values, source, unit) if w.subject not in flagged]


def fit_verdict(residual: float | None, noise: float) -> tuple[str, float | None]:
    """(``"poor"`` | ``"consistent"`` | ``"unknown"``, ratio of the fit's residual to
    max(noise, ``RESIDUAL_FLOOR``)): poor above ``POOR_FIT_FACTOR``, the misfit is then far
    above what the noise explains and the model does not describe the data."""
    if residual is None or not np.isfinite(residual):
        return "unknown", None
    ratio = float(residual) / max(float(noise), RESIDUAL_FLOOR)
    return ("poor" if ratio > POOR_FIT_FACTOR else "consistent"), ratio


def residual_warnings(residual: float | None, noise: float, noise_source: str, source: str = "") -> list[TrustWarning]:
    """``residual_above_noise`` when the fit's residual noise level exceeds
    ``RESIDUAL_FACTOR`` × max(noise, ``RESIDUAL_FLOOR``)."""
    if residual is None or not np.isfinite(residual):
        return []
    reference = max(float(noise), RESIDUAL_FLOOR)
    if residual <= RESIDUAL_FACTOR * reference:
        return []
    return [TrustWarning(
        "fit", "residual_above_noise",
        f"the fit's residual ({100 * residual:.3g} % of |H|) is {residual / reference:.1f}× the noise level used "
        f"({100 * noise:.3g} %, {noise_source}): the model misses part of the behaviour or the noise level is "
        f"understated; the 95 % intervals are widened by the model-form error (the spread of the fits with one "
        f"level left out, or the noise spread times the ratio)", source)]


def shift_warnings(stats: dict[str, Any], source: str = "") -> list[TrustWarning]:
    """``moves_with_noise`` for every statistic (:class:`~nlupdate.core.identification.uncertainty.ParameterStatistics`)
    whose Monte-Carlo median is further from its value than the 95 % interval's half-width
    plus twice the median's own sampling error (1.25·std/√n); judged from
    ``SHIFT_MIN_SAMPLES`` samples on (with fewer the percentiles are not yet an interval)."""
    out = []
    for name, st in stats.items():
        if st.count < SHIFT_MIN_SAMPLES:
            continue
        half = 0.5 * (st.ci95[1] - st.ci95[0])
        limit = half + 2 * 1.2533 * st.std / np.sqrt(st.count)
        if np.isfinite(st.shift) and np.isfinite(limit) and abs(st.shift) > limit:
            out.append(TrustWarning(
                name, "moves_with_noise",
                f"{name} = {st.value:.6g}: its Monte-Carlo re-identifications are centred at {st.median:.6g}, "
                f"{abs(st.shift):.3g} away, more than their 95 % half-width ({half:.3g}): the estimate moves with the "
                f"noise more than the noise spreads it (biased, most often because the model does not describe the "
                f"data); its interval [{st.ci95[0]:.6g}, {st.ci95[1]:.6g}] reflects the samples about it, towards "
                f"the noise-free value, and reaches it", source))
    return out


def consistency_warnings(consistency: Any, response_dof: str, source: str = "identification") -> tuple[TrustWarning, ...]:
    """``levels_disagree`` when the placement check
    (:class:`~nlupdate.core.identification.consistency.LevelConsistency`) failed; none when it
    passed or was not made (None)."""
    if consistency is None or consistency.passed:
        return ()
    span = consistency.worst_band_hz()
    where = "" if span is None else (f"; {int(consistency.inconsistent.sum())} lines disagree beyond their noise, "
                                     f"{span[0]:.4g}–{span[1]:.4g} Hz")
    how = (f"differs between the levels by {consistency.spread_ratio:.3g}× their noise (RMS over the lines; at most "
           f"{SPREAD_LIMIT:g}× when the model describes the data{where})" if np.isfinite(consistency.spread_ratio) else
           "cannot be formed: the fitted elements leave no finite value at any line two levels share (a degenerate "
           "fit)")
    return (TrustWarning(
        "linear_frf", "levels_disagree",
        f"NOT TRUSTWORTHY: the linear FRF extracted from each force level {how}. The linear FRF is the same at every level, so the identified model does not "
        f"describe the structure at coordinate {response_dof}: most likely the nonlinearity is not at the measured "
        f"coordinate (it acts between other coordinates, or between {response_dof} and another), or the element set "
        f"is wrong. The identified parameters, the extracted linear FRF and its modes are not the structure's; "
        f"run `nlupdate discover` to place the nonlinearity and choose its elements", source),)


def identification_warnings(identification: Any, source: str = "identification") -> tuple[TrustWarning, ...]:
    """Every warning about an :class:`~nlupdate.core.identification.pipeline.Identification`
    (module docstring); empty when nothing is suspicious."""
    result = identification.result
    values = dict(result.parameters())
    stats = identification.uncertainty.parameters
    checked = {name: stats[name].value for name in stats if not _RAW_COEFFICIENT.match(name)}
    unit = getattr(identification, "reference_unit", "N")  # V: every force-like value is per volt
    out = _bound_warnings(result, values, source, unit)
    flagged = {w.subject for w in out}
    out += [w for w in uncertainty_warnings(checked, {n: stats[n].std for n in checked}, "Monte-Carlo", source)
            if w.subject not in flagged]
    flagged = {w.subject for w in out}
    out += [w for w in shift_warnings({n: stats[n] for n in checked}, source) if w.subject not in flagged]
    out += residual_warnings(identification.residual_noise_fraction, identification.noise_fraction,
                             identification.noise_source, source)
    flagged = {w.subject for w in out}
    out += [TrustWarning(name, "at_bound", f"{name} = {st.value:.4g} is {st.bound.why}: the data bound it on one side "
                                           f"only, and its 95 % interval [{st.ci95[0]:.4g}, {st.ci95[1]:.4g}] is "
                                           f"one-sided", source)
            for name, st in stats.items() if st.bound is not None and name not in flagged]
    model = getattr(result, "physical", None) or getattr(result, "model", None)
    if isinstance(model, PhysicalModel) and model.note:
        out.append(TrustWarning(", ".join(name for name, _ in model.fixed), "not_identifiable", model.note, source))
    return tuple(out + _degenerate_warnings(model, values, source, unit))


def _degenerate_warnings(model: Any, values: dict[str, float], source: str, unit: str = "N") -> list[TrustWarning]:
    """Parameters an element's fitted values leave inseparable (its ``degenerate``: an Iwan
    joint fitted at χ → −1 is a Jenkins element, kf = βK_T/(1+β), Fs = F_S, whose K_T and β
    are then not determined separately)."""
    if not isinstance(model, PhysicalModel):
        return []
    out = []
    for element, suffix in model._suffixes():
        kind = ELEMENT_TYPES[element]
        own = {p.name: values[p.name + suffix] for p in kind.parameters if p.name + suffix in values}
        found = kind.degenerate(own, lambda name: parameter_unit(name, unit))
        if found is not None:
            names, message = found
            out.append(TrustWarning(", ".join(name + suffix for name in names), "not_identifiable",
                                    message.replace("{suffix}", suffix), source))
    return out


def sign_warnings(parameters: dict[str, float], reference_unit: str = "N",
                  dissipates: bool = True) -> tuple[TrustWarning, ...]:
    """A warning for each parameter that must be positive and is not (``kf``: a stuck
    friction stiffness, from a polynomial's constant term). ``dissipates``: whether the
    describing function takes energy out somewhere (:func:`dissipation_warnings` found
    nothing); then the direction signs are not what it points to first."""
    out = []
    for name, value in parameters.items():
        if name.split("_")[0] == "kf" and value < 0:
            stated = f"{name} = {value:.4g} {parameter_unit(name, reference_unit)} is negative, but a stuck friction " \
                     f"stiffness is > 0"
            why = ("the describing function's real part, extrapolated to zero amplitude, falls below zero: the lowest "
                   "level is not stuck (the joint already slips there) or the element's form does not follow the "
                   "softening; the describing function dissipates, so the direction signs are not the first suspect"
                   if dissipates else
                   "the describing function has the wrong sign (a transfer FRF, a negative modal constant — exciter "
                   "and sensor on opposite sides of a node —, or a reversed direction sign) or the low level is not "
                   "stuck")
            out.append(TrustWarning(name, "negative", f"{stated}: {why}", "identification"))
    return tuple(out)


#: the largest relative RMS misfit of a linear mode's one-mode fit that still describes its curve
MODE_FIT_LIMIT = 0.2


def mode_fit_warnings(modes: Any, source: str = "identification") -> tuple[TrustWarning, ...]:
    """``mode_fit_poor`` for each linear mode (:class:`~nlupdate.core.identification.modal_fit.ModalFit`,
    in order: ``linear_f<i>_hz``, ``linear_eta<i>``) whose fit misses its curve by more than
    :data:`MODE_FIT_LIMIT` RMS (module docstring)."""
    out = []
    for i, fit in enumerate(modes, start=1):
        if fit.relative_rms_error > MODE_FIT_LIMIT:
            out.append(TrustWarning(
                f"linear_f{i}_hz, linear_eta{i}", "mode_fit_poor",
                f"the one-mode fit of the extracted linear FRF misses it by {100 * fit.relative_rms_error:.3g} % RMS "
                f"({100 * MODE_FIT_LIMIT:g} % at most for a mode that describes it): linear_f{i}_hz = "
                f"{float(fit.natural_frequencies_hz[0]):.6g} Hz and linear_eta{i} = {float(fit.loss_factors[0]):.4g} "
                f"are not that curve's (linear_frf.png shows it)", source))
    return tuple(out)


def dissipation_warnings(result: Any, reference_unit: str = "N") -> tuple[TrustWarning, ...]:
    """A warning when the identified describing function ν (``result.nu_high``, N/m) has
    Im ν < 0 at every amplitude the fit covers (``result.amplitude_range``): the
    nonlinearity then feeds energy into the structure at every level, less damping the
    harder it is driven. A joint only adds damping as it slips; what gives this sign is
    mostly the data's: a response or force direction reversed (the published Brake–Reuss
    beam read along +y, its accelerometer opposing the force: Im ν from −123 to −3925 N/m,
    against +123 … +3925 read along −y), a transfer FRF or a negative modal constant."""
    low, high = result.amplitude_range
    imag = np.imag(result.nu_high(np.linspace(low, high, 50)))
    if not (imag.size and np.all(imag < 0)):
        return ()
    unit = parameter_unit("kf", reference_unit)
    return (TrustWarning(
        "describing_function", "generates_energy",
        f"the describing function's imaginary part is negative at every fitted amplitude ({imag[0]:.4g} … "
        f"{imag[-1]:.4g} {unit} over {low:.3g}–{high:.3g} m): the nonlinearity would feed energy into the structure, "
        f"less damped the harder it is driven, which a joint does not do; check the direction signs of the response "
        f"and the input (--coordinates FILE=NODE:-DIR,…), a transfer FRF, or a negative modal constant", "identification"),)


def excitation_warnings(excitation: str, method: str) -> tuple[TrustWarning, ...]:
    """A warning when the FRFs are not stepped-sine FRFs, which PRD and DDF assume."""
    kinds = set(excitation.split("+")) - {"stepped_sine", "unknown"}
    if not kinds:
        return ()
    return (TrustWarning(
        "data", "not_stepped_sine",
        f"{method.upper()} assumes stepped-sine FRFs at a constant force amplitude; these are {excitation} FRFs "
        f"(an estimate averaged over the amplitudes the excitation passed through), so the describing function is an "
        f"equivalent linearisation at an ill-defined amplitude and the fit residual includes that distortion",
        "identification"),)
