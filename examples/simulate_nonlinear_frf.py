"""Tutorial 1 — nonlinear FRFs of a model at several force levels (docs/python-api.md).

The docs/methods.md §8 two-degree-of-freedom rig (examples/two_dof.toml: masses 0.1 and 0.5 kg,
springs 1e6 N/m, a cubic spring k3 = 1e10 N/m³ and a Jenkins friction joint kf = 8e4 N/m,
slip force 1 N on mass "0") is driven at mass "0" by 0.01 N … 100 N, 650–900 Hz. At
0.01 N the joint sticks and the rig is linear (K + kf at dof 0, mode at 745 Hz); at 1–5 N
it slips: the resonance softens towards the mode without kf and friction flattens the
peak; at 50–100 N the cubic spring takes over and the resonance hardens.

    python examples/simulate_nonlinear_frf.py [OUT_DIR]     # writes OUT_DIR/two_dof_frf.parquet
"""
import sys
import tempfile
from pathlib import Path

import numpy as np

import nlupdate as nlu

here = Path(__file__).resolve().parent
out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp(prefix="nlupdate-simulate-"))

model = nlu.load_model(here / "two_dof.toml")
frequency_hz = np.linspace(650.0, 900.0, 501)  # Hz
force_levels_n = [0.01, 1.0, 5.0, 50.0, 100.0]  # force amplitudes, N
# receptance H = X/F (m/N) of every dof, read as a stepped-sine test sweeping up
measured = nlu.simulate(model, input_dof="0", frequency_hz=frequency_hz, force_levels_n=force_levels_n)

peaks = {}
for level in force_levels_n:
    f, h = nlu.select_frf(measured, "0", "0", level)
    i = int(np.argmax(np.abs(h)))
    peaks[level] = (float(f[i]), float(np.abs(h[i])))
    print(f"{level:6g} N: resonance peak at {f[i]:7.2f} Hz, |H| = {np.abs(h[i]):.3e} m/N")

out.mkdir(parents=True, exist_ok=True)
path = nlu.save_measurements(measured, out / "two_dof_frf.parquet")
print(f"wrote {len(measured)} rows ({measured['response_dof'].nunique()} dofs × {len(force_levels_n)} levels) to {path}")
