"""What an identification reports: the ``identification.json`` schema and the tables and
numbers its outputs and plots show (the plots themselves: :mod:`nlupdate.reporting.identification_plots`).

``identification.json`` keys (SI units, polynomial coefficients highest order first):

* ``trustworthy``: false when the placement check failed (below) — the identified model
  does not describe the structure at the measured coordinate; ``not_trustworthy_because``
  says why and what to do (empty when trustworthy);
* ``method`` ("prd"/"ddf"), ``estimator``, ``model``, ``response_dof``, ``input_dof``;
* ``warnings``: results not to be trusted as they stand, each ``{"subject", "kind",
  "message", "source"}`` (:mod:`nlupdate.core.identification.trust`; empty when none);
* ``excitation_frequency_hz`` (PRD; null for DDF), ``low_force_n`` and ``high_forces_n``
  (PRD) or ``force_pair_n`` and ``band_hz`` (DDF);
* ``describing_function``: ``{"real", "imag", "definition", "amplitude_range_m"}`` — the DF
  ν(A) (N/m) that, added to the extracted linear dynamic stiffness, reproduces the
  high-force data (PRD: ``y + Δ_f1``; DDF: ``Δ``);
* ``prd_fit`` (PRD): the fitted PRD curve ``y(A) = 1/H_i − 1/H_1`` (the source's
  "identified DF", constant term ``−Δ_f1``) and ``delta_f1`` (real, imag);
* ``elements`` (physical models): type, dofs and parameters, ready for
  :data:`nlupdate.core.model.elements.ELEMENT_TYPES`;
* ``parameters``: per parameter ``{"value", "mean", "std", "ci95", "mc_median"}`` (and
  ``bound``, the limit a value sits on, its ``ci95`` then one-sided; docs/methods.md §4,
  Intervals; ``diverged``, what the number means when the fit ran off with it — ``kf
  diverged (8.95e+47 N/m): the data support no finite value of it``: no estimate, its
  ``ci95`` no band) and ``uncertainty`` (how the statistics were made, ``residual_ratio``,
  ``jackknife_fits``); ``noise_fraction`` (the noise level used) and
  ``fit_residual`` (the noise level the fit's residuals imply, and its ratio to it);
* ``fit``: ``"poor"`` when that ratio exceeds 5 or the placement check failed (the model
  does not describe the data; the fit plot shows the residual against amplitude),
  ``"consistent"``, or ``"unknown"`` (no spare degrees of freedom), with
  ``fit_ratio_to_noise``;
* ``linear_frf_consistency``: the placement check — is the linear FRF each level gives the
  same at every level, within the noise (:mod:`nlupdate.core.identification.consistency`)?
  null when not made (a polynomial DF);
* ``linear_frf``: the table file and the natural frequencies of the extracted linear FRF;
* ``defaults_used``: every option that was not given and the value chosen;
* ``element_between`` (``nlupdate identify``, when the placement check failed and the
  table holds other responses to the same input): the elements placed between each of
  them and the driven coordinate by the aa-partition form
  (:mod:`nlupdate.core.identification.partition`), best explained first.
"""
from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike

from nlupdate.core.identification.dfmodels import PhysicalModel
from nlupdate.core.identification.methods import METHODS
from nlupdate.core.identification.trust import POOR_FIT_FACTOR, RESIDUAL_FACTOR, RESIDUAL_FLOOR, fit_verdict
from nlupdate.core.measurement.units import parameter_unit, units_block

JSON_NAME = "identification.json"


def linear_frf_table(frequency_hz: ArrayLike, h: ArrayLike, response_dof: str, input_dof: str) -> pd.DataFrame:
    """Tidy table of the extracted linear FRF; ``force_level_n = 0`` means "linear"."""
    f = np.asarray(frequency_hz, dtype=float)
    hh = np.asarray(h, dtype=complex)
    return pd.DataFrame({
        "frequency_hz": f, "force_level_n": np.zeros(f.size), "response_dof": str(response_dof),
        "input_dof": str(input_dof), "h_real": hh.real, "h_imag": hh.imag,
    })


def elements_summary(result: Any, dof_name: str) -> list[dict] | None:
    """Physical elements as ``{"type", "dofs", <parameters>}`` dictionaries, else None."""
    model = getattr(result, "physical", None) or getattr(result, "model", None)
    if not isinstance(model, PhysicalModel):
        return None
    p = result.p
    out = []
    for name, element in zip(model.element_names, model.elements(p)):
        entry = {"type": name, "dofs": [dof_name]}
        entry.update({k: float(v) for k, v in vars(element).items() if k != "dofs"})
        out.append(entry)
    return out


def residual_in_noise_units(result: Any, noise_fraction: float) -> np.ndarray:
    """The misfit of each PRD/DDF point, ``|y_i − ŷ(A_i)|``, over the noise it carries,
    about ``σ·√2·F_i/A_i`` (σ: relative noise; ``F_i/A_i = |1/H_i|``, and the reference
    level's ``|1/H|`` taken as the same size) — about 1 where the model fits."""
    amplitude = np.asarray(result.amplitude, dtype=float)
    force = METHODS[result.method].point_forces(result)
    misfit = np.abs(np.asarray(result.y) - result.fitted_y(amplitude))
    return misfit / (max(float(noise_fraction), 1e-12) * np.sqrt(2) * force / amplitude)


def identification_summary(identification: Any) -> dict[str, Any]:
    """The ``identification.json`` content of an
    :class:`~nlupdate.core.identification.pipeline.Identification` (keys: the module docstring)."""
    s, r = identification.settings, identification.result
    warnings = identification.warnings
    out: dict[str, Any] = {"trustworthy": identification.trustworthy,
                           "not_trustworthy_because": [w.message for w in warnings if w.kind == "levels_disagree"],
                           "method": s.method, "estimator": r.estimator, "model": identification.model_description,
                           "response_dof": s.response_dof, "input_dof": s.input_dof,
                           "warnings": [w.as_dict() for w in warnings],
                           "units": units_block(identification.reference_unit),
                           "band_hz": None if identification.band_hz is None else list(identification.band_hz),
                           "band_reason": identification.band_reason, "excitation": identification.excitation,
                           "lines_below_coherence_threshold": identification.lines_below_coherence}
    order = max(identification.defaults_used.get("order", s.order) or 2, 1)
    real, imag = r.describing_function(order)
    out.update(METHODS[s.method].summary(r, s, real, imag, order))
    if identification.frequency_choice is not None:
        choice = identification.frequency_choice
        out["frequency_choice"] = {"visited_hz": list(choice.visited_hz),
                                   "linear_natural_frequency_hz": choice.linear_natural_frequency_hz,
                                   "reason": choice.reason}
    stats = identification.uncertainty.parameters
    diverged = identification.diverged  # what a diverged parameter's number means, as the terminal prints it
    verdict, ratio = fit_verdict(identification.residual_noise_fraction, identification.noise_fraction)
    if not identification.trustworthy:
        verdict = "poor"
    consistency = identification.level_consistency
    out.update({
        "linear_from_level_n": identification.linear_from_level_n,
        "linear_from_levels_n": list(identification.linear_from_levels_n),
        "parameters": {name: dict(stats[name].as_dict(), unit=parameter_unit(name, identification.reference_unit),
                                  **({"diverged": diverged[name]} if name in diverged else {}))
                       for name in r.parameters()},
        "uncertainty": dict(identification.uncertainty.as_dict(),
                            held_fixed="excitation frequency / band, force levels, model and the modes' start values"),
        "noise_fraction": {"value": identification.noise_fraction, "source": identification.noise_source},
        "fit_residual": {
            "noise_fraction": identification.residual_noise_fraction,
            "ratio_to_noise": (identification.residual_noise_fraction / identification.noise_fraction
                               if identification.residual_noise_fraction is not None and identification.noise_fraction > 0 else None),
            "definition": "RMS of the fit's residuals normalised like the noise (std / |H|), corrected for the "
                          "fitted degrees of freedom; about noise_fraction when the model fits; warned above "
                          f"{RESIDUAL_FACTOR:g} x max(noise_fraction, {RESIDUAL_FLOOR:g}); 'fit' is 'poor' above "
                          f"{POOR_FIT_FACTOR:g} x (the model does not describe the data: see the residual against "
                          "amplitude in fit.png)",
        },
        "fit": verdict,
        "fit_ratio_to_noise": ratio,
        "linear_frf_consistency": None if consistency is None else consistency.as_dict(),
        "elements": elements_summary(r, s.response_dof),
        "linear_frf": {
            "file": "linear_frf.parquet",
            "from_force_level_n": identification.linear_from_level_n,
            "from_force_levels_n": list(identification.linear_from_levels_n),
            "from": identification.linear_source,
            "modes": [
                {"natural_frequency_hz": stats[f"linear_f{i + 1}_hz"].as_dict(),
                 "loss_factor": stats[f"linear_eta{i + 1}"].as_dict(),
                 "relative_rms_error": m.relative_rms_error}
                for i, m in enumerate(identification.modes)
            ],
            "definition": "one mode + residuals H = A/(w_r^2 - w^2 + i eta w_r^2) + R - R_m/w^2 fitted over "
                          f"±{100 * s.modal_band_fraction:g} % around each resonance of the extracted linear FRF, "
                          "weighted by the noise of 1/H of the level it came from",
        },
        "defaults_used": identification.defaults_used,
    })
    return out
