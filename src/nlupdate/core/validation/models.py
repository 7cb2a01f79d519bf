"""The models a held-out level can be predicted with, by name (``nlupdate validate --model``).

Each fits on the kept levels of one driving-point curve (:class:`~nlupdate.core.identification.data.FRFLevels`)
and returns a predictor of the receptance at any level over any grid:

* ``lines`` — one nonlinear mode whose natural frequency and damping ratio are
  polynomials (order 2) in the modal amplitude, fitted to a sample from every line near
  each resonance (:mod:`nlupdate.core.identification.line_samples`) and continued beyond the
  largest fitted amplitude until they would turn back; the other modes' share and the modal
  constant φ_f² are those found from every line of every level at once
  (:func:`~nlupdate.core.identification.level_residual.frf_residual`), as for the
  ``amplitude-*`` models;
* ``lines-background`` — ``lines`` with a constant complex receptance added to that
  share, the one that makes every level's line samples one curve
  (:func:`~nlupdate.core.identification.line_samples.background_for_lines`);
* ``amplitude-polynomial``, ``amplitude-iwan``, ``amplitude-jenkins`` (the Iwan joint in its
  Jenkins limit) — the same single-mode model fitted to one sample per level, the resonance peak (:func:`~nlupdate.core.identification.amplitude_modal_fit.amplitude_model_from_frfs`,
  ``nlupdate amplitude``);
* ``prd:ELEMENTS`` (e.g. ``prd:cubic,jenkins``) — PRD identification of the elements at the
  driving point, the linear FRF extracted from the kept levels, and the held-out level
  regenerated from both (:func:`~nlupdate.core.identification.regenerate.regenerate_frf`).

A fitted model (:class:`Fitted`) predicts at a force level and, the amplitude models, at a
held response amplitude too (a response-controlled run: :func:`held_receptance`). The
single-mode models take the force achieved at each line when it is known (a
force-controlled sweep does not hold its nominal level: on the BRB the force at resonance
is 27 % below it at 0.19 N, :func:`frf_at_forces`); PRD regenerates at the nominal level.

* ``baseline`` — the log-amplitude baseline itself (:mod:`nlupdate.core.validation.baseline`),
  the kept levels alone: ``auto``'s fallback.

``auto`` is the tool's own choice (:mod:`nlupdate.core.validation.auto_choice`).

A linear limit kept with the curves (:attr:`FRFLevels.linear_limit`, an impact's pole) is
one more sample of the ``lines`` models' polynomials at a = 0 (:func:`lines_model`); the
other models refuse it (``baseline`` leaves it out), and ``auto`` chooses among the ``lines``
models then.
"""
from __future__ import annotations

import hashlib
import pickle
import threading
from collections import OrderedDict
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.identification.amplitude_modal_fit import amplitude_model_from_frfs
from nlupdate.core.identification.data import FRFLevels, LinearLimitLike
from nlupdate.core.identification.level_residual import LevelResidual, bound_warning, frf_residual
from nlupdate.core.identification.line_samples import background_for_lines, samples_from_lines
from nlupdate.core.identification.modal_samples import ModalSamples
from nlupdate.core.identification.response_controlled import HeldRun
from nlupdate.core.model.amplitude_modal import AmplitudeModalModel
from nlupdate.core.validation.baseline import baseline_at_response, baseline_fits, baseline_frf

#: frequency (Hz), level → receptance (m/N, or per volt)
Predictor = Callable[[NDArray, float], NDArray[np.complex128]]

#: The polynomial order of the ``lines`` backbone and damping curve.
LINES_ORDER = 2
#: How far (a factor either way) from X/|φ_f| the modal amplitude of a held response is sought
#: (:func:`held_receptance`)
HELD_RANGE = 10.0


@dataclass(frozen=True)
class Fitted:
    """A model fitted on kept levels: called as ``fitted(frequency_hz, level)``, the
    receptance at a force level; ``at_response(frequency_hz, amplitude_m)``, the receptance
    of a run that holds the response amplitude (m, one value or one per line) at the driving
    point — None where the model cannot say (PRD)."""

    at_force: Predictor
    at_response: Predictor | None = None
    #: whether ``at_force`` takes one force per line (else the nominal level only)
    per_line_force: bool = False
    #: what the fit warns of (the other modes' share on its fit's bound:
    #: :func:`~nlupdate.core.identification.level_residual.bound_warning`), '' if nothing
    note: str = ""

    def noted(self, note: str) -> str:
        """``note`` of a comparison with the fit's own warning (:attr:`note`) before it."""
        return "; ".join(filter(None, [self.note, note]))

    def __call__(self, frequency_hz: NDArray, level: float, force: NDArray | None = None) -> NDArray[np.complex128]:
        """The receptance at ``level``; ``force`` (one per line of ``frequency_hz``, the
        reference unit) the force achieved at each line, used where the model can."""
        if force is not None and self.per_line_force:
            return self.at_force(frequency_hz, np.asarray(force, dtype=float))
        return self.at_force(frequency_hz, level)


def frf_at_forces(model: AmplitudeModalModel, frequency_hz: NDArray, force: float | NDArray,
                  dof: str) -> NDArray[np.complex128]:
    """The driving-point receptance of ``model`` when line k is excited by ``force[k]`` (or
    one force at every line): line k read from the stepped-sine sweep (upward) over the lines
    up to it at that line's force (:meth:`AmplitudeModalModel.frf`), so the amplitude at each
    line is the one its own force drives. Where ``a·|D(a, Ω)| = |φ_f F|`` has one root (no
    fold at that line) it is found directly, on a grid in log a and by bisection; only lines
    with several roots trace the sweep (45 × slower per line)."""
    f = np.asarray(frequency_hz, dtype=float)
    forces = np.broadcast_to(np.asarray(force, dtype=float), f.shape)
    if np.all(forces == forces.flat[0]):
        return model.frf(f, float(forces.flat[0]), dof, dof)
    shape = model.shape(dof)
    omega = 2 * np.pi * f[:, None]
    modal_force = np.abs(shape * forces)[:, None]
    lowest = modal_force / (4 * (model.omega0**2 + omega**2))
    z_min = max(float(np.min(model.omega_zeta(np.geomspace(1e-12, 1e3, 200))[1])), 1e-6)
    grid = lowest * np.geomspace(1.0, 40.0 * (model.omega0**2 + float(omega.max()) ** 2) / (z_min * model.omega0**2),
                                 600)[None, :]

    def mismatch(a: NDArray) -> NDArray:
        return np.log(a * np.abs(model.dynamic_stiffness(a, omega)) / modal_force)

    g = mismatch(grid)
    change = np.sign(g[:, :-1]) != np.sign(g[:, 1:])
    single = change.sum(axis=1) == 1
    k = np.argmax(change, axis=1)
    rows = np.arange(f.size)
    low, high = grid[rows, k][:, None], grid[rows, k + 1][:, None]
    g_low = g[rows, k][:, None]
    for _ in range(60):
        mid = np.sqrt(low * high)
        g_mid = mismatch(mid)
        same = np.sign(g_mid) == np.sign(g_low)
        low, g_low, high = np.where(same, mid, low), np.where(same, g_mid, g_low), np.where(same, high, mid)
    out = model.receptance(np.sqrt(low * high)[:, 0], omega[:, 0], dof, dof)
    order = np.argsort(f)
    for rank, line in enumerate(order):
        if not single[line]:
            out[line] = model.frf(f[order[:rank + 1]], float(forces[line]), dof, dof)[-1]
    return out


def held_receptance(model: AmplitudeModalModel, background: Callable[[NDArray], NDArray], dof: str,
                    frequency_hz: NDArray, amplitude_m: float | NDArray) -> NDArray[np.complex128]:
    """The driving-point receptance of ``model`` plus the other modes' ``background`` when
    the response amplitude is held at ``amplitude_m`` (m; one value, or one per line — a run
    holding acceleration A holds A/Ω²: :attr:`HeldRun.held_on_lines`): the force there is
    ``X/|H|``, so the modal amplitude solves ``a = X·|H_mode(a)|/(|H(a)|·|φ_f|)`` with
    ``H_mode`` the model's receptance (:meth:`AmplitudeModalModel.receptance`),
    ``H = H_mode + background``. Per line the
    root nearest ``X/|φ_f|`` within a factor :data:`HELD_RANGE` either way, bracketed on a
    grid and bisected in log a (a plain fixed-point iteration diverges at resonance where the
    backbone is steep: the BRB's continued quadratic above its largest fitted amplitude)."""
    f = np.asarray(frequency_hz, dtype=float)
    w, shape = 2 * np.pi * f[:, None], model.shape(dof)
    rest = background(f)[:, None]
    held = np.broadcast_to(np.asarray(amplitude_m, dtype=float), f.shape)[:, None]
    centre = held / abs(shape)

    def mismatch(log_a: NDArray) -> NDArray:
        h_mode = model.receptance(np.exp(log_a), w, dof, dof)
        return log_a - np.log(held * np.abs(h_mode) / (np.abs(h_mode + rest) * abs(shape)))

    grid = np.log(centre) + np.linspace(-np.log(HELD_RANGE), np.log(HELD_RANGE), 241)[None, :]
    g = mismatch(grid)
    change = np.sign(g[:, :-1]) != np.sign(g[:, 1:])
    nearest = np.argmin(np.where(change, np.abs(grid[:, :-1] - np.log(centre)), np.inf), axis=1)
    rows = np.arange(f.size)
    low, high = grid[rows, nearest], grid[rows, nearest + 1]
    g_low = g[rows, nearest]
    for _ in range(50):
        mid = 0.5 * (low + high)
        g_mid = mismatch(mid[:, None])[:, 0]
        same = np.sign(g_mid) == np.sign(g_low)
        low, g_low, high = np.where(same, mid, low), np.where(same, g_mid, g_low), np.where(same, high, mid)
    a = np.where(change.any(axis=1), np.exp(0.5 * (low + high)), centre[:, 0])
    return model.receptance(a, 2 * np.pi * f, dof, dof) + background(f)


def lines_model(samples: ModalSamples, input_dof: str, order: int = LINES_ORDER, first_run: int | None = None,
                limit: LinearLimitLike | None = None) -> AmplitudeModalModel:
    """Natural frequency and damping ratio as polynomials of ``order`` in a/a_ref, fitted to
    line samples by least squares (equal weights: the lines near resonance carry equal
    relative noise, :mod:`nlupdate.core.identification.line_samples`), continued beyond a_ref as
    fitted until they would turn back (a held-out top level lies there). ``first_run``: the
    samples from it on come from response-controlled runs, a different test of the mode —
    one constant offset of the frequency and one of the damping ratio for that test type
    are fitted beside the polynomials (a block effect: the BRB's runs resonate up to 0.05 Hz
    higher and damp 5–17 % more than its force-controlled levels at equal modal amplitude),
    so the runs shape the curves without shifting the force-controlled ones; the model
    returned is the force-controlled one (:func:`run_model` the runs'). ``limit``: the mode's
    linear limit from another test (an impact), one more sample of both polynomials at
    a = 0 weighted by its own standard errors against the samples' scatter
    (:func:`_anchored_fit`): the quadratics through the BRB's levels alone put ζ₀ at
    0.05 %, a third of what its hammer impact measures (0.14 %)."""
    return _lines_models(samples, input_dof, order, first_run, limit)[0]


def run_model(samples: ModalSamples, input_dof: str, first_run: int, order: int = LINES_ORDER) -> AmplitudeModalModel:
    """:func:`lines_model` of the response-controlled runs' test type: its polynomials with
    the runs' offsets added."""
    return _lines_models(samples, input_dof, order, first_run)[1]


def _anchored_fit(design: NDArray, values: NDArray, limit: tuple[float, float] | None) -> NDArray:
    """Least squares of ``design @ c = values``; with ``limit`` = (value, standard error) at
    a = 0 (the first coefficient), that one more equation weighted against the samples by
    their scatter about the fit without it over the limit's standard error — each source by
    its own noise, as the joint fit of ``nlupdate amplitude`` weights them."""
    c = np.linalg.lstsq(design, values, rcond=None)[0]
    if limit is None:
        return c
    residual = values - design @ c
    scatter = float(np.sqrt(np.sum(residual**2) / max(values.size - design.shape[1], 1)))
    weight = scatter / max(float(limit[1]), 1e-9 * abs(float(limit[0])), 1e-300)
    row = np.zeros(design.shape[1])
    row[0] = weight
    return np.linalg.lstsq(np.vstack([design, row]), np.r_[values, weight * float(limit[0])], rcond=None)[0]


def _lines_models(samples: ModalSamples, input_dof: str, order: int, first_run: int | None,
                  limit: LinearLimitLike | None = None) -> tuple[AmplitudeModalModel, AmplitudeModalModel]:
    a_ref = float(np.max(samples.amplitude))
    design = (samples.amplitude / a_ref)[:, None] ** np.arange(order + 1)[None, :]
    with_runs = first_run is not None and 0 < first_run < samples.amplitude.size
    if with_runs:
        design = np.column_stack([design, np.arange(samples.amplitude.size) >= first_run])
    f = _anchored_fit(design, samples.frequency_hz, None if limit is None else
                      (limit.frequency_hz, limit.frequency_std_hz))
    zeta = _anchored_fit(design, samples.damping_ratio, None if limit is None else
                         (limit.damping_ratio, limit.damping_std))
    offsets = (float(f[-1]), float(zeta[-1])) if with_runs else (0.0, 0.0)
    f, zeta = f[:order + 1], zeta[:order + 1]

    def model(df: float, dzeta: float, note: str) -> AmplitudeModalModel:
        f0 = float(f[0]) + df
        return AmplitudeModalModel(f0, max(float(zeta[0]) + dzeta, 0.0), ((input_dof, samples.input_shape),),
                                   frequency_coefficients=tuple(f[1:] / f0), damping_coefficients=tuple(zeta[1:]),
                                   reference_amplitude=a_ref, beyond_reference="continued",
                                   note=f"line samples: polynomials of order {order} in a/a_ref, a_ref = {a_ref:.4g}"
                                        + note)

    runs_note = (f"; the response-controlled runs' offsets {offsets[0]:+.4g} Hz, {offsets[1]:+.3g} in ζ"
                 if with_runs else "")
    if limit is not None:
        runs_note += (f"; the linear limit of {limit.source} ({limit.frequency_hz:.6g} Hz, "
                      f"{100 * limit.damping_ratio:.4g} %) fitted at a = 0")
    return model(0.0, 0.0, runs_note), model(*offsets, runs_note + " (the runs' model)")


def _single_mode(model: AmplitudeModalModel, background: Callable[[NDArray], NDArray], dof: str,
                 held_model: AmplitudeModalModel | None = None, share: LevelResidual | None = None) -> Fitted:
    """:class:`Fitted` of a single-mode model plus the other modes' share ``background``;
    ``held_model`` the one response-controlled runs are predicted with (``model`` if None);
    ``share`` the fit of that share, whose bound its note says."""
    def at_force(frequency_hz: NDArray, force: float | NDArray) -> NDArray[np.complex128]:
        f = np.asarray(frequency_hz, dtype=float)
        return frf_at_forces(model, f, force, dof) + background(f)

    def at_response(frequency_hz: NDArray, amplitude_m: float | NDArray) -> NDArray[np.complex128]:
        return held_receptance(held_model or model, background, dof, frequency_hz, amplitude_m)

    return Fitted(at_force, at_response, per_line_force=True, note=(share and bound_warning(share)) or "")


def _lines_fitted(kept: FRFLevels, runs: Sequence[HeldRun], share: LevelResidual, background: complex) -> Fitted:
    """:func:`_single_mode` of the line samples of ``kept`` (and of the kept ``runs``, with
    their test type's offsets: :func:`lines_model`) read with ``share``'s modal constant
    after its other modes' share and the constant ``background``."""
    samples, _ = samples_from_lines(kept, share, background, runs)
    first_run = samples_from_lines(kept, share, background)[0].amplitude.size if runs else None
    models = _lines_models(samples, kept.input_dof, LINES_ORDER, first_run, kept.linear_limit)
    return _single_mode(models[0], lambda f: share.receptance(f) + background, kept.input_dof, models[1], share)


def _lines(kept: FRFLevels, runs: Sequence[HeldRun] = ()) -> Fitted:
    return _lines_fitted(kept, runs, frf_residual(kept)[1], 0.0)


def _lines_background(kept: FRFLevels, runs: Sequence[HeldRun] = ()) -> Fitted:
    background, share = background_for_lines(kept, LINES_ORDER, runs=runs)
    return _lines_fitted(kept, runs, share, background)


def _amplitude(backbone: str) -> Callable[[FRFLevels], Fitted]:
    def fit_on(kept: FRFLevels) -> Fitted:
        order = min(2, kept.levels.size - 1)  # a polynomial through one sample per level
        model = amplitude_model_from_frfs(kept, backbone, order=order)
        share = frf_residual(kept)[1]  # the other modes' share its samples were read without
        return _single_mode(model, share.receptance, kept.input_dof, share=share)

    return fit_on


def _prd(elements: tuple[str, ...]) -> Callable[[FRFLevels], Fitted]:
    def fit_on(kept: FRFLevels) -> Fitted:
        from nlupdate.core.identification.pipeline import IdentificationSettings, identify
        from nlupdate.core.identification.regenerate import regenerate_frf

        identification = identify(kept, IdentificationSettings(kept.response_dof, kept.input_dof,
                                                               elements=elements, samples=2))
        f_linear, h_linear = identification.linear_frequency_hz, identification.linear_frf

        def predict(frequency_hz: NDArray, level: float) -> NDArray[np.complex128]:
            h = regenerate_frf(f_linear, h_linear, identification.result.df_for_force(level), level)
            f = np.asarray(frequency_hz, dtype=float)
            return np.interp(f, f_linear, h.real, left=np.nan, right=np.nan) + \
                1j * np.interp(f, f_linear, h.imag, left=np.nan, right=np.nan)

        return Fitted(predict)

    return fit_on


def _baseline(kept: FRFLevels, runs: Sequence[HeldRun] = ()) -> Fitted:
    """The log-amplitude baseline of the kept levels as a model
    (:mod:`nlupdate.core.validation.baseline`): no joint at all, each quantity of the kept
    curves continued in log amplitude. It keeps the levels alone (kept ``runs`` and a linear
    limit are not used): ``auto``'s fallback where every candidate's extrapolation leaves the
    physical range (:mod:`nlupdate.core.validation.auto_choice`)."""
    fits = baseline_fits(kept, kept.levels)
    return Fitted(lambda f, level: baseline_frf(fits, float(level), f),
                  lambda f, amplitude_m: baseline_at_response(fits, float(np.median(amplitude_m)), f))


#: Models by name (``prd:ELEMENTS`` is parsed by :func:`model_fitter`).
MODELS: dict[str, Callable[[FRFLevels], Fitted]] = {
    "lines": _lines, "lines-background": _lines_background, "amplitude-polynomial": _amplitude("polynomial"),
    "amplitude-iwan": _amplitude("iwan"), "amplitude-jenkins": _amplitude("jenkins"), "baseline": _baseline,
}
AUTO_CANDIDATES = ("lines", "lines-background", "amplitude-polynomial", "amplitude-iwan")
#: The models that take response-controlled runs (their every line a sample) and a linear limit as kept evidence
WITH_RUNS = ("lines", "lines-background")
#: The log-amplitude baseline as a model: it uses the kept levels alone, whatever else is kept
BASELINE = "baseline"


#: The most fits :func:`model_fitter` keeps (a validation of n levels needs about n²/2 distinct ones;
#: ``auto`` with m response-controlled runs kept, about n·m more per candidate).
FIT_CACHE_SIZE = 256
_fits: OrderedDict[tuple[str, bytes], Fitted | Exception] = OrderedDict()
_fits_lock = threading.Lock()


def _remembered(name: str, fit: Callable[[FRFLevels], Fitted], runs: Sequence[HeldRun] = ()
                ) -> Callable[[FRFLevels], Fitted]:
    """``fit`` that fits each set of curves once per process: a validation asks for the
    same kept levels again and again (the jackknife of one held-out level drops the level
    another one keeps; ``auto``'s choice, the held runs' refits and the held-out fits share
    subsets), and every fit is deterministic. Keyed by the model and the curves' (and kept
    ``runs``') whole content; a fit that failed raises the same error again."""
    def fit_on(kept: FRFLevels) -> Fitted:
        if kept.linear_limit is not None and name not in (*WITH_RUNS, BASELINE):
            raise ValueError(f"model {name}: cannot fit a linear limit (an impact) beside the levels (only "
                             f"{', '.join(WITH_RUNS)} can)")
        content = pickle.dumps((kept, tuple(runs)), protocol=pickle.HIGHEST_PROTOCOL)
        key = (name, hashlib.sha256(content).digest())
        with _fits_lock:
            known = _fits.get(key)
            if known is not None:
                _fits.move_to_end(key)
        if known is None:
            try:
                known = fit(kept, runs) if runs else fit(kept)
            except (ValueError, ArithmeticError, np.linalg.LinAlgError) as error:
                known = error
            with _fits_lock:
                _fits[key] = known
                while len(_fits) > FIT_CACHE_SIZE:
                    _fits.popitem(last=False)
        if isinstance(known, Exception):
            raise known
        return known

    return fit_on


def model_fitter(name: str, runs: Sequence[HeldRun] = ()) -> Callable[[FRFLevels], Fitted]:
    """The fitting function of model ``name`` (module docstring), remembering its fits
    (:func:`_remembered`), with the response-controlled ``runs`` as kept evidence beside the
    force-controlled levels (:data:`WITH_RUNS` only); ValueError naming the models for an
    unknown one, or for runs given to a model that cannot take them."""
    if runs and name not in (*WITH_RUNS, BASELINE):
        raise ValueError(f"model {name}: cannot fit response-controlled runs as kept data (only "
                         f"{', '.join(WITH_RUNS)} can: their every line is a backbone sample)")
    if name in MODELS:
        return _remembered(name, MODELS[name], runs)
    if name.startswith("prd:"):
        from nlupdate.core.identification.dfmodels import parse_elements

        elements = tuple(e.strip() for e in name[4:].split(",") if e.strip())
        try:
            parse_elements(elements)  # unknown element names fail here
        except ValueError as error:
            raise ValueError(f"model {name!r}: expected prd:ELEMENTS, identifiable ones ({error})") from None
        return _remembered(name, _prd(elements))
    raise ValueError(f"model {name!r}: expected one of {', '.join([*MODELS, 'prd:ELEMENTS', 'auto'])}")


def curve_error(measured: NDArray, predicted: NDArray) -> float:
    """‖H_p − H_m‖₂/‖H_m‖₂ over one curve's lines (dimensionless; a line where the prediction
    is not finite misses by its |H_m|): each line weighs by what the curve holds there, the
    resonance first, so a line at an antiresonance (|H_m| near zero) cannot decide the error
    as it does in a per-line |H_p − H_m|/|H_m|."""
    miss = np.abs(predicted - measured)
    miss = np.where(np.isfinite(miss), miss, np.abs(measured))
    return float(np.linalg.norm(miss) / np.linalg.norm(measured))
