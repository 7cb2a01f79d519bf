"""The top level from the levels below: the polynomial backbone continued as fitted, or by its tangent.

    python benchmarks/backbone_continuation.py [--seeds 20]     [NLUPDATE_TRANSMITTER_BEAM=FOLDER]

The ``lines`` models (and ``amplitude-polynomial``) continue their polynomials in the modal
amplitude beyond the largest amplitude they were fitted to as fitted, up to where they
would turn back (:class:`~nlupdate.core.model.amplitude_modal.AmplitudeModalModel`,
``beyond_reference = "continued"``). On the BRB the top level from the three below misses
its resonance by +0.083 Hz against the log-amplitude baseline's +0.067 Hz (docs/validation.md,
"The goals"): the continued quadratic hardens too steeply. Would the lowest-order
continuation — beyond the largest fitted amplitude the tangent there (value and slope kept,
curvature dropped) — be better founded? Compared, ``--hold-out top`` (the top level
predicted from the others, an extrapolation), the continuation being

* ``as fitted`` — today;
* ``f by tangent`` — the natural frequency continued by its tangent, the damping ratio as fitted;
* ``f, ζ by tangent`` — both by their tangents;

on truth known and on the two real data sets:

* **cubic spring** (closed form): the Duffing SDOF of the tests (1 kg, 90 Hz, loss factor
  0.02, k₃ = 3·10¹¹ N/m³; 0.25, 0.5, 0.75, 1 N; 321 lines over 80–100 Hz), whose backbone is
  a quadratic in the amplitude to first order — the form the models fit;
* **Iwan joint** (``--seeds`` twins of benchmarks/validate_band_coverage.py, the test's
  repeatability off: ``sigma_f = 0``): a 1 kg SDOF at 80 Hz with a four-parameter Iwan joint
  in microslip, measured like the BRB (four levels over a factor 7.5, 41 lines, 0.5 %
  noise), the describing-function continuation of the true joint; the models are the wrong form;
* **the BRB** (tests/data/brb) from its three lower levels, and with the hammer impact's
  linear limit kept;
* **the transmitter beam** (docs/validation.md; the folder in ``$NLUPDATE_TRANSMITTER_BEAM``,
  skipped without it).

Each row: resonance error (Hz), damping and peak errors (%) of ``lines``,
``lines-background`` and ``auto`` (its choice named), beside the baseline's resonance error.
"""
from __future__ import annotations

import argparse
import contextlib
import dataclasses
import os
import sys
import tempfile
import time
import warnings
from pathlib import Path
from unittest import mock

import numpy as np

if __package__ in (None, ""):  # run as a script: make the repository root importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from nlupdate.core.model import amplitude_modal  # noqa: E402

VARIANTS = {"as fitted": (), "f by tangent": ("frequency",), "f, ζ by tangent": ("frequency", "damping")}
MODELS = ["lines", "lines-background", "auto"]
CUBIC = (1.0, (2 * np.pi * 90.0) ** 2, 0.02, 3e11)  # kg, N/m, loss factor, N/m³


def _tangent_series(coefficients, x, exponent: float) -> np.ndarray:
    """``Σ c_k u^k`` (u = x^exponent) as fitted up to u = 1, beyond it its tangent there."""
    u = np.asarray(x, dtype=float) ** exponent
    p = np.polynomial.Polynomial([0.0, *coefficients])
    return np.where(u > 1.0, p(1.0) + p.deriv()(1.0) * (u - 1.0), p(np.minimum(u, 1.0))) + 0.0 * u


@contextlib.contextmanager
def continued(curves: tuple[str, ...]):
    """Within it, a polynomial model with ``beyond_reference = "continued"`` continues the
    ``curves`` ("frequency", "damping") by their tangents beyond a_ref; the others as today."""
    if not curves:
        yield
        return
    original = amplitude_modal.AmplitudeModalModel.omega_zeta

    def omega_zeta(self, amplitude):
        if self.joint is not None or self.beyond_reference != "continued":
            return original(self, amplitude)
        x = np.asarray(amplitude, dtype=float) / self.reference_amplitude

        def series(name, coefficients, exponent):
            if name in curves and len(coefficients):
                return _tangent_series(coefficients, x, exponent)
            return amplitude_modal._series(coefficients, x, exponent, self.beyond_reference)

        omega = self.omega0 * (1 + series("frequency", self.frequency_coefficients, self.frequency_exponent))
        zeta = np.maximum(self.damping_ratio + series("damping", self.damping_coefficients, self.damping_exponent), 0.0)
        return np.asarray(omega + 0 * x, dtype=float), np.asarray(zeta + 0 * x, dtype=float)

    with mock.patch.object(amplitude_modal.AmplitudeModalModel, "omega_zeta", omega_zeta):
        yield


def cubic_levels():
    """The closed-form cubic spring's four curves (module docstring) as FRFLevels."""
    import pandas as pd

    from nlupdate.core.identification.data import FRFLevels

    m, k, eta, k3 = CUBIC
    f = np.linspace(80.0, 100.0, 321)
    rows = []
    for level in (0.25, 0.5, 0.75, 1.0):
        for w, hz in zip(2 * np.pi * f, f):
            a = k - m * w**2
            roots = np.roots([(0.75 * k3) ** 2, 1.5 * k3 * a, a**2 + (eta * k) ** 2, -level**2])
            u = max(r.real for r in roots if abs(r.imag) < 1e-9 * abs(r) and r.real > 0)
            h = 1.0 / (k * (1 + 1j * eta) - m * w**2 + 0.75 * k3 * u)
            rows.append({"frequency_hz": hz, "force_level_n": level, "response_dof": "x", "input_dof": "x",
                         "h_real": h.real, "h_imag": h.imag})
    return FRFLevels.from_table(pd.DataFrame(rows), "x", "x")


def top_rows(data) -> list[tuple[str, float, float, float, float]]:
    """(label, resonance error Hz, damping error, peak error, baseline resonance error Hz) of
    the top level held out, per model."""
    from nlupdate.core.validation.held_out import validate

    out = []
    for r in validate(data, "top", MODELS).held_out:
        c = r.compared
        out.append((r.label, c["resonance_hz"].error, c["damping_ratio"].relative_error,
                    c["peak_abs"].relative_error, r.baseline["resonance_hz"].error))
    return out


def cells(row) -> str:
    _, df, dz, dp, _ = row
    zeta = "—" if not np.isfinite(dz) else f"{100 * dz:+.1f}"
    return f"{df:+.4f}, {zeta}, {100 * dp:+.1f}"


def print_data_set(name: str, data) -> None:
    rows = {variant: top_rows_in(variant, data) for variant in VARIANTS}
    print(f"\n{name}: the top level from the others; per model resonance error (Hz), damping (%), peak (%); "
          f"baseline's resonance error {rows['as fitted'][0][4]:+.4f} Hz")
    print("| model | " + " | ".join(VARIANTS) + " |\n|---|" + "---|" * len(VARIANTS))
    for i, model in enumerate(MODELS):
        print(f"| {model} | " + " | ".join(f"{cells(rows[v][i])}" + (f" ({rows[v][i][0].split('→ ')[1]})"
                                                                       if model == "auto" else "")
                                          for v in VARIANTS) + " |")


def top_rows_in(variant: str, data):
    with continued(VARIANTS[variant]):
        return top_rows(data)


def print_twins(seeds: int) -> None:
    from benchmarks.validate_band_coverage import simulated_test

    print(f"\nIwan twins, {seeds} seeds (sigma_f = 0): median |error| of the top level — resonance (Hz), damping (%), "
          "peak (%) — mean resonance error (Hz), and the seeds whose resonance beats the baseline's")
    print("| model | " + " | ".join(VARIANTS) + " |\n|---|" + "---|" * len(VARIANTS))
    results = {v: [] for v in VARIANTS}
    for seed in range(seeds):
        data = simulated_test(seed, sigma_f=0.0)
        for v in VARIANTS:
            results[v].append(top_rows_in(v, data))
    for i, model in enumerate(MODELS):
        out = []
        for v in VARIANTS:
            r = np.array([row[i][1:] for row in results[v]], dtype=float)
            beats = int(np.sum(np.abs(r[:, 0]) < np.abs(r[:, 3])))
            out.append(f"{np.nanmedian(np.abs(r[:, 0])):.3f}, {100 * np.nanmedian(np.abs(r[:, 1])):.1f}, "
                       f"{100 * np.nanmedian(np.abs(r[:, 2])):.1f}; mean {np.mean(r[:, 0]):+.3f}; {beats}/{seeds}")
        print(f"| {model} | " + " | ".join(out) + " |")
    picked = {v: sorted({row[2][0] for row in results[v]}) for v in VARIANTS}
    print("auto's choices: " + "; ".join(f"{v}: {', '.join(p)}" for v, p in picked.items()))


def transmitter_levels():
    from benchmarks.validation_transmitter_beam import ENVIRONMENT_VARIABLE, data_file, lockin_table, measured_levels

    if not os.environ.get(ENVIRONMENT_VARIABLE):
        return None
    table = lockin_table(data_file(None))
    with tempfile.TemporaryDirectory() as folder:
        csv = Path(folder) / "transmitter_beam.csv"
        table.to_csv(csv, index=False)
        return measured_levels(csv)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    args = parser.parse_args(argv)
    from benchmarks.validation_brb import brb_levels, impact_limit

    started, cpu = time.perf_counter(), time.process_time()
    print(f"load {os.getloadavg()[0]:.1f} (1 min) on {os.cpu_count()} cores; "
          f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        print_data_set("cubic spring (closed form)", cubic_levels())
        print_twins(args.seeds)
        brb = brb_levels()
        print_data_set("the BRB, levels", brb)
        print_data_set("the BRB, levels + impact", dataclasses.replace(brb, linear_limit=impact_limit()))
        beam = transmitter_levels()
        if beam is None:
            print("\ntransmitter beam: $NLUPDATE_TRANSMITTER_BEAM not set, skipped")
        else:
            print_data_set("the transmitter beam", beam)
    print(f"\n{time.perf_counter() - started:.1f} s wall, {time.process_time() - cpu:.1f} s CPU")
    return 0


if __name__ == "__main__":
    sys.exit(main())
