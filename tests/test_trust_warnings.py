"""Warnings about results that should not be trusted, on computed results.

* Identification (PRD, cubic + Jenkins on the §3.1 SDOF, describing-function data):
  a slip force the data cannot show — a Jenkins that never slips, or one whose
  friction damping drowns in 5 % noise so the fit stops where the low level would
  start to slip (the review's "0.0199 against a true 1.0") — is warned about by name;
  a well-identified case at 1 % noise gets no warning at all. A noise level given far
  below the real one is warned about (the fit's residual is far above it).
* Updating: a target out of reach within the bounds ends the run on the bound (stopped
  there, "parameter at bound", not converged) and is warned about; a reachable one is not; the
  same through a study into ``manifest.json``, ``report.md``'s summary and
  ``identification.json``.
"""
from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from nlupdate.fe.adapters.base import Parameter
from nlupdate.fe.adapters.lumped import LumpedAdapter
from nlupdate.core.identification.data import FRFLevels
from nlupdate.core.identification.pipeline import IdentificationSettings, identify
from nlupdate.core.model.elements import CubicStiffness, JenkinsFriction
from nlupdate.core.model.linear import LumpedModel
from nlupdate.core.model.system import NonlinearSystem
from nlupdate.reporting.archive import write_archive
from nlupdate.reporting.report import summary_section
from nlupdate.core.response.continuation import trace_frequency_response
from nlupdate.core.response.stepped_sine import stepped_sine
from nlupdate.study import run_study, study_from_text
from nlupdate.core.updating.eigensensitivity import EigensensitivityOptions, inverse_eigensensitivity
from nlupdate.core.updating.optimisation import OptimisationOptions, optimise_frequencies
from nlupdate.core.updating.targets import UpdatingTargets
from nlupdate.core.updating.parameter_warnings import updating_warnings

LEVELS = (0.01,) + tuple(float(f) for f in np.arange(100.0, 401.0, 30.0))
GRID = np.arange(680.0, 741.0)


def sdof_data(slip_force: float) -> FRFLevels:
    """Noise-free stepped-sine DF data of the §3.1 SDOF (k* = 1e10 N/m³, kf = 3e5 N/m)."""
    system = NonlinearSystem(LumpedModel.with_loss_factor([[0.1]], [[2e6]], 0.01),
                             (CubicStiffness((0,), 1e10), JenkinsFriction((0,), 3e5, slip_force)))
    curves = []
    for level in LEVELS:
        curve = trace_frequency_response(system, {0: level}, 2 * np.pi * 670.0, 2 * np.pi * 750.0)
        curves.append(stepped_sine(curve, 2 * np.pi * GRID, "up").response([0])[:, 0] / level)
    return FRFLevels("0", "0", np.array(LEVELS), tuple(GRID for _ in LEVELS), tuple(curves))


def identified(data: FRFLevels, noise: float, seed: int, noise_fraction: float | None = None):
    noisy = data.with_noise(noise, np.random.default_rng(seed))
    settings = IdentificationSettings("0", "0", elements=("cubic", "jenkins"), frequency_hz=710.0, samples=20, seed=1,
                                      noise_fraction=noise_fraction)
    return identify(noisy, settings)


@pytest.fixture(scope="module")
def slipping() -> FRFLevels:
    """Slip force 100 N: the high levels slip (slip displacement 0.33 mm), the low level not."""
    return sdof_data(100.0)


def test_a_well_identified_slip_force_gives_no_warning(slipping):
    ident = identified(slipping, 0.01, 0)
    assert ident.parameters()["slip_force"] == pytest.approx(100.0, rel=0.01)
    assert ident.warnings == ()
    assert ident.summary()["warnings"] == []
    assert ident.summary()["fit_residual"]["ratio_to_noise"] == pytest.approx(1.0, abs=0.2)


def test_a_slip_force_that_never_slips_is_warned_about():
    """Slip force 1e4 N: no measured level slips (kf·A_max ≈ 400 N), so nothing in the
    data shows the slip force; the fit still returns a number for it."""
    ident = identified(sdof_data(1e4), 0.01, 0)
    warned = {w.subject: w for w in ident.warnings}
    assert "slip_force" in warned, ident.warnings
    assert warned["slip_force"].kind in ("at_bound", "uncertainty_exceeds_value")
    assert all(w.source == "identification" for w in ident.warnings)
    summary = json.loads(json.dumps(ident.summary()))
    assert any(w["subject"] == "slip_force" for w in summary["warnings"])


def test_a_slip_force_lost_in_the_noise_stops_at_the_low_level_and_is_warned_about():
    """Slip force 1 N at 5 % noise: the friction damping 4Fs/(πA) at the high levels is
    far below the noise, and the fit stops where the 0.01 N level would start to slip
    (≈ 0.011 N = kf × the largest low-force amplitude), a hundred times below the truth."""
    ident = identified(sdof_data(1.0), 0.05, 3)
    result = ident.result
    slip = ident.parameters()["slip_force"]
    limit = ident.parameters()["kf"] * result.amplitude_low_max
    assert slip < 0.05 and slip == pytest.approx(limit, rel=0.1)
    warning = next(w for w in ident.warnings if w.subject == "slip_force")
    assert warning.kind == "at_bound" and "low level is stuck" in warning.message


def test_a_noise_level_given_far_below_the_real_one_is_warned_about(slipping):
    """5 % noise in the data, 0.5 % given: the residual is ~9× the stated noise level,
    and the Monte-Carlo spread (drawn at 0.5 %) would be ten times too small."""
    honest = identified(slipping, 0.05, 1)
    assert not [w for w in honest.warnings if w.kind == "residual_above_noise"]
    understated = identified(slipping, 0.05, 1, noise_fraction=0.005)
    residual = [w for w in understated.warnings if w.kind == "residual_above_noise"]
    assert len(residual) == 1 and residual[0].subject == "fit"
    assert understated.residual_noise_fraction == pytest.approx(0.05, rel=0.15)
    assert understated.summary()["fit_residual"]["ratio_to_noise"] > 3


# ------------------------------------------------------------------------------ updating
MASSES = [0.1, 0.3, 0.2]
NOMINAL_K = [1e6, 1e6, 1e6, 1e6]
TRUTH_K = {"k1": 1.25e6, "k2": 0.8e6, "k3": 1.1e6}


def targets() -> UpdatingTargets:
    return UpdatingTargets(LumpedAdapter(MASSES, NOMINAL_K).evaluate(TRUTH_K).natural_frequencies_hz[:2])


@pytest.mark.parametrize("method", ["eigensensitivity", "optimisation"])
def test_a_run_that_ends_on_a_bound_is_warned_about_and_a_reachable_one_is_not(method):
    """k1's truth (1.25e6 N/m) lies above its bound 1.1e6: the run comes to rest on the
    bound and reports that as its stop, not as convergence; with bounds that hold the
    truth it ends inside, converged and unwarned."""
    def run(k1_upper: float):
        parameters = [Parameter("k1", "N/m", 1e6, 0.9e6, k1_upper, 1e-4), Parameter("k2", "N/m", 1e6, 0.4e6, 2.5e6, 1e-4)]
        if method == "eigensensitivity":
            return inverse_eigensensitivity(LumpedAdapter(MASSES, NOMINAL_K), parameters, targets(),
                                            EigensensitivityOptions(formula="central2"), fixed={"k3": TRUTH_K["k3"]})
        return optimise_frequencies(LumpedAdapter(MASSES, NOMINAL_K), parameters, targets(),
                                    OptimisationOptions(formula="central2"), fixed={"k3": TRUTH_K["k3"]})

    out_of_reach = run(1.1e6)
    assert out_of_reach.parameters["k1"] == pytest.approx(1.1e6, rel=1e-4)
    assert not out_of_reach.converged and out_of_reach.stop == "parameter at bound"
    warnings = updating_warnings(out_of_reach)
    assert [(w.subject, w.kind) for w in warnings] == [("k1", "at_bound")]
    assert "upper bound" in warnings[0].message and "converged" in warnings[0].message
    reachable = run(2.5e6)
    assert reachable.parameters["k1"] == pytest.approx(TRUTH_K["k1"], rel=1e-3)
    assert reachable.converged and updating_warnings(reachable) == ()


STUDY = """
[study]
name = "two-dof-bounded"

[measured.simulate]
model = "{model}"
input_dof = "0"
forces_n = [0.01, 20, 40, 60, 80, 100]
frequencies_hz = [690.0, 770.0, 161]
noise = 0.01
seed = 3

[identification]
response_dof = "0"
input_dof = "0"
elements = ["cubic", "jenkins"]
samples = 8
seed = 1

[adapter]
kind = "lumped"
options = {{ masses = [0.1, 0.5], stiffnesses = [0.8e6, 1.2e6, 1.0e6] }}

[[parameters]]
name = "k1"
unit = "N/m"
start = 0.6e6
lower = 0.5e6
upper = {k1_upper}

[targets]
from_identification = true
modes = [1]
model_response_dof = "x1"
model_input_dof = "x1"
model_modes = [2]

[eigensensitivity]
formulas = ["central2"]
parameter_sets = [["k1"]]
"""


def test_a_study_carries_the_warnings_into_manifest_report_and_identification_json(tmp_path):
    """The updated k1 of the small 2-DOF study is 0.745e6 N/m: with the bound at 0.7e6 the
    run ends on it, and the archive says so where a reader (and the terminal) looks."""
    model = Path(__file__).resolve().parents[1] / "examples" / "two_dof.toml"
    bounded = run_study(study_from_text(STUDY.format(model=model, k1_upper=0.7e6), tmp_path / "study.toml"))
    assert bounded.runs[0].parameters["k1"] == pytest.approx(0.7e6)
    assert [(w.source, w.subject, w.kind) for w in bounded.warnings] == [
        ("eigensensitivity central O(h²) {k1}", "k1", "at_bound")]
    folder = write_archive(bounded, tmp_path / "archive", {"orchestration": "test"})
    manifest = json.loads((folder / "manifest.json").read_text())
    assert [w["subject"] for w in manifest["warnings"]] == ["k1"]
    summary = summary_section((folder / "report.md").read_text())
    first, rest = summary.split("\n", 1)  # the one run stopped on the bound: none converged, the first line says so
    assert first.startswith("The updating run did not converge") and "k1 on its upper bound 700000" in first
    assert rest.strip().startswith("Warnings") and "k1 = 700000 ended on its upper bound" in summary
    updated = next(line for line in summary.splitlines() if "No converged updated model" in line)
    assert "k1 = 7e+05 N/m (not converged" in updated and "±" not in updated  # the unit [[parameters]] declares
    # each identified value with the unit its element declares (the summary read 'kf = 1785 ± 12', no unit)
    identified_line = next(line for line in summary.splitlines() if line.startswith("* Identified"))
    for name, unit in (("k3", "N/m³"), ("kf", "N/m"), ("slip_force", "N")):
        assert re.search(rf"\b{name} = \S+ ± \S+ {unit}(;|$)", identified_line), (name, identified_line)
    assert "on the bound of k1" in (folder / "report.md").read_text()
    assert json.loads((folder / "identification.json").read_text())["warnings"] == []

    free = run_study(study_from_text(STUDY.format(model=model, k1_upper=1.5e6), tmp_path / "study.toml"))
    assert free.warnings == ()
    folder = write_archive(free, tmp_path / "free", {"orchestration": "test"})
    assert json.loads((folder / "manifest.json").read_text())["warnings"] == []
    assert "Warnings" not in summary_section((folder / "report.md").read_text())


def test_warnings_on_per_volt_data_state_volts_not_newtons():
    """The slip force lost in the noise (test above) with the FRFs per volt — the same
    numbers, levels in V and H in m/V: its warning speaks of V; and the Jenkins-end warning
    of an Iwan fit gives kf = beta·kt/(1+beta) in V/m. Both said N and N/m whatever the
    reference."""
    import dataclasses

    from nlupdate.core.identification.dfmodels import PhysicalModel
    from nlupdate.core.identification.trust import _degenerate_warnings

    ident = identified(dataclasses.replace(sdof_data(1.0), reference_unit="V"), 0.05, 3)
    assert ident.reference_unit == "V"
    warning = next(w for w in ident.warnings if w.subject == "slip_force")
    assert warning.kind == "at_bound" and " V " in warning.message and " N" not in warning.message, warning.message
    values = {"slip_force": 2.0, "kt": 3e5, "chi": -0.999, "beta": 1.0}
    (jenkins,) = _degenerate_warnings(PhysicalModel(("iwan",)), values, "identification", "V")
    assert "= 1.5e+05 V/m" in jenkins.message and "slip force 2 V;" in jenkins.message, jenkins.message


def test_a_one_mode_fit_that_misses_its_curve_is_named():
    """Closed form: one mode (100 Hz, η = 1 %) is fitted exactly; two modes 2 Hz apart (99 and
    101 Hz) fitted as one are missed by 28 % RMS — a natural frequency between them and a loss
    factor 3.4 × either's — and the warning names both values (the transmitter beam's two lowest
    levels gave η = 0.3 against the curve's half-power 9.5e-4, printed without a word)."""
    from nlupdate.core.identification.modal_fit import fit_mode_near
    from nlupdate.core.identification.trust import MODE_FIT_LIMIT, mode_fit_warnings

    f = np.linspace(90.0, 110.0, 201)
    w = 2 * np.pi * f

    def mode(f_r, eta):
        w_r = 2 * np.pi * f_r
        return 1.0 / (w_r**2 - w**2 + 1j * eta * w_r**2)

    assert mode_fit_warnings([fit_mode_near(f, mode(100.0, 0.01), 100.0)]) == ()
    blend = fit_mode_near(f, mode(99.0, 0.01) + mode(101.0, 0.01), 99.0)
    assert blend.relative_rms_error > MODE_FIT_LIMIT and blend.loss_factors[0] > 2 * 0.01
    (warning,) = mode_fit_warnings([blend])
    assert warning.kind == "mode_fit_poor" and warning.subject == "linear_f1_hz, linear_eta1"
    assert f"{float(blend.loss_factors[0]):.4g}" in warning.message


def test_a_parameter_the_fit_ran_off_with_is_said_to_have_diverged_not_printed(tmp_path, capsys):
    """The Brake–Reuss beam read with its sensor's sign reversed (acc3:y against acc3:y),
    Jenkins identified: the improved PRD fit, unbounded, carried kf from its start (8.4e6 N/m)
    to 9e47 N/m — every level then slips at Fs/kf ≈ 1e-49 m, where kf acts on nothing. It
    printed 'kf = 8.95461e+47 N/m (95 % [0, 9.27e+48] …)' with only the levels' NOT
    TRUSTWORTHY above it. Now the terminal, identification.json and its warnings say it
    diverged; the correctly signed beam (kf 1785 N/m, 0.55× its start) is printed as before."""
    from cli_runs import run_cli
    from test_real_measurements import BRB

    printed = {}
    for sign in ("", "-"):
        out = tmp_path / f"sign{sign}"
        code, text, err = run_cli(capsys, "identify", "--measured", BRB, "--coordinates", f"{BRB}=acc3:{sign}y,acc3:y",
                                  "--elements", "jenkins", "--samples", "2", "--out", out)
        assert code == 0, err
        printed[sign] = text.splitlines(), json.loads((out / "identification.json").read_text())
    lines, summary = printed[""]
    kf = summary["parameters"]["kf"]
    assert kf["value"] > 1e40 and kf["diverged"] == f"kf diverged ({kf['value']:.3g} N/m): the data support no finite " \
                                                     f"value of it"
    assert kf["diverged"] in lines and not any(line.startswith("kf = ") for line in lines)
    (warning,) = [w for w in summary["warnings"] if w["kind"] == "diverged"]
    assert warning["subject"] == "kf" and "beyond the factor 1e6" in warning["message"]
    assert f"warning: identification: {warning['message']}" in lines
    assert lines.index(f"warning: identification: {warning['message']}") < lines.index(kf["diverged"])
    assert "diverged" not in summary["parameters"]["slip_force"]
    lines, summary = printed["-"]
    assert not [w for w in summary["warnings"] if w["kind"] == "diverged"]
    assert 1000 < summary["parameters"]["kf"]["value"] < 3000 and "diverged" not in summary["parameters"]["kf"]
    assert any(line.startswith("kf = 1784.") and " N/m (95 % [" in line for line in lines)
