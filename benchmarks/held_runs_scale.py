"""The BRB's response-controlled runs against the force-controlled fit, one estimator at a time (issue 34).

    python benchmarks/held_runs_scale.py

Why does ``validate`` miss run 2's damping (−18 % from the levels and the impact) where
the simulated twin (benchmarks/held_runs_truth.py) is unbiased? Per run, on the BRB
(tests/data/brb, acc3), printed side by side:

* ``circle``: the run's damping ratio as ``validate`` reads it (the circle fit of its curve:
  a curve's width, which does not depend on the mode's modal constant);
* ``fit``: a one-mode fit of the run (a linear curve: every line at one amplitude), its
  damping ratio, its modal constant over the one the ``lines`` models take from every line of
  every force-controlled level at once (φ_f² = P, :func:`~nlupdate.core.identification.level_residual.frf_residual`;
  the lowest level's one-mode fit before issue 34), and its other modes' share at 79.2, 80.2,
  81.2 Hz beside that fit's;
* ``run lines``: the run's own line samples (:mod:`nlupdate.core.identification.line_samples`,
  the lines within half its peak) with the tool's φ_f and background B — ζ there scales as
  1/φ_f², as the model's does;
* ``model``: ζ(a) of ``lines-background`` fitted on the four levels and the impact at the
  run's modal amplitude (its median over the run's lines), the predicted run read as the
  measured one, and the same prediction with the other modes' share held flat at its value
  at 80.2 Hz (the share of every level at once has a slope S across the band).

A single-mode curve's peak is ``φ_f²/(2ζω²)``: a modal constant taken too small makes the
damping too small by the same factor and keeps the peak.
"""
from __future__ import annotations

import dataclasses
import sys
import time
import warnings
from pathlib import Path

import numpy as np

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

LINES = np.array([79.2, 80.2, 81.2])  # Hz, where the other modes' share is printed


def background(share) -> np.ndarray:
    """The other modes' share (a function of frequency, m/N) at :data:`LINES` (µm/N)."""
    return 1e6 * share(LINES)


def main() -> int:
    from benchmarks.validation_brb import _runs, brb_levels, impact_limit
    from nlupdate.core.identification.line_samples import PEAK_FRACTION, background_for_lines, samples_from_lines
    from nlupdate.core.identification.modal_fit import fit_mode_near
    from nlupdate.core.model.single_mode import natural_and_damping
    from nlupdate.core.validation.models import LINES_ORDER, lines_model, model_fitter
    from nlupdate.core.validation.resonance import resonance

    started, cpu = time.perf_counter(), time.process_time()
    warnings.simplefilter("ignore")
    data = dataclasses.replace(brb_levels(), linear_limit=impact_limit())
    runs = _runs(data)
    b, fit = background_for_lines(data, LINES_ORDER)
    samples, _ = samples_from_lines(data, fit, b)
    phi = samples.input_shape
    model = lines_model(samples, data.input_dof, LINES_ORDER, limit=data.linear_limit)
    fitted = model_fitter("lines-background")(data)
    print(f"every level's lines at once (level_residual): φ_f² = P = {phi**2:.4f} m/N·(rad/s)²; other modes' share at "
          f"{', '.join(f'{v:g}' for v in LINES)} Hz: "
          + ", ".join(f"{v.real:+.1f}{v.imag:+.1f}j" for v in background(fit.receptance))
          + f" µm/N; B = {1e6 * b.real:+.1f}{1e6 * b.imag:+.1f}j µm/N")
    print("\n| run | held X (µm) | circle ζ (%) | fit ζ (%) | fit A / φ_f² | fit's other modes (µm/N) "
          "| run lines ζ (%) | model ζ(a) (%) | predicted, read as measured (%) | predicted / circle − 1 "
          "| predicted, flat other modes / circle − 1 |\n|---|---|---|---|---|---|---|---|---|---|---|")
    for run in runs:
        f, h = run.frequency_hz, run.h
        near = float(f[int(np.argmax(np.abs(h)))])
        own = fit_mode_near(f, h, near, band_fraction=min(0.9, max(near - f.min(), f.max() - near) / near * 1.0001))
        modal = h - fit.receptance(f) - b
        zeta_lines = natural_and_damping(phi**2 / modal, 2 * np.pi * f)[1]
        used = np.abs(modal) >= PEAK_FRACTION * np.max(np.abs(modal))
        amplitude = float(np.median((np.abs(modal) * run.force_n / phi)[used]))
        zeta_model = float(model.omega_zeta(np.array([amplitude]))[1][0])
        circle = resonance(f, h).damping_ratio
        curve = fitted.at_response(f, run.held_on_lines)
        predicted = resonance(f, curve).damping_ratio
        flat = resonance(f, curve - fit.receptance(f) + fit.receptance(LINES[1:2])).damping_ratio
        share = ", ".join(f"{v.real:+.1f}" for v in background(own.residual_receptance))
        print(f"| {run.name.split('.')[-1]} | {1e6 * run.held_m:.1f} | {100 * circle:.4f} | "
              f"{50 * own.loss_factors[0]:.4f} | {abs(own.modal_constants[0]) / phi**2:.3f} | {share} | "
              f"{100 * float(np.median(zeta_lines[used])):.4f} | {100 * zeta_model:.4f} | {100 * predicted:.4f} | "
              f"{100 * (predicted / circle - 1):+.1f} % | {100 * (flat / circle - 1):+.1f} % |")
    print(f"\n{time.perf_counter() - started:.1f} s wall, {time.process_time() - cpu:.1f} s CPU")
    return 0


if __name__ == "__main__":
    sys.exit(main())
