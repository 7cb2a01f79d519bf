"""The reduction exact at the joint (issue 38), checked against CalculiX itself.

The structure: a clamped solid beam and a second beam joined end to end by springs between
every pair of coincident nodes of their end faces (the joint). CalculiX writes the two beams'
matrices (no springs); the Craig–Bampton model keeps the joint's node pairs and the tip as
boundary and the springs are added on the reduced coordinates — the way the library's
joint elements act. References, all independent of the reduction:

* ccx's own ``*FREQUENCY`` eigenvalues of the same deck (the matrices are read right);
* ccx's ``*STEADY STATE DYNAMICS`` of the full mesh with the springs (60 modes) and the
  direct solve of the full matrices (every dof) on a fine grid that holds the anti-resonances;
* the full model's static flexibility;
* Euler–Bernoulli for a free–free bar meshed like the Brake–Reuss beam.
"""
from __future__ import annotations

import re
import subprocess
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg
import scipy.sparse.linalg

from nlupdate.core.model.linear import LumpedModel
from nlupdate.fe.adapters.calculix_matrices import CalculixMatrices, check_model_data, parse_matrix_file
from nlupdate.fe.adapters.calculix_tbeam import box_mesh
from nlupdate.fe.reduction import craig_bampton

pytestmark = pytest.mark.calculix

E, NU, RHO = 2.1e11, 0.3, 7850.0
LENGTH, HEIGHT, WIDTH, ELEMENTS = 0.3, 0.01, 0.02, 8  # each beam: m, m (y), m (z), elements along x
K_JOINT = 2e6  # N/m per node pair and direction
BETA = 2e-5  # s, stiffness-proportional (Rayleigh) damping C = βK
BAND_HZ = (5.0, 300.0)  # 1.5 × the 4th mode (167 Hz) and more


def _elements(lines: list[str], connectivity: np.ndarray, first: int) -> int:
    for number, nodes in enumerate(connectivity, start=first):
        ids = [str(number), *map(str, nodes)]
        lines += [", ".join(ids[:16]) + ",", ", ".join(ids[16:])]
    return first + len(connectivity)


@pytest.fixture(scope="module")
def jointed():
    """Model text (no springs), the springs' text, the joint's node pairs and the tip node."""
    beams = [box_mesh((np.linspace(x0, x0 + LENGTH, ELEMENTS + 1), np.array([-HEIGHT / 2, HEIGHT / 2]),
                       np.array([-WIDTH / 2, WIDTH / 2])), [((0, ELEMENTS), (0, 1), (0, 1))]) for x0 in (0.0, LENGTH)]
    nodes = np.vstack([beam.nodes for beam in beams])
    offset = len(beams[0].nodes)
    lines = ["*NODE"] + [f"{i + 1}, {x:.12e}, {y:.12e}, {z:.12e}" for i, (x, y, z) in enumerate(nodes)]
    lines.append("*ELEMENT, TYPE=C3D20, ELSET=EALL")
    number = _elements(lines, np.vstack([beams[0].elements + 1, beams[1].elements + 1 + offset]), 1)
    face_a = np.flatnonzero(np.isclose(nodes[:offset, 0], LENGTH)) + 1
    face_b = np.flatnonzero(np.isclose(nodes[offset:, 0], LENGTH)) + 1 + offset
    pairs = [(int(a), int(face_b[np.argmin(np.linalg.norm(nodes[face_b - 1] - nodes[a - 1], axis=1))])) for a in face_a]
    clamp = np.flatnonzero(np.isclose(nodes[:, 0], 0.0)) + 1
    tip = int(np.argmin(np.linalg.norm(nodes - [2 * LENGTH, -HEIGHT / 2, 0.0], axis=1))) + 1
    lines += ["*NSET, NSET=CLAMP", ", ".join(map(str, clamp)), "*NSET, NSET=TIP", str(tip),
              "*NSET, NSET=JA", str(pairs[0][0]), "*MATERIAL, NAME=S", "*ELASTIC", f"{E}, {NU}", "*DENSITY", f"{RHO}",
              "*SOLID SECTION, ELSET=EALL, MATERIAL=S", "*BOUNDARY", "CLAMP, 1, 3"]
    springs = []
    for direction in (1, 2, 3):
        springs.append(f"*ELEMENT, TYPE=SPRING2, ELSET=SPRING{direction}")
        for a, b in pairs:
            springs.append(f"{number}, {a}, {b}")
            number += 1
        springs += [f"*SPRING, ELSET=SPRING{direction}", f"{direction}, {direction}", f"{K_JOINT:.6e}"]
    return "\n".join(lines) + "\n", "\n".join(springs) + "\n", pairs, tip


@pytest.fixture(scope="module")
def matrices(jointed):
    return CalculixMatrices().assemble(jointed[0], "two-beams")


def _boundary(matrices, pairs, tip):
    rows, names = [], []
    for k, (a, b) in enumerate(pairs):
        for direction, axis in ((1, "ux"), (2, "uy"), (3, "uz")):
            rows += [matrices.index(a, direction), matrices.index(b, direction)]
            names += [f"a{k}:{axis}", f"b{k}:{axis}"]
    rows.append(matrices.index(tip, 2))
    names.append("tip:uy")
    return rows, names


def _springs(n: int, index, n_pairs: int) -> np.ndarray:
    """The joint's spring matrix on coordinates found by ``index(name)``."""
    springs = np.zeros((n, n))
    for k in range(n_pairs):
        for axis in ("ux", "uy", "uz"):
            i, j = index(f"a{k}:{axis}"), index(f"b{k}:{axis}")
            springs[[i, j], [i, j]] += K_JOINT
            springs[i, j] -= K_JOINT
            springs[j, i] -= K_JOINT
    return springs


def _run_ccx(folder: Path, deck: str) -> str:
    (folder / "job.inp").write_text(deck)
    subprocess.run(["ccx", "-i", "job"], cwd=folder, capture_output=True, check=True, timeout=300)
    return (folder / "job.dat").read_text()


def _ssd(text: str, node_set: str, column: int) -> tuple[np.ndarray, np.ndarray]:
    """Frequencies (Hz) and complex displacement of ``node_set`` (one node) from a steady-state ``.dat``:
    ccx prints each frequency's real part, then its imaginary part."""
    pattern = rf"displacements \(vx,vy,vz\) for set {node_set} and time\s+(\S+)\s*\n\s*\n\s*\d+\s+(\S+)\s+(\S+)\s+(\S+)"
    rows = re.findall(pattern, text)
    table = np.array([[float(value) for value in row] for row in rows])
    return table[0::2, 0], table[0::2, column] + 1j * table[1::2, column]


def test_matrices_give_ccx_own_eigenvalues(jointed, matrices, tmp_path):
    """The springs' deck through MATRIXSTORAGE and through ccx's *FREQUENCY: the same 8 eigenvalues
    (ccx prints 7 digits)."""
    model, springs, _, _ = jointed
    with_springs = CalculixMatrices().assemble(model + springs, "with-springs")
    text = _run_ccx(tmp_path, model + springs + "*STEP\n*FREQUENCY\n8\n*END STEP\n")
    rows = re.findall(r"^\s+\d+\s+(\S+)\s+\S+\s+\S+\s+\S+\s*$", text, flags=re.MULTILINE)[:8]
    ccx = np.array([float(row) for row in rows])
    ours = scipy.linalg.eigh(with_springs.stiffness.toarray(), with_springs.mass.toarray(), eigvals_only=True,
                             subset_by_index=[0, 7])
    np.testing.assert_allclose(ours, ccx, rtol=2e-6)


def test_reduced_frf_matches_ccx_steady_state_dynamics(jointed, matrices, tmp_path):
    """Joint springs on the Craig–Bampton coordinates vs the full mesh: within 0.5 % over the band,
    anti-resonances included; the modal sum of the first modes misses by far more."""
    model, springs, pairs, tip = jointed
    deck = (model + springs + "*STEP\n*FREQUENCY, STORAGE=YES\n60\n*END STEP\n*STEP\n*STEADY STATE DYNAMICS\n"
            f"{BAND_HZ[0]}, {BAND_HZ[1]}, 20\n*CLOAD\nTIP, 2, 1.0\n*MODAL DAMPING, RAYLEIGH\n, , 0., {BETA}\n"
            "*NODE PRINT, NSET=TIP\nU\n*NODE PRINT, NSET=JA\nU\n*END STEP\n")
    text = _run_ccx(tmp_path, deck)
    frequencies, ccx_tip = _ssd(text, "TIP", 2)
    _, ccx_joint = _ssd(text, "JA", 1)
    assert frequencies.size > 60 and frequencies.min() == BAND_HZ[0] and frequencies.max() == BAND_HZ[1]

    rows, names = _boundary(matrices, pairs, tip)
    reduced = craig_bampton(matrices.stiffness, matrices.mass, rows, names, n_modes=20)
    stiffness = reduced.stiffness + _springs(len(reduced.dof_names), reduced.index, len(pairs))
    model_r = LumpedModel(reduced.mass, stiffness, BETA * stiffness, None, reduced.dof_names)
    out = [reduced.index("tip:uy"), reduced.index("a0:ux")]
    h = model_r.receptance(2 * np.pi * frequencies, out, [out[0]])[:, :, 0]
    assert np.max(np.abs(h[:, 0] / ccx_tip - 1)) < 5e-3
    assert np.max(np.abs(h[:, 1] / ccx_joint - 1)) < 5e-3

    # every dof, direct solve, on a grid fine enough for the anti-resonances
    lookup = dict(zip(names, rows))
    full_k = matrices.stiffness.toarray() + _springs(matrices.n_dof, lookup.__getitem__, len(pairs))
    full = LumpedModel(matrices.mass.toarray(), full_k, BETA * full_k, None)
    grid = np.linspace(*BAND_HZ, 1500)
    exact = full.receptance(2 * np.pi * grid, [lookup["tip:uy"]], [lookup["tip:uy"]])[:, 0, 0]
    reduced_grid = model_r.receptance(2 * np.pi * grid, [out[0]], [out[0]])[:, 0, 0]
    magnitude = np.abs(exact)
    anti = [i for i in range(1, grid.size - 1) if magnitude[i] < magnitude[i - 1] and magnitude[i] < magnitude[i + 1]]
    assert len(anti) >= 1  # the drive point's anti-resonance lies in the band
    assert np.max(np.abs(reduced_grid / exact - 1)) < 5e-3

    # modal truncation beside it: the full model's first modes (all below 1.5× the band), no residual
    values, vectors = scipy.linalg.eigh(full_k, matrices.mass.toarray(), subset_by_index=[0, 5])
    phi = vectors[lookup["tip:uy"]]
    omega = 2 * np.pi * grid
    truncated = np.sum(phi**2 / (values - omega[:, None] ** 2 + 1j * omega[:, None] * BETA * values), axis=1)
    truncation_error = np.max(np.abs(truncated / exact - 1))
    reduction_error = np.max(np.abs(reduced_grid / exact - 1))
    print(f"\nmax |H/H_full − 1| at the tip, {BAND_HZ[0]}–{BAND_HZ[1]} Hz: Craig–Bampton (20 modes) "
          f"{reduction_error:.2e}, modal truncation (6 modes, up to {np.sqrt(values[-1]) / 2 / np.pi:.0f} Hz) "
          f"{truncation_error:.2e}")
    assert truncation_error > 20 * reduction_error


def test_reduction_is_exact_statically(jointed, matrices):
    """Forces at the boundary of the jointed structure: the reduced model without any mode (the
    Guyan part) plus the joint's springs has the full model's static flexibility there."""
    _, _, pairs, tip = jointed
    rows, names = _boundary(matrices, pairs, tip)
    reduced = craig_bampton(matrices.stiffness, matrices.mass, rows, names, n_modes=0)
    lookup = dict(zip(names, rows))
    full_k = matrices.stiffness.toarray() + _springs(matrices.n_dof, lookup.__getitem__, len(pairs))
    loads = np.zeros((matrices.n_dof, len(rows)))
    loads[rows, np.arange(len(rows))] = 1.0
    flexibility = np.linalg.solve(full_k, loads)[rows]
    reduced_k = reduced.stiffness + _springs(len(names), reduced.index, len(pairs))
    np.testing.assert_allclose(np.linalg.inv(reduced_k), flexibility, rtol=1e-7, atol=1e-10 * np.abs(flexibility).max())


def test_free_free_bar_first_bending_against_euler_bernoulli():
    """A free–free bar of the Brake–Reuss beam's section, meshed as its deck meshes (C3D20,
    2 × 2 elements across, 20 mm long): first bending in y within 1 % of Euler–Bernoulli."""
    length, thickness, width, n_x = 0.72, 0.0127, 0.0254, 36
    mesh = box_mesh((np.linspace(0, length, n_x + 1), np.linspace(-thickness / 2, thickness / 2, 3),
                     np.linspace(-width / 2, width / 2, 3)), [((0, n_x), (0, 2), (0, 2))])
    lines = ["*NODE"] + [f"{i + 1}, {x:.12e}, {y:.12e}, {z:.12e}" for i, (x, y, z) in enumerate(mesh.nodes)]
    lines.append("*ELEMENT, TYPE=C3D20, ELSET=EALL")
    _elements(lines, mesh.elements + 1, 1)
    lines += ["*MATERIAL, NAME=S", "*ELASTIC", "193e9, 0.29", "*DENSITY", "8000",
              "*SOLID SECTION, ELSET=EALL, MATERIAL=S"]
    bar = CalculixMatrices().assemble("\n".join(lines) + "\n", "bar")
    # a shift well clear of the six zero eigenvalues (σ = −1 converged to the wrong values)
    values, vectors = scipy.sparse.linalg.eigsh(bar.stiffness, k=10, M=bar.mass, sigma=-1e4)
    y_share = np.array([np.sum(vectors[bar.directions == 2, j] ** 2) / np.sum(vectors[:, j] ** 2) for j in range(10)])
    elastic = (values > 1.0) & (y_share > 0.5)
    first_y = np.sqrt(np.min(values[elastic])) / (2 * np.pi)
    euler_bernoulli = 4.730041**2 / (2 * np.pi * length**2) * np.sqrt(193e9 * thickness**2 / (12 * 8000))
    assert abs(first_y / euler_bernoulli - 1) < 0.01


def test_matrix_files_and_refusals():
    """The upper triangle is mirrored; constraints and reduced-integration bricks are refused."""
    matrix = parse_matrix_file("1 1 2.0\n1 2 -1.0\n2 2 3.0\n", 2, "x.sti").toarray()
    np.testing.assert_array_equal(matrix, [[2.0, -1.0], [-1.0, 3.0]])
    with pytest.raises(ValueError, match=r"outside 1\.\.2"):
        parse_matrix_file("1 3 2.0\n", 2, "x.sti")
    with pytest.raises(ValueError, match="EQUATION"):
        check_model_data("*NODE\n1,0,0,0\n*EQUATION\n2\n1,1,1.,2,1,-1.\n")
    with pytest.raises(ValueError, match="singular"):
        check_model_data("*ELEMENT, TYPE=C3D20R, ELSET=E\n")
