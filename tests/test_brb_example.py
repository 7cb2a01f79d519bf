"""The Brake–Reuss beam example (examples/brb, issue 38) on a coarse mesh.

References independent of the code under test: the full (patched) FE matrices solved
directly for the reduction; the library's describing-function continuation for the
example's per-line balance; the published data for the whole example (slow).
"""
from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import scipy.sparse
import scipy.sparse.linalg

import nlupdate as nlu
from nlupdate.fe.adapters.calculix_brb import BOLTS, BRBAdapter, BRBMesh, BRBModel, JOINT_DEFAULTS
from nlupdate.fe.adapters.calculix_matrices import CalculixMatrices
from nlupdate.fe.reduction import rigid_patches

pytestmark = pytest.mark.calculix
ROOT = Path(__file__).resolve().parents[1]
COARSE = BRBMesh(n_full=8, n_lap=8)


def _example():
    spec = importlib.util.spec_from_file_location("brb_predict_runs", ROOT / "examples" / "brb" / "predict_runs.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def adapter():
    return BRBAdapter(COARSE, n_modes=4, fixed_interface_modes=12)


def test_reduced_modes_match_the_full_mesh(adapter):
    """Craig–Bampton (12 fixed-interface modes) against the whole patched mesh with the same joint
    springs, solved directly: the two y-bending modes within 0.05 %, the first four modes within 0.2 %."""
    model = BRBModel(COARSE)
    deck, nodes, sets = model.build({})
    full = CalculixMatrices().assemble(deck, "brb-full")
    patches = model.bolt_patches({}, nodes, sets)
    k, m, kept, names = rigid_patches(full.stiffness, full.mass, full.nodes, full.directions,
                                      np.vstack([np.zeros(3), nodes]), patches)
    k = k.tolil()
    for bolt in BOLTS:
        for axis, value in (("ux", "kt"), ("uy", "kn"), ("uz", "kt"), ("rx", "kr"), ("ry", "kr"), ("rz", "kr")):
            i, j = (kept.size + names.index(f"{bolt}_{side}:{axis}") for side in "ab")
            stiffness = JOINT_DEFAULTS[value]
            k[i, i] += stiffness
            k[j, j] += stiffness
            k[i, j] -= stiffness
            k[j, i] -= stiffness
    values = scipy.sparse.linalg.eigsh(scipy.sparse.csr_matrix(k), k=10, M=m, sigma=-1e4, return_eigenvectors=False)
    elastic = np.sort(np.sqrt(values[values > 1e2]) / (2 * np.pi))
    reduced = adapter.evaluate({}).natural_frequencies_hz
    np.testing.assert_allclose(reduced[[0, 2]], elastic[[0, 2]], rtol=5e-4)  # the y-bending modes (2.1e-4 at most)
    np.testing.assert_allclose(reduced, elastic[:4], rtol=2e-3)
    result = adapter.evaluate({})
    drive = result.mode_shapes[result.coordinates.index("acc3:uy")]
    assert abs(drive[1]) < 1e-6 * abs(drive[0])  # mode 2 bends across the width: acc3 (along y) does not see it


def test_line_balance_matches_the_library_continuation(adapter):
    """The example's per-line balance at a fixed force equals the describing-function continuation
    of nlupdate simulate on the same reduced nonlinear model; the held-amplitude solve finds that force."""
    example = _example()
    joint = {"slip_force": 800.0, "chi": -0.3, "beta": 0.0}
    system = example.nonlinear_model(adapter, {}, 0.002, joint, shaker_mass=0.01)
    frequency = np.linspace(77.0, 80.0, 13)
    table = nlu.simulate(system, "acc3:uy", frequency, [1.5])
    curve = table[table.response_dof == "acc3:uy"].sort_values("frequency_hz")
    reference = (curve.h_real + 1j * curve.h_imag).to_numpy()
    h, _ = example.harmonic_response(system, curve.frequency_hz.to_numpy(), force_n=np.full(len(curve), 1.5))
    np.testing.assert_allclose(h, reference, rtol=1e-6)
    held = abs(h[6]) * 1.5
    _, force = example.harmonic_response(system, curve.frequency_hz.to_numpy()[6:7], held_m=held)
    assert force[0] == pytest.approx(1.5, rel=1e-5)


@pytest.mark.slow
def test_the_example_runs_from_its_readme(tmp_path):
    """README's two commands on a coarse mesh: the updated model meets the impact modes, and every
    forced run has a row per model with the measured and predicted values."""
    study = (ROOT / "examples" / "brb" / "brb.toml").read_text().replace(
        "mesh = { n_full = 15, n_lap = 12, n_thickness = 2, n_width = 2 }",
        "mesh = { n_full = 8, n_lap = 8, n_thickness = 2, n_width = 2 }")
    path = tmp_path / "brb.toml"
    path.write_text(study)
    archive = tmp_path / "out"
    subprocess.run([sys.executable, "-m", "nlupdate", "update", str(path), "--out", str(archive)],
                   check=True, timeout=1200)
    script = ROOT / "examples" / "brb" / "predict_runs.py"
    subprocess.run([sys.executable, str(script), str(archive), "--fit-evaluations", "4"], check=True, timeout=1800)
    modes = pd.read_parquet(archive / "tables" / "fe_modes.parquet")
    paired = modes.dropna(subset=["frequency_hz_measured"])
    error = (paired.frequency_hz / paired.frequency_hz_measured - 1).abs().groupby(paired.model).max()
    assert error["updated"] < 1e-4 < error["initial"]
    validation = pd.read_parquet(archive / "tables" / "validation.parquet")
    quantities = [f"{q}_{side}" for q in ("resonance_hz", "damping_ratio", "peak")
                  for side in ("measured", "predicted")]
    assert sorted(validation.columns) == sorted(["run", "control", "level", "model", *quantities])
    assert (validation.groupby("model").size() == 12).all()
    assert set(validation.control) == {"force", "response"}
