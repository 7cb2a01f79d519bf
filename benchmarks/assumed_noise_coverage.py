"""``python benchmarks/assumed_noise_coverage.py S_TRUE TRIALS`` (docs/ring-down.md, "The bands").

Coverage of the polynomial backbone's 95 % frequency band at the samples' middle amplitude
with four samples (order 2: one degree of freedom): truth f = 42.81 Hz·(1 − 9e-4 √(a/a_max)),
the transmitter beam's amplitudes, frequencies measured with relative noise S_TRUE, the fit
assuming 0.1 %. (A) misfits drawn from the assumed noise (the rule under five samples);
(B) the assumed noise scaled by √(χ²/dof), the samples' own scatter from one degree of freedom.
"""
from __future__ import annotations

import sys

import numpy as np

from nlupdate.core.identification.amplitude_modal_fit import fit_amplitude_model
from nlupdate.core.identification.backbone_samples import bootstrap_bands
from nlupdate.core.identification.modal_samples import ModalSamples

AMPLITUDE = np.array([0.484, 0.7, 0.93, 1.15]) * 1e-3  # m·√(kg·V/N)
MIDDLE = np.array([0.8e-3])
ASSUMED = 1e-3


def truth(a: np.ndarray) -> np.ndarray:
    return 42.81 * (1 - 9e-4 * np.sqrt(a / AMPLITUDE.max()))


def band(samples: ModalSamples, model, noise: float, seed: int) -> tuple[float, float]:
    def refit(draw: ModalSamples):
        return fit_amplitude_model(draw, [("x", 1.0)], "polynomial", 2, noise, 0.05)
    (low, high), _ = bootstrap_bands(model, samples, MIDDLE, refit, 100, seed=seed, noise=(noise, 0.05))
    return float(low[0]), float(high[0])


def main(noise: float, trials: int) -> None:
    results = {"assumed": [], "residual-scaled": []}
    damping = 4e-4 * (1 + AMPLITUDE / AMPLITUDE.max())
    for trial in range(trials):
        rng = np.random.default_rng(100 + trial)
        f = truth(AMPLITUDE) * (1 + noise * rng.standard_normal(AMPLITUDE.size))
        zeta = damping * (1 + 0.02 * rng.standard_normal(AMPLITUDE.size))
        samples = ModalSamples(AMPLITUDE, f, zeta, np.ones(AMPLITUDE.size), 1.0)
        model = fit_amplitude_model(samples, [("x", 1.0)], "polynomial")
        chi2 = float(model.note.split("chi² ")[1].split(" ")[0])  # the frequency fit's, one degree of freedom
        for name, sigma in (("assumed", ASSUMED), ("residual-scaled", max(ASSUMED * np.sqrt(chi2), 1e-7))):
            low, high = band(samples, model, sigma, trial)
            results[name].append((low <= truth(MIDDLE)[0] <= high, high - low))
    for name, rows in results.items():
        rows = np.array(rows, float)
        print(f"noise {noise:g}, {name}: coverage {rows[:, 0].mean():.2f}, median width {1e3 * np.median(rows[:, 1]):.3g} mHz")


if __name__ == "__main__":
    main(float(sys.argv[1]), int(sys.argv[2]))
