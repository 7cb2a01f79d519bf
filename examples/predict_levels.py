"""Tutorial 4 — the chain step by step: identify, update the linear model, predict every level.

The "real structure" is the docs/methods.md §8 2-DOF rig (examples/two_dof.toml: springs
k1 = k2 = k3 = 1e6 N/m from ground to mass 1 (0.1 kg), between the masses, and from
mass 2 (0.5 kg) to ground; cubic spring and Jenkins joint on mass 1). The analyst's FE
model is the same spring chain with k1 = 0.8e6 N/m (the joint's support, not known well). A test at 0.01–100 N
around the second mode (690–770 Hz, 1 % noise) gives, through PRD, the joint and the
*linear* natural frequency (the joint's stuck stiffness removed); k1 is updated against it,
and the updated model plus the identified joint predicts every measured level (truth:
k1 = 1e6 N/m, loss factor 0.005; the initial model's fitted loss factor runs to its bound
0.2 trying to make up for the wrong resonance).

    python examples/predict_levels.py
"""
from pathlib import Path

import numpy as np

import nlupdate as nlu

here = Path(__file__).resolve().parent
truth = nlu.load_model(here / "two_dof.toml")
levels_n = [0.01, 20.0, 40.0, 60.0, 80.0, 100.0]
measured = nlu.simulate(truth, "0", np.linspace(690.0, 770.0, 161), levels_n, noise=0.01, seed=3)

# 1. identification: the joint and the linear FRF at the driving point "0"
found = nlu.identify(measured, elements=("cubic", "jenkins"), samples=8, seed=1)
print("identified: " + ", ".join(f"{k} = {v:.4g}" for k, v in found.parameters().items()))
target_hz = found.natural_frequencies_hz[:1]
print(f"linear natural frequency of the extracted FRF: {target_hz[0]:.2f} Hz "
      f"(± {found.natural_frequency_std_hz[0]:.2f} Hz)")

# 2. updating: the FE spring chain (coordinates x1, x2); the measured mode is its mode 2
chain = nlu.fe_model("lumped", masses=[0.1, 0.5], stiffnesses=[0.8e6, 1.0e6, 1.0e6])
k1 = nlu.Parameter("k1", unit="N/m", start=0.8e6, lower=0.5e6, upper=1.5e6)
updated = nlu.update(chain, [k1], target_hz, model_modes=[2], formula="central2")
print(f"updated k1 = {updated.parameters['k1']:.5g} N/m ({updated.reason}); mode 2: "
      f"{updated.frequencies_hz('initial')[0]:.2f} → {updated.frequencies_hz('final')[0]:.2f} Hz")

# 3. prediction at every level: FE modes + identified joint, loss factor fitted at 0.01 N
for name, modes in (("initial", updated.initial), ("updated", updated.final)):
    prediction = nlu.predict(modes, found, measured, model_response_dof="x1")
    frac = prediction.correlation["frac"].to_numpy()
    print(f"{name:>8} model (loss factor {prediction.loss_factor:.4f}): FRAC per level "
          + " ".join(f"{v:.3f}" for v in frac))
