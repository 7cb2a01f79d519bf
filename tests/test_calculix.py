"""CalculiX adapter and solid T-beam deck.

References are independent of the code under test: the 1-D quadratic rod element
(single-element check of the C3D20 node order and mass matrix), Euler–Bernoulli and
Timoshenko cantilever theory (Timoshenko by an exact transfer matrix), and the
source thesis' published ANSYS SOLID186 results for the T-beam (§4.2.4.1: converged
46.4 / 197–197.5 / 280–282 Hz; Table 4.15 with sensor masses 41.4 / 193.3 / 266.0 Hz;
global modes are FE modes 1, 2 and 6).
"""
from __future__ import annotations

import stat
import sys
import textwrap
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Mapping

import numpy as np
import pytest
import scipy.linalg
import scipy.optimize
from patience import timed_out_once_ready

from nlupdate.core.updating.evaluation import MemoisedEvaluator
from nlupdate.fe.adapters.base import AdapterError
from nlupdate.fe.adapters.calculix import CalculixAdapter, count_elements, fortran_float, frequency_step, parse_dat
from nlupdate.fe.adapters.calculix_tbeam import (
    SENSOR_MASSES,
    TBEAM_PARAMETER_NAMES,
    TBeamDeck,
    TBeamMesh,
    beam1_modal_mass_fraction,
    box_mesh,
    global_modes,
    mesh_study,
)
from nlupdate.fe.adapters.runner import ExecutableNotFoundError, RunTimeoutError

E_STEEL, NU_STEEL, RHO_STEEL = 210e9, 0.3, 7850.0


def ids_text(ids: np.ndarray) -> str:
    numbers = [str(int(i) + 1) for i in ids]
    return "\n".join(", ".join(numbers[k : k + 16]) for k in range(0, len(numbers), 16))


class BlockDeck:
    """Solid block x ∈ [0, L], |y| ≤ b/2, |z| ≤ h/2 meshed by ``box_mesh``.

    support: "clamp" (x = 0 face fixed in x, y, z) or "axial" (x = 0 face fixed in x,
    every node fixed in y and z, a 1-D rod).
    """

    def __init__(self, n: tuple[int, int, int], L: float, b: float, h: float, element: str = "C3D20R", support: str = "clamp", nu: float = NU_STEEL) -> None:
        self.n, self.L, self.b, self.h, self.element, self.support, self.nu = n, L, b, h, element, support, nu

    def fingerprint(self) -> str:
        return repr((self.n, self.L, self.b, self.h, self.element, self.support, self.nu))

    def __call__(self, parameters: Mapping[str, float]):
        E = parameters.get("E", E_STEEL)
        nx, ny, nz = self.n
        mesh = box_mesh(
            (np.linspace(0, self.L, nx + 1), np.linspace(-self.b / 2, self.b / 2, ny + 1), np.linspace(-self.h / 2, self.h / 2, nz + 1)),
            [((0, nx), (0, ny), (0, nz))],
        )
        nodes = mesh.nodes
        lines = ["*NODE"] + [f"{i + 1}, {x:.11e}, {y:.11e}, {z:.11e}" for i, (x, y, z) in enumerate(nodes)]
        lines.append(f"*ELEMENT, TYPE={self.element}, ELSET=EALL")
        for number, connectivity in enumerate(mesh.elements + 1, start=1):
            ids = [str(number), *map(str, connectivity)]
            lines += [", ".join(ids[:16]) + ",", ", ".join(ids[16:])]
        root = np.flatnonzero(np.abs(nodes[:, 0]) < 1e-12)
        face = np.flatnonzero(np.abs(nodes[:, 0] - self.L) < 1e-12)
        distance = np.linalg.norm(nodes[face, 1:], axis=1)
        tip = face[distance <= distance.min() + 1e-12]
        lines += ["*NSET, NSET=ROOT", ids_text(root), "*NSET, NSET=TIP", ids_text(tip), "*NSET, NSET=ALLN", ids_text(np.arange(len(nodes)))]
        lines += ["*MATERIAL, NAME=STEEL", "*ELASTIC", f"{E:.11e}, {self.nu}", "*DENSITY", f"{RHO_STEEL}", "*SOLID SECTION, ELSET=EALL, MATERIAL=STEEL", "*BOUNDARY"]
        lines += ["ROOT, 1, 3"] if self.support == "clamp" else ["ROOT, 1, 1", "ALLN, 2, 3"]
        return "\n".join(lines) + "\n", {"tip:ux": ("TIP", "ux"), "tip:uy": ("TIP", "uy"), "tip:uz": ("TIP", "uz")}


def timoshenko_cantilever_hz(E: float, nu: float, rho: float, L: float, width: float, depth: float, n_modes: int) -> np.ndarray:
    """Clamped-free Timoshenko beam bending frequencies (Hz) for bending across ``depth``.

    Exact: state [w, w', ψ, ψ'] with κGA(w'' − ψ') + ρAω²w = 0 and
    EIψ'' + κGA(w' − ψ) + ρIω²ψ = 0; w = ψ = 0 at x = 0, ψ' = 0 and w' − ψ = 0 at x = L;
    the roots of the 2×2 determinant of the transfer matrix expm(A L).
    """
    G = E / (2 * (1 + nu))
    kappa = 10 * (1 + nu) / (12 + 11 * nu)  # rectangular section (Cowper)
    area, inertia = width * depth, width * depth**3 / 12
    a = kappa * G * area / (E * inertia)

    def determinant(f: float) -> float:
        w2 = (2 * np.pi * f) ** 2
        A = np.array([[0, 1, 0, 0], [-rho * w2 / (kappa * G), 0, 0, 1], [0, 0, 0, 1], [0, -a, a - rho * w2 / E, 0]])
        T = scipy.linalg.expm(A * L)
        return float(np.linalg.det(np.array([[T[3, 1], T[3, 3]], [T[1, 1] - T[2, 1], T[1, 3] - T[2, 3]]])))

    euler_bernoulli = euler_bernoulli_cantilever_hz(E, rho, L, width, depth, n_modes)
    grid = np.linspace(1.0, 1.05 * euler_bernoulli[-1], 4000)
    values = np.array([determinant(f) for f in grid])
    roots = [scipy.optimize.brentq(determinant, grid[i], grid[i + 1], xtol=1e-10) for i in np.flatnonzero(np.sign(values[:-1]) != np.sign(values[1:]))]
    return np.array(roots[:n_modes])


def euler_bernoulli_cantilever_hz(E: float, rho: float, L: float, width: float, depth: float, n_modes: int) -> np.ndarray:
    beta_l = np.array([1.8751040687, 4.6940911330, 7.8547574382, 10.9955407349])[:n_modes]
    area, inertia = width * depth, width * depth**3 / 12
    return beta_l**2 / (2 * np.pi * L**2) * np.sqrt(E * inertia / (rho * area))


# --------------------------------------------------------------------------- pure unit tests


def test_fortran_float_reads_three_digit_exponents() -> None:
    assert fortran_float("-1.580678E-02") == pytest.approx(-1.580678e-2)
    assert fortran_float("0.1234567-101") == pytest.approx(0.1234567e-101)
    assert fortran_float("1.5D+03") == pytest.approx(1500.0)
    with pytest.raises(ValueError, match="not a number"):
        fortran_float("*******")


def test_parse_dat_rejects_output_without_eigenvalues() -> None:
    with pytest.raises(ValueError, match=r"bad\.dat: no 'E I G E N V A L U E   O U T P U T' block"):
        parse_dat("\n STEP 1\n", "bad.dat")


def test_frequency_step_prints_each_set_once() -> None:
    assert frequency_step(4, ["TIP", "B1_50"]) == (
        "*STEP\n*FREQUENCY\n4\n*NODE PRINT,NSET=TIP,GLOBAL=YES\nU\n*NODE PRINT,NSET=B1_50,GLOBAL=YES\nU\n*END STEP\n"
    )


def test_box_mesh_shares_nodes_between_touching_boxes() -> None:
    mesh = box_mesh((np.array([0.0, 1.0, 2.0]), np.array([0.0, 1.0]), np.array([0.0, 1.0])), [((0, 1), (0, 1), (0, 1)), ((1, 2), (0, 1), (0, 1))])
    assert mesh.elements.shape == (2, 20)
    assert len(mesh.nodes) == 20 + 20 - 8  # the common face has 4 corner + 4 mid-side nodes
    shared = np.intersect1d(mesh.elements[0], mesh.elements[1])
    assert np.allclose(mesh.nodes[shared, 0], 1.0) and len(shared) == 8


def test_tbeam_deck_geometry_sets_and_counts() -> None:
    mesh = TBeamMesh(n_h1=2, n_w1=2, n_l1=10, n_h2=1, n_w2=2, n_l2=5)
    deck = TBeamDeck(mesh)
    p = {"L1": 0.42, "L2": 0.38, "h1": 0.008, "w1": 0.012, "h2": 0.0015, "w2": 0.013}
    hex_mesh, sets = deck.build_mesh({**dict.fromkeys(TBEAM_PARAMETER_NAMES, 1.0), **p})
    nodes = hex_mesh.nodes
    assert len(hex_mesh.elements) == mesh.n_elements()
    assert np.allclose(nodes[sets["TIP"]].mean(axis=0), [0.42, 0.0, 0.0], atol=1e-12)
    assert np.allclose(nodes[sets["CLAMP1"], 0], 0.0)
    assert np.allclose(np.abs(nodes[sets["CLAMP2"], 1]), 0.19)
    assert nodes[:, 2].min() == pytest.approx(-0.004 - 0.0015) and nodes[:, 2].max() == pytest.approx(0.004 + 0.0015)
    thin_x = nodes[np.abs(nodes[:, 2]) > 0.004 + 1e-12, 0]
    assert thin_x.min() == pytest.approx(0.42 - 0.013) and thin_x.max() == pytest.approx(0.42)
    assert np.allclose(nodes[sets["B1_50"]].mean(axis=0)[1:], 0.0, atol=1e-12)
    text, coordinates = deck({**p, **SENSOR_MASSES})
    assert count_elements(text) == mesh.n_elements()  # MASS elements are not mesh
    assert coordinates["tip:uz"] == ("TIP", "uz") and len(coordinates) == 10
    n_face = len(sets["TIPFACE"])
    mass_line = text.split("*MASS, ELSET=ESENSORS\n")[1].splitlines()[0]
    assert float(mass_line) * n_face == pytest.approx(0.035)


def test_tbeam_deck_rejects_bad_parameters() -> None:
    deck = TBeamDeck(TBeamMesh(1, 1, 4, 1, 1, 2))
    with pytest.raises(ValueError, match="unknown parameter 'thickness'"):
        deck({"thickness": 1.0})
    with pytest.raises(ValueError, match="h1 must be positive"):
        deck({"h1": 0.0})
    with pytest.raises(ValueError, match="nu must be in"):
        deck({"nu": 0.5})
    with pytest.raises(ValueError, match="n_l1 must be a positive integer"):
        TBeamMesh(n_l1=0)


def test_adapter_requires_a_model_identity(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="model_id"):
        CalculixAdapter(lambda p: ("", {}), ["E"], work_root=tmp_path)


# --------------------------------------------------------------------------- real ccx runs


@pytest.mark.calculix
def test_single_c3d20_element_matches_quadratic_rod(tmp_path: Path) -> None:
    """One 20-node brick as an axial rod (ν = 0, lateral motion fixed) = one 3-node rod element."""
    L, a = 1.0, 0.1
    adapter = CalculixAdapter(BlockDeck((1, 1, 1), L, a, a, element="C3D20", support="axial", nu=0.0), ["E"], n_modes=1, work_root=tmp_path)
    result = adapter.evaluate({})
    K = E_STEEL * a * a / (3 * L) * np.array([[16.0, -8.0], [-8.0, 7.0]])
    M = RHO_STEEL * a * a * L / 30 * np.array([[16.0, 2.0], [2.0, 4.0]])
    omega2 = scipy.linalg.eigh(K, M, eigvals_only=True)
    expected_hz = np.sqrt(omega2[0]) / (2 * np.pi)
    assert result.natural_frequencies_hz[0] == pytest.approx(expected_hz, rel=2e-6)
    # mass-normalised: the tip value of the rod mode with φᵀMφ = 1
    _, vectors = scipy.linalg.eigh(K, M)
    assert abs(result.mode_shapes[0, 0]) == pytest.approx(abs(vectors[1, 0]), rel=1e-5)


@pytest.mark.calculix
def test_solid_cantilever_matches_beam_theory(tmp_path: Path) -> None:
    L, b, h = 0.200, 0.010, 0.008  # width b (y), depth h (z)
    adapter = CalculixAdapter(BlockDeck((40, 2, 2), L, b, h), ["E"], n_modes=6, work_root=tmp_path)
    result = adapter.evaluate({})
    assert result.metadata["solver"] == "calculix" and result.metadata["mesh_size"] == 160
    assert Path(result.metadata["log_path"]).exists() and Path(result.metadata["run_dir"]).is_dir()
    tip = dict(zip(result.coordinates, result.mode_shapes))
    z_modes = np.flatnonzero(np.abs(tip["tip:uz"]) > 10 * np.abs(tip["tip:uy"]))
    y_modes = np.flatnonzero(np.abs(tip["tip:uy"]) > 10 * np.abs(tip["tip:uz"]))
    fz = result.natural_frequencies_hz[z_modes[:2]]
    fy = result.natural_frequencies_hz[y_modes[:2]]
    timo_z = timoshenko_cantilever_hz(E_STEEL, NU_STEEL, RHO_STEEL, L, b, h, 2)
    timo_y = timoshenko_cantilever_hz(E_STEEL, NU_STEEL, RHO_STEEL, L, h, b, 2)
    eb_z = euler_bernoulli_cantilever_hz(E_STEEL, RHO_STEEL, L, b, h, 2)
    print(f"\ncantilever z-bending: solid {fz.round(2)} Hz, Timoshenko {timo_z.round(2)}, Euler-Bernoulli {eb_z.round(2)}")
    print(f"cantilever y-bending: solid {fy.round(2)} Hz, Timoshenko {timo_y.round(2)}")
    np.testing.assert_allclose(fz, timo_z, rtol=0.02)
    np.testing.assert_allclose(fy, timo_y, rtol=0.02)
    assert fz[0] == pytest.approx(eb_z[0], rel=0.01)
    # Mass normalisation: an Euler–Bernoulli cantilever mode with ∫ρAφ² dx = 1 has |φ(L)| = 2/√(ρAL).
    assert abs(tip["tip:uz"][z_modes[0]]) == pytest.approx(2 / np.sqrt(RHO_STEEL * b * h * L), rel=0.02)


@pytest.mark.calculix
def test_parallel_runs_do_not_collide_and_a_point_is_solved_once(tmp_path: Path) -> None:
    adapter = CalculixAdapter(BlockDeck((10, 1, 1), 0.2, 0.01, 0.008), ["E"], n_modes=2, work_root=tmp_path / "runs")
    moduli = [150e9, 210e9, 270e9]
    with ThreadPoolExecutor(max_workers=2) as pool:
        results = list(pool.map(lambda E: adapter.evaluate({"E": E}), moduli))
    assert len({r.metadata["run_dir"] for r in results}) == 3
    f = np.array([r.natural_frequencies_hz[0] for r in results])
    np.testing.assert_allclose(f / f[1], np.sqrt(np.array(moduli) / 210e9), rtol=1e-5)  # f ∝ √E
    assert len(list((tmp_path / "runs").iterdir())) == 3
    evaluator = MemoisedEvaluator(adapter)
    first, again = evaluator([{"E": 270e9}, {"E": 270e9}])
    assert again is first and evaluator.counts() == {"new": 1, "cached": 1}
    np.testing.assert_allclose(first.natural_frequencies_hz, results[2].natural_frequencies_hz)
    # the key names the model too: another deck is another point
    other = CalculixAdapter(BlockDeck((12, 1, 1), 0.2, 0.01, 0.008), ["E"], n_modes=2, work_root=tmp_path / "runs")
    assert other.key({"E": 270e9}) != adapter.key({"E": 270e9})


@pytest.mark.calculix
def test_ccx_error_with_exit_code_zero_is_detected(tmp_path: Path) -> None:
    # 100 modes of a 1-element model (36 dofs): ARPACK fails, ccx prints *ERROR and exits 0.
    adapter = CalculixAdapter(BlockDeck((1, 1, 1), 0.2, 0.01, 0.01, element="C3D20"), ["E"], n_modes=100, work_root=tmp_path)
    with pytest.raises(AdapterError) as info:
        adapter.evaluate({})
    message = str(info.value)
    run_dir = next(tmp_path.iterdir())
    assert "although it exited with code 0" in message and "*ERROR in d[n,s]aupd" in message
    assert f"run directory: {run_dir}" in message and f"log: {run_dir / 'ccx.log'}" in message


@pytest.mark.calculix
def test_ccx_input_error_is_reported_with_its_message(tmp_path: Path) -> None:
    adapter = CalculixAdapter(BlockDeck((1, 1, 1), 0.2, 0.01, 0.01, nu=0.7), ["E"], n_modes=2, work_root=tmp_path)
    with pytest.raises(AdapterError, match=r"ccx error: \*ERROR reading \*ELASTIC: Poisson") as info:
        adapter.evaluate({})
    assert "ccx.log" in str(info.value)


FAKE_DAT_NEGATIVE = """
     E I G E N V A L U E   O U T P U T

 MODE NO    EIGENVALUE                       FREQUENCY
                                     REAL PART            IMAGINARY PART
                           (RAD/TIME)      (CYCLES/TIME     (RAD/TIME)

      1  -0.1414106E+08   0.0000000E+00   0.0000000E+00   0.3760460E+04
      2   0.1370838E+08   0.3702482E+04   0.5892684E+03   0.0000000E+00

                    E I G E N V A L U E    N U M B E R     1


 displacements (vx,vy,vz) for set TIP and time  0.1000000E+01

         2 -1.580678E-02 -5.666819E+05  5.666819E+05

                    E I G E N V A L U E    N U M B E R     2


 displacements (vx,vy,vz) for set TIP and time  0.1000000E+01

         2  5.763234E-03  2.421300E+03 -2.421285E+03
"""


def fake_ccx(tmp_path: Path, dat_text: str) -> Path:
    """A stand-in for ccx that writes ``dat_text`` as job.dat and exits 0."""
    (tmp_path / "fake.dat").write_text(dat_text)
    script = tmp_path / "fake_ccx"
    script.write_text(f"#!{sys.executable}\nimport shutil\nprint('fake ccx')\nshutil.copy({str(tmp_path / 'fake.dat')!r}, 'job.dat')\n")
    script.chmod(script.stat().st_mode | stat.S_IXUSR)
    return script


def test_negative_eigenvalue_is_a_mechanism_error(tmp_path: Path) -> None:
    # Parsing of a ccx .dat in which mode 1 has a negative eigenvalue (seen with hourglassing).
    exe = fake_ccx(tmp_path, FAKE_DAT_NEGATIVE)
    adapter = CalculixAdapter(BlockDeck((1, 1, 1), 1.0, 1.0, 1.0), ["E"], n_modes=2, executable=str(exe), work_root=tmp_path / "runs")
    with pytest.raises(AdapterError, match=r"negative eigenvalues for modes \[1\].*mechanism") as info:
        adapter.evaluate({})
    assert "ccx.log" in str(info.value)


def test_missing_displacement_table_is_an_error(tmp_path: Path) -> None:
    # ccx only warns (exit 0) when a *NODE PRINT set is missing: the table check catches it.
    exe = fake_ccx(tmp_path, FAKE_DAT_NEGATIVE.replace("-0.1414106E+08   0.0000000E+00   0.0000000E+00   0.3760460E+04", "0.1314106E+08   0.3625060E+04   0.5769462E+03   0.0000000E+00").replace("set TIP", "set OTHER"))
    adapter = CalculixAdapter(BlockDeck((1, 1, 1), 1.0, 1.0, 1.0), ["E"], n_modes=2, executable=str(exe), work_root=tmp_path / "runs")
    with pytest.raises(AdapterError, match="no displacement table for node set TIP in mode 1"):
        adapter.evaluate({})


def test_missing_ccx_says_how_to_install(tmp_path: Path) -> None:
    adapter = CalculixAdapter(BlockDeck((1, 1, 1), 0.2, 0.01, 0.01), ["E"], executable="ccx-not-installed-here", work_root=tmp_path)
    with pytest.raises(ExecutableNotFoundError, match=r"apt-get install calculix-ccx.*executable"):
        adapter.evaluate({})


def test_ccx_timeout_is_an_adapter_error(tmp_path: Path) -> None:
    """Killed at its timeout, the error quotes what the program printed (a timeout that
    fired before it printed, a slow start on a loaded machine, is made longer)."""
    fake = tmp_path / "slow_ccx"
    fake.write_text(f"#!{sys.executable}\n" + textwrap.dedent("import time\nprint('pretending to factorise', flush=True)\ntime.sleep(600)\n"))
    fake.chmod(fake.stat().st_mode | stat.S_IXUSR)

    def attempt(timeout_s: float) -> str:
        adapter = CalculixAdapter(BlockDeck((1, 1, 1), 0.2, 0.01, 0.01), ["E"], executable=str(fake), timeout_s=timeout_s,
                                  work_root=tmp_path / "runs")
        with pytest.raises(RunTimeoutError, match=f"timed out after {timeout_s} s") as info:
            adapter.evaluate({})
        assert str(tmp_path / "runs") in str(info.value)
        return str(info.value)

    timed_out_once_ready(attempt, lambda message: "pretending to factorise" in message, 0.5)


# A well-formed two-mode output (mode 1 of FAKE_DAT_NEGATIVE made positive and below mode 2),
# and what a broken ccx run leaves instead: each must fail the run naming its folder and log.
GOOD_MODE_1 = "0.1314106E+08   0.3625060E+04   0.5769462E+03   0.0000000E+00"
FAKE_DAT_GOOD = FAKE_DAT_NEGATIVE.replace("-0.1414106E+08   0.0000000E+00   0.0000000E+00   0.3760460E+04", GOOD_MODE_1)
MODE_2 = "0.1370838E+08   0.3702482E+04   0.5892684E+03   0.0000000E+00"
GARBAGE_OUTPUTS = {
    "NaN frequency": (FAKE_DAT_GOOD.replace(MODE_2, "NaN   NaN   NaN   0.0000000E+00"), 2, r"mode\(s\) \[2\] are not finite"),
    "infinite eigenvalue": (FAKE_DAT_GOOD.replace(MODE_2, "Infinity   Infinity   Infinity   0.0000000E+00"), 2,
                            r"mode\(s\) \[2\] are not finite"),
    "fewer modes than asked": (FAKE_DAT_GOOD, 3, r"2 of the 3 requested modes"),
    "descending frequencies": (FAKE_DAT_GOOD.replace(GOOD_MODE_1, "0.1414106E+08   0.3760460E+04   0.5984912E+03   0.0000000E+00"), 2,
                               r"not ascending \(mode\(s\) \[2\] below the previous one\)"),
    "negative frequency": (FAKE_DAT_GOOD.replace(GOOD_MODE_1, "0.1314106E+08   0.3625060E+04  -0.5769462E+03   0.0000000E+00"), 2,
                           r"negative frequencies for mode\(s\) \[1\]"),
    "NaN displacement": (FAKE_DAT_GOOD.replace("5.763234E-03  2.421300E+03 -2.421285E+03", "5.763234E-03  NaN -2.421285E+03"), 2,
                         r"displacements that are not finite numbers .*\('tip:uy', 2\)"),
    "text that is not a .dat": ("Segmentation fault (core dumped)\n\x00\x00garbage\n", 2,
                                r"could not read the ccx results: .*no 'E I G E N V A L U E   O U T P U T' block"),
    "empty .dat": ("", 2, r"could not read the ccx results"),
}


def assert_names_run_and_log(message: str, runs: Path) -> None:
    run_dir = next(runs.iterdir())
    assert f"run directory: {run_dir}" in message and f"log: {run_dir / 'ccx.log'}" in message, message
    assert "last lines of the log:" in message, message


@pytest.mark.parametrize("case", sorted(GARBAGE_OUTPUTS))
def test_garbage_output_fails_the_run_naming_its_folder_and_log(tmp_path: Path, case: str) -> None:
    dat, n_modes, expected = GARBAGE_OUTPUTS[case]
    exe = fake_ccx(tmp_path, dat)
    adapter = CalculixAdapter(BlockDeck((1, 1, 1), 1.0, 1.0, 1.0), ["E"], n_modes=n_modes, executable=str(exe),
                              work_root=tmp_path / "runs")
    with pytest.raises(AdapterError, match=expected) as info:
        adapter.evaluate({})
    assert_names_run_and_log(str(info.value), tmp_path / "runs")
    assert "fake ccx" in str(info.value)  # the log's last lines are quoted


def test_the_well_formed_fake_output_passes_the_checks(tmp_path: Path) -> None:
    """The garbage cases above differ from this output only in what they break."""
    exe = fake_ccx(tmp_path, FAKE_DAT_GOOD)
    adapter = CalculixAdapter(BlockDeck((1, 1, 1), 1.0, 1.0, 1.0), ["E"], n_modes=2, executable=str(exe), work_root=tmp_path / "runs")
    result = adapter.evaluate({})
    np.testing.assert_allclose(result.natural_frequencies_hz, [576.9462, 589.2684])
    assert result.mode_shapes.shape == (3, 2) and np.all(np.isfinite(result.mode_shapes))


def fake_ccx_program(tmp_path: Path, body: str) -> Path:
    script = tmp_path / "fake_ccx"
    script.write_text(f"#!{sys.executable}\n" + textwrap.dedent(body))
    script.chmod(script.stat().st_mode | stat.S_IXUSR)
    return script


@pytest.mark.parametrize("body, expected", [
    ("import os, signal\nprint('factorising', flush=True)\nos.kill(os.getpid(), signal.SIGSEGV)\n", r"ccx was killed by signal 11"),
    ("print('factorising', flush=True)\nraise SystemExit(3)\n", r"ccx exited with code 3"),
    ("print('factorising: done')\n", r"ccx finished but wrote no job.dat"),
], ids=["segfault", "non-zero exit", "no .dat"])
def test_a_crashing_ccx_fails_the_run_naming_its_folder_and_log(tmp_path: Path, body: str, expected: str) -> None:
    exe = fake_ccx_program(tmp_path, body)
    exe = exe.rename(tmp_path / "ccx")  # the message names the program
    adapter = CalculixAdapter(BlockDeck((1, 1, 1), 1.0, 1.0, 1.0), ["E"], n_modes=2, executable=str(exe), work_root=tmp_path / "runs")
    with pytest.raises(AdapterError, match=expected) as info:
        adapter.evaluate({})
    assert_names_run_and_log(str(info.value), tmp_path / "runs")
    assert "factorising" in str(info.value)


def test_a_hanging_ccx_is_killed_at_its_timeout_naming_its_folder_and_log(tmp_path: Path) -> None:
    exe = fake_ccx_program(tmp_path, "import time\nprint('factorising', flush=True)\ntime.sleep(60)\n")
    adapter = CalculixAdapter(BlockDeck((1, 1, 1), 1.0, 1.0, 1.0), ["E"], n_modes=2, executable=str(exe), timeout_s=0.5,
                              work_root=tmp_path / "runs")
    with pytest.raises(RunTimeoutError, match="timed out after 0.5 s") as info:
        adapter.evaluate({})
    assert_names_run_and_log(str(info.value), tmp_path / "runs")


# --------------------------------------------------------------------------- solid T-beam

# Published ANSYS values (thesis §4.2.4.1 converged mesh; Table 4.15 with sensor masses).
PUBLISHED_CONVERGED_HZ = np.array([46.4, 197.25, 281.0])
PUBLISHED_WITH_SENSORS_HZ = np.array([41.4, 193.3, 266.0])
# The thesis FE reproduces with the effective (clamped-to-clamped) lengths of §4.1.1:
EFFECTIVE = {"L1": 0.420, "L2": 0.380}


@pytest.mark.calculix
def test_tbeam_reproduces_the_published_fe_frequencies(tmp_path: Path) -> None:
    adapter = CalculixAdapter(TBeamDeck(TBeamMesh(2, 2, 40, 1, 2, 20)), TBEAM_PARAMETER_NAMES, n_modes=8, work_root=tmp_path)
    for parameters, published in ((EFFECTIVE, PUBLISHED_CONVERGED_HZ), ({**EFFECTIVE, **SENSOR_MASSES}, PUBLISHED_WITH_SENSORS_HZ)):
        result = adapter.evaluate(parameters)
        chosen = global_modes(result, parameters)
        f = result.natural_frequencies_hz[chosen[:3]]
        print(f"\nT-beam {parameters}: global modes {chosen[:3] + 1}, {f.round(2)} Hz (published {published})")
        np.testing.assert_array_equal(chosen[:3] + 1, [1, 2, 6])
        np.testing.assert_allclose(f, published, rtol=0.02)
        fraction = beam1_modal_mass_fraction(result, parameters)
        assert np.all(fraction[[2, 3, 4]] < 1e-3)  # thin-beam local modes: beam 1 at rest


@pytest.mark.calculix
def test_mesh_study_converges(tmp_path: Path) -> None:
    table = mesh_study([TBeamMesh(1, 1, 20, 1, 1, 10), TBeamMesh(2, 2, 40, 1, 2, 20)], n_modes=8, work_root=tmp_path)
    print("\n" + table.drop(columns="all_frequencies_hz").to_string())
    assert list(table["elements"]) == [TBeamMesh(1, 1, 20, 1, 1, 10).n_elements(), TBeamMesh(2, 2, 40, 1, 2, 20).n_elements()]
    assert all(numbers == [1, 2, 6] for numbers in table["global_mode_numbers"])
    for column in ("f1_hz", "f2_hz", "f3_hz"):
        coarse, fine = table[column]
        assert coarse == pytest.approx(fine, rel=0.02)
    assert (table["wall_time_s"] > 0).all()


@pytest.mark.calculix
def test_fine_tbeam_matches_the_published_converged_frequencies(tmp_path: Path) -> None:
    adapter = CalculixAdapter(TBeamDeck(TBeamMesh(3, 3, 80, 2, 3, 40)), TBEAM_PARAMETER_NAMES, n_modes=8, work_root=tmp_path)
    result = adapter.evaluate(EFFECTIVE)
    chosen = global_modes(result, EFFECTIVE)
    np.testing.assert_array_equal(chosen[:3] + 1, [1, 2, 6])
    np.testing.assert_allclose(result.natural_frequencies_hz[chosen[:3]], PUBLISHED_CONVERGED_HZ, rtol=0.005)
