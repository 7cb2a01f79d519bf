"""The BRB's top level from the three lower levels alone: is either curve folded, and does a
differently bounded backbone predict it better than the log-amplitude baseline? (issue 34)

    python benchmarks/brb_top_candidates.py

Prints, for the measured 1.46 N curve and each candidate's prediction of it from the three
lower levels (at the force each of its lines achieved): the resonance, the damping ratio as
``validate`` reads it (circle fit, half-power where the jump rule finds a jump) and by both
estimators, whether the jump rule fires, and the largest step of ln|H| between two lines;
then each candidate's natural frequency and damping ratio at the amplitudes the runs held.
Candidates (all on the line samples of ``lines-background``, its constant background B and
residual terms; the Iwan ones' backbone softens only and ends at the fully slipped joint):

* ``quadratic, continued`` — ``lines-background`` as ``validate`` fits it;
* ``quadratic, held`` — the same quadratics held at their value beyond the largest fitted
  amplitude (``beyond_reference = "hold"``);
* ``straight line, continued`` — polynomials of order 1;
* ``Iwan on the line samples`` — the modal Iwan backbone (``nlupdate amplitude``'s
  ``iwan``) fitted to every line sample instead of one sample per level;
* ``amplitude-iwan`` — ``validate``'s model, one sample per level.
"""
from __future__ import annotations

import dataclasses
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if __package__ in (None, ""):
    sys.path.insert(0, str(ROOT))


def describe(f: np.ndarray, h: np.ndarray) -> str:
    """resonance (Hz), validate's ζ, circle-fit ζ, half-power ζ (%), jump rule, largest step."""
    from nlupdate.core.validation.circle_fit import circle_fit_damping, jump_in_run
    from nlupdate.core.validation.resonance import resonance

    r = resonance(f, h)
    step = np.abs(np.diff(np.log(np.abs(h))))
    return (f"{r.resonance_hz:.3f} | {100 * r.damping_ratio:.4f} | {100 * circle_fit_damping(f, h):.4f} | "
            f"{100 * r.half_power_damping_ratio:.4f} | {'jump' if jump_in_run(f, h, r.half_power_damping_ratio) else 'no'}"
            f" | {step.max():.3f} at {f[int(np.argmax(step))]:.2f} Hz")


def main() -> int:
    from benchmarks.validation_brb import _runs, brb_levels
    from nlupdate.core.identification.amplitude_modal_fit import fit_amplitude_model
    from nlupdate.core.identification.line_samples import background_for_lines, samples_from_lines
    from nlupdate.core.validation.models import LINES_ORDER, frf_at_forces, lines_model, model_fitter

    started, cpu = time.perf_counter(), time.process_time()
    data = brb_levels()
    top = float(data.levels[-1])
    f, h = data.frequencies[-1], data.receptances[-1]
    force = data.force_at(top, f)
    kept = data.subset(data.levels[:-1])
    dof = kept.input_dof
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        background, fit = background_for_lines(kept, LINES_ORDER)
        samples, _ = samples_from_lines(kept, fit, background)
        quadratic = lines_model(samples, dof, LINES_ORDER)
        candidates = {"quadratic, continued": quadratic,
                      "quadratic, held": dataclasses.replace(quadratic, beyond_reference="hold"),
                      "straight line, continued": lines_model(samples, dof, 1),
                      "Iwan on the line samples": fit_amplitude_model(samples, ((dof, samples.input_shape),), "iwan")}
        curves = {name: frf_at_forces(model, f, force, dof) + fit.receptance(f) + background
                  for name, model in candidates.items()}
        curves["amplitude-iwan"] = model_fitter("amplitude-iwan")(kept)(f, top, force)
    print(f"Brake–Reuss beam, {top:g} N from {', '.join(f'{v:g}' for v in kept.levels)} N "
          f"({time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())})")
    print("\n| curve | resonance (Hz) | validate's ζ (%) | circle fit ζ (%) | half-power ζ (%) | jump rule | "
          "largest step of ln|H| |\n|---|---|---|---|---|---|---|")
    print(f"| measured | {describe(f, h)} |")
    for name, curve in curves.items():
        print(f"| {name} | {describe(f, curve)} |")
    runs = _runs(data)
    held = np.array([run.held_m for run in runs])
    print("\nbackbone and damping at the runs' held amplitudes (µm): natural frequency (Hz) / ζ (%)")
    print("| | " + " | ".join(f"{1e6 * x:.0f}" for x in held) + " |\n|---|" + "---|" * held.size)
    from nlupdate.core.validation.resonance import resonance
    measured = [resonance(run.frequency_hz, run.h) for run in runs]
    print("| runs, measured | " + " | ".join(f"{r.resonance_hz:.2f} / {100 * r.damping_ratio:.3f}" for r in measured)
          + " |")
    for name, model in candidates.items():
        w, zeta = model.omega_zeta(held / samples.input_shape)
        print(f"| {name} | " + " | ".join(f"{wk / (2 * np.pi):.2f} / {100 * zk:.3f}" for wk, zk in zip(w, zeta)) + " |")
    print(f"\nlargest amplitude of the kept levels' line samples: {1e6 * samples.amplitude.max() * samples.input_shape:.0f} µm;"
          f" the top level reached {1e6 * np.abs(h).max() * force[int(np.argmax(np.abs(h)))]:.0f} µm")
    print(f"\n{time.perf_counter() - started:.1f} s wall, {time.process_time() - cpu:.1f} s CPU")
    return 0


if __name__ == "__main__":
    sys.exit(main())
