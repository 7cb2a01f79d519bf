"""Tutorial 3 — update a linear FE model against a natural frequency.

The source's single-mode study (thesis §4.1.5, examples/tbeam_single_mode.toml): the
built-in T-beam surrogate (Timoshenko frames; beam 1 clamped at its tip between two thin
fixed–fixed beams) starts from E = 210 GPa, where its first global mode is at 46.42 Hz;
the PRD-extracted linear FRF of the test put that mode at 40.75 Hz. Inverse
eigensensitivity updates E with each finite-difference formula. Only E changes and
mass does not, so f ∝ √E: the exact answer is E = 210 GPa · (40.75 / f1_initial)².

    python examples/update_linear_model.py
"""
import nlupdate as nlu

tbeam = nlu.fe_model("surrogate", "tbeam", n_modes=2, global_modes_only=True)
modulus = nlu.Parameter("E", unit="Pa", start=210e9, lower=100e9, upper=300e9, relative_step=1e-3)
target_hz = [40.75]  # first global mode of the extracted linear FRF

results = {}
for formula in ("forward", "backward", "central2", "central4"):
    result = nlu.update(tbeam, [modulus], target_hz, method="eigensensitivity", formula=formula,
                        frequency_tolerance=1e-9)
    results[formula] = result
    (f1_initial,), (f1_final,) = result.frequencies_hz("initial"), result.frequencies_hz("final")
    print(f"{formula:>9}: E = {result.parameters['E'] / 1e9:.4f} GPa after {result.iterations} iterations "
          f"({result.counts['new']} new FE runs); f1 {f1_initial:.2f} → {f1_final:.4f} Hz, "
          f"f2 {result.initial.natural_frequencies_hz[1]:.2f} → {result.final.natural_frequencies_hz[1]:.2f} Hz")

exact = 210e9 * (target_hz[0] / f1_initial) ** 2
print(f"exact (f ∝ √E): E = {exact / 1e9:.4f} GPa")
