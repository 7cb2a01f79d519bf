"""Tutorial 5 — discovery: which effect the model is missing, where, and the gap closing.

examples/discovery/sdof_linear.toml is the analyst's linear model of the docs/methods.md §8 SDOF
rig (0.1 kg, 2e6 N/m, loss factor 0.04); sdof_friction_cubic.csv was measured on the same
rig by time integration, with 1 % noise, at 2, 8, 25 and 60 N — with a dry-friction joint
and a cubic spring the model does not have (truth, examples/discovery/README.md:
kf = 1.40e5 N/m, slip force 11.1 N, k3 = 1.20e11 N/m³). Discovery searches the effect
library at every place, adds what the data support and reports the gap (mean 1 − FRAC
over the levels) before and after.

    python examples/discover_missing_effect.py [OUT_DIR]     # writes OUT_DIR/augmented_model.toml
"""
import sys
import tempfile
from pathlib import Path

import nlupdate as nlu

here = Path(__file__).resolve().parent / "discovery"
out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp(prefix="nlupdate-discover-"))

model = nlu.load_model(here / "sdof_linear.toml")
measured = nlu.load_measurements(here / "sdof_friction_cubic.csv")
found = nlu.discover(model, measured, max_effects=3)

for effect in found.effects:
    values = ", ".join(f"{name} = {value:.4g}" for name, value in effect.parameters.items())
    print(f"found {effect.name} on {found.place(effect.dofs)}: {values}")  # as the model names it
print(f"gap (mean 1 − FRAC): before {found.gap_before.gap:.3g}, after {found.gap_after.gap:.3g}; "
      f"residual {found.misfit_ratio:.2f}× the noise; stopped: {found.stop_reason}")

out.mkdir(parents=True, exist_ok=True)
print(f"wrote {nlu.save_model(found.augmented, out / 'augmented_model.toml')}")
