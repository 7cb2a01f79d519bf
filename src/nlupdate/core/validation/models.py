"""The models a held-out level can be predicted with, by name (``nlupdate validate --model``).

Each fits on the kept levels of one driving-point curve (:class:`~nlupdate.core.identification.data.FRFLevels`)
and returns a predictor of the receptance at any level over any grid:

* ``lines`` — one nonlinear mode whose natural frequency and damping ratio are
  polynomials (order 2) in the modal amplitude, fitted to a sample from every line near
  each resonance (:mod:`nlupdate.core.identification.line_samples`) and continued beyond the
  largest fitted amplitude until they would turn back; the other modes' share is the
  lowest level's residual terms;
* ``amplitude-polynomial``, ``amplitude-iwan`` — the same single-mode model fitted to one
  sample per level, the resonance peak (:func:`~nlupdate.core.identification.amplitude_modal_fit.amplitude_model_from_frfs`,
  ``nlupdate amplitude``);
* ``prd:ELEMENTS`` (e.g. ``prd:cubic,jenkins``) — PRD identification of the elements at the
  driving point, the linear FRF extracted from the kept levels, and the held-out level
  regenerated from both (:func:`~nlupdate.core.identification.regenerate.regenerate_frf`).

``auto`` is the tool's own choice, made on the kept levels alone: the candidate
(:data:`AUTO_CANDIDATES`) whose leave-one-kept-level-out predictions miss least (RMS of
the relative receptance error), or ``lines`` with fewer than three kept levels.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from numpy.typing import NDArray

from nlupdate.core.identification.amplitude_modal_fit import ModalSamples, amplitude_model_from_frfs
from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.line_samples import lowest_level_fit, samples_from_lines
from nlupdate.core.model.amplitude_modal import AmplitudeModalModel

#: frequency (Hz), level → receptance (m/N, or per volt)
Predictor = Callable[[NDArray, float], NDArray[np.complex128]]

#: The polynomial order of the ``lines`` backbone and damping curve.
LINES_ORDER = 2


def lines_model(samples: ModalSamples, input_dof: str, order: int = LINES_ORDER) -> AmplitudeModalModel:
    """Natural frequency and damping ratio as polynomials of ``order`` in a/a_ref, fitted to
    line samples by least squares (equal weights: the lines near resonance carry equal
    relative noise, :mod:`nlupdate.core.identification.line_samples`), continued beyond a_ref as
    fitted until they would turn back (a held-out top level lies there)."""
    a_ref = float(np.max(samples.amplitude))
    design = (samples.amplitude / a_ref)[:, None] ** np.arange(order + 1)[None, :]
    f = np.linalg.lstsq(design, samples.frequency_hz, rcond=None)[0]
    zeta = np.linalg.lstsq(design, samples.damping_ratio, rcond=None)[0]
    return AmplitudeModalModel(float(f[0]), max(float(zeta[0]), 0.0), ((input_dof, samples.input_shape),),
                               frequency_coefficients=tuple(f[1:] / f[0]), damping_coefficients=tuple(zeta[1:]),
                               reference_amplitude=a_ref, beyond_reference="continued",
                               note=f"line samples: polynomials of order {order} in a/a_ref, a_ref = {a_ref:.4g}")


def _lines(kept: FRFLevels) -> Predictor:
    samples, fit = samples_from_lines(kept)
    model = lines_model(samples, kept.input_dof)

    def predict(frequency_hz: NDArray, level: float) -> NDArray[np.complex128]:
        f = np.asarray(frequency_hz, dtype=float)
        return model.frf(f, level, kept.input_dof, kept.input_dof) + fit.residual_receptance(f)

    return predict


def _amplitude(backbone: str) -> Callable[[FRFLevels], Predictor]:
    def fit_on(kept: FRFLevels) -> Predictor:
        order = min(2, kept.levels.size - 1)  # a polynomial through one sample per level
        model = amplitude_model_from_frfs(kept, backbone, order=order)
        residual = lowest_level_fit(kept)

        def predict(frequency_hz: NDArray, level: float) -> NDArray[np.complex128]:
            f = np.asarray(frequency_hz, dtype=float)
            return model.frf(f, level, kept.input_dof, kept.input_dof) + residual.residual_receptance(f)

        return predict

    return fit_on


def _prd(elements: tuple[str, ...]) -> Callable[[FRFLevels], Predictor]:
    def fit_on(kept: FRFLevels) -> Predictor:
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

        return predict

    return fit_on


#: Models by name (``prd:ELEMENTS`` is parsed by :func:`model_fitter`).
MODELS: dict[str, Callable[[FRFLevels], Predictor]] = {
    "lines": _lines, "amplitude-polynomial": _amplitude("polynomial"), "amplitude-iwan": _amplitude("iwan"),
}
AUTO_CANDIDATES = ("lines", "amplitude-polynomial", "amplitude-iwan")


@dataclass(frozen=True)
class ModelChoice:
    """The model ``auto`` chose and each candidate's leave-one-kept-level-out RMS relative
    error (NaN where a candidate failed on the kept levels)."""

    name: str
    scores: dict[str, float]
    reason: str


def model_fitter(name: str) -> Callable[[FRFLevels], Predictor]:
    """The fitting function of model ``name`` (module docstring); ValueError naming the
    models for an unknown one."""
    if name in MODELS:
        return MODELS[name]
    if name.startswith("prd:"):
        from nlupdate.core.identification.dfmodels import parse_elements

        elements = tuple(e.strip() for e in name[4:].split(",") if e.strip())
        parse_elements(elements)  # unknown element names fail here
        return _prd(elements)
    raise ValueError(f"model {name!r}: expected one of {', '.join([*MODELS, 'prd:ELEMENTS', 'auto'])}")


def relative_error(measured: NDArray, predicted: NDArray) -> float:
    """RMS of |H_p − H_m|/|H_m| over the lines both have (NaN lines of the prediction count
    as a miss of 1)."""
    error = np.abs(predicted - measured) / np.abs(measured)
    return float(np.sqrt(np.mean(np.where(np.isfinite(error), error, 1.0) ** 2)))


def choose_model(kept: FRFLevels) -> ModelChoice:
    """``auto`` (module docstring)."""
    if kept.levels.size < 3:
        return ModelChoice("lines", {}, f"{kept.levels.size} kept levels: too few to compare models on them")
    scores = {}
    for name in AUTO_CANDIDATES:
        errors = []
        try:
            for level, f, h in zip(kept.levels, kept.frequencies, kept.receptances):
                inner = kept.subset([lv for lv in kept.levels if lv != level])
                errors.append(relative_error(h, MODELS[name](inner)(f, float(level))))
            scores[name] = float(np.sqrt(np.mean(np.square(errors))))
        except (ValueError, ArithmeticError, np.linalg.LinAlgError):
            scores[name] = float("nan")
    usable = {name: score for name, score in scores.items() if np.isfinite(score)}
    if not usable:
        return ModelChoice("lines", scores, "no candidate predicted the kept levels from each other")
    best = min(usable, key=usable.get)
    return ModelChoice(best, scores, "the smallest leave-one-kept-level-out error "
                                     f"({', '.join(f'{n} {s:.3g}' for n, s in scores.items())})")
