"""Tutorial 2 — identify the nonlinearity and the linear FRF from tests at several levels.

A simulated stepped-sine test of the docs/methods.md §8 SDOF rig (examples/sdof.toml: 0.1 kg,
2e6 N/m, loss factor 0.01, cubic spring k3 = 1e10 N/m³, Jenkins joint kf = 3e5 N/m with a
slip force of 1 N) with 1 % noise, then PRD identification of a cubic spring plus a
Jenkins joint, with Monte-Carlo uncertainty. The printed values stand next to the truth
of the model file, which the identification never sees.

The levels are chosen for what each shows: the slip force only shows where the joint goes
from sticking to slipping (kf·amplitude ≈ slip force: 1–5 N here); at 100–300 N friction
is a small part of the force and the cubic spring shows. Tested at 100–300 N alone, the
slip force is not determined, and identify warns so.

    python examples/identify_nonlinearity.py [OUT_DIR] [--seed N]   # writes OUT_DIR/identification.json
"""
import argparse
import json
import tempfile
from pathlib import Path

import numpy as np

import nlupdate as nlu

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("out", nargs="?", type=Path, help="output folder (default: a new temporary folder)")
parser.add_argument("--seed", type=int, default=1, help="noise seed of the simulated test (default 1)")
args = parser.parse_args()
out = args.out or Path(tempfile.mkdtemp(prefix="nlupdate-identify-"))
here = Path(__file__).resolve().parent

truth = nlu.load_model(here / "sdof.toml")
levels_n = [0.01, 1.0, 2.0, 5.0, 100.0, 200.0, 300.0]
measured = nlu.simulate(truth, "0", np.linspace(650.0, 780.0, 131), levels_n, noise=0.01, seed=args.seed)

# PRD (the default method) with physical elements; 20 Monte-Carlo samples for the uncertainty
found = nlu.identify(measured, elements=("cubic", "jenkins"), samples=20, seed=0)

true_values = {name: value for element in truth.elements for name, value in vars(element).items() if name != "dofs"}
units = {"k3": "N/m³", "kf": "N/m", "slip_force": "N"}
print(f"PRD at {found.frequency_choice.frequency_hz:.1f} Hz ({found.frequency_choice.reason}); "
      f"noise {found.noise_fraction:.3g} of |H|")
for name, stats in found.uncertainty.parameters.items():
    if name in true_values:
        print(f"{name:>10} = {stats.value:.4g} ± {stats.std:.2g} {units[name]}   (truth {true_values[name]:g})")
print("linear mode of the extracted FRF: " + ", ".join(f"{f:.2f} Hz" for f in found.natural_frequencies_hz)
      + f"   (truth √(k/m)/2π = {np.sqrt(2e6 / 0.1) / (2 * np.pi):.2f} Hz)")
for warning in found.warnings:
    print(f"warning: {warning}")

out.mkdir(parents=True, exist_ok=True)
(out / "identification.json").write_text(json.dumps(found.summary(), indent=2, default=str))
print(f"wrote {out / 'identification.json'}")
