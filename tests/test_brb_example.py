"""The Brake–Reuss beam example (examples/brb, issue 38) on a coarse mesh.

References independent of the code under test: the full (patched) FE matrices solved
directly for the reduction; the library's describing-function continuation for the
[fe_validation] step's per-line balance; for the whole example (slow): the published data
through the resonance estimator and the stuck structure's eigenvalues.
"""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import scipy.linalg
import scipy.sparse
import scipy.sparse.linalg

import nlupdate as nlu
from nlupdate.fe.adapters.calculix_brb import BOLTS, BRBAdapter, BRBMesh, BRBModel, JOINT_DEFAULTS, joint_stiffness
from nlupdate.core.validation.forced_runs import harmonic_response, read_forced_runs
from nlupdate.core.validation.resonance import resonance
from nlupdate.fe.adapters.calculix_matrices import CalculixMatrices
from nlupdate.fe.joint_validation import nonlinear_model
from nlupdate.fe.reduction import rigid_patches

pytestmark = pytest.mark.calculix
ROOT = Path(__file__).resolve().parents[1]
COARSE = BRBMesh(n_full=8, n_lap=8)
DATA = ROOT / "tests" / "data" / "brb"


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
    """The [fe_validation] step's per-line balance at a fixed force equals the describing-function
    continuation of nlupdate simulate on the same reduced nonlinear model; the held-amplitude solve
    finds that force."""
    joint = {"slip_force": 800.0, "chi": -0.3, "beta": 0.0}
    system = nonlinear_model(adapter, {}, 0.002, joint, "iwan", "acc3:uy", shaker_mass=0.01)
    frequency = np.linspace(77.0, 80.0, 13)
    table = nlu.simulate(system, "acc3:uy", frequency, [1.5])
    curve = table[table.response_dof == "acc3:uy"].sort_values("frequency_hz")
    reference = (curve.h_real + 1j * curve.h_imag).to_numpy()
    h, _ = harmonic_response(system, "acc3:uy", curve.frequency_hz.to_numpy(), force_n=np.full(len(curve), 1.5))
    np.testing.assert_allclose(h, reference, rtol=1e-6)
    held = abs(h[6]) * 1.5
    _, force = harmonic_response(system, "acc3:uy", curve.frequency_hz.to_numpy()[6:7], held_m=held)
    assert force[0] == pytest.approx(1.5, rel=1e-5)


@pytest.mark.slow
def test_the_example_runs_from_its_readme(tmp_path):
    """README's one command on a coarse mesh and a short joint fit: the updated model meets the
    impact modes; every forced run has a row per model whose measured values are the estimator's
    on the raw file's runs, and whose predicted resonance at the lowest held amplitude is the
    linear limit — the stuck structure with the shaker's mass, solved directly — softened a little
    by microslip, never stiffened."""
    study = (ROOT / "examples" / "brb" / "brb.toml").read_text()
    for old, new in (("mesh = { n_full = 15, n_lap = 12, n_thickness = 2, n_width = 2 }",
                      "mesh = { n_full = 8, n_lap = 8, n_thickness = 2, n_width = 2 }"),
                     ("fit_evaluations = 60", "fit_evaluations = 3"), ("../../tests/data/brb/", f"{DATA}/")):
        assert old in study
        study = study.replace(old, new)
    path = tmp_path / "brb.toml"
    path.write_text(study)
    subprocess.run([sys.executable, "-m", "nlupdate", "run", str(path), "--out", str(tmp_path / "out")],
                   check=True, timeout=1800)
    archive = next((tmp_path / "out" / "brb").iterdir())
    modes = pd.read_parquet(archive / "tables" / "fe_modes.parquet")
    assert list(modes.columns) == ["model", "mode", "frequency_hz", "frequency_hz_measured"]
    paired = modes.dropna(subset=["frequency_hz_measured"])
    error = (paired.frequency_hz / paired.frequency_hz_measured - 1).abs().groupby(paired.model).max()
    assert error["updated"] < 1e-4 < error["initial"]
    validation = pd.read_parquet(archive / "tables" / "validation.parquet")
    assert list(validation.columns) == ["run", "control", "level", "model", "resonance_hz_measured",
                                        "resonance_hz_predicted", "damping_ratio_measured", "damping_ratio_predicted",
                                        "peak_measured", "peak_predicted"]
    assert (validation.groupby("model").size() == 12).all() and set(validation.model) == {"initial", "updated"}
    assert (validation.groupby("control").size() == [8, 16]).all()

    runs = {run.run: run for run in read_forced_runs(DATA / "ForcedFrequencyResponses.mat", ("acc3:-y", "acc3:y"))}
    for row in validation.itertuples():
        reference = resonance(runs[row.run].frequency_hz, np.abs(runs[row.run].h))
        assert row.resonance_hz_measured == pytest.approx(reference.resonance_hz, rel=1e-12)
        assert row.peak_measured == pytest.approx(reference.peak_abs, rel=1e-12)

    record = json.loads((archive / "fe_validation.json").read_text())
    adapter = BRBAdapter(COARSE, n_modes=4, fixed_interface_modes=12)
    point = record["points"]["updated"]
    deck, springs = adapter.split(point)
    reduced = adapter.reduced(deck)
    mass = reduced.mass.copy()
    drive = reduced.index("acc3:uy")
    mass[drive, drive] += record["shaker_mass_kg"]
    stiffness = reduced.stiffness + joint_stiffness(reduced, springs["kt"], springs["kn"], springs["kr"])
    eigenvalues = scipy.linalg.eigh(stiffness, mass, eigvals_only=True)
    stuck_hz = np.sqrt(eigenvalues[eigenvalues > (2 * np.pi) ** 2].min()) / (2 * np.pi)
    lowest = validation[(validation.model == "updated") & (validation.control == "response")].sort_values("level")
    assert stuck_hz * (1 - 5e-3) < lowest.resonance_hz_predicted.iloc[0] < stuck_hz
    report = (archive / "report.md").read_text()
    assert "## FE model against every forced run" in report and "ResponseControl(8)" in report
