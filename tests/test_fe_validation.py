"""``[fe_validation]``: the reduced FE model with a joint element per bolt against every forced
run (issue 38).

References independent of the code under test: the measured file read directly with
scipy.io and put through the resonance estimator; the FE model's own eigenvalue solution for
the linear limit of the harmonic balance (a stuck joint is the FE model's tangential spring);
the table's rules as docs/validation.md states them. The whole study on the example's
data runs in tests/test_brb_example.py.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.io

from nlupdate.core.validation.fe_settings import FEValidationSettings
from nlupdate.core.validation.forced_runs import ForcedRun, features, harmonic_response, predict_run, read_forced_runs
from nlupdate.core.validation.resonance import resonance
from nlupdate.study.loading import study_from_text
from nlupdate.study.reader import StudyError

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data" / "brb"
FORCED = DATA / "ForcedFrequencyResponses.mat"


def _raw_runs() -> dict[str, list]:
    """Each run's (frequency, receptance) straight from the file: amplitude·e^{i·phase} / force / ω²
    (the file's acceleration in m/s², phase in rad; the damping's circle fit needs the phase)."""
    runs = scipy.io.loadmat(FORCED, squeeze_me=True, struct_as_record=False)["FRdata"]
    out = {}
    for group in ("ForceControl", "ResponseControl"):
        out[group] = []
        for run in np.atleast_1d(getattr(runs, group)):
            f = np.asarray(run.frequency, float)
            out[group].append((f, run.amplitude * np.exp(1j * run.phase) / run.force / (2 * np.pi * f) ** 2))
    return out


def test_measured_runs_are_the_files_curves():
    """Every run of the file, in order, its resonance, damping ratio and peak as the estimator
    gives them on the raw curve (force-controlled runs ascending in force); each response-controlled
    run's displacement on each line the file's acceleration amplitude over Ω²."""
    runs = read_forced_runs(FORCED, ("acc3:-y", "acc3:y"))
    raw = _raw_runs()
    assert [r.control for r in runs] == ["force"] * len(raw["ForceControl"]) + ["response"] * len(raw["ResponseControl"])
    order = np.argsort([np.mean(np.abs(run.force)) for run in
                        np.atleast_1d(scipy.io.loadmat(FORCED, squeeze_me=True, struct_as_record=False)["FRdata"].ForceControl)])
    expected = [raw["ForceControl"][i] for i in order] + raw["ResponseControl"]
    for run, (frequency, receptance) in zip(runs, expected):
        reference = resonance(frequency, receptance)
        found = features(run.frequency_hz, run.h)
        assert found["resonance_hz"] == pytest.approx(reference.resonance_hz, rel=1e-12)
        assert found["damping_ratio"] == pytest.approx(reference.damping_ratio, rel=1e-9)
        assert found["peak"] == pytest.approx(reference.peak_abs, rel=1e-9)
    held = [run.level for run in runs if run.control == "response"]
    assert held == sorted(held) and 1e-5 < held[0] < held[-1] < 1e-3  # metres of held displacement
    raw_runs = np.atleast_1d(scipy.io.loadmat(FORCED, squeeze_me=True, struct_as_record=False)["FRdata"].ResponseControl)
    for run, raw_run in zip([run for run in runs if run.control == "response"], raw_runs):
        # each line's held displacement: the file's acceleration amplitude over Ω² (falls across the band)
        f = np.asarray(raw_run.frequency, float)
        np.testing.assert_allclose(run.held_line_m, np.abs(raw_run.amplitude) / (2 * np.pi * f) ** 2, rtol=1e-9)
        assert run.level == pytest.approx(np.median(run.held_line_m), rel=1e-12)


def test_a_run_holding_acceleration_is_predicted_at_its_displacement_on_each_line():
    """A response-controlled run holding the acceleration A holds the displacement X = A/Ω² on
    line Ω (5 % more on the lowest line than on the highest of a BRB-like 79.3–81.3 Hz band);
    the run is predicted on each line at the X it achieved there. Reference: an SDOF (1 kg,
    loss factor η on the spring K − k_f) with a Jenkins element (spring k_f, slip force F_s) in
    microslip, whose first-harmonic receptance at displacement amplitude X is the closed form
    H = 1/((K − k_f)(1 + iη) − Ω² + ν(X)), ν the textbook describing function (β = arccos(1 − 2F_s/(k_f X))):
    Re ν = (k_f/π)(β − ½ sin 2β), Im ν = 4F_s(X − F_s/k_f)/(πX²). Its ζ rises with X, so the run's
    curve at the per-line X reads 1.3 % more damped than one held at its median X — which the
    single-amplitude prediction gave; the per-line prediction matches the closed form to 1e-5."""
    from nlupdate.core.model.elements.jenkins import JenkinsFriction
    from nlupdate.core.model.linear import LumpedModel
    from nlupdate.core.model.system import NonlinearSystem

    frequency = np.round(np.arange(79.3, 81.3001, 0.05), 4)  # Hz, the BRB's 41 lines
    omega = 2 * np.pi * frequency
    held = 30.0 / omega**2  # m: 30 m/s² held, 115-121 µm
    k, kf = (2 * np.pi * 80.705) ** 2, 0.02 * (2 * np.pi * 80.705) ** 2  # N/m: resonance at 80.30 Hz, ζ 0.47 %
    slip, eta = 0.5 * kf * float(np.median(held)), 0.0028

    def closed_form(x: np.ndarray, w: np.ndarray) -> np.ndarray:
        beta = np.arccos(1 - 2 * slip / (kf * x))
        nu = kf / np.pi * (beta - 0.5 * np.sin(2 * beta)) + 4j * slip * (x - slip / kf) / (np.pi * x**2)
        return 1 / ((k - kf) * (1 + 1j * eta) - w**2 + nu)

    system = NonlinearSystem(LumpedModel.with_loss_factor([[1.0]], [[k - kf]], eta, dof_names=("x",)),
                             (JenkinsFriction((0,), kf=kf, slip_force=slip),))
    exact = features(frequency, closed_form(held, omega))
    single = features(frequency, closed_form(np.full(held.shape, np.median(held)), omega))
    assert single["damping_ratio"] / exact["damping_ratio"] - 1 < -0.01  # what one held amplitude gets wrong
    h, force = harmonic_response(system, "x", frequency, held_m=held)
    np.testing.assert_allclose(h, closed_form(held, omega), rtol=1e-5)
    np.testing.assert_allclose(np.abs(h) * force, held, rtol=1e-5)  # the force holds each line's X
    run = ForcedRun("held", "response", float(np.median(held)), frequency, closed_form(held, omega),
                    np.abs(held / closed_form(held, omega)), held)
    predicted = predict_run(system, "x", run)
    assert predicted["resonance_hz"] == pytest.approx(exact["resonance_hz"], abs=1e-4)
    assert predicted["damping_ratio"] == pytest.approx(exact["damping_ratio"], rel=1e-4)
    assert predicted["peak"] == pytest.approx(exact["peak"], rel=1e-5)
    # beyond the band (margin_hz) the end lines' displacement is held, as their force for force control
    wide = np.round(np.arange(78.3, 82.3001, 0.05), 4)
    clamped = features(wide, closed_form(np.interp(wide, frequency, held), 2 * np.pi * wide))
    outside = predict_run(system, "x", run, margin_hz=1.0)
    assert outside["damping_ratio"] == pytest.approx(clamped["damping_ratio"], rel=1e-4)
    assert outside["resonance_hz"] == pytest.approx(clamped["resonance_hz"], abs=1e-4)


@pytest.mark.calculix
def test_a_stuck_joint_is_the_fe_models_spring():
    """At a slip force no run reaches, a Jenkins element per bolt is the FE model's tangential
    spring: the harmonic balance's curve of a force-controlled run around mode 1 is the reduced
    matrices' direct linear solve (the joint's x springs undamped, η = 2ζ on the rest), and its
    resonance the adapter's eigenvalue (within the 3e-5 the other modes' background moves a peak
    of |H|); an Iwan element there slips a little (microslip at every amplitude): softer, never stiffer."""
    from nlupdate.fe.adapters.calculix_brb import BRBAdapter, BRBMesh, joint_stiffness
    from nlupdate.fe.joint_validation import nonlinear_model

    adapter = BRBAdapter(BRBMesh(n_full=8, n_lap=8), n_modes=1, fixed_interface_modes=12)
    point = {"h": 0.0125, "kt": 5e8}
    mode1 = float(adapter.evaluate(point).natural_frequencies_hz[0])
    frequency = mode1 + np.linspace(-0.6, 0.6, 61)
    run = ForcedRun("synthetic", "force", 0.5, frequency, np.zeros(61, complex), np.full(61, 0.5))
    joint = {"slip_force": 1e7, "chi": -0.5, "beta": 0.0}
    jenkins = nonlinear_model(adapter, point, 0.002, joint, "jenkins", "acc3:uy")
    h, _ = harmonic_response(jenkins, "acc3:uy", frequency, force_n=run.force_n)

    deck, springs = adapter.split(point)
    reduced = adapter.reduced(deck)
    elastic = reduced.stiffness + joint_stiffness(reduced, springs["kt"], springs["kn"], springs["kr"], tangential_x=False)
    stuck = joint_stiffness(reduced, springs["kt"], 0.0, 0.0) - joint_stiffness(reduced, springs["kt"], 0.0, 0.0,
                                                                               tangential_x=False)
    drive = reduced.index("acc3:uy")
    unit = np.eye(len(reduced.dof_names))[:, drive]
    direct = np.array([np.linalg.solve(elastic * (1 + 0.004j) + stuck - (2 * np.pi * f) ** 2 * reduced.mass, unit)[drive]
                       for f in frequency])
    np.testing.assert_allclose(h, direct, rtol=1e-6)
    found = predict_run(jenkins, "acc3:uy", run)
    assert found["resonance_hz"] == pytest.approx(mode1, rel=1e-4)
    iwan = predict_run(nonlinear_model(adapter, point, 0.002, joint, "iwan", "acc3:uy"), "acc3:uy", run)
    assert found["resonance_hz"] * (1 - 1e-4) < iwan["resonance_hz"] <= found["resonance_hz"]


def _study(extra: str, adapter: str = 'kind = "calculix"\nmodel = "brb"', parameter: str = "h") -> str:
    return (f'[study]\nname = "brbcheck"\n[adapter]\n{adapter}\n'
            f'[[parameters]]\nname = "{parameter}"\nstart = 0.0127\nlower = 0.011\nupper = 0.0145\n'
            '[targets]\nfrequencies_hz = [80.569]\n[eigensensitivity]\nformulas = ["central2"]\n' + extra)


def test_the_table_is_read_by_its_declaration(tmp_path):
    """The table's keys and defaults; every mistake one line naming the file, table and key."""
    study_path = ROOT / "examples" / "brb" / "study_check.toml"
    table = '[fe_validation]\nfile = "../../tests/data/brb/ForcedFrequencyResponses.mat"\n'
    study = study_from_text(_study(table + "fit_evaluations = 5\n"), study_path)
    assert study.fe_validation == FEValidationSettings(file="../../tests/data/brb/ForcedFrequencyResponses.mat",
                                                       fit_evaluations=5)
    assert study.input_files["../../tests/data/brb/ForcedFrequencyResponses.mat"] == study_path.parent / \
        "../../tests/data/brb/ForcedFrequencyResponses.mat"  # archived with the run and part of its key
    mistakes = {
        table + 'element = "coulomb"\n': "key 'element': expected one of ['iwan', 'jenkins']",
        table + 'runs = ["sine"]\n': "runs: expected a non-empty list of ['force', 'response']",
        table + "fit_evaluations = 0\n": "key 'fit_evaluations': expected an integer ≥ 1",
        table + "slip_force = 3\n": "key 'slip_force': expected one of the keys",
        '[fe_validation]\nfile = "missing.mat"\n': "key 'file': expected an existing file",
        '[fe_validation]\nfile = "runs.csv"\n': "key 'file': expected a MATLAB file (.mat)",
        '[fe_validation]\nfit_evaluations = 5\n': "key 'file': expected a file name (string) (required)",
    }
    for text, message in mistakes.items():
        with pytest.raises(StudyError) as raised:
            study_from_text(_study(text), study_path)
        assert str(raised.value).startswith(f"{study_path}: [fe_validation]") and message in str(raised.value)
    with pytest.raises(StudyError, match=r"\[fe_validation\]: expected an \[adapter\] kind = \"calculix\", model = \"brb\""):
        study_from_text(_study(table, 'kind = "calculix"\nmodel = "tbeam"', "h1"), study_path)


def test_the_docs_table_is_the_declaration():
    """docs/validation.md's table of `[fe_validation]` keys is generated from the declaration."""
    from nlupdate.settings import docs_table

    assert docs_table(FEValidationSettings) in (ROOT / "docs" / "validation.md").read_text()


@pytest.mark.calculix
def test_the_step_on_two_runs_and_a_short_fit():
    """The step's numerics on a coarse mesh, one force- and one response-controlled run and a
    one-evaluation fit (the whole study on every run: tests/test_brb_example.py, slow): the two
    tables' columns and rows, the measured columns the estimator's on the raw file, the paired
    FE modes the adapter's own, and a predicted resonance below the stuck structure's."""
    from nlupdate.fe.adapters.calculix_brb import BRBAdapter, BRBMesh
    from nlupdate.fe.joint_validation import VALIDATION_COLUMNS, validate_fe

    runs = read_forced_runs(FORCED, ("acc3:-y", "acc3:y"))
    chosen = [runs[0], next(run for run in runs if run.control == "response")]
    adapter = BRBAdapter(BRBMesh(n_full=8, n_lap=8), n_modes=3, fixed_interface_modes=12)
    initial, updated = {"h": 0.0127, "kt": 3e8}, {"h": 0.0122, "kt": 7e8}
    settings = FEValidationSettings(file=str(FORCED), fit_evaluations=1, shaker_mass=False)
    found = validate_fe(adapter, initial, updated, {1: 80.569}, chosen, settings, 0.0015, "test")
    assert list(found.modes.columns) == ["model", "mode", "frequency_hz", "frequency_hz_measured"]
    assert list(found.table.columns) == list(VALIDATION_COLUMNS)
    assert [(r.model, r.control) for r in found.table.itertuples()] == [
        ("initial", "force"), ("initial", "response"), ("updated", "force"), ("updated", "response")]
    for point, name in ((initial, "initial"), (updated, "updated")):
        modes = found.modes[found.modes.model == name]
        np.testing.assert_allclose(modes.frequency_hz, adapter.evaluate(point).natural_frequencies_hz, rtol=1e-12)
        assert modes.frequency_hz_measured.iloc[0] == 80.569 and modes.frequency_hz_measured.iloc[1:].isna().all()
        rows = found.table[found.table.model == name]
        # no shaker mass: the stuck joint is the stiffest the model can be, so no resonance above mode 1
        assert (rows.resonance_hz_predicted < modes.frequency_hz.iloc[0] * (1 + 1e-4)).all()
    raw = _raw_runs()
    for row, (frequency, receptance) in zip(found.table.itertuples(),
                                           [raw["ForceControl"][0], raw["ResponseControl"][0]] * 2):
        reference = resonance(frequency, receptance)
        assert (row.resonance_hz_measured, row.peak_measured) == pytest.approx(
            (reference.resonance_hz, reference.peak_abs), rel=1e-12)
    assert found.fit["evaluations"] >= 1 and set(found.joint) == {"slip_force", "chi", "beta", "damping_ratio_forced"}
